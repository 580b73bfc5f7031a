"""Axes as an NVH engineer reads them: log frequency, |K| on a log axis with its band, loss factor or phase.

Small helpers shared by the stiffness figures (:mod:`.joint_stiffness`,
:mod:`.studies`, :mod:`.direct`):

* :func:`set_frequency_axis` -- a log frequency axis when the band spans a decade or more;
* :func:`magnitude_band` -- the 90 % band of ``|K|`` from the standard deviations of Re and Im;
* :func:`loss_or_phase` -- the loss factor ``Im K / Re K`` while ``Re K > 0`` on every line,
  else the phase of ``K`` in degrees (a loss factor runs to +-infinity where ``Re K`` crosses zero);
* :func:`robust_log_limits`, :func:`robust_limits` -- axis limits from the estimate and its band,
  never from outlying per-line scatter.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "LOG_FREQUENCY_MIN_RATIO", "use_log_frequency", "set_frequency_axis", "magnitude_band", "loss_or_phase",
    "loss_or_phase_std", "robust_log_limits", "robust_limits",
]

#: A frequency axis is logarithmic when the band's highest/lowest frequency is at least this.
LOG_FREQUENCY_MIN_RATIO = 10.0


def use_log_frequency(f_hz: np.ndarray) -> bool:
    """True when ``f_hz`` (Hz) is positive and spans at least :data:`LOG_FREQUENCY_MIN_RATIO`."""
    f = np.asarray(f_hz, dtype=float)
    f = f[np.isfinite(f)]
    return bool(f.size > 1 and f.min() > 0 and f.max() / f.min() >= LOG_FREQUENCY_MIN_RATIO)


def set_frequency_axis(ax, f_hz: np.ndarray, label: bool = True, pad: float = 0.0) -> bool:
    """Frequency on ``ax``'s x axis: log scale (plain-number ticks) when :func:`use_log_frequency`, limits at the band.

    ``pad``: margin beyond the band as a fraction of it (of its decades on a
    log axis), so that markers at the ends are drawn whole. Returns True when
    the axis is logarithmic.
    """
    f = np.asarray(f_hz, dtype=float)
    log = use_log_frequency(f)
    if log:
        ax.set_xscale("log")
    if f.size > 1:
        lo, hi = float(np.nanmin(f)), float(np.nanmax(f))
        if log:
            r = (hi / lo) ** pad
            ax.set_xlim(lo / r, hi * r)
        else:
            ax.set_xlim(lo - pad * (hi - lo), hi + pad * (hi - lo))
    if log:  # plain-number labels (2 and 5 of a decade too on a short axis), tick artists only where drawn
        from .fast_axes import plain_log_ticks

        plain_log_ticks(ax.xaxis)
    if label:
        ax.set_xlabel("frequency [Hz]")
    return log


def magnitude_band(k: np.ndarray, std_real: np.ndarray, std_imag: np.ndarray, z: float) -> tuple[np.ndarray, np.ndarray]:
    """``|K| -+ z sigma_|K|``, first order: ``sigma_|K| = sqrt((Re K s_re)^2 + (Im K s_im)^2) / |K|``.

    Parameters
    ----------
    k : ndarray, complex, shape (F,)
    std_real, std_imag : ndarray, shape (F,)
        1-sigma standard deviations of Re K and Im K (independent).
    z : float
        Normal quantile (1.645 for a two-sided 90 % band).

    Returns
    -------
    lo, hi : ndarray, shape (F,)
        The band; ``lo`` may be <= 0 (the magnitude is not determined there).
    """
    mag = np.abs(k)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.hypot(k.real * std_real, k.imag * std_imag) / mag
    s = np.where(mag > 0, s, np.hypot(std_real, std_imag))
    return mag - z * s, mag + z * s


def loss_or_phase(f_hz: np.ndarray, k: np.ndarray, force_phase: bool | None = None) -> tuple[np.ndarray, str]:
    """The loss factor ``Im K / Re K`` while ``Re K > 0`` on every line, else the phase of ``K`` (deg, unwrapped).

    Where the storage stiffness ``Re K`` crosses zero (past an internal mode, or
    a mass-like term) ``Im/Re`` runs to +-infinity and is no loss factor; the
    phase ``atan2(Im K, Re K)`` is continuous there and equals ``atan(eta)``
    below it. It is unwrapped along frequency (a joint's phase passes -180 deg
    past its internal mode), unless that spans more than a turn (noise): then
    it is given in (-180, 180].

    Parameters
    ----------
    f_hz : ndarray, shape (F,)
    k : ndarray, complex, shape (F,)
    force_phase : bool, optional
        True/False to force the phase / the loss factor (e.g. so that several
        curves on one axis agree); default: the phase when ``Re K <= 0`` somewhere.

    Returns
    -------
    values : ndarray, shape (F,)
    kind : {"loss factor", "phase"}
    """
    k = np.asarray(k, dtype=complex)
    phase = bool(np.any(k.real <= 0)) if force_phase is None else bool(force_phase)
    if not phase:
        with np.errstate(divide="ignore", invalid="ignore"):
            return k.imag / k.real, "loss factor"
    order = np.argsort(f_hz)
    out = np.empty(k.shape)
    out[order] = np.degrees(np.unwrap(np.angle(k[order])))
    if out.size and np.nanmedian(out) > 180:  # unwrapping may start a turn away: keep the phase near (-180, 180]
        out -= 360 * np.round(np.nanmedian(out) / 360)
    if out.size and np.nanmax(out) - np.nanmin(out) > 360:  # noisy data: unwrapping drifts by turns, show (-180, 180]
        out = np.degrees(np.angle(k))
    return out, "phase"


def loss_or_phase_std(k: np.ndarray, std_real: np.ndarray, std_imag: np.ndarray, kind: str) -> np.ndarray:
    """First-order 1-sigma of :func:`loss_or_phase`'s values (independent Re and Im errors).

    Loss factor ``eta = Im/Re``: ``sqrt(s_im^2 + eta^2 s_re^2) / |Re K|``;
    phase (deg): ``(180/pi) sqrt((Re K s_im)^2 + (Im K s_re)^2) / |K|^2``.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "loss factor":
            eta = k.imag / k.real
            return np.hypot(std_imag, eta * std_real) / np.abs(k.real)
        return np.degrees(np.hypot(k.real * std_imag, k.imag * std_real) / np.abs(k) ** 2)


