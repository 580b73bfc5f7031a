"""The structured joint estimate (one viscoelastic material, all lines at once): derivatives, physics, noise, fallback.

Figures over many seeds are in benchmarks/robust_identification.py; here fixed seeds.
"""

import dataclasses
from types import SimpleNamespace

import numpy as np

from jointid.dofs import Dof
import pytest

from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.methods.hong_lee.inverse import InverseOptions
from jointid.methods.receptance.structured_model import StructuredModel, structured_stiffness
from jointid.methods.receptance.structured_select import model_average
from jointid.physics.joints import parametric_joint
from jointid.physics.synthesis import synthesize_frf
from jointid.pipeline import experiment, free_model, identify, simulate

TERMS = [(0, 0), (0, 1), (1, 1)]


def _study(material="A", node=10, **beam):
    st = benchmark_study()
    joint = dataclasses.replace(st.joint, dofs=tuple(Dof(node, d.direction) for d in st.joint.dofs), model=dataclasses.replace(st.joint.model, parameters={"material": material}))
    st = dataclasses.replace(st, joints=(joint,), frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))
    return dataclasses.replace(st, structure=dataclasses.replace(st.beam, **beam)) if beam else st


def _errors(K, truth):
    return np.array([np.median(np.abs(K[:, i, j] - truth[:, i, j]) / np.abs(truth[:, i, j])) for i, j in TERMS])


def _noisy(frf, level, seed):
    rng = np.random.default_rng(seed)
    d = frf.data
    noise = level * np.abs(d) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)) / np.sqrt(2)
    return FRF(frf.frequency, d + noise, frf.responses, frf.references, frf.kind)


@pytest.mark.parametrize("n_modes, g_basis, residual", [(0, 1, False), (2, 1, True), (1, 6, True)])
def test_model_jacobian_matches_finite_differences(n_modes, g_basis, residual):
    model = StructuredModel(2, n_modes, g_basis, residual, (1.0, 1.0), 1000.0, (100.0, 1000.0))
    rng = np.random.default_rng(1)
    theta = rng.standard_normal(model.n_params) * 0.3
    for r in range(n_modes):  # poles inside the band, g near 1 + 0.1j
        theta[model.sizes["A"] + model.sizes["B"] + model.sizes["E"] + r * 3 + 2] = np.log(0.5 + 0.3 * r)
    theta[-2 * g_basis::2] += 1.0
    hz = np.linspace(100.0, 1000.0, 37)
    D, J = structured_stiffness(theta, hz, model, jacobian=True)
    assert np.allclose(D, np.swapaxes(D, 1, 2))  # symmetric, reciprocity
    h = 1e-6
    for k in range(model.n_params):
        step = np.zeros_like(theta)
        step[k] = h
        fd = (structured_stiffness(theta + step, hz, model) - structured_stiffness(theta - step, hz, model)) / (2 * h)
        assert np.max(np.abs(fd - J[..., k])) <= 1e-6 * max(1.0, np.max(np.abs(fd))), k


def test_one_material_joint_with_a_constant_modulus_is_a_rational_function():
    """With 0 modes, constant g and no residual the model is exactly g A - w'^2 B."""
    model = StructuredModel(2, 0, 1, False, (2.0, 3.0), 500.0, (100.0, 500.0))
    theta = np.array([0.2, 1.5, 0.1, -0.3, 0.4, 0.9, 0.05])  # A01, A11, B00, B01, B11, Re g, Im g
    hz = np.array([100.0, 250.0, 500.0])
    g = 0.9 + 0.05j
    A = np.array([[1.0, 0.2], [0.2, 1.5]])
    B = np.array([[0.1, -0.3], [-0.3, 0.4]])
    S = np.outer([2.0, 3.0], [2.0, 3.0])
    expect = np.array([(g * A - (f / 500.0) ** 2 * B) * S for f in hz])
    assert np.allclose(structured_stiffness(theta, hz, model) * S, expect, rtol=1e-14, atol=0)


@pytest.fixture(scope="module")
def material_b():
    st = _study("B")
    return st, simulate(st)


