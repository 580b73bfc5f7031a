"""Per-line condition numbers of a matrix linear in w^2, certified from a few exact SVDs.

For ``A(t) = A0 - t M`` (``t = w^2`` in (rad/s)^2), Weyl's inequality for
singular values gives, for every ``i`` and any two lines,

    |sigma_i(A(t)) - sigma_i(A(t0))| <= |t - t0| ||M||_2.

An exact SVD at some lines (the anchors) therefore brackets ``sigma_max`` and
``sigma_min`` on every line between two anchors. :func:`pencil_condition` adds
anchors (it bisects the gaps) until, on every line, the bracket of
``sigma_max / sigma_min`` lies within ``rtol`` of the reported value, which is
interpolated linearly in ``t`` between the anchors and clipped to the bracket.
Where ``sigma_min`` is small (a spike of the condition number) the bracket is
wide and the anchors become dense, down to an SVD on every line; where it is
smooth a few hundred SVDs cover tens of thousands of lines. Lines whose bracket
straddles one of the caller's decision ``levels`` (a reliability threshold)
also get an SVD, so a decision taken on the reported value is the one the exact
value would give.

The anchor SVDs themselves carry LAPACK's round-off, ``max(r, c) eps
sigma_max`` in absolute terms; the brackets are widened by it, so the bound is
certified up to that round-off on the anchors themselves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...parallel import map_chunks

__all__ = ["ConditionNumbers", "pencil_condition"]

_CHUNK = 500


@dataclass(frozen=True, eq=False)
class ConditionNumbers:
    """``sigma_max / sigma_min`` per line with its certified accuracy.

    Attributes
    ----------
    values : ndarray, shape (F,)
        Condition numbers (inf where the matrix is singular).
    bound : ndarray, shape (F,)
        Certified relative error bound of ``values`` (0 where ``exact``).
    exact : ndarray of bool, shape (F,)
        Lines computed by an SVD.
    """

    values: np.ndarray
    bound: np.ndarray
    exact: np.ndarray


def pencil_condition(A0: np.ndarray, M: np.ndarray, w2: np.ndarray, rtol: float = 1e-2, *,
                     levels: Sequence[float] = (), first_anchors: int = 33) -> ConditionNumbers:
    """Condition numbers ``sigma_max / sigma_min`` of ``A0 - w^2 M`` on every line, within ``rtol``.

    Parameters
    ----------
    A0 : ndarray, shape (r, c), complex
        The matrix at ``w = 0``.
    M : ndarray, shape (r, c), real or complex
        The coefficient of ``-w^2``.
    w2 : ndarray, shape (F,)
        Squared circular frequencies, (rad/s)^2, non-decreasing.
    rtol : float
        Certified relative accuracy; 0 computes an SVD on every line.
    levels : sequence of float
        Decision thresholds: a line whose bracket contains one gets an SVD.
    first_anchors : int
        Number of evenly spaced anchors to start from (the gaps are then bisected).

    Returns
    -------
    ConditionNumbers
    """
    w2 = np.asarray(w2, dtype=float)
    F = w2.size
    if not (np.isfinite(rtol) and rtol >= 0):
        raise ValueError(f"rtol must be a finite number >= 0, got {rtol!r}")
    if np.any(np.diff(w2) < 0):
        raise ValueError("w2 must be non-decreasing")
    if F == 0 or min(A0.shape) == 0:
        return ConditionNumbers(np.ones(F), np.zeros(F), np.ones(F, bool))
    lip = float(np.linalg.norm(M, 2))
    smax, smin = np.full(F, np.nan), np.full(F, np.nan)
    exact = np.zeros(F, bool)
    roundoff = max(A0.shape) * np.finfo(float).eps
    levels = np.asarray(levels, dtype=float).reshape(-1)
    new = np.arange(F) if rtol == 0 else np.unique(np.linspace(0, F - 1, max(int(first_anchors), 2)).round().astype(int))
    while True:
        smax[new], smin[new] = _extreme_singular_values(A0, M, w2[new])
        exact[new] = True
        values, bound, lo, hi = _bracket(w2, smax, smin, exact, lip, roundoff)
        straddle = np.any((lo[:, None] <= levels[None, :]) & (levels[None, :] < hi[:, None]), axis=1)
        bad = np.flatnonzero(~(bound <= rtol) | (straddle & ~exact))
        if bad.size == 0:
            return ConditionNumbers(values, bound, exact)
        anchors = np.flatnonzero(exact)
        j = np.searchsorted(anchors, bad)  # bad lines lie strictly between anchors j-1 and j
        new = np.unique((anchors[j - 1] + anchors[j]) // 2)


def _extreme_singular_values(A0, M, t):
    """(sigma_max, sigma_min) of ``A0 - t M`` for each ``t``, batched SVDs in chunks."""
    smax, smin = np.empty(t.size), np.empty(t.size)

    def run(idx):
        s = np.linalg.svd(A0[None] - t[idx, None, None] * M[None], compute_uv=False)
        smax[idx], smin[idx] = s[:, 0], s[:, -1]

    map_chunks(run, np.arange(t.size), _CHUNK)
    return smax, smin


def _bracket(w2, smax, smin, exact, lip, roundoff):
    """Interpolated condition number, its certified relative error bound and bracket (lo, hi) per line."""
    F = w2.size
    anchors = np.flatnonzero(exact)  # always includes 0 and F - 1
    pos = np.searchsorted(anchors, np.arange(F))
    right = anchors[np.minimum(pos, anchors.size - 1)]
    left = np.where(exact, np.arange(F), anchors[np.maximum(pos - 1, 0)])
    # Weyl, widened by the anchor SVDs' own round-off
    dl = lip * (w2 - w2[left]) + roundoff * smax[left]
    dr = lip * (w2[right] - w2) + roundoff * smax[right]
    span = w2[right] - w2[left]
    frac = np.divide(w2 - w2[left], span, out=np.zeros(F), where=span > 0)

    def interval(s):
        lo = np.maximum(s[left] - dl, s[right] - dr)
        hi = np.minimum(s[left] + dl, s[right] + dr)
        return np.clip(s[left] + frac * (s[right] - s[left]), lo, hi), lo, hi

    amax, amax_lo, amax_hi = interval(smax)
    amin, amin_lo, amin_hi = interval(smin)
    with np.errstate(divide="ignore", invalid="ignore"):
        values = amax / amin
        hi = np.where(amin_lo > 0, amax_hi / amin_lo, np.inf)
        lo = amax_lo / amin_hi
        bound = np.maximum(hi / values - 1.0, 1.0 - lo / values)
    bound[exact] = 0.0
    lo[exact] = hi[exact] = values[exact]
    return values, bound, lo, hi
