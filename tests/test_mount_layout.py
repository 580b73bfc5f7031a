"""A 6-DOF mount's layout: the joint spline fit's bound (what `jointid design` predicts), per-term targets, and a
layout of the joint model's own form (6 x 6), which identifies the joint but cannot check the excitation columns."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from jointid.cli.design import parse_targets
from jointid.errors import IdentificationError, StudyError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.methods.design.estimator import spline_bound
from jointid.methods.design.term_goals import target_report, term_targets
from jointid.methods.receptance.column_redundancy import MIN_COLUMN_REDUNDANCY, column_redundancy
from jointid.methods.receptance.coupling import identify_joint_coupling
from jointid.physics import build_frame
from jointid.physics.jointed_model import JointedModel
from jointid.physics.reduction import craig_bampton
from jointid.physics.structure import ComplexStiffness
from test_frame_mounts import fixture_frame

COMP = ("x", "y", "z", "rx", "ry", "rz")
JOINT = tuple(f"1{c}" for c in COMP)
NINE = tuple(f"{g}{c}" for g in (3, 5, 10) for c in "xyz")  # three grids away from the mount
SIX = tuple(f"{g}{c}" for g in (2, 4) for c in "xyz")  # two corners: observed = excited, as many as the joint's DOFs
K0 = np.diag([3e6, 2e6, 4e6, 8e3, 6e3, 5e3]) * (1 + 0.1j)


def mount(f):
    return np.broadcast_to(K0, (np.size(f), 6, 6)).copy()


@pytest.fixture(scope="module")
def frame():
    fm = build_frame(*fixture_frame(elements=4))  # the 3-D frame of test_frame_mounts: corners 1-4, post top 5
    keep = JOINT + tuple(dict.fromkeys(NINE + SIX))
    free = craig_bampton(fm.mass, fm.stiffness, fm.dofs, keep, cutoff_hz=2000.0, loss_factor=0.002).free_model()
    return free, Frequency.from_range(4.0, 150.0, 4.0)


def _blocks(free, freq, obs, exc):
    m, n = len(obs), len(JOINT)
    Y = free.receptance(freq, tuple(obs) + JOINT, JOINT + tuple(exc))
    return Y[:, :m, :n], Y[:, m:, :n], Y[:, m:, n:], Y[:, :m, n:]


def test_spline_bound_of_a_constant_joint_is_the_inverse_of_the_fisher_information_by_finite_differences(frame):
    """One coefficient per term: the bound is (sum_f J_f^H W_f J_f)^-1 with J_f = dH_f / dK, here by central
    differences of the jointed receptance itself (an independent path: JointedModel, not the fit's Jacobian)."""
    free, freq = frame
    Ymn, Ynn, Yne, _ = _blocks(free, freq, NINE, NINE)
    H = JointedModel(free, [ComplexStiffness(JOINT, mount, "m")]).receptance(freq, NINE, NINE)
    var = (0.01 * np.abs(H)) ** 2
    V = spline_bound(freq.hz, Ymn, Ynn, Yne, var, mount(freq.hz), n_basis=1)
    ia, ib = np.triu_indices(6)
    cols = []
    for a, b in zip(ia, ib):  # dH / dK_ab (K_ab = K_ba), central differences of step h |K_ab| relative
        h = 1e-4 * np.sqrt(abs(K0[a, a] * K0[b, b]))
        E = np.zeros((6, 6))
        E[a, b] = E[b, a] = h

        def Hk(sign):
            return JointedModel(free, [ComplexStiffness(JOINT, lambda f: mount(f) + sign * E, "m")]).receptance(freq, NINE, NINE)
        cols.append(((Hk(1) - Hk(-1)) / (2 * h)).reshape(freq.size, -1))
    J = np.stack(cols, axis=2) / np.sqrt(var.reshape(freq.size, -1))[:, :, None]  # (F, 81, 21), whitened
    N = np.einsum("fri,frj->ij", J.conj(), J)
    C = np.linalg.inv(N)
    want = np.real(np.diag(C))
    got = V[0][ia, ib]
    # central differences: relative error O(h^2) = 1e-8 in J, amplified by cond(N) (~1e4 here) in its inverse
    assert np.allclose(got, want, rtol=1e-3, atol=0)
    assert np.allclose(V, V[0], rtol=1e-12)  # constant basis: the same on every line


def test_spline_bound_scales_with_the_noise_variance(frame):
    free, freq = frame
    Ymn, Ynn, Yne, _ = _blocks(free, freq, NINE, NINE)
    H = JointedModel(free, [ComplexStiffness(JOINT, mount, "m")]).receptance(freq, NINE, NINE)
    var = (0.01 * np.abs(H)) ** 2
    V1 = spline_bound(freq.hz, Ymn, Ynn, Yne, var, mount(freq.hz))
    V4 = spline_bound(freq.hz, Ymn, Ynn, Yne, 4.0 * var, mount(freq.hz))
    assert np.allclose(V4, 4.0 * V1, rtol=1e-9)  # linear in the FRF variance (round-off of the inverse: cond x eps)


def test_a_six_by_six_layout_has_no_residual_outside_the_columns_and_says_so_instead_of_a_unit_error(frame):
    free, freq = frame
    Ymn, Ynn, Yne, Yme = _blocks(free, freq, SIX, SIX)
    H = JointedModel(free, [ComplexStiffness(JOINT, mount, "m")]).receptance(freq, SIX, SIX)
    # Y[m,e] of the model's own form: the residual is round-off, (cond x eps)^2 and below
    assert column_redundancy(Ymn, Yne, Yme, np.abs(H) ** 2) < 1e-14
    Ymn9, _, Yne9, Yme9 = _blocks(free, freq, NINE, NINE)
    H9 = JointedModel(free, [ComplexStiffness(JOINT, mount, "m")]).receptance(freq, NINE, NINE)
    assert column_redundancy(Ymn9, Yne9, Yme9, np.abs(H9) ** 2) > 1e3 * MIN_COLUMN_REDUNDANCY
    rng = np.random.default_rng(3)
    noisy = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2))
    r = identify_joint_coupling(free, FRF(freq, noisy, SIX, SIX, "receptance"), JOINT)  # no DataError: nothing misread
    assert ("this layout (6 observed x 6 excited DOFs for 6 joint DOFs) leaves no residual outside the excitation columns' "
            "directions: the force calibration, units and force-noise checks cannot run (the FRFs' units and noise model "
            "are taken as given); observe more DOFs than the joint has (`jointid design`) to have them") in r.findings()
    assert not any("scaled by" in f or "force noise" in f for f in r.findings())
    assert r.calibration is None


