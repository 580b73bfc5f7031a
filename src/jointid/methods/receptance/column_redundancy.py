"""Whether a layout leaves a residual to test the excitation columns against: the column checks need one.

The column calibration (:mod:`.column_calibration`), the units check (:mod:`.units_check`)
and the force-noise test (:mod:`.force_noise`) each compare the per-line residual along
the *column directions* ``G_j`` (column j of the weighted measured ``H``: what a scale
error of that column changes) with the residual left in the other directions. Counting
equations (``m e - p - e > 0``) is not enough for that: when the free receptance of the
layout is itself of the joint model's form, ``Y[m,e] = Y[m,n] X0 Y[n,e]`` for some
admissible ``X0``, the residual of the per-line fit of ``Y - H`` is the residual of ``-H``,
and ``H`` is the sum of the column directions: every residual lies along them, for any
noise. That is the case when the observed DOFs are the excited ones and there are as many
as the joint has DOFs (a 6 x 6 layout for a 6-DOF mount, reciprocal model: every symmetric
matrix is fitted exactly), although ``m e - p - e = 9``. An F test against a residual that
is not there reads the noise as a column error of 10^9 (seen: "the FRFs look scaled by
1.4e+09 in every excitation column"). Such a layout still identifies the joint; it cannot
check the columns, and says so.

:func:`column_redundancy` is the median over :data:`REDUNDANCY_LINES` lines spread over the
band of ``|(I - Q Q^H) y|^2 / |y|^2``, ``y`` the weighted ``vec Y[m,e]`` and ``Q`` an
orthonormal basis of the weighted per-line design (the weights do not change whether ``y``
is in its range: both are scaled elementwise alike). A layout of the model's form gives
round-off (about ``1e-22`` for the 6 x 6 layouts of a 6-DOF mount); the others tried leave
far more (the benchmark beam's 7 x 3: 0.31; a 6-DOF mount's 9 x 9 at three grids: 2e-4):
below :data:`MIN_COLUMN_REDUNDANCY` the column checks do not run.
"""

from __future__ import annotations

import numpy as np

from .coupling_lines import symmetric_parametrization

__all__ = ["column_redundancy", "REDUNDANCY_LINES", "MIN_COLUMN_REDUNDANCY"]

#: Lines (spread over the band) on which the free receptance is projected.
REDUNDANCY_LINES = 16
#: Below this fraction of the free receptance outside the design's range the column checks cannot run (module
#: docstring: layouts of the model's form give round-off, about 1e-22; the others tried 2e-4 and more).
MIN_COLUMN_REDUNDANCY = 1e-8


def column_redundancy(Ymn: np.ndarray, Yne: np.ndarray, Yme: np.ndarray, variance: np.ndarray, symmetric: bool = True,
                      lines: int = REDUNDANCY_LINES) -> float:
    """Fraction of the free receptance ``Y[m,e]`` outside the range of the per-line joint design (median over lines).

    Parameters
    ----------
    Ymn, Yne, Yme : ndarray, shapes (F, m, n), (F, n, e), (F, m, e), complex
        Free receptance blocks, m/N.
    variance : ndarray, shape (F, m, e)
        Variance (shape) of each measured value: the weights.
    symmetric : bool
        ``X = X^T`` (the per-line fit's parametrization).
    lines : int
        Lines on which it is computed.

    Returns
    -------
    float
        ``median_f |(I - Q Q^H) y|^2 / |y|^2`` (module docstring).
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    idx = np.unique(np.linspace(0, F - 1, min(F, int(lines))).round().astype(int))
    k = idx.size
    P = symmetric_parametrization(n, symmetric)
    v = np.asarray(variance, float)[idx].reshape(k, m * e)
    w = np.where(np.isfinite(v) & (v > 0), 1.0 / np.sqrt(np.where(v > 0, v, 1.0)), 0.0)
    A = (np.einsum("fkc,fri->frcik", Yne[idx], Ymn[idx]).reshape(k, m * e, n * n) @ P) * w[:, :, None]
    norm = np.linalg.norm(A, axis=1, keepdims=True)
    Q = np.linalg.qr(A / np.where(norm > 0, norm, 1.0))[0]
    y = (np.asarray(Yme)[idx].reshape(k, m * e) * w)[:, :, None]
    r = y - Q @ (np.conj(np.swapaxes(Q, 1, 2)) @ y)
    yy = np.sum(np.abs(y[:, :, 0]) ** 2, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(yy > 0, np.sum(np.abs(r[:, :, 0]) ** 2, axis=1) / yy, 1.0)
    return float(np.median(frac))
