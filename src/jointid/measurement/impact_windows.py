"""Force and exponential windows of impact tests, and the exponential-window correction.

Processing steps 2-4 of :func:`jointid.measurement.impact.estimate_frfs`; ``t_start`` is the
start of the main force pulse (:func:`jointid.measurement.impact_checks.main_pulse`).

2. **Force window** (optional, ``force_window_s``): 1 on
   ``[t_start - force_pretrigger_s, t_start - force_pretrigger_s + force_window_s]``
   with ``t_start`` the start of the main pulse, half-cosine tapers of
   ``force_taper_s`` on both sides, 0 elsewhere. It removes the force
   channel's noise outside the pulse (which would bias H1 low). It must
   contain the whole pulse.
3. **Exponential window** (optional, ``exp_tau_s``): ``w(t) = exp(-(t - t0)/tau)``
   for ``t >= t0 = t_start - force_pretrigger_s`` and 1 before, applied to the
   response *and* to the force. Because the response before the impact is zero,
   ``w y = (w h) * (w f)`` exactly, so the estimate is the FRF of ``h(t) e^{-t/tau}``:

       H_windowed(j w) = H(j w + 1/tau)                              (Laplace variable)

   i.e. every pole ``lambda_r = -sigma_r + j w_dr`` moves to
   ``lambda_r - 1/tau`` with unchanged residue: the window adds the decay rate
   ``sigma_w = 1/tau`` (rad/s) to every mode, a loss-factor increase
   ``Delta eta_r = 2 sigma_w / w_r`` (viscous: ``Delta zeta_r = sigma_w / w_r``).
4. **Window correction** (``correct_exponential=True``): for each band of
   ``mode_bands_hz`` (one isolated mode per band; detected automatically from
   the peaks of ``sum |H|^2`` when not given), a common-denominator
   second-order rational fraction ``N_m(s) / (s^2 + a1 s + a0)`` is fitted to
   all FRFs (iterated Sanathanan-Koerner weighting), giving the windowed pole
   ``lambda_w`` and each FRF's residue ``R_m``. The pole is moved back,
   ``lambda = lambda_w + 1/tau``, and the difference of the two modal terms is
   added to the measured FRF on all lines::

       H_corr = H_windowed + sum_r [ R/(s - lambda) + R*/(s - lambda*)
                                     - R/(s - lambda_w) - R*/(s - lambda_w*) ]

   which keeps the measured data (noise, other modes, residuals) and only
   replaces the modal term. Exact for viscously damped, well separated modes
   that the fit captures; for structural damping it is the viscous equivalent
   at resonance (``eta = 2 zeta``), accurate for light damping. Limits: modes
   closer than a few windowed half-power bandwidths, or a window much shorter
   than the mode's own decay (``1/tau >> sigma_r``, the loss factor then
   results from a small difference of two large numbers) make it unreliable;
   the coherence is that of the windowed data.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np

from ..errors import DataError

__all__ = ["WindowMode", "force_window", "exponential_window", "correct_exponential_window"]


class WindowMode(NamedTuple):
    """A mode fitted for the exponential-window correction (viscous equivalent, ``eta = 2 zeta``)."""

    band_hz: tuple[float, float]
    frequency_windowed_hz: float
    loss_factor_windowed: float
    frequency_hz: float
    loss_factor: float


def force_window(n_samples: int, sample_rate_hz: float, start_s: np.ndarray, length_s: float, taper_s: float = 0.0) -> np.ndarray:
    """Rectangular window with half-cosine tapers, one row per hit.

    Parameters
    ----------
    n_samples : int
        Record length.
    sample_rate_hz : float
        Sampling rate, Hz.
    start_s : array_like, shape (n_hits,)
        Start of the flat part per hit, s.
    length_s : float
        Length of the flat part, s.
    taper_s : float
        Length of the half-cosine taper before and after the flat part, s.

    Returns
    -------
    ndarray, shape (n_hits, n_samples)
        1 on the flat part, 0 outside the tapers.
    """
    t = np.arange(n_samples) / sample_rate_hz
    a = np.asarray(start_s, dtype=float).reshape(-1, 1)
    b = a + length_s
    if taper_s > 0:
        up = np.clip((t - (a - taper_s)) / taper_s, 0.0, 1.0)
        down = np.clip((b + taper_s - t) / taper_s, 0.0, 1.0)
        return 0.25 * (1.0 - np.cos(np.pi * up)) * (1.0 - np.cos(np.pi * down))
    tol = 1e-9 / sample_rate_hz
    return ((t >= a - tol) & (t <= b + tol)).astype(float)


def exponential_window(n_samples: int, sample_rate_hz: float, start_s: np.ndarray, tau_s: float) -> np.ndarray:
    """``exp(-(t - t_start)/tau)`` after ``t_start`` and 1 before, one row per hit.

    Parameters
    ----------
    n_samples : int
        Record length.
    sample_rate_hz : float
        Sampling rate, Hz.
    start_s : array_like, shape (n_hits,)
        Start of the decay per hit (start of the impact), s.
    tau_s : float
        Time constant, s; the window adds the decay rate ``1/tau`` rad/s to every mode.

    Returns
    -------
    ndarray, shape (n_hits, n_samples)
    """
    t = np.arange(n_samples) / sample_rate_hz
    a = np.asarray(start_s, dtype=float).reshape(-1, 1)
    return np.exp(-np.clip(t - a, 0.0, None) / tau_s)



def _detect_mode_bands(hz: np.ndarray, H: np.ndarray) -> list[tuple[float, float]]:
    """Bands around the peaks (>= 10 dB prominence) of ``sum |H|^2``: +-3 half-power half-widths."""
    mif = np.sum(np.abs(H.reshape(H.shape[0], -1)) ** 2, axis=1)
    if not np.any(mif > 0):
        return []
    db = 10.0 * np.log10(np.maximum(mif, mif.max() * 1e-30))
    from scipy.signal import find_peaks  # scipy.signal takes ~1-2 s to import: only when a window is proposed

    peaks, _ = find_peaks(db, prominence=10.0)
    bands = []
    for i, p in enumerate(peaks):
        under = np.flatnonzero(mif <= mif[p] / 2.0)
        lo = under[under < p].max(initial=0)
        hi = under[under > p].min(initial=mif.size - 1)
        hw = max((hz[hi] - hz[lo]) / 2.0, hz[1] - hz[0])
        a, b = hz[p] - 3.0 * hw, hz[p] + 3.0 * hw
        if i > 0:
            a = max(a, 0.5 * (hz[peaks[i - 1]] + hz[p]))
        if i < len(peaks) - 1:
            b = min(b, 0.5 * (hz[peaks[i + 1]] + hz[p]))
        bands.append((float(a), float(b)))
    return bands


def _fit_pole(s: np.ndarray, H: np.ndarray, n_iter: int = 8):
    """Common-denominator SDOF rational fit ``N_m(s)/(s^2 + a1 s + a0)`` (s scaled).

    Sanathanan-Koerner iterations (weights ``1/|D_previous|``); the numerators
    (degree 2, one per FRF) are eliminated by orthogonal projection, so each
    iteration is one real least-squares problem in ``(a0, a1)``.

    Parameters
    ----------
    s : ndarray, shape (K,)
        Laplace variable ``j w / w_c`` of the band's lines (scaled by the band centre).
    H : ndarray, shape (K, M)
        FRFs in the band (scaled to unit RMS per column).

    Returns
    -------
    a0, a1 : float
        Denominator ``s^2 + a1 s + a0`` (scaled variable).
    b : ndarray, shape (3, M)
        Real numerator coefficients ``b0 + b1 s + b2 s^2`` per FRF.
    """
    K, M = H.shape
    w = np.ones(K)
    V = np.stack([np.ones_like(s), s, s * s], axis=1)  # (K, 3)
    for _ in range(n_iter):
        Phi = w[:, None] * V
        Phir = np.concatenate([Phi.real, Phi.imag])  # (2K, 3)
        Q, _ = np.linalg.qr(Phir)
        Psi = -(w[:, None, None] * H[:, :, None] * V[:, None, :2])  # (K, M, 2)  columns a0, a1
        rhs = w[:, None] * H * s[:, None] ** 2  # (K, M)
        Psir = np.concatenate([Psi.real, Psi.imag])  # (2K, M, 2)
        rr = np.concatenate([rhs.real, rhs.imag])  # (2K, M)
        Pp = Psir - np.einsum("ik,kmj->imj", Q, np.einsum("ik,imj->kmj", Q, Psir))
        Pr = rr - Q @ (Q.T @ rr)
        a, *_ = np.linalg.lstsq(Pp.reshape(-1, 2), Pr.reshape(-1), rcond=None)
        D = s * s + a[1] * s + a[0]
        if not np.all(np.abs(D) > 0):
            break
        w = 1.0 / np.abs(D)
    Phi = w[:, None] * V
    Phir = np.concatenate([Phi.real, Phi.imag])
    rhs = w[:, None] * H * D[:, None]
    b, *_ = np.linalg.lstsq(Phir, np.concatenate([rhs.real, rhs.imag]), rcond=None)  # (3, M)
    return float(a[0]), float(a[1]), b


def correct_exponential_window(
    frequency_hz: np.ndarray,
    H: np.ndarray,
    tau_s: float,
    mode_bands_hz: Sequence[tuple[float, float]] | None = None,
    strict: bool | None = None,
) -> tuple[np.ndarray, tuple[WindowMode, ...], tuple[str, ...]]:
    """Remove an exponential window's added damping ``1/tau`` from FRFs, mode by mode.

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz (uniform or not).
    H : ndarray, shape (F, ...)
        Windowed FRFs (any kind; all share the poles).
    tau_s : float
        Time constant of the window, s.
    mode_bands_hz : sequence of (lo, hi), optional
        One isolated mode per band, Hz. None: detected at the >= 10 dB peaks of
        ``sum |H|^2`` (bands that cannot be fitted are then skipped and noted).
    strict : bool or None
        Raise on a band that cannot be fitted (True) or skip it with a note
        (False); None: strict exactly when ``mode_bands_hz`` is given.

    Returns
    -------
    H_corrected : ndarray, shape of H
        ``H + sum_r [modal term with pole lambda_w + 1/tau - modal term with lambda_w]``.
    modes : tuple of WindowMode
        Windowed and corrected frequency / loss factor (``eta = 2 zeta``) per band.
    notes : tuple of str
        Bands skipped (auto-detected only).

    Raises
    ------
    DataError
        A given band holds fewer than 6 lines, or its fit gives no oscillating
        pole, or a decay rate below ``1/tau`` (the fitted mode cannot carry the
        window's damping: band holds no isolated mode, or noise).
    """
    hz = np.asarray(frequency_hz, dtype=float)
    H = np.asarray(H, dtype=complex)
    shape = H.shape
    Hm = H.reshape(shape[0], -1)
    auto = mode_bands_hz is None
    if strict is None:
        strict = not auto  # bands the user gave must fit; detected ones may be skipped with a note
    bands = _detect_mode_bands(hz, Hm) if auto else [tuple(map(float, b)) for b in mode_bands_hz]
    out = Hm.copy()
    modes, notes = [], []
    sigma_w = 1.0 / tau_s
    if auto and not bands:  # nothing corrected: say so (the window's damping stays in every resonance)
        notes.append(f"exponential window (tau {1e3 * tau_s:g} ms) not corrected: no resonance stands 10 dB above its "
                     f"surroundings in these FRFs (the window's decay rate 1/tau = {sigma_w:.4g} 1/s flattens the peaks), "
                     "so the FRFs keep its damping and their peaks are too low; give the modes' bands (--mode-band-hz) "
                     "or use a longer tau")
    for lo, hi in bands:
        m = (hz >= lo) & (hz <= hi)
        try:
            if m.sum() < 6:
                raise DataError(f"mode band {lo:g}-{hi:g} Hz holds {int(m.sum())} lines; widen it to >= 6 lines")
            wc = 2.0 * np.pi * 0.5 * (lo + hi)
            s = 1j * 2.0 * np.pi * hz[m] / wc
            scale = np.sqrt(np.mean(np.abs(Hm[m]) ** 2, axis=0))
            scale[scale == 0] = 1.0
            a0, a1, b = _fit_pole(s, Hm[m] / scale)
            disc = a1 * a1 - 4.0 * a0
            if not disc < 0:
                raise DataError(
                    f"mode band {lo:g}-{hi:g} Hz: the fit found no oscillating mode; give a band around one resonance"
                )
            lam_w = complex(-a1 / 2.0, math.sqrt(-disc) / 2.0)  # scaled by wc
            lam = lam_w + sigma_w / wc
            if not lam.real < 0:
                raise DataError(
                    f"mode band {lo:g}-{hi:g} Hz: the fitted decay rate {-lam_w.real * wc:.4g} rad/s is below the "
                    f"window's 1/tau = {sigma_w:.4g} rad/s; the band holds no clean mode or tau is wrong"
                )
            num = b[0] + b[1] * lam_w + b[2] * lam_w**2  # (M,)
            R = num / (lam_w - np.conj(lam_w)) * scale
            sa = 1j * 2.0 * np.pi * hz[:, None] / wc
            delta = (
                R / (sa - lam) + np.conj(R) / (sa - np.conj(lam)) - R / (sa - lam_w) - np.conj(R) / (sa - np.conj(lam_w))
            )
            out += delta
            wn_w, wn = abs(lam_w) * wc, abs(lam) * wc
            modes.append(
                WindowMode((lo, hi), wn_w / (2 * np.pi), -2.0 * lam_w.real / abs(lam_w), wn / (2 * np.pi), -2.0 * lam.real / abs(lam))
            )
        except DataError as e:
            if strict:
                raise
            notes.append(f"not corrected: {e}")
    return out.reshape(shape), tuple(modes), tuple(notes)