TERMS = ("K_x_x", "K_y_y", "K_rx_rx")


def test_targets_name_terms_and_relative_errors():
    assert term_targets(TERMS, {"K_rx_rx": 0.05, "K_x_x": 0.002}) == {"K_x_x": 0.002, "K_rx_rx": 0.05}
    with pytest.raises(IdentificationError) as exc:
        term_targets(TERMS, {"K_z_z": 0.05})
    assert str(exc.value) == "targets: unknown term 'K_z_z'; expected one of K_x_x, K_y_y, K_rx_rx"
    with pytest.raises(IdentificationError) as exc:
        term_targets(TERMS, {"K_x_x": -1})
    assert str(exc.value) == "targets: K_x_x = -1; expected a relative error > 0 (0.05 = 5 %)"
    assert parse_targets("K_x_x=0.2, K_rx_rx=5") == {"K_x_x": 0.002, "K_rx_rx": 0.05}
    with pytest.raises(StudyError) as exc:
        parse_targets("K_x_x")
    assert str(exc.value) == "--target: expected TERM=PERCENT pairs like K_x_x=0.2,K_rx_rx=5, got 'K_x_x'"


def test_a_target_is_reached_only_when_the_prediction_and_the_monte_carlo_both_are():
    d = SimpleNamespace(
        targets={"K_x_x": 0.002, "K_rx_rx": 0.05}, terms=TERMS, observed=("3x", "5y"), excited=("3x",),
        current_observed=("2x", "4y"), current_excited=("2x",),
        median=lambda current: ({"K_x_x": 0.01, "K_y_y": 0.01, "K_rx_rx": 0.5} if current else
                                {"K_x_x": 0.001, "K_y_y": 0.001, "K_rx_rx": 0.04}),
        # per noise model (relative, additive): median over seeds of the actual median error per term
        checked=((1.0, ("5y", "3x"), ("3x",), ((0.001, 0.001, 0.03), (0.0015, 0.001, 0.06))),),
    )
    rows = {r["term"]: r for r in target_report(d)}
    assert rows["K_x_x"]["chosen"] == {"predicted": 0.001, "monte_carlo": 0.0015, "reaches": True}
    # predicted 4 % but the worse noise model's Monte Carlo 6 %: not reached
    assert rows["K_rx_rx"]["chosen"] == {"predicted": 0.04, "monte_carlo": 0.06, "reaches": False}
    assert rows["K_rx_rx"]["current"] == {"predicted": 0.5, "monte_carlo": None, "reaches": False}