def test_material_b_internal_mode_is_found_and_every_term_meets_the_targets(material_b):
    st, test = material_b
    r = identify(st, _noisy(test.frf, 0.01, seed=3))
    f = r.frequency.hz
    assert r.estimator == "structured"
    f_peak = f[np.argmax(np.abs(test.truth[:, 0, 0]))]  # the truth's internal mode shows as the peak of |K_ww|
    assert 900 < f_peak < 950
    poles = r.structured.best.poles_hz()
    assert np.min(np.abs(poles - f_peak)) < 0.02 * f_peak, (poles, f_peak)
    e = _errors(r.stiffness, test.truth)
    # measured (seed 3): 0.01 / 0.2 / 0.3 %; the P-spline per term: 0.3 / 3.3 / 11 % over seeds
    assert np.all(e < [0.01, 0.05, 0.10]), e
    summary = r.estimator_summary()
    assert summary["estimator"] == "structured" and summary["structured"]["accepted"]
    assert abs(sum(summary["structured"]["akaike_weights"].values()) - 1.0) < 1e-12


def test_data_from_a_finer_mesh_with_noise_every_term_beats_hong_lee_and_meets_the_targets():
    """FRFs of the beam meshed 16 elements per segment, 1 % noise, identified on the automatic mesh (8) at the beam end."""
    fine = _study("B", node=1, elements_per_segment=16)
    test = simulate(fine)
    st = dataclasses.replace(fine, structure=dataclasses.replace(fine.beam, elements_per_segment=None))
    measured = _noisy(test.frf, 0.01, seed=5)
    new = identify(st, measured)
    plain = identify(st, measured, InverseOptions())
    e_new, e_plain = _errors(new.stiffness, test.truth), _errors(plain.stiffness, test.truth)
    assert new.estimator == "structured"
    # measured: structured 0.04 / 0.6 / 2.4 %, Hong & Lee 6 / 80 / 700 %
    assert np.all(e_new < [0.01, 0.05, 0.10]), e_new
    assert np.all(e_new < e_plain), (e_new, e_plain)


def _hammer_at_the_beam_end(seed):
    """Identify Material B at node 1 from a virtual hammer test (1 % response + force noise); (result, true Du)."""
    st = _study("B", node=1)
    ex = experiment(st, seed=seed, periodic=True)
    return identify(st, ex.frf.band(100, 1000)), ex.truth[ex.frf.frequency.mask(100, 1000)]


def test_virtual_hammer_with_force_noise_at_the_beam_end():
    """The issue's hardest case: Material B, joint at node 1, 1 % response and force noise, 5 averages.

    Seed 1, the seed that missed with total-variance weights: force noise left after the column calibration must
    not be weighted as if it were still there. With the coherence's column-common part kept in the weights after
    the calibration had removed it, this seed gave K_theta_theta 19 % with bands holding the truth on 0.71-0.75
    of the lines; with the split (frf_variance.column_noise_fraction) now 0.08 / 1.0 / 4.4 % and 1.0.
    One noise realization for both claims (seed 0 also ran here: 0.12 / 1.9 / 6.5 %; 50 tests: medians
    0.10 / 1.3 / 5.2 %; the P-spline per term: 1.7 / 16 / 36 %); the lines marked reliable are better than the
    rest on seeds 0-4 (K_theta_theta, seed 1: median 1.1 % against 10 %).
    """
    r, truth = _hammer_at_the_beam_end(seed=1)
    e = _errors(r.stiffness, truth)
    assert r.estimator == "structured" and r.calibration_applied
    assert np.all(e < [0.01, 0.05, 0.05]), e
    rel = np.abs(r.stiffness - truth) / np.abs(truth)
    for i, j in TERMS:
        ok = r.reliable_terms[:, i, j]
        if ok.any() and (~ok).any():
            assert np.median(rel[ok, i, j]) < np.median(rel[~ok, i, j])
        z_re = np.abs(r.stiffness[:, i, j].real - truth[:, i, j].real) / r.std_real[:, i, j]
        z_im = np.abs(r.stiffness[:, i, j].imag - truth[:, i, j].imag) / r.std_imag[:, i, j]
        assert np.mean(z_re < 1.645) > 0.85 and np.mean(z_im < 1.645) > 0.85, (i, j)
    assert not r.reliable_terms[:, 1, 1].all() and r.reliable_terms[:, 1, 1].any()  # the comparison above is not empty


