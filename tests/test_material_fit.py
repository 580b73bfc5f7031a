"""Material identification from K21: static G, E; constant (E, eta, rho) fit; E*(f) per line; Zener."""

import json
import math

import numpy as np
import pytest

from jointid.errors import DataError
from jointid.methods.fit_statistics import correlation_matrix, jacobian_covariance, propagate_covariance
from jointid.physics.elastomer_joint import MATERIALS, ElastomerJoint
from jointid.methods.direct.material_fit import (
    complex_modulus_per_line,
    fit_material,
    fit_zener,
    static_estimate,
    zener_modulus,
)
from jointid.measurement.stepsine import process_stepsine
from jointid.measurement.stepsine_synth import synthesize_stepsine

F = np.arange(25.0, 601.0, 25.0)
A = math.pi * 0.0254**2 / 4


def test_static_estimate_formulas():
    k = np.array([4.0e4 * (1 + 0.1j), 4.1e4 * (1 + 0.1j), 9e4])
    st = static_estimate([25.0, 50.0, 600.0], k, lines=2)
    assert st.stiffness_n_m == pytest.approx(4.05e4)
    assert st.shear_modulus_pa == pytest.approx(4.05e4 * 0.0254 / A)
    assert st.elastic_modulus_pa == pytest.approx(2 * st.shear_modulus_pa * 1.49)
    assert st.loss_factor == pytest.approx(0.1)
    assert st.frequency_hz == (25.0, 50.0)
    with pytest.raises(DataError, match="25 Hz"):
        static_estimate([25.0, 50.0], [-1.0, 2.0])


@pytest.mark.parametrize("name", ["A", "B"])
def test_static_estimate_underreads_g_by_the_guided_ratio(name):
    m = MATERIALS[name]
    k = ElastomerJoint.from_material(name).blocked_transfer_stiffness(F)
    st = static_estimate(F, k)
    assert st.shear_modulus_pa / m.G == pytest.approx(st.guided_ratio, rel=0.005)
    assert st.corrected_shear_modulus_pa == pytest.approx(m.G, rel=0.005)
    assert st.corrected_elastic_modulus_pa == pytest.approx(m.E, rel=0.005)


@pytest.mark.parametrize("name", ["A", "B"])
def test_fit_recovers_exact_parameters(name):
    m = MATERIALS[name]
    k = ElastomerJoint.from_material(name).blocked_transfer_stiffness(F)
    fit = fit_material(F, k)
    assert fit.elastic_modulus_pa == pytest.approx(m.E, rel=1e-6)
    assert fit.loss_factor == pytest.approx(m.eta, rel=1e-6)
    assert fit.density_kg_m3 == pytest.approx(m.rho, rel=1e-6)
    assert fit.residual_rms < 1e-8 and fit.success


@pytest.mark.parametrize("name", ["A", "B"])
def test_fit_from_noisy_step_sine_within_one_percent(name):
    m = MATERIALS[name]
    joint = ElastomerJoint.from_material(name)
    blocks = synthesize_stepsine(F, joint.blocked_transfer_stiffness, 2.5e-5, displacement_noise=0.01,
                                 force_noise=0.01, force_harmonics={3: 0.05}, seed=7)
    res = process_stepsine(blocks, commanded_amplitude_m=2.5e-5)
    fit = fit_material(res.frequency_hz, res.stiffness)
    assert abs(fit.elastic_modulus_pa / m.E - 1) < 0.01
    assert abs(fit.loss_factor / m.eta - 1) < 0.01
    assert abs(fit.density_kg_m3 / m.rho - 1) < 0.01
    # the reported standard errors are consistent with the actual errors (within 5 sigma, and small)
    actual = (fit.elastic_modulus_pa / m.E - 1, fit.loss_factor / m.eta - 1, fit.density_kg_m3 / m.rho - 1)
    assert all(abs(a) <= 5 * s + 1e-4 for a, s in zip(actual, fit.relative_std))
    assert all(s < 0.01 for s in fit.relative_std)
    assert all(p.status == "identified" for p in fit.parameters) and fit.warnings == ()
    json.loads(json.dumps(fit.to_dict(), allow_nan=False))
    assert fit.to_dict()["blocked_internal_mode_hz"] == pytest.approx(joint.modes().frequency_hz[0], rel=0.01)


