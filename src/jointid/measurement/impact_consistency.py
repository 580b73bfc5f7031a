"""Hits that disagree with the other hits of their excited node: a hit at another point, or one that went wrong.

Every accepted hit of a roving-hammer excited node should give the same ratio of response to force
spectrum, within the noise. A hit struck at another point (a neighbouring node, the wrong side of a
rib) passes the double-hit and overload checks and is averaged in: the FRF is then a mixture of two
columns, its coherence only a little lower in some bands, and ``jointid identify`` sees a force
calibration error or a free model that does not fit.

For hit ``k`` of ``H`` (``H >= 3``), with ``X_k`` its force spectrum and ``Y_k`` its responses' on the
band's lines, the other hits' H1 is ``H_rest = sum_{j != k} conj(X_j) Y_j / sum_{j != k} |X_j|^2`` and
the hit's misfit on each line and response is ``e_k = |Y_k - H_rest X_k|^2 / |Y_k|^2`` (the share of
the response this hit does not share with the others). Its median over lines and responses is of the
order of the noise-to-signal ratio for a hit like the others and of order 1 for a hit elsewhere (the
FRFs of two points differ by their own size over most of a band). A hit is inconsistent when its
median is above :data:`INCONSISTENT_FACTOR` times the median of every hit's (the node's own noise
level: the bad hit is one of ``H >= 3``, so it does not set that median) and above
:data:`INCONSISTENT_FLOOR` (a misfit of 10 % of the response amplitude: more than a hammer's
calibration scatter between hits).

Caveats: with two hits nothing tells which one is off (each is the other's reference); two of five
hits at the same wrong point pull ``H_rest`` half way and may pass.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hit_misfits", "inconsistent_hits", "INCONSISTENT_FACTOR", "INCONSISTENT_FLOOR"]

#: A hit whose median misfit is this many times the node's median over its hits is inconsistent (a misfit amplitude
#: sqrt(10) ~ 3x what the other hits leave).
INCONSISTENT_FACTOR = 10.0
#: ... and above this median share of the response (a 10 % amplitude misfit, beyond a hammer's scatter between hits).
INCONSISTENT_FLOOR = 0.01


def hit_misfits(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Median over lines and responses of each hit's misfit against the other hits' H1 (module docstring).

    Parameters
    ----------
    X : ndarray, shape (H, K), complex
        Force spectra of the hits on the band's lines, N s.
    Y : ndarray, shape (H, C, K), complex
        Response spectra (any response unit times s).

    Returns
    -------
    ndarray, shape (H,)
        ``median |Y_k - H_rest X_k|^2 / |Y_k|^2``; NaN for fewer than 3 hits.
    """
    H = X.shape[0]
    if H < 3:
        return np.full(H, np.nan)
    sxy = np.conj(X)[:, None, :] * Y  # (H, C, K)
    sxx = np.abs(X) ** 2  # (H, K)
    rest_xy = sxy.sum(axis=0)[None] - sxy
    rest_xx = (sxx.sum(axis=0)[None] - sxx)[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        h_rest = rest_xy / rest_xx
        e = np.abs(Y - h_rest * X[:, None, :]) ** 2 / np.abs(Y) ** 2
    e = np.where(np.isfinite(e), e, np.nan).reshape(H, -1)
    return np.nanmedian(e, axis=1)


def inconsistent_hits(misfit: np.ndarray) -> np.ndarray:
    """Indices of the hits whose misfit (:func:`hit_misfits`) is above :data:`INCONSISTENT_FACTOR` times the median of
    all and above :data:`INCONSISTENT_FLOOR`; empty for fewer than 3 hits."""
    m = np.asarray(misfit, float)
    if m.size < 3 or not np.isfinite(m).all():
        return np.zeros(0, int)
    return np.flatnonzero((m > INCONSISTENT_FACTOR * np.median(m)) & (m > INCONSISTENT_FLOOR))