def test_k_ww_bands_at_mid_span_hold_with_force_noise():
    """Material A at node 10, 1 % force + response noise, seed 1: the calibration's errors reach K_ww.

    Before the errors-in-variables compensation of the calibration, the residual-based weights and
    keeping only models with the residual term, K_ww's bands held the truth on 0.35 / 0.64 of the lines
    (real / imaginary; 50 tests 0.67 / 0.72); now 0.92 / 0.85 (50 tests 0.87 / 0.87).
    """
    st = _study("A", node=10)
    ex = experiment(st, seed=1, periodic=True)
    r, truth = identify(st, ex.frf.band(100, 1000)), ex.truth[ex.frf.frequency.mask(100, 1000)]
    assert r.estimator == "structured" and r.calibration_applied
    assert all(order[2] for order in r.structured.fits), list(r.structured.fits)  # every model kept has the residual E
    z_re = np.abs(r.stiffness[:, 0, 0].real - truth[:, 0, 0].real) / r.std_real[:, 0, 0]
    z_im = np.abs(r.stiffness[:, 0, 0].imag - truth[:, 0, 0].imag) / r.std_imag[:, 0, 0]
    assert np.mean(z_re < 1.645) > 0.8 and np.mean(z_im < 1.645) > 0.8, (np.mean(z_re < 1.645), np.mean(z_im < 1.645))
    assert np.all(_errors(r.stiffness, truth) < [0.001, 0.005, 0.005])


def test_a_joint_outside_the_class_falls_back_to_per_term_smoothing():
    """A power-law joint (k ~ f^0.5 growth) with 0.01 % noise: the structured model's misfit is far above the noise.

    On a 5 Hz grid (181 lines; the 1 Hz grid's 901 lines took 2.5x as long): chi^2/dof 150 (1 Hz: 135), errors
    0.2-0.4 % of the targets below (1 Hz: 0.1-0.2 %), over seeds 2-4."""
    st = _study("A")
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, step=5.0))
    beam = free_model(st)
    joint = parametric_joint(10, 2e5, 60.0, 1.5e3, 0.12, growth=0.5, reference_frequency=100, exponent=0.5)
    frf = synthesize_frf(beam.with_joint(joint), st.frequency.frequency(), [f"{n}w" for n in (1, 3, 6, 9, 12, 15, 19)],
                         ["3w", "9w", "15w"], kind="accelerance")
    r = identify_joint_coupling(beam, _noisy(frf, 1e-4, seed=2), joint.dofs)
    assert r.structured is not None and not r.structured.accepted
    assert r.estimator == "gcv"
    line = r.findings()[0]
    assert line.startswith("the structured joint model does not fit these FRFs (chi^2/dof ")
    assert line.endswith(" > 1.5: not one viscoelastic material, a model error, or FRF errors larger than their coherence says, e.g. hammer "
                         "records without a force window): each term smoothed on its own instead")
    K = joint(frf.frequency.hz)
    assert np.all(_errors(r.stiffness, K) < [0.01, 0.05, 0.10])


def test_options_select_the_estimator(material_b):
    st, test = material_b
    measured = _noisy(test.frf, 0.01, seed=3)
    model = free_model(st)
    dofs = st.joint.joint_dofs
    gcv = identify_joint_coupling(model, measured, dofs, CouplingOptions(smoothing="gcv"))
    none = identify_joint_coupling(model, measured, dofs, CouplingOptions(smoothing="none"))
    assert gcv.estimator == "gcv" and gcv.structured is None
    assert none.estimator == "per-line" and np.array_equal(none.stiffness, none.per_line)