def test_complex_modulus_per_line_recovers_frequency_dependent_modulus_through_the_mode():
    zp = (6e6, 15e6, 1 / (2 * np.pi * 300.0), 0.45)
    f = np.arange(25.0, 2501.0, 25.0)  # through the blocked internal mode
    joint = ElastomerJoint(8e6, 0.1, 1150.0, modulus=lambda ff: zener_modulus(ff, *zp))
    k = joint.blocked_transfer_stiffness(f)
    cm = complex_modulus_per_line(f, k, 1150.0)
    assert cm.converged.all()
    assert np.max(np.abs(cm.modulus_pa / zener_modulus(f, *zp) - 1)) < 1e-8
    z = fit_zener(f, cm.modulus_pa)
    assert z.E0 == pytest.approx(zp[0], rel=0.01)
    assert z.Einf == pytest.approx(zp[1], rel=0.01)
    assert z.tau_s == pytest.approx(zp[2], rel=0.01)
    assert z.alpha == pytest.approx(zp[3], rel=0.01)
    assert z.identified and z.warnings == ()
    assert z.to_dict()["parameters"]["tau_s"]["value"] == pytest.approx(zp[2], rel=0.01)
    json.dumps(z.to_dict(), allow_nan=False)
    json.dumps(cm.to_dict(), allow_nan=False)
    # the storage modulus rises with frequency as the model says: a constant fit cannot follow it
    const = fit_material(f[f <= 600], k[f <= 600])
    assert const.residual_rms > 100 * max(z.residual_rms, 1e-12)


def test_complex_modulus_vectorized_start_and_noisy_lines():
    m = MATERIALS["B"]
    joint = ElastomerJoint.from_material("B")
    k = joint.blocked_transfer_stiffness(F)
    Ec = m.E * (1 + 1j * m.eta)
    cm = complex_modulus_per_line(F, k, m.rho, initial_modulus=1.1 * Ec)
    assert np.allclose(cm.modulus_pa, Ec, rtol=1e-9)
    noisy = k * (1 + 0.002 * np.cos(np.arange(F.size)))
    cm = complex_modulus_per_line(F, noisy, m.rho)
    assert np.max(np.abs(cm.storage_modulus_pa / m.E - 1)) < 0.01
    # well below the internal mode (925 Hz) the 0.2 % error stays ~0.2 %; towards it, it grows
    low = F <= 400
    assert np.max(np.abs(cm.loss_factor[low] - m.eta)) < 0.002
    assert np.max(np.abs(cm.loss_factor - m.eta)) < 0.02


def test_fit_needs_two_lines():
    with pytest.raises(DataError, match="at least 2 lines"):
        fit_material([100.0], [1e5])


def _strict(obj):
    """Round trip through a strict JSON parser (no NaN/Infinity)."""
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(json.dumps(obj), parse_constant=refuse)


def _stepsine_fit(material, f, noise=0.01, seed=3, **kw):
    joint = ElastomerJoint.from_material(material)
    blocks = synthesize_stepsine(f, joint.blocked_transfer_stiffness, 2.5e-5, displacement_noise=noise, force_noise=noise, seed=seed)
    res = process_stepsine(blocks, commanded_amplitude_m=2.5e-5)
    return fit_material(res.frequency_hz, res.stiffness, **kw)


def test_density_held_when_the_band_lies_far_below_the_internal_mode():
    # Material A's blocked internal mode is ~1155 Hz; 10-200 Hz sees only ~5 % of inertia in K21
    fit = _stepsine_fit("A", np.arange(10.0, 201.0, 10.0))
    rho = fit.parameter("density_kg_m3")
    assert rho.status == "held_at_default" and not rho.identified and rho.held
    assert fit.density_kg_m3 == 1100.0 and 0.04 < fit.inertia_fraction < 0.08
    assert "inertia changes K21 by only 5%" in rho.reason
    d = _strict(fit.to_dict())
    assert d["parameters"]["density_kg_m3"]["value"] is None
    assert d["parameters"]["density_kg_m3"]["held_value"] == 1100.0
    assert d["blocked_internal_mode_hz"] is None
    assert fit.warnings == ("density held at default: " + rho.reason + "; held at 1100 kg/m^3",)
    # E and eta, refitted with rho held, stay within 0.5 % (inertia is small there)
    assert fit.parameter("elastic_modulus_pa").identified and abs(fit.elastic_modulus_pa / 15e6 - 1) < 0.005
    assert abs(fit.loss_factor / 0.10 - 1) < 0.01


