"""The bias part of the joint spline fit's bands: one term at a time in its richer class (spline_bands.one_term_bias_variance).

On a linear least-squares problem the partitioned Gauss-Newton step is the enriched fit itself, so every quantity
has an independent reference: the enriched fits solved directly (``numpy.linalg.lstsq``) and their covariances
inverted directly.
"""

from __future__ import annotations

import numpy as np

from jointid.methods.receptance.spline_bands import bias_band_variance, nested_extension, normal_inverse, one_term_bias_variance
from jointid.methods.receptance.spline_fit import log_frequency_basis


def _linear_case(seed: int):
    """p = 3 terms of a 2 x 2 symmetric joint, nb = 3 functions each (the last one inactive on terms 0 and 2)."""
    rng = np.random.default_rng(seed)
    F, nb, p = 40, 3, 3
    basis = log_frequency_basis(np.linspace(2.0, 150.0, F), nb)
    P, obs = p * nb, 200
    X = rng.standard_normal((obs, P)) + 1j * rng.standard_normal((obs, P))
    y = X @ (rng.standard_normal(P) + 1j * rng.standard_normal(P)) + 0.3 * (rng.standard_normal(obs) + 1j * rng.standard_normal(obs))
    active = np.ones(P, bool)
    active[[2, 8]] = False  # term 0's and term 2's third function
    return basis, X, y, active, (np.array([0, 0, 1]), np.array([0, 1, 1]))


def _values(basis, coef_full, t):
    nb = basis.shape[1]
    return basis @ coef_full[t * nb:(t + 1) * nb]


def test_one_term_bias_equals_the_enriched_fits_solved_directly():
    basis, X, y, active, pairs = _linear_case(3)
    F, nb = basis.shape
    P = active.size
    p = P // nb
    A = np.flatnonzero(active)
    cA = np.linalg.lstsq(X[:, A], y, rcond=None)[0]
    r = y - X[:, A] @ cA
    s2 = float(np.sum(np.abs(r) ** 2)) / (X.shape[0] - A.size)
    N, grad = X.conj().T @ X, -X.conj().T @ r  # r = y - X c: dr/dc = -X
    b_re, b_im = one_term_bias_variance(N, grad, basis, active, s2, pairs)

    def fit(S):
        c = np.zeros(P, complex)
        c[S] = np.linalg.lstsq(X[:, S], y, rcond=None)[0]
        cov = np.zeros((P, P), complex)
        cov[np.ix_(S, S)] = s2 * np.linalg.inv(X[:, S].conj().T @ X[:, S])
        return c, cov

    c_sel, cov_sel = fit(A)
    want_re, want_im = np.zeros((F, p)), np.zeros((F, p))
    for j in range(p):
        E = np.flatnonzero(~active & (np.arange(P) // nb == j))
        if E.size == 0:
            continue
        c_j, cov_j = fit(np.r_[A, E])
        for t in range(p):
            rows = np.zeros((F, P))
            rows[:, t * nb:(t + 1) * nb] = basis
            var = 0.5 * np.einsum("fa,ab,fb->f", rows, cov_sel, rows).real
            tau2 = 0.5 * np.einsum("fa,ab,fb->f", rows, cov_j, rows).real - var
            d = _values(basis, c_sel, t) - _values(basis, c_j, t)
            want_re[:, t] += bias_band_variance(var, tau2, d.real) - var  # summed over the enriched terms j
            want_im[:, t] += bias_band_variance(var, tau2, d.imag) - var
    # both are the same linear algebra: within a few cond(N) eps of the largest variance
    tol = 100 * np.linalg.cond(N) * np.finfo(float).eps * max(want_re.max(), want_im.max())
    ia, ib = pairs
    np.testing.assert_allclose(b_re[:, ia, ib], want_re, rtol=0, atol=tol)
    np.testing.assert_allclose(b_im[:, ia, ib], want_im, rtol=0, atol=tol)
    np.testing.assert_array_equal(b_re[:, 1, 0], b_re[:, 0, 1])  # mirrored
    assert want_re.max() > 0 and np.all(b_re >= 0) and np.all(b_im >= 0)


def test_a_fit_with_every_coefficient_active_gets_no_bias_term():
    basis, X, y, active, pairs = _linear_case(4)
    active[:] = True
    c = np.linalg.lstsq(X, y, rcond=None)[0]
    N, grad = X.conj().T @ X, -X.conj().T @ (y - X @ c)
    b_re, b_im = one_term_bias_variance(N, grad, basis, active, 1.0, pairs)
    assert not b_re.any() and not b_im.any()


def test_nested_extension_completes_the_smaller_space_orthogonally():
    f = np.geomspace(2.0, 150.0, 60)
    for nb, rich in ((4, 5), (6, 9)):
        B, R = log_frequency_basis(f, nb), log_frequency_basis(f, rich)
        E = nested_extension(B, R)
        assert E.shape == (f.size, rich - nb)
        # orthogonal to the smaller space, unit mean square, and together they span the richer one
        assert np.abs(B.T @ E).max() <= 1e3 * np.finfo(float).eps * f.size * np.abs(B).max() * np.abs(E).max()
        np.testing.assert_allclose(E.T @ E / f.size, np.eye(rich - nb), atol=1e3 * np.finfo(float).eps)
        both = np.hstack([B, E])
        fit = both @ np.linalg.lstsq(both, R, rcond=None)[0]
        np.testing.assert_allclose(fit, R, atol=1e3 * np.linalg.cond(both) * np.finfo(float).eps)


def test_normal_inverse_of_a_singular_matrix_is_a_reflexive_generalized_inverse():
    # rank 1 with a zero row: the equilibrated matrix is singular, so the pseudo-inverse of it is scaled back,
    # G = D^-1 pinv(D^-1 N D^-1) D^-1: N G N = N and G N G = G (not the Moore-Penrose inverse of N itself)
    v = np.array([1.0, 2.0, 0.0])
    N = np.outer(v, v)
    G = normal_inverse(N)
    tol = 100 * np.finfo(float).eps * np.abs(G).max() * np.abs(N).max()  # a few roundings of 3-term sums
    np.testing.assert_allclose(N @ G @ N, N, rtol=0, atol=tol * np.abs(N).max())
    np.testing.assert_allclose(G @ N @ G, G, rtol=0, atol=tol * np.abs(G).max())
    assert not G[2].any() and not G[:, 2].any()
