"""Horizontal shift between two temperature curves from their overlap (time-temperature superposition).

Each curve is its complex logarithm ``y = ln K = ln|K| + j phi`` on
``x = log10 f``: for a relative error ``e`` of the complex stiffness both
``ln|K|`` and the loss angle ``phi = arctan(loss factor)`` carry the same
error ``e``, so one complex residual weighs the magnitude and the loss factor
alike. Curve ``j`` shifted by ``d`` decades (``x_j + d``) overlaps curve ``i``
when both follow one smooth function there.

Estimation of ``d = log10 a_j - log10 a_i``:

1. **Scan**: for ``d`` on a 0.01-decade grid over every shift that puts at
   least 2 points of each curve inside the other's range, the mean squared
   mismatch of each curve's points against the other's linear interpolant.
2. **Refine**: the points of both curves inside the overlap window
   ``[max(min x_i, min x_j + d), min(max x_i, max x_j + d)]`` are fitted
   jointly by one complex polynomial ``P`` (degree 1-3 by the number of points)
   in ``x`` and the shift: residuals ``y_i - P(x_i)`` and ``y_j - P(x_j + d)``
   (weighted by ``|K| / std |K|`` when given), least squares in ``(d, P)``;
   the window is re-selected until it no longer changes.
   The standard error of ``d`` is ``s^2 (J^T J)^-1`` of that fit (it includes
   the polynomial's model error in ``s``).
3. **Accept** the overlap only if the joint fit's rms residual is at most
   ``ratio`` x the noise of the two curves (each fitted alone by a cubic over
   its whole range) or the ``floor``: a shift that only makes two different
   curves touch leaves a large misfit and is refused, not forced.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..fit_statistics import jacobian_covariance

__all__ = ["PairShift", "estimate_pair_shift", "curve_noise", "SCAN_STEP_DECADES"]

#: Grid step of the initial scan, decades.
SCAN_STEP_DECADES = 0.01


@dataclass(frozen=True)
class PairShift:
    """Relative shift of curve j onto curve i, ``d = log10 a_j - log10 a_i`` (decades).

    Parameters
    ----------
    shift : float
        ``d``, decades (NaN when there is no usable overlap).
    std : float
        Standard error of ``d``, decades.
    rms_residual : float
        rms of the joint fit's residuals (``ln K`` units, or whitened when weighted).
    noise : float
        Noise level of the two curves alone (same units).
    points_i, points_j : int
        Points of each curve inside the overlap window.
    accepted : bool
        The overlap passed the misfit check.
    reason : str
        Why it was refused (empty when accepted).
    """

    shift: float
    std: float
    rms_residual: float
    noise: float
    points_i: int
    points_j: int
    accepted: bool
    reason: str = ""


def _vander(u: np.ndarray, deg: int) -> np.ndarray:
    return u[:, None] ** np.arange(deg + 1)[None, :]


def curve_noise(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> float:
    """rms residual of one curve's complex log fitted alone by a cubic (fewer points: lower degree); NaN if too few."""
    n = x.size
    deg = 3 if n >= 6 else (2 if n >= 5 else (1 if n >= 4 else -1))
    if deg < 0:
        return math.nan
    u = (x - x.mean()) / max(np.ptp(x) / 2.0, 1e-12)
    V = _vander(u, deg) * w[:, None]
    c, *_ = np.linalg.lstsq(V, y * w, rcond=None)
    r = y * w - V @ c
    dof = 2 * n - 2 * (deg + 1)
    return float(np.sqrt(np.sum(np.abs(r) ** 2) / dof))


def _cinterp(q, x, y):
    return np.interp(q, x, y.real) + 1j * np.interp(q, x, y.imag)


def _scan(xi, yi, wi, xj, yj, wj) -> float:
    lo, hi = xi.min() - xj.max(), xi.max() - xj.min()
    d = np.arange(lo, hi + 0.5 * SCAN_STEP_DECADES, SCAN_STEP_DECADES)
    qj = xj[None, :] + d[:, None]
    in_j = (qj >= xi.min() - 1e-12) & (qj <= xi.max() + 1e-12)
    ej = np.where(in_j, np.abs(yj[None, :] - _cinterp(qj.ravel(), xi, yi).reshape(qj.shape)) * wj[None, :], 0.0)
    qi = xi[None, :] - d[:, None]
    in_i = (qi >= xj.min() - 1e-12) & (qi <= xj.max() + 1e-12)
    ei = np.where(in_i, np.abs(yi[None, :] - _cinterp(qi.ravel(), xj, yj).reshape(qi.shape)) * wi[None, :], 0.0)
    ni, nj = in_i.sum(1), in_j.sum(1)
    ok = (ni >= 2) & (nj >= 2)
    if not ok.any():
        return math.nan
    cost = np.where(ok, (np.sum(ej**2, 1) + np.sum(ei**2, 1)) / np.maximum(ni + nj, 1), np.inf)
    return float(d[int(np.argmin(cost))])