def test_structured_asked_for_but_not_applicable_is_said(material_b):
    st, test = material_b
    r = identify_joint_coupling(free_model(st), _noisy(test.frf, 0.01, seed=3), st.joint.joint_dofs,
                                CouplingOptions(smoothing="structured", symmetric=False))
    assert r.estimator == "gcv" and r.structured is None
    assert r.findings()[0] == ('smoothing = "structured" not used: symmetric = false (the structured model is symmetric); '
                               "each term smoothed on its own instead")


def test_a_model_whose_parameters_the_data_do_not_determine_is_left_out_of_the_average():
    """Its bands (here 100x wider) would swamp the average; a model with plausibly wider bands (5x) stays in."""
    K = np.full((50, 2, 2), 1e6 + 1e5j)

    def fit(aic, width):
        return SimpleNamespace(aic=aic, stiffness=K, std_real=np.full(K.shape, width * 1e3), std_imag=np.full(K.shape, width * 1e3))

    _, sr, _, w = model_average({"a": fit(100.0, 1.0), "b": fit(101.0, 100.0)})
    assert list(w) == ["a"] and np.allclose(sr, 1e3)
    _, sr, _, w = model_average({"a": fit(100.0, 1.0), "b": fit(101.0, 5.0)})
    assert set(w) == {"a", "b"} and np.all(sr > 2e3)


@pytest.mark.parametrize("order, with_common", [((0, 1, False), False), ((2, 4, True), True), ((1, 1, True), False)])
def test_whitened_fit_jacobian_matches_finite_differences(order, with_common):
    """The fit's factored Jacobian (one map per line applied to fixed matrices) is the derivative of its residual."""
    from jointid.methods.receptance.structured_fit import _Problem

    rng = np.random.default_rng(4)
    F, n = 23, 2
    p = n * (n + 1) // 2
    model = StructuredModel(n, order[0], order[1], order[2], (3.0, 0.5), 1000.0, (100.0, 1000.0))
    hz = np.linspace(100.0, 1000.0, F)
    Y = rng.standard_normal((F, n, n)) + 1j * rng.standard_normal((F, n, n))
    Ynn = 1e-2 * (Y + np.swapaxes(Y, 1, 2))  # symmetric receptance (reciprocity)
    G = rng.standard_normal((F, p, p)) + 1j * rng.standard_normal((F, p, p))
    cov = G @ np.conj(np.swapaxes(G, 1, 2)) + np.eye(p)  # Hermitian positive definite per line
    x = rng.standard_normal((F, p)) + 1j * rng.standard_normal((F, p))
    common = 0.3 * (rng.standard_normal((F, p, 2)) + 1j * rng.standard_normal((F, p, 2))) if with_common else None
    prob = _Problem(hz, x, cov, Ynn, model, common)
    theta = 0.3 * rng.standard_normal(model.n_params)
    for r in range(model.n_modes):  # poles inside the band
        theta[model.sizes["A"] + model.sizes["B"] + model.sizes["E"] + r * (n + 1) + n] = np.log(0.4 + 0.3 * r)
    theta[-2 * model.g_basis::2] += 1.0  # g near 1
    J = prob.jacobian(theta)
    assert J.shape == (2 * F * p, model.n_params)
    h = 1e-6
    for k in range(model.n_params):
        step = np.zeros_like(theta)
        step[k] = h
        fd = (prob.residual(theta + step) - prob.residual(theta - step)) / (2 * h)
        # central difference: error ~ h^2 |r'''| + eps |r| / h, far below 1e-6 of the column's scale here
        assert np.max(np.abs(fd - J[:, k])) <= 1e-6 * max(1.0, np.max(np.abs(fd))), k


