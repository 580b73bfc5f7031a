"""Receptance coupling of joints onto a free model: against dense and sparse direct solves of the jointed structure."""

import numpy as np
import pytest
import scipy.sparse as sp

from jointid.errors import ModelError
from jointid.frequency import Frequency
from jointid.physics import FrameSection, Material, build_frame, constant_stiffness
from jointid.physics.jointed_model import JointedModel
from jointid.physics.sparse_model import SparseModel
from jointid.physics.structure import ComplexStiffness, build_beam
from jointid.physics.elements import Section
from jointid.physics.synthesis import synthesize_frf

STEEL = Material(210e9, 7850.0, loss_factor=0.002, poisson_ratio=0.3)


def test_beam_on_a_frequency_dependent_joint_matches_the_dense_jointed_structure():
    beam = build_beam(1.0, Section.rectangle(0.03, 0.01), STEEL, 11)
    joint = ComplexStiffness(("5w", "5theta"), lambda f: np.array([[2e5, 3e3], [3e3, 40.0]]) * (1 + 0.1j) * (1 + f / 500.0)[:, None, None])
    f = Frequency(np.linspace(10.0, 900.0, 30))
    rows, cols = ["2w", "9w", "5theta"], ["3w", "5w"]
    dense = synthesize_frf(beam.with_joint(joint), f, rows, cols, kind="receptance").data
    coupled = JointedModel(beam, [joint]).receptance(f, rows, cols)
    assert np.max(np.abs(coupled - dense) / np.abs(dense)) < 1e-9


def test_frame_with_a_grounded_mount_and_a_mount_between_two_nodes_matches_a_sparse_direct_solve():
    sec = FrameSection.rectangle(0.03, 0.04)
    fm = build_frame({1: (0, 0, 0), 2: (0.8, 0, 0), 3: (0.8, 0.6, 0.0)}, [(1, 2, sec, STEEL, 6), (2, 3, sec, STEEL, 6)])
    rng = np.random.default_rng(0)
    A = rng.normal(size=(6, 6))
    K6 = np.diag([1e6, 2e6, 3e6, 1e4, 2e4, 3e4]) + 1e3 * (A + A.T)
    ground = constant_stiffness([f"1{c}" for c in ("x", "y", "z", "rx", "ry", "rz")], K6 * (1 + 0.05j), "ground")
    pair = [f"{n}{c}" for n in (3, 2) for c in ("x", "y", "z")]  # a 3+3 DOF mount between nodes 3 and 2
    K3 = np.diag([5e5, 6e5, 7e5])
    between = constant_stiffness(pair, np.block([[K3, -K3], [-K3, K3]]) * (1 + 0.1j), "between")
    f = Frequency(np.linspace(20.0, 600.0, 15))
    rows, cols = ["3z", "2y", "1x"], ["3x", "8z"]
    H = JointedModel(fm.free_model(method="direct"), [ground, between]).receptance(f, rows, cols)
    # reference: the joints added into K (constant complex stiffness), one sparse solve per line
    N = len(fm.dofs)
    idx = lambda labels: fm.dofs.indices(labels)  # noqa: E731
    Kj = sp.lil_array((N, N), dtype=complex)
    for joint in (ground, between):
        i = idx([str(d) for d in joint.dofs])
        Kj[np.ix_(i, i)] = Kj[np.ix_(i, i)].toarray() + joint(np.array([0.0]))[0]
    D0 = sp.csc_array(fm.stiffness) * (1 + 1j * fm.loss_factor) + Kj.tocsc()
    r, c = idx(rows), idx(cols)
    import scipy.sparse.linalg as spla
    for k, fk in enumerate(f.hz):
        D = (D0 - (2 * np.pi * fk) ** 2 * sp.csc_array(fm.mass)).tocsc()
        rhs = np.zeros((N, len(c)), complex)
        rhs[c, np.arange(len(c))] = 1.0
        ref = spla.spsolve(D, rhs)[r]
        assert np.max(np.abs(H[k] - ref)) / np.max(np.abs(ref)) < 1e-9


def test_bad_joints_raise_one_line():
    beam = build_beam(1.0, Section.rectangle(0.03, 0.01), STEEL, 5)
    with pytest.raises(ModelError, match=r"^JointedModel needs at least one joint$"):
        JointedModel(beam, [])
    with pytest.raises(ModelError, match=r"^joint 'j': DOF\(s\) \['9w'\] are not DOFs of the free model$"):
        JointedModel(beam, [constant_stiffness(["9w"], [[1.0]], "j")])
