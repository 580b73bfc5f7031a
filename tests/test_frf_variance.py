"""FRF variance from coherence, and its split into a column-common (force) and a per-value (response) part."""

import dataclasses

import numpy as np
import pytest

from jointid.benchmark import benchmark_study
from jointid.methods.frf_variance import SPLIT_MIN_FRACTION, column_noise_fraction, frf_variance
from jointid.pipeline import experiment


def _layout(seed, F=60, m=7, e=3, a_level=1e-3):
    """Exact coherences of the split's model: q = a_j + s_r t_j / |H_rj|^2, constant over frequency."""
    rng = np.random.default_rng(seed)
    a = a_level * rng.uniform(0.5, 2.0, e)
    s = 1e-3 * rng.uniform(0.2, 5.0, m)
    t = rng.uniform(0.5, 2.0, e)
    M = rng.uniform(0.05, 20.0, (m, e))
    b = s[:, None] * t[None, :] / M
    q = np.broadcast_to(a[None, :] + b, (F, m, e))
    H = np.broadcast_to(np.sqrt(M) * np.exp(1j * rng.uniform(0, 6, (m, e))), (F, m, e))
    return np.array(H), 1.0 / (1.0 + q), b / (a[None, :] + b)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_split_recovers_the_column_common_part_of_exact_coherences(seed):
    H, g2, truth = _layout(seed)
    frac = column_noise_fraction(H, g2)
    assert frac.shape == H.shape
    truth = np.maximum(truth, SPLIT_MIN_FRACTION)
    assert np.max(np.abs(frac[0] - truth) / truth) < 0.02, (frac[0], truth)


def test_without_force_noise_nothing_is_taken_as_column_common():
    H, g2, _ = _layout(3, a_level=0.0)
    frac = column_noise_fraction(H, g2)
    assert np.min(frac) > 0.99


@pytest.mark.parametrize("m, e", [(2, 3), (7, 1), (3, 2)])
def test_a_layout_that_cannot_separate_the_parts_is_not_split(m, e):
    H, g2, _ = _layout(4, m=m, e=e)
    assert np.all(column_noise_fraction(H, g2) == 1.0)


def test_split_of_a_virtual_hammer_test_matches_its_force_and_response_noise():
    """Coherence of 1 % force + 1 % response noise, split, against the coherences of each noise alone (same hits)."""
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))

    def q(**noise):
        ex = experiment(dataclasses.replace(st, experiment=dataclasses.replace(st.experiment, **noise)), seed=0, periodic=True)
        frf = ex.frf.band(100, 1000)
        return frf, frf_variance(np.ones(frf.data.shape), frf.coherence, "coherence")[0]  # smoothed (1 - g^2) / g^2

    both, _ = q()
    _, qa = q(response_noise=0.0)  # smoothed (1 - g^2) / g^2 of the force noise alone
    _, qb = q(force_noise=0.0)
    frac = column_noise_fraction(both.data, both.coherence)
    truth = np.maximum(qb / (qa + qb), SPLIT_MIN_FRACTION)
    ratio = frac / truth
    # measured: median 1.0, 80 % of values within 0.75-1.7
    assert 0.85 < np.median(ratio) < 1.2, np.median(ratio)
    assert np.mean((ratio > 0.5) & (ratio < 2.0)) > 0.8
