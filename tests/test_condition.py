"""Certified per-line condition numbers of A0 - w^2 M (Weyl brackets from anchor SVDs)."""

import numpy as np
import pytest

from jointid.methods.hong_lee.condition import pencil_condition


def _pencil(seed=0, r=12, c=9):
    rng = np.random.default_rng(seed)
    A0 = rng.standard_normal((r, c)) + 1j * rng.standard_normal((r, c))
    M = rng.standard_normal((r, c)) * 1e-4  # sigma changes by O(1) over w2 = 0..2000
    return A0, M


def _exact(A0, M, w2):
    return np.linalg.cond(A0[None] - w2[:, None, None] * M[None])


@pytest.mark.parametrize("rtol", [1e-2, 1e-3])
def test_bound_holds_on_every_line_and_few_svds_are_needed(rtol):
    A0, M = _pencil()
    w2 = np.linspace(0.0, 2e3, 5000)
    c = pencil_condition(A0, M, w2, rtol)
    exact = _exact(A0, M, w2)
    err = np.abs(c.values / exact - 1)
    assert np.all(err <= c.bound + 1e-12)
    assert c.bound.max() <= rtol
    assert np.all(c.bound[c.exact] == 0) and np.allclose(c.values[c.exact], exact[c.exact], rtol=1e-12)
    assert c.exact.sum() < 0.2 * w2.size  # measured: 97 (1e-2) and 337 (1e-3) of 5000 lines


def test_anchors_crowd_where_the_matrix_becomes_singular():
    rng = np.random.default_rng(3)
    A0, M = _pencil(1)
    # make A(t*) rank deficient: subtract its smallest singular triplet at t*
    t_star = 1000.0
    U, s, Vh = np.linalg.svd(A0 - t_star * M)
    A0 = A0 - s[-1] * np.outer(U[:, len(s) - 1], Vh[-1])
    w2 = np.sort(np.r_[np.linspace(0, 2e3, 2000) + rng.uniform(0, 0.1), t_star])
    c = pencil_condition(A0, M, w2, 1e-2)
    exact = _exact(A0, M, w2)
    # sigma_min ~ |t - t*| there, so a 1% bracket needs anchors ever closer to t*
    near, far = np.abs(w2 - t_star) < 20, np.abs(w2 - t_star) > 500
    assert c.exact[near].all() and c.exact[far].mean() < 0.3  # measured: 0.19
    k = int(np.flatnonzero(w2 == t_star)[0])
    assert c.exact[k] and c.values[k] > 1e13  # singular to round-off
    finite = np.isfinite(exact) & (exact < 1e12)
    assert np.all(np.abs(c.values[finite] / exact[finite] - 1) <= c.bound[finite] + 1e-9)


def test_zero_tolerance_is_an_svd_on_every_line():
    A0, M = _pencil(2)
    w2 = np.linspace(1.0, 100.0, 50)
    c = pencil_condition(A0, M, w2, 0.0)
    assert c.exact.all() and np.allclose(c.values, _exact(A0, M, w2), rtol=1e-12)


@pytest.mark.parametrize(
    "w2, rtol, msg",
    [
        (np.array([1.0, 3.0, 2.0]), 1e-2, "w2 must be non-decreasing"),
        (np.array([1.0, 2.0]), -1e-2, "rtol must be a finite number >= 0, got -0.01"),
    ],
)
def test_bad_input(w2, rtol, msg):
    A0, M = _pencil()
    with pytest.raises(ValueError, match=msg):
        pencil_condition(A0, M, w2, rtol)


def test_lines_whose_bracket_straddles_a_level_get_an_svd():
    A0, M = _pencil()
    w2 = np.linspace(0.0, 2e3, 5000)
    exact = _exact(A0, M, w2)
    level = float(np.median(exact))  # a threshold crossed inside the band
    c = pencil_condition(A0, M, w2, 1e-2, levels=[level])
    assert np.array_equal(c.values <= level, exact <= level)
    crossing = np.flatnonzero(np.diff(exact <= level))
    assert c.exact[crossing].all() and c.exact[crossing + 1].all()


def test_repeated_frequency_lines_are_allowed():
    A0, M = _pencil()
    w2 = np.array([1.0, 5.0, 5.0, 9.0, 9.0])
    c = pencil_condition(A0, M, w2, 1e-2)
    assert np.all(np.abs(c.values / _exact(A0, M, w2) - 1) <= c.bound + 1e-12)
