"""FE model of the elastomeric joint: static limits, symmetry, internal modes, massless limit."""

import math

import numpy as np
import pytest

from jointid.errors import ModelError
from jointid.physics.elastomer_joint import (
    MATERIALS,
    ElastomerJoint,
    EndCap,
    elastomer_joint_from_parameters,
)
from jointid.physics.structure import ComplexStiffness

L = D = 0.0254
NU = 0.49


def _props(E):
    """Independent section and Timoshenko quantities of the 1 in x 1 in cylinder."""
    A = math.pi * D**2 / 4
    I = math.pi * D**4 / 64
    G = E / (2 * (1 + NU))
    kappa = 6 * (1 + NU) / (7 + 6 * NU)
    phi = 12 * E * I / (kappa * G * A * L**2)
    return A, I, G, kappa, phi


@pytest.mark.parametrize("name", ["A", "B"])
def test_static_blocked_transfer_equals_guided_timoshenko(name):
    m = MATERIALS[name]
    j = ElastomerJoint.from_material(name)
    Ec = m.E * (1 + 1j * m.eta)
    A, I, G, kappa, phi = _props(Ec)
    analytic = 12 * Ec * I / ((1 + phi) * L**3)
    k = j.blocked_transfer_stiffness([1e-6])[0]
    assert abs(k / analytic - 1) < 1e-9
    assert j.static_guided_stiffness() == pytest.approx(analytic, rel=1e-12)
    assert j.static_shear_stiffness() == pytest.approx(G * A / L, rel=1e-12)
    # about two thirds of GA/L: bending is not negligible for L = d
    ratio = (k / (G * A / L)).real
    assert ratio == pytest.approx(kappa * phi / (1 + phi), rel=1e-9)
    assert 0.62 < ratio < 0.68


@pytest.mark.parametrize("name", ["A", "B"])
def test_static_driving_point_is_inverse_cantilever_flexibility(name):
    m = MATERIALS[name]
    Ec = m.E * (1 + 1j * m.eta)
    A, I, G, kappa, _ = _props(Ec)
    C = np.array([[L**3 / (3 * Ec * I) + L / (kappa * G * A), L**2 / (2 * Ec * I)], [L**2 / (2 * Ec * I), L / (Ec * I)]])
    analytic = np.linalg.inv(C)
    j = ElastomerJoint.from_material(name)
    assert np.allclose(j.static_cantilever_matrix(), analytic, rtol=1e-12, atol=0)
    for include_cap in (True, False):
        K = j.driving_point_matrix([1e-7], include_cap=include_cap)[0]
        assert np.allclose(K, analytic, rtol=1e-9, atol=0)
    # theta = dw/dx with the ground at x = 0: a tip force rotates the end positively -> negative coupling
    assert analytic[0, 1].real < 0


def test_condensed_matrices_symmetric():
    f = np.linspace(0, 3000, 31)
    j = ElastomerJoint.from_material("B")
    K = j.driving_point_matrix(f)
    assert K.shape == (31, 2, 2)
    assert np.max(np.abs(K - K.transpose(0, 2, 1))) <= 1e-12 * np.max(np.abs(K))
    S = j.blocked_condensed_matrix(f)
    assert np.max(np.abs(S - S.transpose(0, 2, 1))) <= 1e-12 * np.max(np.abs(S))
    # reciprocity of the blocked test: K21 = K12
    assert np.allclose(S[:, 2, 0], S[:, 0, 2], rtol=1e-12)


def test_material_B_blocked_internal_mode_near_950_hz():
    j = ElastomerJoint.from_material("B")
    f_mode = j.modes("blocked").frequency_hz[0]
    assert abs(f_mode / 950 - 1) < 0.05
    # the damped |K21| of the direct test peaks there (first local maximum)
    f = np.arange(100, 1500, 1.0)
    mag = np.abs(j.blocked_transfer_stiffness(f))
    first_peak = f[np.argmax((mag[1:-1] > mag[:-2]) & (mag[1:-1] > mag[2:])) + 1]
    assert abs(first_peak / 950 - 1) < 0.05
    # Material A: about 1.2 kHz
    assert abs(ElastomerJoint.from_material("A").modes().frequency_hz[0] / 1200 - 1) < 0.05