def test_density_from_a_rising_modulus_is_never_reported():
    # a storage modulus rising with frequency (Zener) fitted with a constant one: the free fit's density
    # runs to ~2500 kg/m^3 (out of the rubber range) on 10-200 Hz; it must not appear as a result
    zp = (15e6, 15e6 * 1.2 * 1.3, 1 / (2 * np.pi * 3000.0), 0.3)
    joint = ElastomerJoint(15e6, 0.1, 1200.0, modulus=lambda ff: zener_modulus(ff, *zp))
    f = np.arange(10.0, 201.0, 10.0)
    fit = fit_material(f, joint.blocked_transfer_stiffness(f))
    rho = fit.parameter("density_kg_m3")
    assert rho.status == "held_at_default"
    assert rho.reason == "the fitted value lies outside the physical range [800, 2000] kg/m^3"
    assert _strict(fit.to_dict())["parameters"]["density_kg_m3"]["value"] is None


def test_band_through_the_internal_mode_identifies_density_with_small_error():
    fit = _stepsine_fit("A", np.arange(25.0, 2001.0, 25.0))
    rho = fit.parameter("density_kg_m3")
    assert rho.identified
    assert abs(rho.value / 1200.0 - 1) < 0.01
    assert rho.relative_std_error < 0.002
    assert abs(rho.value - 1200.0) < 4 * rho.std_error + 0.5


def test_standard_errors_match_the_scatter_and_scale_with_noise():
    # relative complex noise on K21 (the residual model of the fit), Material A, 25-600 Hz
    f = np.arange(25.0, 601.0, 25.0)
    k = ElastomerJoint.from_material("A").blocked_transfer_stiffness(f)
    true = np.array([15e6, 0.10, 1200.0])

    def run(sigma, seed):
        rng = np.random.default_rng(seed)
        noise = sigma * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / math.sqrt(2)
        fit = fit_material(f, k * (1 + noise))
        assert all(p.identified for p in fit.parameters)
        return np.array([p.value for p in fit.parameters]), np.array([p.std_error for p in fit.parameters])

    est, se = zip(*(run(0.004, s) for s in range(30)))
    est, se = np.array(est), np.array(se)
    ratio = est.std(axis=0, ddof=1) / se.mean(axis=0)
    assert np.all((ratio > 0.65) & (ratio < 1.5)), ratio  # the reported error is the scatter (30 samples: +-13 %)
    assert np.mean(np.all(np.abs(est - true) < 3 * se, axis=1)) >= 0.9
    # one seed, noise x4: the standard errors x ~4 and the truth within 3 of them
    (v1, s1), (v4, s4) = run(0.002, 11), run(0.008, 11)
    assert np.all(np.abs(s4 / s1 - 4) < 0.6)
    assert np.all(np.abs(v1 - true) < 3 * s1) and np.all(np.abs(v4 - true) < 3 * s4)


def test_correlation_and_units_of_the_standard_errors():
    f = np.arange(25.0, 601.0, 25.0)
    k = ElastomerJoint.from_material("B").blocked_transfer_stiffness(f)
    fit = fit_material(f, k * (1 + 0.003 * np.cos(7 * np.arange(f.size))))
    c = fit.correlation
    assert c.shape == (3, 3) and np.allclose(np.diag(c), 1) and np.allclose(c, c.T) and np.all(np.abs(c) <= 1 + 1e-12)
    d = _strict(fit.to_dict())
    assert d["correlation"]["order"] == ["elastic_modulus_pa", "loss_factor", "density_kg_m3"]
    e = d["parameters"]["elastic_modulus_pa"]
    assert e["unit"] == "Pa" and e["std_error"] == pytest.approx(e["relative_std_error"] * e["value"])
    assert d["shear_modulus_pa"]["value"] == pytest.approx(e["value"] / (2 * 1.49))


