"""The per-term smoothing fallback when the lines err more than their stated variance: the bands must widen.

Small fixed-seed series (a joint-like smooth curve on 1200 lines): the smoother is told a variance 9x smaller than the
data's (the FRFs' coherence missing part of their error, as hammer records without a force window do). Checked on the
independent truth, not on bits: the coverage of the 90 % band (|z| < 1.645 on each line) of a right band is 0.9 with a
binomial standard error sqrt(0.09 / n_eff) <= 0.03 for the >= 100 effectively independent windows here, so >= 0.8 holds
with margin; the told-too-small band covers about a third of the lines.
"""

import numpy as np

from jointid.methods.receptance.fallback_bands import widen_fallback_bands
from jointid.methods.receptance.smoothing import residual_scale, resolution_lines, smooth_series

Z90 = 1.645


def _series(seed, true_sd_factor, smooth_error=0.0):
    rng = np.random.default_rng(seed)
    x = np.linspace(5.0, 1000.0, 1200)
    truth = 1.0 + 0.3 * np.sin(x / 90.0) + 0.1 * x / 1000.0
    sd = 0.01 * (1.0 + x / 500.0)  # the stated standard deviation
    bias = smooth_error * np.exp(-((x - 150.0) / 60.0) ** 2)  # an error smooth over frequency
    y = truth + bias + true_sd_factor * sd * rng.standard_normal(x.size)
    return x, y, sd**2, truth


def _coverage(value, variance, truth):
    return float(np.mean(np.abs(value - truth) <= Z90 * np.sqrt(variance)))


def test_residual_scale_widens_the_bands_of_lines_erring_more_than_their_variance():
    x, y, v, truth = _series(seed=3, true_sd_factor=3.0)
    s = smooth_series(x, y, v)
    scale = residual_scale(y, v, s)
    before, after = _coverage(s.value, s.variance, truth), _coverage(s.value, s.variance * scale, truth)
    assert before < 0.6, before  # the posterior variance takes the stated variance as absolute: too narrow
    assert after >= 0.8, after
    # the scale is the residuals' chi^2/dof: 9 (the variance ratio) within its sampling error over a window
    assert np.all((scale > 4.0) & (scale < 16.0)), (scale.min(), scale.max())


def test_residual_scale_is_one_when_the_variance_is_right():
    # false alarm at most RESIDUAL_FALSE_ALARM (1 %) per series: these seeds keep every band
    for seed in (0, 1, 2):
        x, y, v, truth = _series(seed=seed, true_sd_factor=1.0)
        s = smooth_series(x, y, v)
        assert np.all(residual_scale(y, v, s) == 1.0)
        assert _coverage(s.value, s.variance, truth) >= 0.8


def test_a_rejected_structured_estimate_carries_an_error_smooth_over_frequency_into_the_bands():
    """An error smooth over frequency (a 0.2 bump at 150 Hz, 20 stated sigma) is followed by the smoother and shows in no
    residual; the structured model (here: the truth, as a model of the right class would give) differs by it."""
    x, y, v, truth = _series(seed=4, true_sd_factor=3.0, smooth_error=0.2)
    re, im = smooth_series(x, y, v), smooth_series(x, y, v)
    scale = residual_scale(y, v, re)
    K = (re.value + 1j * im.value)[:, None, None]
    var = (re.variance * scale)[:, None, None]
    structured = (truth + 1j * truth)[:, None, None]
    bump = np.abs(x - 150.0) < 60.0
    assert _coverage(re.value[bump], var[bump, 0, 0], truth[bump]) < 0.5  # the residual scale alone misses it
    wide = widen_fallback_bands(K, var, var, {"K_w_w": (0, 0, float(scale.max()))},
                                {"K_w_w": resolution_lines(x.size, re.edf)}, structured)
    assert wide.structured_added and wide.terms == ("K_w_w",)
    assert _coverage(re.value, wide.var_real[:, 0, 0], truth) >= 0.8
    assert _coverage(re.value[bump], wide.var_real[bump, 0, 0], truth[bump]) >= 0.8
    assert "err more than their coherence says" in wide.finding()
    # a term whose residuals agree with its variance keeps its bands (the misfit is the model's)
    same = widen_fallback_bands(K, var, var, {"K_w_w": (0, 0, 1.0)}, {"K_w_w": 8}, structured)
    assert not same.terms and np.array_equal(same.var_real, var) and same.finding() == ""