def test_mesh_convergence_of_internal_mode():
    coarse = ElastomerJoint.from_material("B", elements=16).modes().frequency_hz[0]
    fine = ElastomerJoint.from_material("B", elements=64).modes().frequency_hz[0]
    assert abs(coarse / fine - 1) < 0.005


def test_thin_disc_matches_one_dimensional_shear_wave():
    # L = d / 10: bending negligible, K21 = kappa G* A beta / sin(beta L) (method notes, section 3)
    Lt = D / 10
    j = ElastomerJoint(8.8e6, 0.15, 1100.0, length_m=Lt, diameter_m=D, elements=32, cap=None)
    f = np.array([0.2, 0.5, 0.8, 0.95]) * j.modes().frequency_hz[0]
    Gk = 8.8e6 * (1 + 0.15j) / (2 * (1 + NU)) * (6 * (1 + NU) / (7 + 6 * NU))
    beta = 2 * np.pi * f * np.sqrt(1100.0 / Gk)
    k1d = Gk * (math.pi * D**2 / 4) * beta / np.sin(beta * Lt)
    assert np.max(np.abs(j.blocked_transfer_stiffness(f) / k1d - 1)) < 0.01
    assert abs(j.modes().frequency_hz[0] / j.shear_wave_frequency_hz() - 1) < 0.002


def test_massless_joint_is_frequency_independent():
    j = ElastomerJoint(15e6, 0.1, 1e-12, cap=None)
    f = np.linspace(0, 5000, 11)
    k = j.blocked_transfer_stiffness(f)
    assert np.allclose(k, k[0], rtol=1e-9, atol=0)
    K = j.driving_point_matrix(f)
    assert np.allclose(K, K[0], rtol=1e-9, atol=0)
    # while the real joint's stiffness does depend on frequency
    kr = ElastomerJoint.from_material("A").blocked_transfer_stiffness(f[:3])
    assert abs(kr[2] / kr[0] - 1) > 0.05


def test_caps_enter_only_the_driving_point_matrix():
    cap = EndCap()
    assert cap.mass_kg == pytest.approx(7850 * math.pi * 0.0127**2 * 0.003)
    with_cap = ElastomerJoint.from_material("A")
    no_cap = ElastomerJoint.from_material("A", cap=None)
    f = np.array([10.0, 300.0, 900.0])
    assert np.allclose(with_cap.blocked_transfer_stiffness(f), no_cap.blocked_transfer_stiffness(f), rtol=1e-13)
    diff = with_cap.driving_point_matrix(f) - no_cap.driving_point_matrix(f)
    w2 = (2 * np.pi * f) ** 2
    m, e, J = cap.mass_kg, cap.thickness_m / 2, cap.mass_kg * (0.0127**2 / 4 + 0.003**2 / 12)
    expected = -w2[:, None, None] * np.array([[m, m * e], [m * e, J + m * e**2]])
    assert np.allclose(diff, expected, rtol=1e-6, atol=1e-9)


def test_frequency_dependent_modulus_callable():
    const = ElastomerJoint(8.8e6, 0.15, 1100.0)
    func = ElastomerJoint(8.8e6, 0.0, 1100.0, modulus=lambda f: np.full(f.shape, 8.8e6 * (1 + 0.15j)))
    f = np.array([25.0, 500.0])
    assert np.allclose(const.blocked_transfer_stiffness(f), func.blocked_transfer_stiffness(f), rtol=1e-12)
    # doubling E* doubles the static stiffness
    stiff = ElastomerJoint(8.8e6, 0.0, 1100.0, modulus=lambda f: 2 * 8.8e6 * (1 + 0.15j) * np.ones_like(f))
    assert stiff.blocked_transfer_stiffness([1e-6])[0] == pytest.approx(2 * const.blocked_transfer_stiffness([1e-6])[0], rel=1e-9)


