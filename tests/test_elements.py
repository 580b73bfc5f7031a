"""Timoshenko / Euler-Bernoulli elements and beam assembly against analytic values."""

import numpy as np
import pytest

from jointid.dofs import Dof
from jointid.errors import ModelError
from jointid.physics.elements import Material, Section, timoshenko_element
from jointid.physics.modes import natural_modes
from jointid.physics.structure import build_beam

L, B = 0.9144, 0.0127
SEC = Section.rectangle(B, B)
AL = Material(69e9, 2700.0, 0.006, 0.33)


def test_section_properties():
    assert SEC.area == pytest.approx(B * B)
    assert SEC.second_moment == pytest.approx(B**4 / 12)
    c = Section.circle(0.0254)
    assert c.area == pytest.approx(np.pi * 0.0254**2 / 4)
    assert c.second_moment == pytest.approx(np.pi * 0.0254**4 / 64)


def test_element_matrices_symmetric_and_eb_limit():
    K, M = timoshenko_element(0.05, SEC, AL, 5 / 6)
    assert np.allclose(K, K.T) and np.allclose(M, M.T)
    Ke, Me = timoshenko_element(0.05, SEC, AL, euler_bernoulli=True)
    l, rAl = 0.05, AL.density * SEC.area * 0.05
    ref = rAl / 420 * np.array([[156, 22 * l, 54, -13 * l], [22 * l, 4 * l * l, 13 * l, -3 * l * l],
                                [54, 13 * l, 156, -22 * l], [-13 * l, -3 * l * l, -22 * l, 4 * l * l]])
    # closed-form entries, a few roundings each (no BLAS): a small multiple of eps of each entry's size
    assert np.allclose(Me, ref, rtol=64 * np.finfo(float).eps, atol=0)
    # rigid-body motions carry no strain energy
    for u in (np.array([1, 0, 1, 0.0]), np.array([0, 1, l, 1.0])):
        assert np.allclose(K @ u, 0, atol=1e-6 * np.abs(K).max())


def test_total_translational_mass():
    s = build_beam(L, SEC, AL, 19)
    assert s.translational_mass() == pytest.approx(AL.density * SEC.area * L, rel=1e-12)


def test_cantilever_static_tip_deflection():
    s = build_beam(L, SEC, AL, 7).clamped(1)
    P = 10.0
    K = s.K.real
    f = np.zeros(len(s.dofs))
    f[s.index(["7w"])[0]] = P
    tip = np.linalg.solve(K, f)[s.index(["7w"])[0]]
    E, I, A, G = AL.elastic_modulus, SEC.second_moment, SEC.area, AL.G
    exact = P * L**3 / (3 * E * I) + P * L / (5 / 6 * G * A)
    assert tip == pytest.approx(exact, rel=1e-12)


def test_timoshenko_19_nodes_within_0p2_percent_of_converged():
    f19 = natural_modes(build_beam(L, SEC, AL, 19)).frequencies_hz[2:6]
    fine = natural_modes(build_beam(L, SEC, AL, 401)).frequencies_hz[2:6]
    assert np.allclose(fine, [78.87, 217.12, 424.81, 700.41], rtol=2e-4)
    assert np.all(np.abs(f19 / fine - 1) < 2e-3)


def test_free_free_has_two_rigid_body_modes():
    modes = natural_modes(build_beam(L, SEC, AL, 19))
    assert modes.rigid_body_count() == 2
    assert modes.frequencies_hz[2] > 70


def test_euler_bernoulli_fine_mesh_matches_analytic():
    modes = natural_modes(build_beam(L, SEC, AL, 201, euler_bernoulli=True))
    beta_l = np.array([4.7300, 7.8532, 10.9956, 14.1372])
    E, I, rho, A = AL.elastic_modulus, SEC.second_moment, AL.density, SEC.area
    analytic = beta_l**2 / (2 * np.pi * L**2) * np.sqrt(E * I / (rho * A))
    assert np.all(np.abs(modes.frequencies_hz[2:6] / analytic - 1) < 1e-3)


def test_lumped_mass_and_supports():
    s = build_beam(L, SEC, AL, 5)
    s2 = s.with_mass(3, 0.1, 1e-5)
    assert s2.translational_mass() == pytest.approx(s.translational_mass() + 0.1)
    assert s.translational_mass() == pytest.approx(AL.density * SEC.area * L)  # original untouched
    c = s.clamped(1)
    assert Dof(1, "w") not in c.dofs and len(c.dofs) == 8


@pytest.mark.parametrize(
    "call, msg",
    [
        (lambda: Section.rectangle(-1, 1), "section width must be a positive finite number in m, got -1"),
        (lambda: Material(-1, 2700), "elastic modulus must be a positive finite number in Pa, got -1"),
        (lambda: build_beam(L, SEC, AL, 1), "a beam needs an integer number of nodes >= 2, got 1"),
        (lambda: build_beam(L, SEC, AL, 5).with_mass(9, 0.1), "lumped mass at node 9: DOF 9w is not in the structure (nodes 1..5)"),
    ],
)
def test_bad_model_input(call, msg):
    with pytest.raises(ModelError if "DOF" not in msg else Exception, match=None) as e:
        call()
    assert str(e.value) == msg


def test_modes_of_the_same_matrices_are_solved_once_and_cannot_be_changed():
    """A structure rebuilt with the same matrices gets the kept eigensolution (read-only: a caller cannot corrupt
    it for the next one); other matrices (one value changed by a few units in its last place) are solved anew, with their dofs."""
    from dataclasses import replace

    a, b = natural_modes(build_beam(L, SEC, AL, 19)), natural_modes(build_beam(L, SEC, AL, 19))
    assert b.shapes is a.shapes and b.eigenvalues is a.eigenvalues
    with pytest.raises(ValueError, match="read-only"):
        a.shapes[0, 0] = 1.0
    beam = build_beam(L, SEC, AL, 19)
    K = beam.stiffness.copy()
    K[-1, -1] += 4 * np.finfo(float).eps * abs(K[-1, -1])
    other = natural_modes(replace(beam, stiffness=K))
    assert other.shapes is not a.shapes and other.dofs == beam.dofs
    assert np.allclose(other.frequencies_hz, a.frequencies_hz, rtol=1e-12, atol=1e-6)
