"""The running mean of the receptance method equals scipy.ndimage.uniform_filter1d(mode="nearest") bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from jointid.methods.receptance.running_mean import running_mean


@pytest.mark.parametrize("F, size", [(1, 1), (1, 5), (2, 3), (7, 8), (10, 25), (100, 7), (301, 1), (600, 150), (2000, 51), (19901, 497)])
@pytest.mark.parametrize("shape", [(), (3,), (2, 3)])
def test_equals_uniform_filter1d_bit_for_bit(F, size, shape):
    rng = np.random.default_rng(F + size)
    x = np.exp(5.0 * rng.standard_normal((F,) + shape))  # 10 decades: the rounding of the running sum shows
    x[rng.random(x.shape) < 0.01] *= -1.0
    assert np.array_equal(running_mean(x, size), uniform_filter1d(x, size, axis=0, mode="nearest"))


def test_other_axes_and_integer_input():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((4, 50, 3))
    assert np.array_equal(running_mean(x, 9, axis=1), uniform_filter1d(x, 9, axis=1, mode="nearest"))
    k = np.arange(20)
    assert np.array_equal(running_mean(k, 4), uniform_filter1d(k.astype(float), 4, mode="nearest"))
    with pytest.raises(ValueError):
        running_mean(x, 0)
