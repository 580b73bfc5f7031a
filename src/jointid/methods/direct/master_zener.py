"""Fractional Zener fit of a master curve's shifted data: a fast start, derivatives and the full covariance.

The master curve (:mod:`.master_curve`) fits
``K(f_r) = (K0 + Kinf (j w_r tau)^alpha) / (1 + (j w_r tau)^alpha)`` to all shifted points with
:func:`.zener_fit.fit_zener`. Here: a single data-based start that avoids the multi-start when it
fits cleanly (:func:`fit_zener_fast`), the analytic derivatives of ``K`` (:func:`zener_jacobian`)
and the parameter covariance including the error of the shift factors (:func:`zener_covariance`).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import DataError
from .zener_fit import ZenerFit, fit_zener

__all__ = ["zener_jacobian", "fit_zener_fast", "zener_covariance"]


def zener_jacobian(f_hz: np.ndarray, z: ZenerFit):
    """``K`` (F,), ``dK/d(K0, Kinf, tau, alpha)`` (F, 4) and ``dK/d log10 f`` (F,) of a fractional Zener fit.

    With ``s = (j w tau)^alpha``: ``dK/dK0 = 1/(1+s)``, ``dK/dKinf = s/(1+s)``,
    ``dK/ds = (Kinf - K0)/(1+s)^2``, ``ds/dtau = alpha s / tau``, ``ds/dalpha = s ln(j w tau)``,
    ``ds/d log10 f = alpha s ln 10``.

    Parameters
    ----------
    f_hz : ndarray, shape (F,)
        (Reduced) frequency, Hz.
    z : ZenerFit
        Parameters (E0, Einf in the fit's unit, here N/m).
    """
    jwt = 1j * 2.0 * np.pi * f_hz * z.tau_s
    s = jwt**z.alpha
    K = (z.E0 + z.Einf * s) / (1.0 + s)
    dKds = (z.Einf - z.E0) / (1.0 + s) ** 2
    J = np.column_stack([1.0 / (1.0 + s), s / (1.0 + s), dKds * z.alpha * s / z.tau_s, dKds * s * np.log(jwt)])
    return K, J, dKds * z.alpha * s * math.log(10.0)


def fit_zener_fast(fr: np.ndarray, K: np.ndarray, noise: float) -> ZenerFit:
    """:func:`fit_zener` from one data-based start, or from its own multi-start when that fit is not clean.

    The start: ``K0``, ``Kinf`` just outside the lowest and highest ``|K|``, ``tau`` where ``|K|`` crosses
    ``sqrt(K0 Kinf)``, ``alpha = 0.5``. The single-start fit is kept when every parameter is identified
    and its rms relative residual is within ``3 sqrt(2) noise + 1e-3`` (``noise``: the curves' own noise
    per real component of ``ln K``; NaN forces the multi-start); else the multi-start runs.

    Parameters
    ----------
    fr : ndarray, shape (P,)
        Reduced frequency, Hz, ascending.
    K : ndarray, shape (P,), complex
        Shifted stiffness, N/m.
    noise : float
        Noise of the curves (see above).
    """
    bounds = (0.0, math.inf)
    mag = np.abs(K)
    lo, hi = float(mag[0]), float(mag[-1])
    if math.isfinite(noise) and hi > 1.05 * lo:
        k0, kinf = 0.95 * lo, 1.05 * hi
        mid = math.sqrt(k0 * kinf)
        env = np.maximum.accumulate(mag)
        f_mid = float(10 ** np.interp(mid, env, np.log10(fr)))
        try:
            z = fit_zener(fr, K, initial=(k0, kinf, 1.0 / (2.0 * math.pi * f_mid), 0.5), modulus_bounds_pa=bounds)
            if z.identified and z.residual_rms <= 3.0 * math.sqrt(2.0) * noise + 1e-3:
                return z
        except DataError:
            pass
    return fit_zener(fr, K, modulus_bounds_pa=bounds)


def zener_covariance(z: ZenerFit, fr: np.ndarray, K: np.ndarray, node_of_point: np.ndarray, shift_cov: np.ndarray):
    """Covariance of (K0, Kinf, tau, alpha): the fit's own plus the shift factors' error carried through the refit.

    The fit minimizes ``|r|^2`` with ``r = (K_model(f aT) - K) / |K|``; a change of the
    shifts moves the optimum by ``dp/ds = -pinv(J_p) J_s`` (``J_s``: ``dr/d log10 aT``),
    so ``cov_p = cov_fit + (dp/ds) cov_s (dp/ds)^T``.

    Parameters
    ----------
    z : ZenerFit
        The fit (its parameters' standard errors and correlation give ``cov_fit``).
    fr : ndarray, shape (P,)
        Reduced frequency of every point, Hz.
    K : ndarray, shape (P,), complex
        Shifted stiffness of every point, N/m.
    node_of_point : ndarray of int, shape (P,)
        Index of each point's temperature in ``shift_cov``.
    shift_cov : ndarray, shape (N, N)
        Covariance of the temperatures' ``log10 aT``, decades^2.

    Returns
    -------
    ndarray, shape (4, 4)
        Covariance of (K0, Kinf, tau, alpha); the fit's own (with its inf/NaN) when that is not finite.
    """
    sd = np.array([p.std_error for p in z.parameters], dtype=float)
    corr = np.asarray(z.correlation, dtype=float) if z.correlation is not None else np.full((4, 4), np.nan)
    cov_fit = corr * np.outer(sd, sd)
    if not np.all(np.isfinite(cov_fit)):
        return cov_fit
    _, Jp, dKdx = zener_jacobian(fr, z)
    w = 1.0 / np.abs(K)
    Jp = Jp * w[:, None]
    Js = np.zeros((fr.size, shift_cov.shape[0]), dtype=complex)
    Js[np.arange(fr.size), node_of_point] = dKdx * w
    G = -np.linalg.pinv(np.concatenate([Jp.real, Jp.imag])) @ np.concatenate([Js.real, Js.imag])
    return cov_fit + G @ shift_cov @ G.T