def test_out_of_bounds_modulus_is_not_identified_and_a_known_density_is_fixed():
    f = np.arange(25.0, 601.0, 25.0)
    k = ElastomerJoint.from_material("A").blocked_transfer_stiffness(f)
    fit = fit_material(f, k, bounds={"elastic_modulus_pa": (20e6, 500e6)})
    E = fit.parameter("elastic_modulus_pa")
    assert E.status == "not_identified" and not fit.identified
    assert E.reason == "the fitted value lies outside the physical range [2e+07, 5e+08] Pa"
    assert _strict(fit.to_dict())["parameters"]["elastic_modulus_pa"]["value"] is None
    assert fit.warnings[0].startswith("E not identified: ") and fit.warnings[0].endswith("; its value is not reported")
    fixed = fit_material(f, k, density_kg_m3=1200.0)
    assert fixed.parameter("density_kg_m3").status == "fixed"
    assert fixed.elastic_modulus_pa == pytest.approx(15e6, rel=1e-8)


def test_zener_fit_that_runs_to_a_bound_says_so():
    # a constant complex modulus has no relaxation in the band: tau -> 0 and Einf -> infinity
    f = np.arange(25.0, 601.0, 25.0)
    E = 15e6 * (1 + 0.1j) * (1 + 0.002 * np.random.default_rng(0).standard_normal(f.size))
    z = fit_zener(f, E)
    status = {p.name: p.status for p in z.parameters}
    assert status["tau_s"] == "at_bound" and status["Einf_pa"] == "at_bound" and not z.identified
    assert any(w.startswith("Zener tau at bound: tau ran to 0") for w in z.warnings)
    d = json.loads(json.dumps(z.to_dict(), allow_nan=False))
    assert d["parameters"]["tau_s"]["value"] is None and d["identified"] is False


def test_jacobian_covariance_is_the_textbook_line_fit():
    # straight line y = a + b x: var(b) = s^2 / sum (x - xbar)^2, s^2 = RSS / (n - 2)
    x = np.linspace(0.0, 1.0, 11)
    r = np.array([0.1, -0.2, 0.05, 0.0, 0.3, -0.1, 0.2, -0.3, 0.1, 0.0, -0.15])
    J = np.column_stack([np.ones_like(x), x])
    cov = jacobian_covariance(J, r)
    s2 = r @ r / 9
    assert cov[1, 1] == pytest.approx(s2 / np.sum((x - x.mean()) ** 2))
    assert cov[0, 0] == pytest.approx(s2 * np.sum(x**2) / (11 * np.sum((x - x.mean()) ** 2)))
    # p = exp(x): delta method multiplies by p_i p_j
    p = np.array([2.0, 3.0])
    assert np.allclose(propagate_covariance(cov, np.diag(p)), cov * np.outer(p, p))
    # a parameter the residuals do not depend on: infinite variance, undefined correlation
    cov3 = jacobian_covariance(np.column_stack([J, np.zeros_like(x)]), r)
    assert np.isinf(cov3[2, 2]) and np.isfinite(cov3[1, 1])
    assert np.isnan(correlation_matrix(cov3)[0, 2]) and correlation_matrix(cov3)[1, 1] == pytest.approx(1.0)


def test_static_estimate_names_too_many_lines_and_a_line_that_is_not_quasi_static():
    from jointid.errors import DataError
    from jointid.methods.direct.material_fit import static_estimate

    f = np.array([1.0, 2.0, 50.0])
    k = np.array([1e5 + 1e4j, 1.01e5 + 1e4j, -2e4 + 1e4j])  # the top line past a resonance: storage negative
    with pytest.raises(DataError, match=r"^static lines: 4 asked for, the test has 3; the static estimate averages the "
                                        r"lowest few lines \(default 2\)$"):
        static_estimate(f, k, lines=4)
    with pytest.raises(DataError, match=r"^line 50 Hz: storage stiffness -20000 N/m is not positive: it is not "
                                        r"quasi-static, yet one of the 3 lowest lines the static estimate averages; average fewer$"):
        static_estimate(f, k, lines=3)
    with pytest.raises(DataError, match=r"^line 1 Hz: storage stiffness -100000 N/m is not positive; check the force sign$"):
        static_estimate(f, -k, lines=1)
    assert static_estimate(f, k, lines=2) is not None