def _window(xi, xj, d):
    lo = max(xi.min(), xj.min() + d)
    hi = min(xi.max(), xj.max() + d)
    tol = 1e-9
    return (xi >= lo - tol) & (xi <= hi + tol), (xj + d >= lo - tol) & (xj + d <= hi + tol)


def _joint_fit(xi, yi, wi, xj, yj, wj, d0):
    ni, nj = xi.size, xj.size
    n = ni + nj
    deg = 3 if n >= 8 else (2 if n >= 5 else 1)
    center = 0.5 * (np.concatenate([xi, xj + d0]).min() + np.concatenate([xi, xj + d0]).max())
    half = max(0.5 * np.ptp(np.concatenate([xi, xj + d0])), 1e-6)
    w = np.concatenate([wi, wj])
    y = np.concatenate([yi, yj])

    def split(p):
        c = p[1 : deg + 2] + 1j * p[deg + 2 :]
        return p[0], c

    def resid(p):
        d, c = split(p)
        u = (np.concatenate([xi, xj + d]) - center) / half
        r = (y - _vander(u, deg) @ c) * w
        return np.concatenate([r.real, r.imag])

    u0 = (np.concatenate([xi, xj + d0]) - center) / half
    V = _vander(u0, deg) * w[:, None]
    c0, *_ = np.linalg.lstsq(V, y * w, rcond=None)
    p0 = np.concatenate([[d0], c0.real, c0.imag])
    sol = least_squares(resid, p0, method="lm", xtol=1e-13, ftol=1e-13, max_nfev=500)
    cov = jacobian_covariance(sol.jac, sol.fun)
    dof = 2 * n - p0.size
    rms = float(np.sqrt(np.sum(sol.fun**2) / dof)) if dof > 0 else math.nan
    return float(sol.x[0]), float(math.sqrt(cov[0, 0])), rms


def estimate_pair_shift(xi, yi, wi, xj, yj, wj, *, ratio: float = 3.0, floor: float = 2e-3) -> PairShift:
    """Shift ``d`` (decades) that lays curve j (``x_j + d``) onto curve i, with its standard error and an overlap check.

    Parameters
    ----------
    xi, xj : ndarray, shape (Fi,), (Fj,)
        ``log10`` frequency of each curve, ascending.
    yi, yj : ndarray, complex
        ``ln K`` of each curve (``ln|K| + j angle``).
    wi, wj : ndarray
        Weights ``|K| / std|K|`` (ones when the errors are unknown).
    ratio : float
        Largest accepted joint-fit rms residual over the curves' own noise.
    floor : float
        Misfit always accepted (``ln K`` units), so noise-free curves that a
        cubic does not fit exactly still overlap.

    Returns
    -------
    PairShift
    """
    noise = float(np.nanmax([curve_noise(xi, yi, wi), curve_noise(xj, yj, wj), 0.0]))
    d = _scan(xi, yi, wi, xj, yj, wj)
    if not math.isfinite(d):
        return PairShift(math.nan, math.nan, math.nan, noise, 0, 0, False,
                         "fewer than 2 lines of each curve can overlap at any shift")
    sel = None
    std = rms = math.nan
    for _ in range(6):
        si, sj = _window(xi, xj, d)
        if si.sum() < 2 or sj.sum() < 2:
            return PairShift(math.nan, math.nan, math.nan, noise, int(si.sum()), int(sj.sum()), False,
                             "the best-matching shift leaves fewer than 2 lines of each curve in the overlap "
                             "(the curves only touch)")
        key = (tuple(si), tuple(sj))
        if key == sel:
            break
        sel = key
        d, std, rms = _joint_fit(xi[si], yi[si], wi[si], xj[sj], yj[sj], wj[sj], d)
    si, sj = _window(xi, xj, d)
    limit = max(ratio * noise, floor)
    ok = math.isfinite(rms) and rms <= limit and math.isfinite(std)
    if ok:
        reason = ""
    elif not math.isfinite(std):
        reason = "the curves are flat where they overlap: the shift is not determined"
    else:
        reason = (f"best overlap misfit {rms:.3g} exceeds {limit:.3g} ({ratio:g} x the curves' noise "
                  f"{noise:.3g} or the floor {floor:g}, ln K units)")
    return PairShift(d, std, rms, noise, int(si.sum()), int(sj.sum()), bool(ok), reason)
