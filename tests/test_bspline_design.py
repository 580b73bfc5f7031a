"""The B-spline design matrices built without scipy.interpolate equal BSpline.design_matrix bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from jointid.methods.receptance.bspline_design import design_csr, design_dense


@pytest.mark.parametrize("degree", [1, 2, 3])
@pytest.mark.parametrize("n_basis", [4, 5, 6, 10, 200])
def test_equals_scipy_design_matrix_bit_for_bit(degree, n_basis):
    rng = np.random.default_rng(n_basis)
    inner = np.linspace(0.0, 1.0, n_basis - degree + 1)
    t = np.r_[[0.0] * degree, inner, [1.0] * degree]
    x = np.r_[0.0, 1.0, inner, rng.random(300), np.sort(rng.random(300)), np.nextafter(inner, 2.0)[:-1]]
    ref = BSpline.design_matrix(x, t, degree)
    got = design_csr(x, t, degree)
    assert type(got) is type(ref) and got.shape == ref.shape and got.indices.dtype == ref.indices.dtype
    assert np.array_equal(got.data, ref.data) and np.array_equal(got.indices, ref.indices) and np.array_equal(got.indptr, ref.indptr)
    assert np.array_equal(design_dense(x, t, degree), ref.toarray())


def test_uneven_knots_and_bounds():
    t = np.array([0.0, 0.0, 0.0, 0.0, 0.1, 0.15, 0.7, 1.0, 1.0, 1.0, 1.0])
    x = np.linspace(0.0, 1.0, 97)
    assert np.array_equal(design_dense(x, t, 3), BSpline.design_matrix(x, t, 3).toarray())
    with pytest.raises(ValueError):
        design_csr(np.array([1.5]), t, 3)
    with pytest.raises(ValueError):
        design_csr(np.array([np.nan]), t, 3)
