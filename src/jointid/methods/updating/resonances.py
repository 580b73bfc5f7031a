"""Stage 1 of model updating: the frequency scale that puts the model's natural frequencies on the measured peaks.

Used by the fit (:mod:`.fit`, its first stage) and by its verdict (:mod:`.check`: resonances left misaligned).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import median_filter

from ...frf import FRF

__all__ = ["frequency_scale"]


def frequency_scale(measured: FRF, model_hz: np.ndarray, lo: float = 0.7, hi: float = 1.4) -> tuple[float, int]:
    """Stage 1: the scale ``s`` that puts the model's natural frequencies on the measured peaks.

    Parameters
    ----------
    measured : FRF
    model_hz : ndarray
        The initial model's natural frequencies, Hz (rigid-body modes are ignored).
    lo, hi : float
        Range of ``s`` scanned.

    Returns
    -------
    s : float
        Median over the matched modes of ``f_peak / f_model`` (1.0 when no mode can be matched).
    matched : int
        Number of modes matched.
    """
    f = measured.frequency.hz
    F = f.size
    if F < 8:
        return 1.0, 0
    S = np.log(np.sum(np.abs(measured.data) ** 2, axis=(1, 2)) + 1e-300)
    width = max(5, (F // 40) | 1)
    P = S - median_filter(S, size=width, mode="nearest")  # peaks above the local level
    fr = np.asarray(model_hz, dtype=float)
    fr = fr[fr > 0.5 * f[0] + 1e-9]
    if fr.size == 0:
        return 1.0, 0
    scales = np.exp(np.linspace(math.log(lo), math.log(hi), 4001))
    inside = (scales[:, None] * fr[None, :] > f[1]) & (scales[:, None] * fr[None, :] < f[-2])
    score = np.where(inside, np.interp(scales[:, None] * fr[None, :], f, P), 0.0).sum(axis=1)
    s0 = scales[int(np.argmax(score))]
    ratios = []
    for x in s0 * fr:
        if not f[1] < x < f[-2]:
            continue
        win = np.flatnonzero(np.abs(f - x) <= max(0.01 * x, 2.5 * np.median(np.diff(f))))
        if win.size == 0:
            continue
        k = int(win[np.argmax(S[win])])
        if k in (0, F - 1) or P[k] < 1.0:  # not a peak (a resonance rises >> e above the running median)
            continue
        y0, y1, y2 = S[k - 1], S[k], S[k + 1]
        den = y0 - 2.0 * y1 + y2
        delta = 0.5 * (y0 - y2) / den if den < 0 else 0.0
        fk = f[k] + float(np.clip(delta, -0.5, 0.5)) * 0.5 * (f[k + 1] - f[k - 1])
        ratios.append(fk / (x / s0))
    if not ratios:
        return float(s0) if score.max() > 0 else 1.0, 0
    return float(np.median(ratios)), len(ratios)