def robust_log_limits(*arrays, band: tuple | None = None, pad: float = 1.25, decades: float = 1.0) -> tuple[float, float] | None:
    """Log-axis limits covering the positive values of ``arrays`` (estimate, truth) and their band, not outliers.

    The limits span the smallest to the largest value of ``arrays`` (times
    ``1/pad``, ``pad``), widened to the ``band`` (lo, hi) but by at most
    ``decades`` beyond them: a band reaching zero, or a few lines of huge
    uncertainty, must not stretch the axis over decades and flatten the
    estimate. None when nothing is positive and finite.
    """
    def positive(a):
        v = np.ravel(np.asarray(a, dtype=float))
        return v[np.isfinite(v) & (v > 0)]

    vals = np.concatenate([positive(a) for a in arrays if a is not None] or [np.empty(0)])
    if not vals.size:
        return None
    lo, hi = float(vals.min()), float(vals.max())
    if band is not None:
        blo, bhi = positive(band[0]), positive(band[1])
        if blo.size:
            lo = min(lo, max(float(blo.min()), lo / 10 ** decades))
        if bhi.size:
            hi = max(hi, min(float(bhi.max()), hi * 10 ** decades))
    return lo / pad, hi * pad


def robust_limits(*arrays, percentile: float = 1.0, pad: float = 0.08, include: tuple = ()) -> tuple[float, float] | None:
    """Linear-axis limits covering the ``percentile``..``100 - percentile`` range of ``arrays``, padded.

    ``include`` values (e.g. 0) are always inside. None when nothing is finite.
    """
    vals = np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in arrays if a is not None] + [np.asarray(include, float)])
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return None
    lo, hi = np.percentile(vals, [percentile, 100 - percentile])
    lo, hi = min(lo, *include) if include else lo, max(hi, *include) if include else hi
    width = hi - lo if hi > lo else max(abs(hi), 1.0)
    return float(lo - pad * width), float(hi + pad * width)
