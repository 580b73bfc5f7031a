"""B-spline basis functions on a clamped knot vector: the design matrices of the smoothers and the structured model.

``scipy.interpolate.BSpline.design_matrix`` computes the same values, but importing
``scipy.interpolate`` imports ``scipy.optimize`` with it (0.26 s, a fifth of ``jointid identify``'s
imports, on the critical path of every identification from the command line). The basis is
de Boor's recurrence (Piegl & Tiller, *The NURBS Book*, algorithm A2.2; de Boor, *A Practical
Guide to Splines*, ch. X), as FITPACK's ``fpbspl`` that scipy runs: for ``t[i] <= x < t[i+1]`` the
``k + 1`` non-zero functions ``B_(i-k..i)`` of degree ``k`` are built from degree 0 up,

    ``N_r^(j) = saved + (t[i+r+1] - x) / (t[i+r+1] - t[i+r+1-j]) N_r^(j-1)`` ...

in convex combinations only (every term non-negative, each value rounded within ``~2 k eps`` of
the exact one; ``tests/test_bspline_basis.py`` compares with scipy's). ``x`` at the last knot
belongs to the last non-empty interval, as in scipy (the basis still sums to 1 there).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["bspline_values", "bspline_design", "bspline_design_sparse", "clamped_uniform_knots"]


def clamped_uniform_knots(n_basis: int, degree: int) -> np.ndarray:
    """Knots of ``n_basis`` B-splines of ``degree`` on [0, 1]: ``degree + 1`` at each end, uniform inside."""
    if n_basis < degree + 1:
        raise ValueError(f"{n_basis} B-splines of degree {degree}: at least {degree + 1} needed")
    return np.r_[[0.0] * degree, np.linspace(0.0, 1.0, n_basis - degree + 1), [1.0] * degree]


def bspline_values(x: np.ndarray, t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k + 1`` non-zero B-splines of degree ``k`` at each ``x``: ``(first, values)``.

    Parameters
    ----------
    x : ndarray, shape (F,)
        Points inside ``t[k]..t[-k-1]`` (the base interval).
    t : ndarray, shape (n + k + 1,)
        Non-decreasing knots (``n`` basis functions).
    k : int
        Degree (3: cubic).

    Returns
    -------
    first : ndarray of int, shape (F,)
        Index of the first non-zero function at each point (``B_first .. B_first+k``).
    values : ndarray, shape (F, k + 1)
        Their values.
    """
    x = np.asarray(x, dtype=float).reshape(-1)
    t = np.asarray(t, dtype=float)
    n = t.size - k - 1
    if n < k + 1 or np.any(np.diff(t) < 0):
        raise ValueError("knots must be non-decreasing, with at least 2 k + 2 of them")
    lo, hi = t[k], t[n]
    if x.size and (np.any(~np.isfinite(x)) or x.min() < lo or x.max() > hi):
        raise ValueError(f"points outside the base interval {lo:g}..{hi:g}")
    # the interval t[i] <= x < t[i+1] with k <= i < n; the last knot belongs to the last non-empty interval
    i = np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)
    while True:  # repeated knots at the right end: step back to an interval of positive length
        empty = t[i + 1] <= t[i]
        if not empty.any():
            break
        i = np.where(empty, i - 1, i)
    N = np.zeros((x.size, k + 1))
    N[:, 0] = 1.0
    left = np.empty((x.size, k + 1))
    right = np.empty((x.size, k + 1))
    for j in range(1, k + 1):
        left[:, j] = x - t[i + 1 - j]
        right[:, j] = t[i + j] - x
        saved = np.zeros(x.size)
        for r in range(j):
            temp = N[:, r] / (right[:, r + 1] + left[:, j - r])
            N[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        N[:, j] = saved
    return i - k, N


def bspline_design(x: np.ndarray, t: np.ndarray, k: int) -> np.ndarray:
    """Dense design matrix ``B[f, b] = B_b(x_f)``, shape (F, n) (``n = len(t) - k - 1``); see :func:`bspline_values`."""
    first, values = bspline_values(x, t, k)
    out = np.zeros((first.size, t.size - k - 1))
    rows = np.arange(first.size)[:, None]
    out[rows, first[:, None] + np.arange(k + 1)[None, :]] = values
    return out


def bspline_design_sparse(x: np.ndarray, t: np.ndarray, k: int) -> sp.csr_matrix:
    """The design matrix of :func:`bspline_design` as CSR (``k + 1`` stored values per row, zeros included)."""
    first, values = bspline_values(x, t, k)
    F = first.size
    indices = (first[:, None] + np.arange(k + 1)[None, :]).reshape(-1)
    return sp.csr_matrix((values.reshape(-1), indices, np.arange(0, F * (k + 1) + 1, k + 1)), shape=(F, t.size - k - 1))