def test_deformed_shape_quasi_static_vs_internal_mode():
    j = ElastomerJoint.from_material("B")
    x, w150 = j.deformed_shape(150.0)
    assert x[0] == 0 and x[-1] == pytest.approx(L)
    assert w150[0] == 1 and w150[-1] == 0
    assert np.max(np.abs(w150)) <= 1.0 + 1e-6  # quasi-static: monotone from 1 to 0
    assert np.all(np.diff(w150.real) <= 1e-9)
    _, wm = j.deformed_shape(j.modes().frequency_hz[0])
    assert np.max(np.abs(wm)) > 2.0  # the internal mode amplifies the interior
    _, wf = j.deformed_shape([150.0, 900.0])
    assert wf.shape == (2, x.size)


def test_study_joint_from_parameters():
    cs = elastomer_joint_from_parameters(10, ("w", "theta"), {"material": "B"})
    assert isinstance(cs, ComplexStiffness)
    assert [str(d) for d in cs.dofs] == ["10w", "10theta"]
    f = np.array([50.0, 400.0])
    assert np.allclose(cs(f), ElastomerJoint.from_material("B").driving_point_matrix(f))
    only_w = elastomer_joint_from_parameters(3, ("w",), {"material": "A", "loss_factor": 0.2})
    assert only_w(f).shape == (2, 1, 1)
    k0 = only_w(np.array([1e-3]))[0, 0, 0]
    assert k0.imag / k0.real == pytest.approx(0.2, rel=1e-9)
    bare = elastomer_joint_from_parameters(3, ("w", "theta"), {"material": "B", "cap": False})
    assert np.allclose(bare(f), ElastomerJoint.from_material("B", cap=None).driving_point_matrix(f))
    with pytest.raises(ModelError, match="material"):
        elastomer_joint_from_parameters(3, ("w",), {"material": "C"})
    with pytest.raises(ModelError, match="density"):
        ElastomerJoint(1e7, 0.1, -5.0)


def test_deformed_shape_figure_has_units():
    from jointid.plots.direct import plot_deformed_shapes

    fig = plot_deformed_shapes(ElastomerJoint.from_material("B"), (150.0, 950.0))
    ax = fig.axes[0]
    assert "(mm)" in ax.get_xlabel() and "(-)" in ax.get_ylabel()
    assert len(ax.lines) == 5  # real and imaginary part at two frequencies, zero line


def test_the_modal_condensation_equals_a_dense_solve_within_its_conditioning():
    """``S = D_bb - D_bi D_ii^-1 D_ib`` by the interior's clamped modes against a dense solve per line of the full
    ``D(f)``: both backward stable, so they agree to ``n eps cond(D_ii)`` (relative), n the interior's size."""
    from jointid.physics.elastomer_joint import ElastomerJoint

    joint = ElastomerJoint.from_material("A")
    f = np.linspace(1.0, 4000.0, 400)  # through the cylinder's first internal resonances
    D = joint.dynamic_stiffness(f)
    n = D.shape[1]
    i, b = np.arange(2, n - 2), np.array([n - 2, n - 1])
    dense = D[:, b][:, :, b] - D[:, b][:, :, i] @ np.linalg.solve(D[:, i][:, :, i], D[:, i][:, :, b])
    got = joint.driving_point_matrix(f, include_cap=False)
    rel = np.max(np.abs(got - dense), axis=(1, 2)) / np.max(np.abs(dense), axis=(1, 2))
    bound = i.size * np.finfo(float).eps * np.linalg.cond(D[:, i][:, :, i])
    assert np.all(rel <= bound), float(np.max(rel / bound))
    blocked = D[:, [0, 1, n - 2, n - 1]][:, :, [0, 1, n - 2, n - 1]]
    X = np.linalg.solve(D[:, i][:, :, i], D[:, i][:, :, [0, 1, n - 2, n - 1]])
    dense4 = blocked - D[:, [0, 1, n - 2, n - 1]][:, :, i] @ X
    rel4 = np.max(np.abs(joint.blocked_condensed_matrix(f) - dense4), axis=(1, 2)) / np.max(np.abs(dense4), axis=(1, 2))
    assert np.all(rel4 <= bound)
    _, w = joint.deformed_shape(f)
    np.testing.assert_allclose(w[:, 1:-1], -X[:, 0::2, 0], rtol=0, atol=float(np.max(bound)))
