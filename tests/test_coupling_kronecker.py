"""The Kronecker path of the per-line coupling fit (many joint DOFs): exactness, agreement with the exact path, variance."""

import numpy as np
import pytest

from jointid.methods.receptance.coupling_lines import DENSE_PATH_BYTES, coupling_per_line, relinearize, uses_kronecker


def _case(seed=3, F=40):
    """A 30-DOF mass-spring structure, 4 grounded joint DOFs with a full complex symmetric Du, 13 x 8 FRFs."""
    rng = np.random.default_rng(seed)
    N = 30
    k = rng.uniform(0.5, 1.5, N - 1) * 1e6
    K = np.diag(np.r_[k, 0] + np.r_[0, k]) - np.diag(k, 1) - np.diag(k, -1)
    Kc = rng.normal(size=(N, N)) * 3e4
    K += Kc @ Kc.T / N
    M = np.diag(rng.uniform(0.5, 1.5, N))
    hz = np.linspace(20, 300, F)
    Y = np.linalg.inv(K[None] * (1 + 0.01j) - ((2 * np.pi * hz) ** 2)[:, None, None] * M[None])
    n, m, e = [3, 4, 12, 20], [0, 2, 3, 5, 8, 11, 12, 15, 18, 20, 22, 25, 29], [1, 4, 6, 10, 16, 20, 21, 27]
    ks = 1 / np.abs(np.diagonal(Y[F // 2][np.ix_(n, n)]))
    D0 = 0.3 * np.sqrt(ks[:, None] * ks[None]) * (np.eye(4) + 0.2 * (1 - np.eye(4)))
    Du = D0[None] * (1 + 0.1j + 0.001 * hz[:, None, None])
    Ymn, Yne, Ynn, Yme = (Y[:, a][:, :, b] for a, b in ((m, n), (n, e), (n, n), (m, e)))
    H = Yme - Ymn @ np.linalg.solve(Ynn + np.linalg.inv(Du), Yne)
    return rng, Ymn, Yne, Ynn, Yme, H, Du


@pytest.mark.parametrize("symmetric", [True, False])
def test_exact_data_are_recovered_exactly_on_both_paths(symmetric):
    _, Ymn, Yne, Ynn, Yme, H, Du = _case()
    var = np.abs(H) ** 2  # relative weights: not separable
    kr = coupling_per_line(Ymn, Yne, Ynn, Yme - H, var, symmetric, path="kronecker")
    ex = coupling_per_line(Ymn, Yne, Ynn, Yme - H, var, symmetric, path="exact")
    assert kr.kronecker and not ex.kronecker and kr.x_covariance is None
    assert np.max(np.abs(kr.stiffness - Du) / np.abs(Du)) < 1e-8  # measured 8e-12 (symmetric), 8e-13
    assert np.max(np.abs(ex.stiffness - Du) / np.abs(Du)) < 1e-8  # measured 1.3e-11, 3.6e-12


@pytest.mark.parametrize("symmetric", [True, False])
def test_with_separable_variance_the_kronecker_path_is_the_exact_weighted_fit(symmetric):
    """Same estimate, same variance (the memory-free formula vs the dense p x p covariance), same scale."""
    rng, Ymn, Yne, Ynn, Yme, H, Du = _case()
    F, m, e = H.shape
    var = rng.uniform(0.5, 2, (F, m))[:, :, None] * rng.uniform(0.5, 2, (F, e))[:, None, :] * 1e-6 * np.mean(np.abs(H)) ** 2  # ~0.1 %
    Hn = H + np.sqrt(var / 2) * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    ex = coupling_per_line(Ymn, Yne, Ynn, Yme - Hn, var, symmetric, path="exact")
    kr = coupling_per_line(Ymn, Yne, Ynn, Yme - Hn, var, symmetric, path="kronecker")
    assert np.max(np.abs(kr.stiffness - ex.stiffness) / np.sqrt(ex.variance)) < 1e-8  # measured 6e-11
    assert np.max(np.abs(kr.variance / ex.variance - 1)) < 1e-8  # measured 4e-12
    assert np.max(np.abs(kr.scale / ex.scale - 1)) < 1e-9 and kr.dof == ex.dof == m * e - (10 if symmetric else 16)
    assert np.max(np.abs(kr.stiffness - Du) / np.abs(Du)) > 1e-2  # the noise is there
    # relinearized around another estimate (no p x p arrays on the Kronecker path): the same again
    around = Du * (1 + 0.02)
    a, b = relinearize(ex, around), relinearize(kr, around)
    assert np.max(np.abs(b.stiffness - a.stiffness) / np.sqrt(a.variance)) < 1e-8
    assert np.max(np.abs(b.variance / a.variance - 1)) < 1e-8


def test_the_variance_is_that_of_the_estimator_by_finite_differences():
    """Brute force: E|dDu_ij|^2 = sum_rc |d Du_ij / d C_rc|^2 var_rc for the estimator itself (central differences)."""
    rng, Ymn, Yne, Ynn, Yme, H, Du = _case(F=1)
    F, m, e = H.shape
    var = rng.uniform(0.5, 2, (F, m))[:, :, None] * rng.uniform(0.5, 2, (F, e))[:, None, :] * np.mean(np.abs(H)) ** 2
    C0 = Yme - H + 1e-3 * np.sqrt(var) * rng.standard_normal(H.shape)
    fit = lambda C: coupling_per_line(Ymn, Yne, Ynn, C, var, path="kronecker").stiffness[0]  # noqa: E731
    est = coupling_per_line(Ymn, Yne, Ynn, C0, var, path="kronecker")
    h = 1e-7 * np.abs(C0).max() / np.sqrt(var).max()
    V = np.zeros((4, 4))
    for r in range(m):
        for c in range(e):
            dC = np.zeros_like(C0)
            dC[0, r, c] = h * np.sqrt(var[0, r, c])
            V += np.abs((fit(C0 + dC) - fit(C0 - dC)) / (2 * h)) ** 2
    assert np.max(np.abs(est.variance[0] / est.scale[0] / V - 1)) < 1e-6  # measured 9e-9


def test_nonseparable_weights_cost_little_accuracy():
    """Relative weights 1/|H|^2 (not separable) at 0.2 % noise: both paths err alike; the Kronecker one predicts its error."""
    rng, Ymn, Yne, Ynn, Yme, H, Du = _case()
    Hn = H + 0.002 * np.abs(H) * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    var = np.abs(Hn) ** 2
    ex = coupling_per_line(Ymn, Yne, Ynn, Yme - Hn, var, path="exact")
    kr = coupling_per_line(Ymn, Yne, Ynn, Yme - Hn, var, path="kronecker")
    rms = lambda r: np.sqrt(np.mean(np.abs(r.stiffness - Du) ** 2 / np.abs(Du) ** 2))  # noqa: E731
    assert rms(kr) < 1.3 * rms(ex)  # measured 0.35 vs 0.32
    z = np.sqrt(np.mean(np.abs(kr.stiffness - Du) ** 2 / kr.variance))
    assert 0.5 < z < 2.0  # measured 1.21 (the exact path: 0.86)


def test_the_path_is_chosen_by_the_memory_of_the_exact_one():
    assert not uses_kronecker(2000, 7, 3, 2)  # the beam: 2 joint DOFs
    assert not uses_kronecker(200, 24, 24, 12)  # two 6-DOF mounts, 24 x 24 FRFs, 200 lines: 0.8 GB
    assert uses_kronecker(500, 24, 24, 12)  # ... 500 lines: 2.0 GB
    assert uses_kronecker(2000, 48, 36, 24)  # the large-model benchmark: 96 GB
    assert DENSE_PATH_BYTES == 1_000_000_000
    _, Ymn, Yne, Ynn, Yme, H, _ = _case(F=8)
    with pytest.raises(ValueError, match=r"^path must be 'auto', 'exact' or 'kronecker', got 'qr'$"):
        coupling_per_line(Ymn, Yne, Ynn, Yme - H, np.abs(H) ** 2, path="qr")


def test_identify_joint_coupling_takes_the_kronecker_path_for_a_large_problem():
    """12 joint DOFs, 24 x 24 FRFs, 500 lines (the exact path would need 2 GB): exact recovery; no column calibration."""
    import scipy.sparse as sp

    from jointid.errors import IdentificationError
    from jointid.frequency import Frequency
    from jointid.frf import FRF
    from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
    from jointid.physics.sparse_model import SparseModel

    rng = np.random.default_rng(7)
    N = 60
    k = rng.uniform(0.5, 1.5, N - 1) * 1e6
    K = np.diag(np.r_[k, 0] + np.r_[0, k]) - np.diag(k, 1) - np.diag(k, -1)
    Kc = rng.normal(size=(N, N)) * 3e4
    K = K + Kc @ Kc.T / N
    model = SparseModel(sp.diags(rng.uniform(0.5, 1.5, N)), sp.csc_array(K), [f"{i + 1}x" for i in range(N)], loss_factor=0.01, method="modal")
    freq = Frequency(np.linspace(20, 150, 500))  # weighted design condition < 1e6 (1e9 near 250 Hz)
    lab = lambda idx: [f"{i + 1}x" for i in idx]  # noqa: E731
    n, m, e = lab(range(3, 60, 5)), lab(range(0, 60, 5)) + lab(range(2, 60, 5)), lab(range(1, 60, 5)) + lab(range(4, 60, 5))
    Ynn = model.receptance(freq, n, n)
    ks = 1 / np.abs(np.diagonal(Ynn[250]))
    D0 = 0.3 * np.sqrt(ks[:, None] * ks[None]) * (np.eye(12) + 0.05 * (1 - np.eye(12)))
    Du = D0[None] * (1 + 0.1j + 0.001 * freq.hz[:, None, None])
    H = model.receptance(freq, m, e) - model.receptance(freq, m, n) @ np.linalg.solve(Ynn + np.linalg.inv(Du), model.receptance(freq, n, e))
    frf = FRF(freq, H, m, e, kind="receptance")
    assert uses_kronecker(500, 24, 24, 12)
    r = identify_joint_coupling(model, frf, n)  # default options: calibration "auto" is skipped on this path
    assert r.calibration is None and np.max(np.abs(r.stiffness - Du) / np.abs(Du)) < 1e-8  # measured 2e-10
    with pytest.raises(IdentificationError, match=r"^calibration = 'columns' needs the full per-line design, too large for 12 joint DOFs on 500 lines; use 'auto' or 'none'$"):
        identify_joint_coupling(model, frf, n, CouplingOptions(calibration="columns"))


@pytest.mark.parametrize("symmetric", [True, False])
def test_inverse_perturbation_is_the_rms_of_the_perturbed_inverse(symmetric):
    """``inverse_perturbation`` against its definition, per line: ``sqrt(tr(A C A^H))`` with ``A = (L kron Y^T) P``
    formed explicitly; the batched Kronecker identity it uses is exact up to the round-off of n^4 products."""
    from jointid.methods.receptance.coupling_lines import LineEstimates, inverse_perturbation, symmetric_parametrization

    rng = np.random.default_rng(4)
    F, n = 9, 3
    P = symmetric_parametrization(n, symmetric)
    p = P.shape[1]
    cplx = lambda *s: rng.standard_normal(s) + 1j * rng.standard_normal(s)  # noqa: E731
    Ynn = cplx(F, n, n)
    Ynn = Ynn + np.swapaxes(Ynn, 1, 2)
    K = cplx(F, n, n)
    R = cplx(F, p, p)
    C = R @ np.conj(np.swapaxes(R, 1, 2))
    lines = LineEstimates(K, np.ones((F, n, n)), np.ones(F), np.ones(F), 3, x=cplx(F, p), x_covariance=C, Ynn=Ynn,
                          symmetric=symmetric)
    L = np.eye(n)[None] + K @ Ynn
    ref = np.array([np.sqrt(np.real(np.trace(A @ C[f] @ np.conj(A.T)))) for f in range(F)
                    for A in [np.kron(L[f], Ynn[f].T) @ P]])
    got = inverse_perturbation(lines, chunk=4)
    # both sides sum n^4 p^2 products of the same factors in another order: a few eps per product, relative
    assert np.all(np.abs(got - ref) <= 8 * n ** 4 * p ** 2 * np.finfo(float).eps * ref)
