"""B-spline design matrices without scipy.interpolate: the values of ``BSpline.design_matrix``, bit for bit.

:func:`bspline_values` evaluates the ``k + 1`` B-splines that are nonzero at each abscissa by
the Cox-de Boor recursion in the order scipy's ``_deBoor_D`` runs it (``w = h[n-1] / (t_b - t_a)``,
``h[n-1] += w (t_b - x)``, ``h[n] = w (x - t_a)``), vectorized over the abscissae, and finds the
knot interval as scipy's ``_find_interval`` does (``t[l] <= x < t[l+1]``, the last interval for
``x = t[n]``): the values are those of ``scipy.interpolate.BSpline.design_matrix`` bit for bit
(``tests/test_bspline_design.py``). Importing scipy.interpolate (and the scipy.optimize it
loads) costs ``jointid identify`` about 0.05 s of its start-up; this is numpy only.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bspline_values", "design_csr", "design_dense"]


def bspline_values(x: np.ndarray, t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The nonzero B-splines of degree ``k`` on knots ``t`` at each ``x``: ``(values (m, k + 1), offsets (m,))``.

    Row ``i`` holds the B-splines ``offsets[i] .. offsets[i] + k`` at ``x[i]`` (``t[k] <= x <= t[n]``,
    ``n = len(t) - k - 1``).

    Raises
    ------
    ValueError
        ``x`` outside ``[t[k], t[n]]`` or not finite, or ``t`` too short or not sorted.
    """
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1)
    t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
    k = int(k)
    n = t.size - k - 1
    if k < 0 or t.size < 2 * k + 2 or np.any(t[1:] < t[:-1]):
        raise ValueError(f"knots {t} do not define B-splines of degree {k}")
    if x.size and not (np.all(x >= t[k]) and np.all(x <= t[n])):  # also NaN
        raise ValueError(f"abscissae outside the knots' interval [{t[k]}, {t[n]}]")
    ell = np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)  # t[ell] <= x < t[ell + 1]
    h = np.zeros((x.size, k + 1))
    h[:, 0] = 1.0
    for j in range(1, k + 1):
        hh = h[:, :j].copy()
        h[:, 0] = 0.0
        for m in range(1, j + 1):
            xb = t[ell + m]
            xa = t[ell + m - j]
            same = xb == xa
            with np.errstate(divide="ignore", invalid="ignore"):
                w = hh[:, m - 1] / (xb - xa)
            h[:, m - 1] += np.where(same, 0.0, w * (xb - x))  # scipy skips the update where the knots coincide
            h[:, m] = np.where(same, 0.0, w * (x - xa))
    return h, ell - k


def design_csr(x: np.ndarray, t: np.ndarray, k: int):
    """``scipy.interpolate.BSpline.design_matrix(x, t, k)``: the same CSR array (values, indices and index dtype)."""
    from scipy.sparse import csr_array

    values, offsets = bspline_values(x, t, k)
    m = values.shape[0]
    itype = np.int32 if m * (k + 1) < np.iinfo(np.int32).max else np.int64
    indices = (offsets.astype(itype)[:, None] + np.arange(k + 1, dtype=itype)).ravel()
    indptr = np.arange(0, (m + 1) * (k + 1), k + 1, dtype=itype)
    return csr_array((values.ravel(), indices, indptr), shape=(m, t.size - k - 1))


def design_dense(x: np.ndarray, t: np.ndarray, k: int) -> np.ndarray:
    """``BSpline.design_matrix(x, t, k).toarray()``, shape (m, len(t) - k - 1)."""
    values, offsets = bspline_values(x, t, k)
    out = np.zeros((values.shape[0], np.asarray(t).size - k - 1))
    rows = np.arange(values.shape[0])
    for j in range(values.shape[1]):
        out[rows, offsets + j] = values[:, j]
    return out
