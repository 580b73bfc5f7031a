"""The B-spline basis of the smoothers and the structured model against scipy's, and its exact properties."""

import numpy as np
import pytest
from scipy.interpolate import BSpline

from jointid.methods.bspline_basis import bspline_design, bspline_design_sparse, clamped_uniform_knots

EPS = np.finfo(float).eps


@pytest.mark.parametrize("k", [1, 2, 3])
@pytest.mark.parametrize("n_basis", [4, 5, 9, 40])
def test_the_basis_is_scipys_within_its_rounding(k, n_basis):
    """Values within 2 (k + 1) eps of scipy's (both are de Boor's convex combinations, each rounded within ~k eps),
    every row summing to 1 within that, the sparse and dense forms identical; the knots themselves and both ends
    included (the last knot belongs to the last interval, as in scipy)."""
    t = clamped_uniform_knots(n_basis, k)
    x = np.r_[t[k:n_basis + 1], np.sort(np.random.default_rng(n_basis + k).random(300))]
    ref = BSpline.design_matrix(x, t, k).toarray()
    B = bspline_design(x, t, k)
    assert np.abs(B - ref).max() <= 2 * (k + 1) * EPS
    assert np.abs(B.sum(axis=1) - 1.0).max() <= 2 * (k + 1) * EPS
    assert np.array_equal(bspline_design_sparse(x, t, k).toarray(), B)


def test_linear_splines_interpolate_between_their_knots_exactly():
    """Degree 1 on knots 0, 0.5, 1: the hat functions, 1 - 2x and 2x below 0.5 (exact in binary at these points)."""
    t = clamped_uniform_knots(3, 1)
    x = np.array([0.0, 0.125, 0.25, 0.5, 0.75, 1.0])
    expected = np.array([[1, 0, 0], [0.75, 0.25, 0], [0.5, 0.5, 0], [0, 1, 0], [0, 0.5, 0.5], [0, 0, 1]])
    assert np.array_equal(bspline_design(x, t, 1), expected)


def test_points_outside_the_base_interval_and_too_few_functions_are_refused():
    t = clamped_uniform_knots(5, 3)
    with pytest.raises(ValueError, match="points outside the base interval 0..1"):
        bspline_design(np.array([0.5, 1.0 + 1e-12]), t, 3)
    with pytest.raises(ValueError, match="3 B-splines of degree 3: at least 4 needed"):
        clamped_uniform_knots(3, 3)
