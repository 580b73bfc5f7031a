"""The running mean over lines that the receptance method's noise estimates use, without scipy.ndimage.

:func:`running_mean` is ``scipy.ndimage.uniform_filter1d(x, size, axis, mode="nearest")``
(origin 0) computed by the same recurrence, so its values are bit-identical to it: the
first window's sum added left to right, then per line ``sum += x[entering] - x[leaving]``,
each output ``sum / size`` (``tests/test_running_mean.py`` compares them). The window is
centred (``size // 2`` lines before, ``size - size // 2 - 1`` after) and the array is
extended by its edge values. Importing scipy.ndimage costs ``jointid identify`` about
0.05 s of its start-up; this is numpy only.
"""

from __future__ import annotations

import numpy as np

__all__ = ["running_mean"]


def running_mean(x: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Mean over a centred window of ``size`` lines along ``axis``, edges extended (float64, same shape as ``x``).

    Parameters
    ----------
    x : array_like, real
        Values, any shape; ``axis`` runs over the lines.
    size : int
        Window length (>= 1).
    axis : int

    Returns
    -------
    ndarray, float64
        ``scipy.ndimage.uniform_filter1d(x, size, axis=axis, mode="nearest")``, bit for bit.
    """
    size = int(size)
    if size < 1:
        raise ValueError(f"size must be >= 1, got {size}")
    a = np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0)
    F = a.shape[0]
    if F == 0:
        return np.moveaxis(a.copy(), 0, axis)
    before = size // 2
    after = size - before - 1
    ext = np.concatenate([np.repeat(a[:1], before, axis=0), a, np.repeat(a[-1:], after, axis=0)], axis=0)
    sums = np.empty_like(a)
    sums[0] = np.cumsum(ext[:size], axis=0)[-1]  # the first window, added left to right
    np.subtract(ext[size:size + F - 1], ext[:F - 1], out=sums[1:])  # per line: the value entering minus the one leaving
    np.cumsum(sums, axis=0, out=sums)  # the running sum, left to right (numpy's accumulate is sequential)
    sums /= float(size)
    return np.moveaxis(sums, 0, axis)
