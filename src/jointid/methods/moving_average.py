"""Moving average over frequency lines with the end values repeated (``scipy.ndimage.uniform_filter1d``, mode "nearest").

Importing ``scipy.ndimage`` for this one filter costs 0.15 s, on the critical path of every
``jointid identify`` from the command line; a prefix sum gives the same average. The window of
``size`` lines about line ``i`` is ``i - size // 2 .. i - size // 2 + size - 1`` (scipy's
alignment, also for an even ``size``), the first and last values repeated beyond the ends.

Rounding: each average is a difference of two prefix sums, so its error is about
``F eps max|x|`` (``F`` lines) -- the same bound as scipy's running sum, which adds and
subtracts every value once along the axis.
"""

from __future__ import annotations

import numpy as np

__all__ = ["moving_average"]


def moving_average(x: np.ndarray, size: int, axis: int = 0) -> np.ndarray:
    """Mean of ``x`` over ``size`` neighbouring entries along ``axis``, the end values repeated beyond the ends.

    Parameters
    ----------
    x : ndarray, real
        Any shape and unit.
    size : int
        Window length (entries), >= 1.
    axis : int
        The axis averaged along (the frequency lines).

    Returns
    -------
    ndarray, shape of ``x``, float
        Equal to ``scipy.ndimage.uniform_filter1d(x, size, axis, mode="nearest")`` within the rounding above.
    """
    size = int(size)
    if size < 1:
        raise ValueError(f"moving average over {size} entries: at least 1")
    z = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    F = z.shape[0]
    before, after = size // 2, size - 1 - size // 2
    padded = z[np.clip(np.arange(-before, F + after), 0, F - 1)]
    prefix = np.concatenate([np.zeros((1,) + z.shape[1:]), np.cumsum(padded, axis=0)])
    return np.moveaxis((prefix[size:] - prefix[:-size]) / size, 0, axis)