def test_grid_costs_are_the_least_squares_costs_of_each_grid_point():
    """The batched per-term QR costs of the first mode's grid are each point's whole least-squares cost (as lstsq gives it)."""
    from jointid.methods.receptance.structured_fit import _NU_GRID, _PHASES, _grid_costs, _grid_design

    rng = np.random.default_rng(5)
    F, p = 30, 3
    w2 = np.linspace(0.05, 1.0, F) ** 2
    y = (1 + 0.1j) - w2[:, None] * rng.random(p) + 0.01 * (rng.standard_normal((F, p)) + 1j * rng.standard_normal((F, p)))
    w = 1.0 + rng.random((F, p))
    rhs = np.concatenate([(y * w).real.ravel(), (y * w).imag.ravel()])
    costs = _grid_costs(y, w, w2)
    ref = np.empty_like(costs)
    for a, phi in enumerate(_PHASES):
        for b, nu in enumerate(_NU_GRID):
            M = _grid_design(w, w2, np.exp(1j * phi), np.exp(nu))
            sol = np.linalg.lstsq(M, rhs, rcond=None)[0]
            ref[a, b] = np.sum((M @ sol - rhs) ** 2)
    # both are backward-stable least squares (Householder QR, SVD): residual norms within ~ m n eps ||rhs|| of the
    # exact one (Higham 2002, ch. 20), so costs within 2 m n eps ||rhs||^2 (m = 2 F p rows, n = 3 p columns), doubled
    tol = 4 * (2 * F * p) * (3 * p) * np.finfo(float).eps * np.sum(rhs ** 2)
    assert np.all(np.abs(costs - ref) <= tol)
    assert np.argmin(costs) == np.argmin(ref)


def test_small_stacked_products_within_their_rounding_bound():
    """The broadcast-sum product of small stacked matrices is matmul within k eps |A| |B| (k inner terms)."""
    from jointid.methods.receptance.structured_fit import _bmm

    rng = np.random.default_rng(6)
    for a, k, c in [(2, 2, 2), (3, 3, 4), (3, 4, 1), (6, 6, 6)]:
        A = rng.standard_normal((50, a, k)) + 1j * rng.standard_normal((50, a, k))
        B = rng.standard_normal((50, k, c)) + 1j * rng.standard_normal((50, k, c))
        bound = 2 * k * np.finfo(float).eps * (np.abs(A) @ np.abs(B))  # complex products: 2 k eps per term (Higham 3.6)
        assert np.all(np.abs(_bmm(A, B) - A @ B) <= bound)


@pytest.mark.parametrize("order", [(0, 1, False), (2, 1, True), (1, 4, True)])
def test_factored_bands_are_the_dense_jacobian_bands(order):
    """The bands from the distinct frequency functions equal ``|W^T j|^2`` of the dense Jacobian within its rounding bound."""
    from jointid.methods.receptance.structured_bands import structured_bands as _bands

    rng = np.random.default_rng(7)
    model = StructuredModel(2, order[0], order[1], order[2], (3.0, 0.5), 1000.0, (100.0, 1000.0))
    hz = np.linspace(100.0, 1000.0, 37)
    theta = 0.3 * rng.standard_normal(model.n_params)
    for r in range(model.n_modes):
        theta[model.sizes["A"] + model.sizes["B"] + model.sizes["E"] + r * 3 + 2] = np.log(0.4 + 0.3 * r)
    theta[-2 * model.g_basis::2] += 1.0
    G = rng.standard_normal((model.n_params, model.n_params))  # the covariance factor: cov = G G^T
    S = np.array(model.scale)
    SS = S[:, None] * S[None, :]
    D, J = structured_stiffness(theta, hz, model, jacobian=True)
    J = J * SS[None, :, :, None]
    K, sr, si = _bands(theta, G, hz, model)
    assert np.allclose(K, D * SS, rtol=8 * np.finfo(float).eps * len(theta), atol=0)
    for part, std in ((J.real, sr), (J.imag, si)):
        ref = np.sum(np.einsum("fijp,pr->fijr", part, G) ** 2, axis=-1)
        # sums of r squares of P-term sums (and E^T W's): within 4 P eps sum_r (|j| |W|)_r^2 of each other
        bound = 4 * model.n_params * np.finfo(float).eps * np.sum(np.einsum("fijp,pr->fijr", np.abs(part), np.abs(G)) ** 2, axis=-1)
        assert np.all(np.abs(std ** 2 - ref) <= bound)
