"""P-spline smoother: the fast path (one eigendecomposition, rss without an (F, G) array, banded
posterior variance) equals a straightforward dense solve per lambda."""

import numpy as np
import pytest
import scipy.sparse as sp

from jointid.methods.receptance import smoothing
from jointid.parallel import single_threaded_blas
from jointid.methods.receptance.smoothing import LOG_LAMBDA_GRID, _posterior_variance, bspline_basis, smooth_series


def _reference(x, y, variance, n_basis=None):
    """Dense normal equations solved anew for every lambda of the grid; GCV; Bayesian variance."""
    ok = np.isfinite(y) & np.isfinite(variance) & (variance > 0)
    K = int(n_basis or min(max(x.size // 2, 4), smoothing.MAX_BASIS))
    K = max(4, min(K, int(ok.sum()) - 1))
    B = bspline_basis(x, K).toarray()
    w = np.where(ok, 1.0 / np.where(ok, variance, 1.0), 0.0)
    yz = np.where(ok, y, 0.0)
    BWB = B.T @ (w[:, None] * B)
    BWBj = BWB + 1e-12 * np.trace(BWB) / K * np.eye(K)  # the smoother's jitter
    D = np.diff(np.eye(K), 2, axis=0)
    P = D.T @ D
    lams = np.trace(BWB) / np.trace(P) * 10.0**LOG_LAMBDA_GRID
    best = None
    for lam in lams:
        A = BWBj + lam * P
        fit = B @ np.linalg.solve(A, B.T @ (w * yz))
        edf = np.trace(np.linalg.solve(A, BWBj))
        gcv = ok.sum() * np.sum(w * (yz - fit) ** 2) / (ok.sum() - edf) ** 2
        if best is None or gcv < best[0]:
            best = (gcv, lam, fit, edf)
    var = np.einsum("fk,kf->f", B, np.linalg.solve(BWBj + best[1] * P, B.T))
    return best[1:] + (var,)


@pytest.mark.parametrize("seed, F, n_basis", [(0, 600, None), (1, 1500, None), (2, 900, 40)])
def test_fast_smoother_equals_a_dense_solve_per_lambda(seed, F, n_basis):
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(5.0, 1000.0, F))  # non-uniform lines
    sd = 0.02 * (1 + x / 300)
    y = np.sin(x / 60) + 0.3 * np.cos(x / 17) + sd * rng.standard_normal(F)
    v = sd**2
    y[[3, 50]] = np.nan  # ignored lines: non-finite value, zero variance
    v[100] = 0.0
    with single_threaded_blas():  # 200 x 200 solves: BLAS threads only contend
        lam, fit, edf, var = _reference(x, y, v, n_basis)
    s = smooth_series(x, y, v, n_basis)
    # the same grid point wins the GCV: lam = trace(B^T W B) / trace(P) * 10**grid, and the trace is a sum
    # of about F + K positive products, so the two computations of it agree to (F + K) eps relative
    # (grid points are 10**0.25 = 1.78x apart: any other grid point is 0.78 away)
    assert abs(s.lam / lam - 1) <= (F + smoothing.MAX_BASIS) * np.finfo(float).eps
    assert abs(s.edf - edf) <= 1e-10 * edf
    assert np.max(np.abs(s.value - fit)) <= 1e-10 * np.max(np.abs(fit))
    assert np.max(np.abs(s.variance - var) / var) <= 1e-10
    assert 3 < s.edf < 100  # a real smoothing decision, not an end of the grid


def test_posterior_variance_of_a_general_sparse_design_takes_the_dense_path():
    x = np.linspace(0.0, 1.0, 300)
    B = bspline_basis(x, 20)
    T = np.random.default_rng(3).standard_normal((20, 20))
    filt = np.linspace(1.0, 0.01, 20)
    banded = _posterior_variance(B, T, filt)
    perm = np.random.default_rng(4).permutation(20)  # columns no longer consecutive in each row
    general = _posterior_variance(sp.csr_matrix(B.toarray()[:, perm]), T[perm], filt)
    dense = np.einsum("fk,kl,fl->f", B.toarray(), (T * filt) @ T.T, B.toarray())
    assert np.allclose(banded, dense, rtol=1e-12, atol=0) and np.allclose(general, dense, rtol=1e-12, atol=0)
