"""Smoothing of a joint term over frequency: a weighted P-spline with lambda by GCV.

A joint's dynamic stiffness is smooth in frequency (the beam's resonances make
its *estimates* noisy, not the joint itself), except at internal joint modes,
which are as wide as the elastomer's loss factor (``eta f``: 140 Hz for
Material B at 950 Hz). Each series ``y`` (the real or imaginary part of one
term, one value per line, with variance ``v``) is fitted by a cubic B-spline
``B a`` with ``K`` basis functions on a uniform knot grid, penalized by the
second differences of its coefficients (Eilers & Marx 1996)::

    min_a  sum_f (y_f - (B a)_f)^2 / v_f  +  lam ||D2 a||^2

``lam`` minimizes the generalized cross-validation score
``F rss / (F - tr H)^2`` over a grid (Craven & Wahba 1979), computed for every
``lam`` at once from one generalized eigendecomposition, the residuals from the
K coefficients (nothing of size F x grid). The uncertainty is the
Bayesian posterior covariance ``B (B^T W B + lam D^T D)^-1 B^T`` (Wahba 1983),
whose intervals include the smoothing bias on average (Nychka 1988); its
diagonal needs only the first diagonals of the coefficients' covariance (banded B).

Caveats: knots every ``band / K`` (``K`` <= :data:`MAX_BASIS`) resolve features
a few knot spacings wide, not sharper ones; the variances ``v`` must be on an
absolute scale for the bands to mean anything: :func:`residual_scale` says by how much the residuals
contradict them, band by band of lines (:mod:`.fallback_bands` applies it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ...parallel import single_threaded_blas
from ..bspline_basis import bspline_design_sparse, clamped_uniform_knots

__all__ = ["SmoothedSeries", "smooth_series", "bspline_basis", "residual_scale", "MAX_BASIS", "LOG_LAMBDA_GRID",
           "RESIDUAL_WINDOW_EDF", "RESIDUAL_MIN_LINES", "RESIDUAL_FALSE_ALARM", "running_mean",
           "resolution_lines"]

#: Most basis functions of the spline (knot spacing = band / MAX_BASIS at most).
MAX_BASIS = 200
#: Order of the difference penalty on the spline coefficients.
PENALTY_ORDER = 2
#: The smoothing parameters searched, log10 of lambda relative to the data's scale (GCV picks one).
LOG_LAMBDA_GRID = np.linspace(-10.0, 8.0, 73)
#: The residual scale's window holds this many of the smoother's resolution cells (``n / edf`` lines each).
RESIDUAL_WINDOW_EDF = 2.0
#: The residual scale's window holds at least this many lines.
RESIDUAL_MIN_LINES = 32
#: Probability that the residual scale widens any band of a series whose variances are right (Bonferroni over windows).
RESIDUAL_FALSE_ALARM = 0.01


@dataclass(frozen=True, eq=False)
class SmoothedSeries:
    """A smoothed series: values, posterior variance, lambda and effective degrees of freedom."""

    value: np.ndarray
    variance: np.ndarray
    lam: float
    edf: float


def bspline_basis(x: np.ndarray, n_basis: int, degree: int = 3):
    """Cubic (``degree``) B-splines on uniform knots over ``x[0]..x[-1]``, shape (F, n_basis), sparse CSR."""
    u = (x - x[0]) / (x[-1] - x[0])
    return bspline_design_sparse(np.clip(u, 0.0, 1.0), clamped_uniform_knots(n_basis, degree), degree)


def smooth_series(x: np.ndarray, y: np.ndarray, variance: np.ndarray, n_basis: int | None = None) -> SmoothedSeries:
    """Smooth ``y(x)`` with weights ``1 / variance`` (P-spline, lambda by GCV).

    Parameters
    ----------
    x : ndarray, shape (F,)
        Increasing abscissa (Hz).
    y : ndarray, shape (F,)
        Values; non-finite values (or non-finite/zero-weight variances) are ignored.
    variance : ndarray, shape (F,)
        Variance of each value (absolute scale).
    n_basis : int, optional
        Number of B-spline basis functions (default ``min(F // 2, MAX_BASIS)``).

    Notes
    -----
    Every matrix is K x K or banded (K <= 200), so BLAS runs on one thread: its
    threads only contend on such sizes (many times slower on a loaded machine).
    """
    with single_threaded_blas():
        return _smooth(np.asarray(x, float), y, variance, n_basis)


def resolution_lines(n: int, edf: float) -> int:
    """Half-width (lines) of the window of :func:`residual_scale`: ``max(RESIDUAL_MIN_LINES, RESIDUAL_WINDOW_EDF n / edf) // 2``."""
    return max(RESIDUAL_MIN_LINES, int(np.ceil(RESIDUAL_WINDOW_EDF * n / max(edf, 1.0)))) // 2


def running_mean(values: np.ndarray, half: int) -> np.ndarray:
    """Mean of ``values`` over ``2 half + 1`` lines about each line (fewer at the ends; non-finite values left out).

    Parameters
    ----------
    values : ndarray, shape (F,)
        Any unit.
    half : int
        Half-width of the window (lines).

    Returns
    -------
    ndarray, shape (F,)
        The running mean (unit of ``values``; NaN where the window holds no finite value).
    """
    x = np.asarray(values, float)
    ok = np.isfinite(x)
    cs, cn = np.r_[0.0, np.cumsum(np.where(ok, x, 0.0))], np.r_[0.0, np.cumsum(ok)]
    i = np.arange(x.size)
    lo, hi = np.clip(i - half, 0, x.size), np.clip(i + half + 1, 0, x.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (cs[hi] - cs[lo]) / (cn[hi] - cn[lo])


def residual_scale(y: np.ndarray, variance: np.ndarray, smoothed: SmoothedSeries) -> np.ndarray:
    """Per-line factor (>= 1) on ``smoothed.variance`` where the residuals say the data err more than ``variance``.

    The posterior variance of :func:`smooth_series` takes ``variance`` as absolute; when the data's errors are larger
    (an FRF variance from the coherence that misses part of the error, e.g. hammer records without a force window),
    its bands are too narrow by the same factor. Over a window of ``max(RESIDUAL_MIN_LINES, RESIDUAL_WINDOW_EDF n /
    edf)`` lines about each line, the whitened residuals' sum ``sum (y - s)^2 / v`` is compared with its degrees of
    freedom ``sum (1 - h)`` (``h = smoothed.variance / v``: the hat matrix's diagonal); where the ratio exceeds the
    chi^2 quantile ``1 - RESIDUAL_FALSE_ALARM / n_windows`` for that many degrees of freedom it is the factor, else 1
    (a series with the right variances keeps its bands, with probability ``1 - RESIDUAL_FALSE_ALARM``).

    Parameters
    ----------
    y : ndarray, shape (F,)
        The values smoothed (any unit).
    variance : ndarray, shape (F,)
        Their stated variance (unit of ``y`` squared); non-finite or non-positive: line left out.
    smoothed : SmoothedSeries
        :func:`smooth_series` of ``y`` with ``variance``.

    Returns
    -------
    ndarray, shape (F,)
        The factor (dimensionless, >= 1; 1 on lines left out).

    Notes
    -----
    Only the part of the error that varies faster than the smoother's resolution shows in the residuals: an error
    smooth over frequency is followed by the smoother and is not seen here.
    """
    from scipy.special import gammaincinv  # chi^2 quantile: 2 P^-1(d / 2, q) (lighter than scipy.stats)

    y, v = np.asarray(y, float), np.asarray(variance, float)
    ok = np.isfinite(y) & np.isfinite(v) & (v > 0) & np.isfinite(smoothed.value) & np.isfinite(smoothed.variance)
    out = np.ones(y.size)
    n = int(ok.sum())
    if n < 2 * RESIDUAL_MIN_LINES:
        return out
    r = (y[ok] - smoothed.value[ok]) ** 2 / v[ok]
    dof = np.clip(1.0 - smoothed.variance[ok] / v[ok], 0.0, 1.0)
    half = resolution_lines(n, smoothed.edf)
    cr, cd = np.r_[0.0, np.cumsum(r)], np.r_[0.0, np.cumsum(dof)]
    i = np.arange(n)
    lo, hi = np.clip(i - half, 0, n), np.clip(i + half + 1, 0, n)
    rss, d = cr[hi] - cr[lo], np.maximum(cd[hi] - cd[lo], 1.0)
    windows = max(n / (2 * half + 1), 1.0)
    limit = 2.0 * gammaincinv(d / 2.0, 1.0 - RESIDUAL_FALSE_ALARM / windows) / d
    ratio = rss / d
    out[ok] = np.where(ratio > limit, ratio, 1.0)
    return out


def _smooth(x: np.ndarray, y: np.ndarray, variance: np.ndarray, n_basis: int | None) -> SmoothedSeries:
    F = x.size
    ok = np.isfinite(y) & np.isfinite(variance) & (variance > 0)
    K = int(n_basis or min(max(F // 2, 4), MAX_BASIS))
    K = max(4, min(K, int(ok.sum()) - 1))
    B = bspline_basis(x, K)
    w = np.where(ok, 1.0 / np.where(ok, variance, 1.0), 0.0)
    yz = np.where(ok, y, 0.0)
    BW = B.multiply(w[:, None]).tocsr()
    BWB = (B.T @ BW).toarray()
    BWy = B.T @ (w * yz)
    D = np.diff(np.eye(K), PENALTY_ORDER, axis=0)
    P = D.T @ D
    # generalized eigenproblem P u = s BWB u with BWB = L L^T: one decomposition serves every lambda
    jitter = 1e-12 * np.trace(BWB) / K
    L = np.linalg.cholesky(BWB + jitter * np.eye(K))
    Li = sla.solve_triangular(L, np.eye(K), lower=True)
    s, U = np.linalg.eigh(Li @ P @ Li.T)
    s = np.clip(s, 0.0, None)
    T = Li.T @ U  # a = T diag(1 / (1 + lam s)) T^T BWy
    c = T.T @ BWy
    scale = np.trace(BWB) / max(np.trace(P), 1e-300)
    lams = scale * 10.0**LOG_LAMBDA_GRID
    filt = 1.0 / (1.0 + lams[None, :] * s[:, None])  # (K, G)
    a = T @ (c[:, None] * filt)  # (K, G): coefficients for every lambda
    # rss(lam) = ||W^1/2 (y - B a)||^2 split about the lam -> 0 fit a0 (exact algebra, no (F, G) array):
    # rss0 + 2 q^T (a0 - a) + (a0 - a)^T BWB (a0 - a), with r0 = y - B a0 and q = B^T W r0 (~0)
    a0 = T @ c
    r0 = yz - B @ a0
    q = BW.T @ r0
    d = a0[:, None] - a
    rss = np.dot(w * r0, r0) + 2.0 * (q @ d) + np.einsum("kg,kg->g", d, BWB @ d)
    n = int(ok.sum())
    edf = filt.sum(axis=0)
    gcv = n * rss / np.maximum(n - edf, 1e-9) ** 2
    g = int(np.argmin(gcv))
    return SmoothedSeries(B @ a[:, g], _posterior_variance(B, T, filt[:, g]), float(lams[g]), float(edf[g]))


def _posterior_variance(B, T: np.ndarray, filt: np.ndarray) -> np.ndarray:
    """``diag(B C B^T)`` with ``C = T diag(filt) T^T``, shape (F,), from C's first diagonals.

    Row f of a B-spline design has nonzeros on ``degree + 1`` consecutive columns
    ``j_f, j_f + 1, ...``, so ``(B C B^T)_ff = sum_ij b_i b_j C[j_f + i, j_f + j]``
    needs only the diagonals ``|i - j| <= degree`` of C.
    """
    C = (T * filt[None, :]) @ T.T
    nnz = np.diff(B.indptr)
    k = int(nnz[0]) if nnz.size else 0
    idx = B.indices.reshape(-1, k) if k and np.all(nnz == k) else None
    if idx is None or np.any(idx - idx[:, :1] != np.arange(k)[None, :]):
        return np.asarray((B @ (T * np.sqrt(filt)[None, :])) ** 2).sum(axis=1)
    val, j0 = B.data.reshape(-1, k), idx[:, 0]
    var = np.zeros(j0.size)
    for off in range(k):
        diag = np.diagonal(C, off)
        for i in range(k - off):
            var += (1.0 if off == 0 else 2.0) * val[:, i] * val[:, i + off] * diag[j0 + i]
    return var
