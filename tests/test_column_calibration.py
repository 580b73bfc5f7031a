"""Force-calibration error per excitation column: detected, estimated, corrected, and its uncertainty carried."""

import dataclasses
import warnings

import numpy as np
import pytest

from jointid.benchmark import benchmark_study
from jointid.errors import DataError, IdentificationError
from jointid.frf import FRF
from jointid.methods.receptance.column_calibration import CALIBRATION_MIN_F, estimate_column_calibration, residual_variance
from jointid.physics.free_model import as_free_model
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.pipeline import free_model, simulate

TERMS = [(0, 0), (0, 1), (1, 1)]


@pytest.fixture(scope="module")
def case():
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0, step=2.0))
    return st, simulate(st), free_model(st)


def _measured(test, column_error, noise, seed):
    """Exact FRFs, each column times (1 + eps_j(f)), plus independent relative noise."""
    rng = np.random.default_rng(seed)
    d = test.frf.data * (1.0 + column_error[:, None, :])
    d = d + noise * np.abs(d) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)) / np.sqrt(2)
    return FRF(test.frf.frequency, d, test.frf.responses, test.frf.references, test.frf.kind)


def _smooth_error(hz, seed, level=0.01):
    """A smooth complex column error, ~level, varying over a few hundred Hz (like force-window noise)."""
    rng = np.random.default_rng(seed)
    x = (hz - hz[0]) / 300.0
    cols = [level * (rng.standard_normal() + 1j * rng.standard_normal()) * np.cos(x + rng.uniform(0, 6)) for _ in range(3)]
    return np.stack(cols, axis=1) / np.sqrt(2)


def _errors(K, truth):
    return np.array([np.median(np.abs(K[:, i, j] - truth[:, i, j]) / np.abs(truth[:, i, j])) for i, j in TERMS])


def test_a_column_error_is_detected_estimated_and_its_cost_is_flagged(case):
    st, test, model = case
    eps = _smooth_error(test.frf.frequency.hz, seed=1)
    measured = _measured(test, eps, 0.002, seed=2)
    fixed = identify_joint_coupling(model, measured, st.joint.joint_dofs)
    ignored = identify_joint_coupling(model, measured, st.joint.joint_dofs, CouplingOptions(calibration="none"))
    cal = fixed.calibration
    assert fixed.calibration_applied and cal.f_statistic > 10 * CALIBRATION_MIN_F and cal.p_value < 1e-10
    assert np.median(np.abs(cal.error - eps)) < 0.1 * np.median(np.abs(eps))  # the column error itself, to 10 %
    e_fixed, e_ignored = _errors(fixed.stiffness, test.truth), _errors(ignored.stiffness, test.truth)
    assert np.all(e_fixed[:2] < e_ignored[:2] / 3), (e_fixed, e_ignored)  # translational and coupling terms recovered
    assert e_fixed[0] < 0.005
    # the uncertainty of the correction is in the bands: the flags stay honest
    rel_std = fixed.relative_std
    for k, (i, j) in enumerate(TERMS):
        err = np.abs(fixed.stiffness[:, i, j] - test.truth[:, i, j]) / np.abs(test.truth[:, i, j])
        ok = fixed.reliable_terms[:, i, j]
        if ok.any() and (~ok).any():
            assert np.median(err[ok]) < np.median(err[~ok])
        assert np.median(err / rel_std[:, i, j]) < 2.0  # errors within a couple of predicted sigmas
    assert fixed.findings()[0].startswith("force calibration error of the excitation columns (median ")


def test_no_column_error_is_not_corrected(case):
    st, test, model = case
    measured = _measured(test, np.zeros((test.frf.frequency.size, 3)), 0.01, seed=3)
    r = identify_joint_coupling(model, measured, st.joint.joint_dofs)
    assert r.calibration is not None and not r.calibration_applied
    assert r.calibration.f_statistic < CALIBRATION_MIN_F
    assert 0.0 <= r.calibration.p_value <= 1.0  # also for F <= 0 (the compensated reduction can be negative)
    assert not any(line.startswith("force calibration") for line in r.findings())
    none = identify_joint_coupling(model, measured, st.joint.joint_dofs, CouplingOptions(calibration="none"))
    assert np.array_equal(none.stiffness, r.stiffness) and none.calibration is None


