"""The harmonic regression of a step-sine block, with a linear trend: the phasors at the block's start.

A block's channels are fitted, over its settled whole cycles, by least squares with

.. math::

    y(t) = d_0 + d_1 \\tau + \\sum_{h=1}^{H} \\left(a_h \\cos h\\omega t + b_h \\sin h\\omega t\\right)
           + \\tau \\sum_{h=1}^{H} \\left(a_h' \\cos h\\omega t + b_h' \\sin h\\omega t\\right),
    \\qquad \\tau = f t,

``t`` (s) counted from the block's first sample, ``tau`` in cycles. The phasors ``P_h = a_h - j b_h``
(``y = Re{P e^{j w t}}``) are those at ``t = 0``; ``P_1' = a_1' - j b_1'`` is the fundamental's change per cycle.
The trend terms make the estimate exact under a slow linear drift of either channel's amplitude (its whole
periodic waveform scaled by ``1 + r t``) (a specimen heating:
``F(t) = F_0 (1 + r t)``; a load cell's gain drifting) or of its offset: without them (the *plain* fit, ``a_h' = b_h' = 0``,
also returned) the fundamental is the average over the analysed cycles, ``F_0 (1 + r t_m)``, off by
``r t_m`` (0.2 %/s, 7 s: 1.4 %, 25 times the noise of 320 samples with 0.5 % noise). Both fits keep the offset's
trend ``d_1``: a ramp has a fundamental (over whole cycles, ``tau`` projects onto ``sin w t`` with ``-1 / pi``), so
a load cell's zero drifting by ``delta`` per cycle would move ``P_1`` by ``delta / pi``; the column costs nothing
(nearly orthogonal to the harmonics). The price is the extrapolation's
variance: for analysed cycles of length ``L`` and mid ``tau_m``, ``var P_1(0) = var P_1(tau_m) (1 + 12 tau_m^2 / L^2)``
(for cycles 2 to 12: a standard error 2.6 times the plain fit's), which is why
:func:`jointid.measurement.stepsine.process_stepsine` uses the trend fit only when a test's blocks drift.
The standard errors of ``a_1', b_1'`` are ``s sqrt(diag (A^T A)^-1)`` with ``s^2`` the residual variance
(``n - p`` degrees of freedom).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HarmonicTrendFit", "fit_harmonics_with_trend"]


@dataclass(frozen=True, eq=False)
class HarmonicTrendFit:
    """Result of :func:`fit_harmonics_with_trend`.

    Parameters
    ----------
    phasors : ndarray, shape (H, C), complex
        ``P_h`` of harmonics ``1..H`` of each channel at ``t = 0`` (the block's first sample), channel units.
    fundamental_slope : ndarray, shape (C,), complex
        ``P_1'``: change of the fundamental phasor per cycle, channel units per cycle.
    residual : ndarray, shape (n, C)
        ``y - model`` at the fitted samples.
    fundamental : ndarray, shape (n, C)
        ``Re{(P_1 + P_1' tau) e^{j w t}}`` at the fitted samples (the drifting fundamental).
    offset : ndarray, shape (n, C)
        ``d_0 + d_1 tau`` at the fitted samples.
    slope_std : ndarray, shape (C,)
        Standard error of the real and of the imaginary part of ``P_1'`` (their rms), channel units per cycle.
    plain_phasors : ndarray, shape (H, C), complex
        ``P_h`` of the plain fit (no trend of the fundamental): the average over the analysed cycles.
    plain_residual : ndarray, shape (n, C)
        Its residual.
    """

    phasors: np.ndarray
    fundamental_slope: np.ndarray
    residual: np.ndarray
    fundamental: np.ndarray
    offset: np.ndarray
    slope_std: np.ndarray
    plain_phasors: np.ndarray
    plain_residual: np.ndarray


def fit_harmonics_with_trend(t: np.ndarray, y: np.ndarray, frequency_hz: float, harmonics: int) -> HarmonicTrendFit:
    """Least-squares fit of offset, harmonics ``1..H`` and linear trends of the offset and the fundamental (module docstring).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times, s, from the block's first sample (the time the phasors refer to).
    y : ndarray, shape (C, n)
        The channels (any units).
    frequency_hz : float
        Test frequency ``f``, Hz (``omega = 2 pi f``).
    harmonics : int
        ``H >= 1``; the caller keeps ``H f`` below the Nyquist frequency.

    Returns
    -------
    HarmonicTrendFit
    """
    t = np.asarray(t, dtype=float)
    H = int(harmonics)
    tau = t * frequency_hz
    h = np.arange(1, H + 1)
    ph = 2.0 * np.pi * tau[:, None] * h[None, :]
    c1, s1 = np.cos(ph[:, 0]), np.sin(ph[:, 0])
    A = np.concatenate([np.ones((t.size, 1)), tau[:, None], np.cos(ph), np.sin(ph), (tau * c1)[:, None],
                        (tau * s1)[:, None], tau[:, None] * np.cos(ph[:, 1:]), tau[:, None] * np.sin(ph[:, 1:])], axis=1)
    y = np.asarray(y, dtype=float).T  # (n, C)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)  # (2 + 4H, C)
    resid = y - A @ coef
    P = coef[2 : 2 + H] - 1j * coef[2 + H : 2 + 2 * H]
    slope = coef[2 + 2 * H] - 1j * coef[3 + 2 * H]
    npar = A.shape[1]
    s2 = np.sum(resid**2, axis=0) / max(t.size - npar, 1)
    cinv = np.diag(np.linalg.pinv(A.T @ A))[2 + 2 * H : 4 + 2 * H]
    slope_std = np.sqrt(s2 * float(np.mean(cinv)))
    fundamental = np.outer(c1, coef[2]) + np.outer(s1, coef[2 + H]) + tau[:, None] * (
        np.outer(c1, coef[2 + 2 * H]) + np.outer(s1, coef[3 + 2 * H]))
    offset = coef[0][None, :] + tau[:, None] * coef[1][None, :]
    plain = A[:, : 2 + 2 * H]
    pcoef, *_ = np.linalg.lstsq(plain, y, rcond=None)
    plain_P = pcoef[2 : H + 2] - 1j * pcoef[H + 2 :]
    return HarmonicTrendFit(P, slope, resid, fundamental, offset, slope_std, plain_P, y - plain @ pcoef)
