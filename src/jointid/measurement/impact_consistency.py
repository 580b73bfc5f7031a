"""Hits that disagree with the other hits of their excited node: a hit at another point, or one that went wrong.

Every accepted hit of a roving-hammer excited node should give the same ratio of response to force
spectrum, within the noise. A hit struck at another point (a neighbouring node, the wrong side of a
rib) passes the double-hit and overload checks and is averaged in: the FRF is then a mixture of two
columns, its coherence only a little lower in some bands, and ``jointid identify`` sees a force
calibration error or a free model that does not fit.

For hits ``k`` and ``j`` of ``H`` (``H >= 3``), with ``X`` their force spectra and ``Y`` their responses' on
the band's lines, the pairwise misfit (:func:`pairwise_misfits`) is
``e_kj = median |Y_k - (Y_j / X_j) X_k|^2 / |Y_k|^2`` over lines and responses: the share of hit ``k``'s
response that hit ``j``'s own FRF does not predict from its force. It is of the order of the
noise-to-signal ratio for two hits at one point and of order 1 for hits at two points (the FRFs of two
points differ by their own size over most of a band).

The decision is by majority. The node's noise level is the median over hits of each one's best agreement, ``min_j e_kj`` (every hit, a wrong one
too, has a partner at its own point when at most a minority is wrong, or none is). Hits ``k`` and
``j`` agree when ``e_kj`` (and ``e_jk``) is at most :data:`INCONSISTENT_FACTOR` times that level or
:data:`INCONSISTENT_FLOOR` (a misfit of 10 % of the response amplitude: more than a hammer's
calibration scatter between hits). A hit is inconsistent when it agrees with fewer than half of the
other hits (``ceil((H - 1) / 2)``) while some hit agrees with at least that many: one of five at
another point agrees with none, two of five at the same wrong point with one (each other), the
three right ones with two. A hit's misfit against the others' average H1 could not tell the two of
five (a blind test, 2026-11-28): that average is pulled half way towards them, and every hit's
misfit is then alike.

Caveats: with two hits nothing tells which one is off (each is the other's reference); nor with two
groups of equal size (two and two of four): none is left out then.
"""

from __future__ import annotations

import numpy as np

__all__ = ["pairwise_misfits", "agreement_threshold", "inconsistent_hits", "INCONSISTENT_FACTOR", "INCONSISTENT_FLOOR"]

#: Two hits disagree when the median misfit of one against the other is this many times the node's noise level (a
#: misfit amplitude sqrt(10) ~ 3x what two hits at one point leave).
INCONSISTENT_FACTOR = 10.0
#: ... and above this median share of the response (a 10 % amplitude misfit, beyond a hammer's scatter between hits).
INCONSISTENT_FLOOR = 0.01


def pairwise_misfits(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Median over lines and responses of each hit's misfit against each other hit's own FRF (module docstring).

    Parameters
    ----------
    X : ndarray, shape (H, K), complex
        Force spectra of the hits on the band's lines, N s.
    Y : ndarray, shape (H, C, K), complex
        Response spectra (any response unit times s).

    Returns
    -------
    ndarray, shape (H, H)
        ``e[k, j] = median |Y_k - (Y_j / X_j) X_k|^2 / |Y_k|^2``; NaN on the diagonal.
    """
    H = X.shape[0]
    out = np.full((H, H), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        Hj = Y / X[:, None, :]  # (H, C, K): each hit's own FRF
        for k in range(H):  # H <= a few tens: one array operation per hit
            e = np.abs(Y[k][None] - Hj * X[k][None, None, :]) ** 2 / np.abs(Y[k][None]) ** 2  # (H, C, K)
            out[k] = np.median(np.where(np.isfinite(e), e, np.inf).reshape(H, -1), axis=1)  # no force or response: no agreement
    out[np.arange(H), np.arange(H)] = np.nan
    return out


def agreement_threshold(pairwise: np.ndarray) -> float:
    """The pairwise misfit up to which two hits agree: :data:`INCONSISTENT_FACTOR` times the node's noise level (the
    median over hits of their smallest misfit) or :data:`INCONSISTENT_FLOOR` (module docstring)."""
    e = np.asarray(pairwise, float)
    off = ~np.eye(e.shape[0], dtype=bool)
    level = float(np.median(np.min(np.where(off, e, np.inf), axis=1)))
    return max(INCONSISTENT_FACTOR * level, INCONSISTENT_FLOOR)


def inconsistent_hits(pairwise: np.ndarray) -> np.ndarray:
    """Indices of the hits that agree with fewer than half of the others while some hit agrees with that many (module
    docstring), from :func:`pairwise_misfits`; empty for fewer than 3 hits."""
    e = np.asarray(pairwise, float)
    H = e.shape[0]
    off = ~np.eye(H, dtype=bool)
    if H < 3 or not np.isfinite(e[off]).all():
        return np.zeros(0, int)
    agree = (np.maximum(e, e.T) <= agreement_threshold(e)) & off
    count = agree.sum(axis=1)
    need = int(np.ceil((H - 1) / 2))
    if not np.any(count >= need):
        return np.zeros(0, int)
    return np.flatnonzero(count < need)