@pytest.mark.parametrize("kwargs, msg", [
    ({"calibration": "rows"}, "calibration must be one of ('auto', 'columns', 'none'), got 'rows'"),
    ({"calibration_basis": 3}, "calibration_basis must be an integer >= 4 or a tuple of them, got 3"),
    ({"calibration_basis": (16, 3)}, "calibration_basis must be an integer >= 4 or a tuple of them, got (16, 3)"),
    ({"calibration_basis": ()}, "calibration_basis must be an integer >= 4 or a tuple of them, got ()"),
])
def test_bad_calibration_options(kwargs, msg):
    with pytest.raises(IdentificationError) as err:
        CouplingOptions(**kwargs)
    assert str(err.value) == msg


def test_the_noise_in_the_regressor_does_not_bias_the_column_error(case):
    """H is in the data and in the regressor: without the errors-in-variables compensation the column error
    came out +0.7 to +1.0 % (real) on every column from 5 % relative noise and no column error at all."""
    st, test, model = case
    frf, n_dofs = test.frf, st.joint.joint_dofs
    H0 = frf.to("receptance").data
    Y = as_free_model(model).receptance(frf.frequency, tuple(frf.responses) + tuple(n_dofs), tuple(n_dofs) + tuple(frf.references))
    Ymn, Yme, Yne = Y[:, :7, :2], Y[:, :7, 2:], Y[:, 7:, 2:]
    means = []
    for seed in range(4):
        rng = np.random.default_rng(10 + seed)
        H = H0 + 0.05 * np.abs(H0) * (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / np.sqrt(2)
        cal = estimate_column_calibration(frf.frequency.hz, Ymn, Yne, Yme - H, H, np.abs(H0) ** 2)
        means.append(np.mean(cal.delta.real, axis=0))
    means = np.array(means)  # (seeds, columns); random error of each ~1e-3
    assert abs(np.mean(means)) < 1e-3 and np.max(np.abs(means)) < 3e-3, means


def test_residual_variance_recovers_a_heteroskedastic_noise_from_wrong_weights():
    rng = np.random.default_rng(5)
    F, m, n, e = 600, 7, 2, 3
    Ymn = rng.standard_normal((F, m, n)) + 1j * rng.standard_normal((F, m, n))
    Yne = rng.standard_normal((F, n, e)) + 1j * rng.standard_normal((F, n, e))
    X = rng.standard_normal((F, n, n)) + 1j * rng.standard_normal((F, n, n))
    X = X + np.swapaxes(X, 1, 2)
    f = np.linspace(0, 1, F)[:, None, None]
    true_var = np.exp(rng.uniform(-2, 2, (1, m, e)) + 1.5 * np.sin(3 * f + rng.uniform(0, 6, (1, m, e))))
    noise = np.sqrt(true_var / 2) * (rng.standard_normal((F, m, e)) + 1j * rng.standard_normal((F, m, e)))
    change = Ymn @ X @ Yne + noise
    wrong = true_var * np.exp(0.6 * rng.standard_normal((1, m, e)) + 0.3 * rng.standard_normal((F, m, e)))  # as the coherence split
    q_wrong = np.percentile(wrong / true_var, [5, 95])
    for start in (wrong, true_var):
        q = np.percentile(residual_variance(Ymn, Yne, change, start) / true_var, [5, 50, 95])
        assert 0.9 < q[1] < 1.1 and q[0] > 0.65 and q[2] < 1.45, q  # 41 lines: ~0.16 relative scatter, plus smearing
    assert q_wrong[0] < 0.45 and q_wrong[1] > 2.0, q_wrong  # what it started from
    # a line with fewer than 3 residual degrees of freedom cannot measure its noise
    assert residual_variance(Ymn[:, :2], Yne[:, :, :2], change[:, :2, :2], np.ones((F, 2, 2))) is None


def _hermitian_factor(C: np.ndarray) -> np.ndarray:
    """``L`` with ``L L^H = C`` for a Hermitian positive semi-definite ``C`` (eigen-decomposition, clipped at 0)."""
    lam, V = np.linalg.eigh(0.5 * (C + np.conj(C.T)))
    return V * np.sqrt(np.clip(lam, 0.0, None))[None, :]


def _reference_calibration(hz, Ymn, Yne, change, H, variance, nb=16):
    """The estimate written term by term as in the module docstring (dense einsum sums over the lines): c, f_stat, Cx, cond(Nc)."""
    from scipy import stats

    from jointid.methods.receptance.coupling_lines import symmetric_parametrization, whitened_line_design
    from jointid.methods.receptance.smoothing import bspline_basis

    F, m, n = Ymn.shape
    e = Yne.shape[2]
    p = symmetric_parametrization(n, True).shape[1]
    dof = F * (m * e - p) - e * nb
    sw, cs, Q, R = whitened_line_design(Ymn, Yne, variance, True)
    Qh = np.conj(np.swapaxes(Q, 1, 2))
    Gw = np.zeros((F, m * e, e), complex)
    for r in range(m):
        for j in range(e):
            Gw[:, r * e + j, j] = H[:, r, j] * sw[:, r * e + j]
    dw = change.reshape(F, m * e) * sw
    QhG = np.einsum("fij,fjk->fik", Qh, Gw)
    Z = Gw - np.einsum("fij,fjk->fik", Q, QhG)
    r0 = dw - np.einsum("fij,fj->fi", Q, np.einsum("fij,fj->fi", Qh, dw))
    B = bspline_basis(hz, nb).toarray()
    N = np.einsum("fai,fb,faj,fc->ibjc", Z.conj(), B, Z, B).reshape(e * nb, e * nb)
    rhs = -np.einsum("fai,fa,fb->ib", Z.conj(), r0, B).reshape(e * nb)
    Ninv = np.linalg.inv(N)
    rss0 = np.sum(np.abs(r0) ** 2)
    c = Ninv @ rhs
    s2 = (rss0 - np.real(np.vdot(c, N @ c))) / dof
    d = np.sum(1.0 - np.sum(np.abs(Q) ** 2, axis=2).reshape(F, m, e), axis=1)
    Dm = np.zeros((e, nb, e, nb))
    for j in range(e):
        Dm[j, :, j, :] = np.einsum("f,fb,fc->bc", d[:, j], B, B)
    Nc = N - s2 * Dm.reshape(e * nb, e * nb)
    rhs_c = rhs - s2 * np.einsum("fj,fb->jb", d, B).reshape(e * nb)
    c = np.linalg.solve(Nc, rhs_c)
    reduction = np.real(np.vdot(rhs_c, Ninv @ rhs_c))  # Wald: the compensated score against its covariance s^2 N
    rss1 = rss0 - reduction
    f_stat = (reduction / (2 * e * nb)) / (rss1 / (2 * dof))
    U = np.linalg.solve(R, QhG) / cs[:, :, None]
    Nci = np.linalg.inv(Nc)
    G = np.einsum("fpj,fb,jbk->fpk", U, B, _hermitian_factor(rss1 / dof * Nci @ N @ Nci.conj().T).reshape(e, nb, e * nb))
    Cx = np.einsum("fpk,fqk->fpq", G, G.conj())
    return c, f_stat, stats.f.sf(f_stat, 2 * e * nb, 2 * dof), Cx, np.linalg.cond(Nc), rss0 / reduction


def test_the_batched_estimate_equals_the_sums_written_out(case):
    """The vectorized estimate (sparse basis products, batched BLAS) equals the normal equations summed term by term.

    Both sum the same F terms in another order: each sum is off by at most ~F eps of the sum of the
    terms' magnitudes, and the solution c by cond(Nc) times that; the F statistic's reduction is a
    difference, amplified by rss0 / reduction. Bounds: 10 F eps cond(Nc) (x rss0 / reduction for F).
    """
    st, test, model = case
    frf, n_dofs = test.frf, st.joint.joint_dofs
    hz = frf.frequency.hz
    measured = _measured(test, _smooth_error(hz, seed=4), 0.003, seed=5)
    H = measured.to("receptance").data
    Y = as_free_model(model).receptance(frf.frequency, tuple(frf.responses) + tuple(n_dofs), tuple(n_dofs) + tuple(frf.references))
    Ymn, Yme, Yne = Y[:, :7, :2], Y[:, :7, 2:], Y[:, 7:, 2:]
    var = (0.003 * np.abs(H)) ** 2
    cal = estimate_column_calibration(hz, Ymn, Yne, Yme - H, H, var)
    c_ref, f_ref, p_ref, Cx_ref, cond, amplification = _reference_calibration(hz, Ymn, Yne, Yme - H, H, var)
    from jointid.methods.receptance.smoothing import bspline_basis

    c = np.linalg.lstsq(bspline_basis(hz, 16).toarray(), cal.delta, rcond=None)[0].T.reshape(-1)  # B has full column rank
    bound = 10 * hz.size * np.finfo(float).eps * cond
    assert cal.significant and bound < 1e-6  # a meaningful comparison: a real column error, a well-posed system
    assert np.max(np.abs(c - c_ref)) <= bound * np.max(np.abs(c_ref))
    assert abs(cal.f_statistic - f_ref) <= bound * amplification * f_ref
    assert np.max(np.abs(cal.x_covariance - Cx_ref)) <= bound * amplification * np.max(np.abs(Cx_ref))
    assert cal.p_value == pytest.approx(p_ref, rel=1e-6, abs=1e-300)


def test_a_residual_below_the_round_off_of_its_difference_is_held_at_that_floor():
    """``rss0 - reduction`` of sums of n real squares is exact to ~n eps rss0: below that, the floor (no overflow,
    no basis chosen by round-off); above it, the difference as computed."""
    from jointid.methods.receptance.column_calibration import _resolved_rss

    rss0, n = 3.07e32, 2 * 451 * 7 * 3
    floor = n * np.finfo(float).eps * rss0
    assert _resolved_rss(rss0, rss0 - 1.08e17, n) == floor  # the residual one OpenBLAS kernel left of an exact fit
    assert _resolved_rss(rss0, rss0, n) == floor  # another kernel's: 0
    assert _resolved_rss(rss0, 0.5 * rss0, n) == 0.5 * rss0
    assert _resolved_rss(0.0, 0.0, n) == np.finfo(float).tiny


@pytest.mark.numerics
def test_an_exact_column_error_keeps_the_coarsest_basis_and_a_finite_f(case):
    """Noise-free FRFs scaled alike in every column (g/N read as m/s^2/N): every basis fits exactly, so none earns more
    functions than the first; the F statistic is finite (was inf, an overflow warning, and a finer basis chosen on
    OpenBLAS's Nehalem kernel with 2 threads, where round-off left 3.5e-16 of rss0 for 16 functions and 0 for 32)."""
    st, test, model = case
    frf, n_dofs = test.frf, st.joint.joint_dofs
    hz = frf.frequency.hz
    H = frf.to("receptance").data / 9.80665
    Y = as_free_model(model).receptance(frf.frequency, tuple(frf.responses) + tuple(n_dofs), tuple(n_dofs) + tuple(frf.references))
    Ymn, Yme, Yne = Y[:, :7, :2], Y[:, :7, 2:], Y[:, 7:, 2:]
    var = (1e-3 * np.abs(H)) ** 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cal = estimate_column_calibration(hz, Ymn, Yne, Yme - H, H, var, n_basis=(16, 32, 64))
    assert cal.n_basis == 16 and np.isfinite(cal.f_statistic) and cal.p_value == 0.0
    sixteen = estimate_column_calibration(hz, Ymn, Yne, Yme - H, H, var, n_basis=16)
    assert np.array_equal(cal.delta, sixteen.delta)  # the first basis' fit itself, kept
    # it is the scale (H = H_true (1 + error)): a fit of round-off would be O(1) off; 1e-6 says which, not how exactly
    # (2e-10 here; the sums' own round-off is bounded in test_the_batched_estimate_equals_the_sums_written_out)
    assert np.max(np.abs(cal.error - (1 / 9.80665 - 1.0))) < 1e-6


def _fast_error(hz, seed, level=0.01, scale_hz=15.0):
    """A complex column error varying on a ``2 pi scale_hz`` (~100 Hz) period, as the noise inside a 10 ms force window."""
    rng = np.random.default_rng(seed)
    x = (hz - hz[0]) / scale_hz
    cols = [level * sum((rng.standard_normal() + 1j * rng.standard_normal()) * np.cos(x * rng.uniform(0.7, 1.3) + rng.uniform(0, 6))
                        for _ in range(3)) for _ in range(3)]
    return np.stack(cols, axis=1) / np.sqrt(6)


def test_a_column_error_finer_than_the_default_basis_gets_a_finer_one(case):
    """A column error of ~100 Hz period over 100-1000 Hz: 16 functions per column (knots every 69 Hz) do not follow it
    (K_w_w 0.8 % off here; on a virtual hammer test with a 10 ms force window 3.7 %, flagged reliable); the finer
    candidates earn their functions, and K_w_w is then 0.02 % off, within its bands (hammer: 0.007 % with 32). Errors
    shared by neighbouring lines do not ask for a finer basis: ``test_model_check``'s 5-line moving average keeps 16."""
    st, test, model = case
    hz = test.frf.frequency.hz
    measured = _measured(test, _fast_error(hz, seed=4), 0.002, seed=5)
    auto = identify_joint_coupling(model, measured, st.joint.joint_dofs)
    coarse = identify_joint_coupling(model, measured, st.joint.joint_dofs, CouplingOptions(calibration_basis=16))
    assert auto.calibration_applied and auto.calibration.n_basis > 16 and coarse.calibration.n_basis == 16
    e_auto, e_coarse = _errors(auto.stiffness, test.truth), _errors(coarse.stiffness, test.truth)
    assert e_auto[0] < e_coarse[0] / 3, (e_auto, e_coarse)
    z = np.abs(auto.stiffness[:, 0, 0] - test.truth[:, 0, 0]) / np.hypot(auto.std_real[:, 0, 0], auto.std_imag[:, 0, 0])
    ok = auto.reliable_terms[:, 0, 0]
    assert ok.mean() > 0.5 and np.mean(z[ok] > 3) < 0.1
    assert any("functions per column, the finest the data ask for" in f for f in auto.findings()), auto.findings()


def test_a_flipped_excitation_column_is_named_as_a_sign(case):
    """One hit column measured with the sign flipped was corrected as a -200 % column error (the joint then took what
    the correction left: on a 6-DOF mount, K_ry_ry flagged reliable 240 % off): it is refused naming the column
    (:mod:`jointid.methods.receptance.gross_errors`); used as it is when asked, with every term flagged and the
    calibration's finding naming the sign."""
    st, test, model = case
    noisy = _measured(test, np.zeros((test.frf.data.shape[0], 3)), 0.002, seed=3)
    d = noisy.data.copy()
    d[:, :, 1] *= -1
    flipped = FRF(test.frf.frequency, d, test.frf.responses, test.frf.references, test.frf.kind)
    with pytest.raises(DataError, match=r"^the excitation at 9w \(column 2\) measured the negative of what the free model "
                                        r"predicts \(with the sign reversed"):
        identify_joint_coupling(model, flipped, st.joint.joint_dofs)
    r = identify_joint_coupling(model, flipped, st.joint.joint_dofs, CouplingOptions(units_check=False))
    assert not r.reliable.any()
    said = [f for f in r.findings() if f.startswith("force calibration error of the excitation columns")]
    assert len(said) == 1 and said[0].endswith(
        "; excitation column 2 (in the study's order) measured the negative of what the free model predicts: a flipped "
        "sign of the hammer or of the responses' direction in that column"), said
