"""The moving average over lines against scipy.ndimage.uniform_filter1d (mode "nearest"), and exact small cases."""

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from jointid.methods.moving_average import moving_average

EPS = np.finfo(float).eps


@pytest.mark.parametrize("F", [1, 2, 5, 400])
@pytest.mark.parametrize("size", [1, 2, 3, 8, 31, 1001])
def test_the_average_is_scipys_within_the_prefix_sums_rounding(F, size):
    """Even and odd windows, windows longer than the series: within 4 (F + size) eps max|x| of scipy's (both sum
    every value of the padded series once: each error below (F + size) eps max|x|)."""
    x = np.random.default_rng(F * size).random((F, 3, 2)) * 10.0 ** np.arange(-2, 4).reshape(1, 3, 2)
    for axis, z in ((0, x), (1, np.swapaxes(x, 0, 1))):
        ref = uniform_filter1d(z, size, axis=axis, mode="nearest")
        assert np.abs(moving_average(z, size, axis=axis) - ref).max() <= 4 * (F + size) * EPS * np.abs(x).max()


def test_ends_repeat_the_end_values_and_an_even_window_leans_back():
    x = np.array([0.0, 4.0, 8.0, 12.0])
    assert np.array_equal(moving_average(x, 3), [4.0 / 3.0, 4.0, 8.0, 32.0 / 3.0])  # (0+0+4)/3 ... (8+12+12)/3
    assert np.array_equal(moving_average(x, 2), [0.0, 2.0, 6.0, 10.0])  # lines i-1, i
    with pytest.raises(ValueError, match="moving average over 0 entries: at least 1"):
        moving_average(x, 0)
