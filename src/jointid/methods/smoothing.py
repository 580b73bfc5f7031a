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
``lam`` at once from one generalized eigendecomposition. The uncertainty is the
Bayesian posterior covariance ``B (B^T W B + lam D^T D)^-1 B^T`` (Wahba 1983),
whose intervals include the smoothing bias on average (Nychka 1988).

Caveats: knots every ``band / K`` (``K`` <= :data:`MAX_BASIS`) resolve features
a few knot spacings wide, not sharper ones; the variances ``v`` must be on an
absolute scale for the bands to mean anything.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.interpolate import BSpline

__all__ = ["SmoothedSeries", "smooth_series", "MAX_BASIS"]

#: Most basis functions of the spline (knot spacing = band / MAX_BASIS at most).
MAX_BASIS = 200
_LOG_LAMBDA = np.linspace(-10.0, 8.0, 73)


@dataclass(frozen=True, eq=False)
class SmoothedSeries:
    """A smoothed series: values, posterior variance, lambda and effective degrees of freedom."""

    value: np.ndarray
    variance: np.ndarray
    lam: float
    edf: float


def _basis(x: np.ndarray, n_basis: int, degree: int = 3):
    u = (x - x[0]) / (x[-1] - x[0])
    inner = np.linspace(0.0, 1.0, n_basis - degree + 1)
    t = np.r_[[0.0] * degree, inner, [1.0] * degree]
    return BSpline.design_matrix(np.clip(u, 0.0, 1.0), t, degree).tocsr()


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
    """
    F = x.size
    ok = np.isfinite(y) & np.isfinite(variance) & (variance > 0)
    K = int(n_basis or min(max(F // 2, 4), MAX_BASIS))
    K = max(4, min(K, int(ok.sum()) - 1))
    B = _basis(np.asarray(x, float), K)
    w = np.where(ok, 1.0 / np.where(ok, variance, 1.0), 0.0)
    yz = np.where(ok, y, 0.0)
    BW = B.multiply(w[:, None]).tocsr()
    BWB = (B.T @ BW).toarray()
    BWy = B.T @ (w * yz)
    D = np.diff(np.eye(K), 2, axis=0)
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
    lams = scale * 10.0**_LOG_LAMBDA
    filt = 1.0 / (1.0 + lams[None, :] * s[:, None])  # (K, G)
    fits = B @ (T @ (c[:, None] * filt))  # (F, G)
    rss = np.sum(w[:, None] * (yz[:, None] - fits) ** 2, axis=0)
    n = int(ok.sum())
    edf = filt.sum(axis=0)
    gcv = n * rss / np.maximum(n - edf, 1e-9) ** 2
    g = int(np.argmin(gcv))
    M = T * np.sqrt(filt[:, g])[None, :]
    var = np.asarray((B @ M) ** 2).sum(axis=1)
    return SmoothedSeries(fits[:, g], var, float(lams[g]), float(edf[g]))
