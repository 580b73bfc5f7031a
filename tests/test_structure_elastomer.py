"""[joint.model] type = "elastomer" on a [structure] study: the elastomer joint FE model on a (translation, rotation)
pair of 3-D DOFs (issue 14, build item 3), and the study-to-model translation of jointid.models (build item 8)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.errors import StudyError
from jointid.io.matrix_files import write_free_matrices
from jointid.models import constrained_model, free_model, true_joint, true_joints
from jointid.physics import FrameSection, Material, build_frame
from jointid.physics.elastomer_joint import ElastomerJoint, elastomer_joint_model
from jointid.physics.elastomer_mount import axis_sign, default_cylinder_axis, elastomer_mount
from jointid.physics.sparse_model import SparseModel
from jointid.pipeline import simulate
from jointid.study import load_study
from study_texts import beam_study_toml
from test_structure_study import _list, _matrix, read_table

L, B, N = 0.9144, 0.0127, 19  # the benchmark beam of study_texts: 0.9144 m, 12.7 mm square, 19 nodes
ALU = Material(69e9, 2700.0, loss_factor=0.006, poisson_ratio=0.33)
OBSERVED, EXCITED = [1, 3, 6, 9, 12, 15, 19], [3, 9, 15]
ELASTOMER = 'type = "elastomer"\nmaterial = "B"\nelements = 8\n'


def beam_study(tmp_path):
    """The benchmark beam on the elastomer joint (material B) at node 10, one element per segment."""
    text = beam_study_toml(start=20.0, stop=1000.0, step=20.0).replace("nodes = 19", "nodes = 19\nelements_per_segment = 1")
    head, tail = text.split('type = "parametric"')
    tail = tail[tail.index("[measurement]"):]
    p = tmp_path / "beam.toml"
    p.write_text(head + ELASTOMER + "\n" + tail)
    return p


def frame_study(tmp_path, axes='["z", "ry"]', joint_dofs=("10z", "10ry"), extra_model="", other=None, frame=None, observed=None, excited=None):
    """The same beam as a 3-D frame along +x (files), the elastomer joint at node 10 on ``axes``."""
    if frame is None:
        s = FrameSection.rectangle(B, B, shear_coefficient=5 / 6)
        frame = build_frame({k: (L * (k - 1) / (N - 1), 0.0, 0.0) for k in range(1, N + 1)}, [(k, k + 1, s, ALU) for k in range(1, N)])
    files = write_free_matrices(tmp_path / "frame", frame.mass, frame.stiffness, frame.dofs)
    text = textwrap.dedent(f"""
        [structure]
        mass = "{files.mass.name}"
        stiffness = "{files.mass.name}"
        dofs = "{files.dofs.name}"
        loss_factor = 0.006
        method = "direct"

        [[joint]]
        name = "bush"
        dofs = {_list(joint_dofs)}
        """) + (f"other = {_list(other)}\n" if other else "") + "[joint.model]\n" + ELASTOMER + f"axes = {axes}\n" + extra_model + textwrap.dedent(f"""
        [measurement]
        observed = {_list(observed or [f"{n}z" for n in OBSERVED])}
        excited = {_list(excited or [f"{n}z" for n in EXCITED])}

        [identification]
        smoothing = "none"

        [frequency]
        start = 20.0
        stop = 1000.0
        step = 20.0
        """)
    p = tmp_path / "frame.toml"
    p.write_text(text)
    return p


def test_elastomer_joint_on_the_frame_gives_the_planar_beam_study_frfs(tmp_path):
    """x-z bending of a frame along +x is the planar beam (theta = -ry): same joint, same constrained FRFs."""
    beam, frame = load_study(beam_study(tmp_path)), load_study(frame_study(tmp_path))
    Hb, Hf = simulate(beam).frf, simulate(frame).frf
    assert Hf.data.shape == Hb.data.shape == (50, 7, 3)
    err = np.abs(Hf.data - Hb.data).max() / np.abs(Hb.data).max()
    assert err < 1e-8
    per_line = np.abs(Hf.data - Hb.data).max(axis=(1, 2)) / np.abs(Hb.data).max(axis=(1, 2))
    assert per_line.max() < 1e-8
    # the wrong sign (cylinder along -x: theta = +ry) is a different structure, by far more than round-off
    flipped = load_study(frame_study(tmp_path, extra_model='cylinder_axis = "-x"\n'))
    assert np.abs(simulate(flipped).frf.data - Hb.data).max() / np.abs(Hb.data).max() > 1e-3
    # the joint truth: the beam's 2x2 on (w, theta) is the frame's on (z, ry) with the coupling negated
    f = Hb.frequency.hz
    Kb, Kf = true_joint(beam)(f), true_joints(frame)[0](f)
    np.testing.assert_allclose(Kf, Kb * np.array([[1, -1], [-1, 1]]), rtol=1e-13, atol=0)


def _frame_cantilever(direction, nu=0.49, E=4e6):
    """Static stiffness on (y, z, rx, ry, rz) of the free end of a clamped rubber rod (the joint's cylinder) as a 3-D frame."""
    d = 0.0254
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    rod = build_frame({1: (0.0, 0.0, 0.0), 2: tuple(0.0254 * np.asarray(direction, float))},
                      [(1, 2, FrameSection.circle(d, shear_coefficient=kappa), Material(E, 1100.0, poisson_ratio=nu), 8)])
    K = rod.clamped([1]).stiffness.toarray()
    dofs = rod.clamped([1]).dofs
    keep = dofs.indices([(2, c) for c in ("x", "y", "z", "rx", "ry", "rz")], "rod")
    drop = np.setdiff1d(np.arange(K.shape[0]), keep)
    return K[np.ix_(keep, keep)] - K[np.ix_(keep, drop)] @ np.linalg.solve(K[np.ix_(drop, drop)], K[np.ix_(drop, keep)])


@pytest.mark.parametrize("axes,cylinder,direction", [
    (("z", "ry"), "+x", (1, 0, 0)), (("y", "rz"), "+x", (1, 0, 0)), (("z", "ry"), "-x", (-1, 0, 0)),
    (("x", "rz"), "+y", (0, 1, 0)), (("y", "rx"), "-z", (0, 0, -1)),
])
def test_sign_convention_is_the_3d_frame_cantilever(axes, cylinder, direction):
    """Independent truth: a clamped Timoshenko rod along the cylinder axis in the 3-D frame factory (its own rotation
    convention), statically condensed to the free end, equals the elastomer joint's static matrix on (t, r)."""
    joint = ElastomerJoint(4e6, 0.0, 1100.0, elements=8, cap=None)
    comps = ["x", "y", "z", "rx", "ry", "rz"]
    from jointid.dofs import Dof

    dofs = tuple(Dof(7, c) for c in comps)
    pair = (comps.index(axes[0]), comps.index(axes[1]))
    K = elastomer_mount(joint, dofs, pair, axis_sign(*axes, cylinder))(np.array([1e-9]))[0]
    frame = _frame_cantilever(direction)
    idx = np.array(pair)
    np.testing.assert_allclose(K[np.ix_(idx, idx)].real, frame[np.ix_(idx, idx)], rtol=1e-9)
    assert abs(frame[pair[0], pair[1]]) > 1e-3 * np.sqrt(frame[pair[0], pair[0]] * frame[pair[1], pair[1]])  # a real coupling
    K[np.ix_(idx, idx)] = 0
    assert not K.any()  # every other DOF of the joint: zero stiffness


def test_sign_rule_and_default_axis():
    assert axis_sign("z", "ry", "+x") == -1 and axis_sign("z", "ry", "-x") == 1  # theta = dw/dx = -ry along +x
    assert axis_sign("y", "rz", "+x") == 1 and axis_sign("z", "rx", "+y") == 1 and axis_sign("x", "ry", "+z") == 1
    assert default_cylinder_axis("z", "ry") == "+x" and default_cylinder_axis("y", "rz") == "-x"
    for t, r in (("x", "ry"), ("x", "rz"), ("y", "rx"), ("y", "rz"), ("z", "rx"), ("z", "ry")):
        assert axis_sign(t, r) == -1  # the default axis r x t always gives theta = -phi_r


def test_two_part_elastomer_joint_is_its_two_end_condensation_with_both_caps():
    from jointid.dofs import Dof

    fe = elastomer_joint_model({"material": "A", "elements": 8})
    dofs, other = (Dof(5, "z"), Dof(5, "ry")), (Dof(6, "z"), Dof(6, "ry"))
    f = np.array([1e-6, 150.0, 900.0])
    two = elastomer_mount(fe, dofs, (0, 1), -1, other)(f)
    one = elastomer_mount(fe, dofs, (0, 1), -1)(f)
    np.testing.assert_allclose(two[:, :2, :2], one, rtol=1e-12)  # the other side held: the grounded joint
    np.testing.assert_allclose(two, np.swapaxes(two, 1, 2), rtol=1e-12)
    # static rigid motions give no force: translation in z; ry = 1 about the other end (s = 0, the cylinder along +x)
    # moves the dofs end (s = L) by y x (L x) = -L in z
    Lc = fe.length_m
    for u in (np.array([1.0, 0, 1.0, 0]), np.array([-Lc, 1.0, 0.0, 1.0])):
        assert np.abs(two[0] @ u).max() < 1e-9 * np.abs(two[0]).max()
    # with inertia the two ends' forces differ: not [[K, -K], [-K, K]]
    assert np.abs(two[2, :2, :2] + two[2, :2, 2:]).max() > 1e-3 * np.abs(two[2]).max()


def _load_error(tmp_path, **kw) -> str:
    p = frame_study(tmp_path, **kw)
    with pytest.raises(StudyError) as exc:
        load_study(p)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg.removeprefix(f"{p}: ")


def test_bad_axes_are_one_exact_line(tmp_path):
    w = "[[joint]] 'bush' [joint.model]"
    assert _load_error(tmp_path, axes='["ry", "z"]') == (
        f"{w}.axes: expected [translation, rotation] playing (w, theta), such as [\"z\", \"ry\"] or [\"w\", \"theta\"], got ['ry', 'z']"
    )
    assert _load_error(tmp_path, axes='["z", "rz"]') == (
        f"{w}.axes: the rotation rz is about the translation z; theta turns about an axis across w: use e.g. [\"z\", \"ry\"]"
    )
    assert _load_error(tmp_path, axes='["y", "rz"]') == (
        f"{w}.axes: y is not a component of the joint's dofs (10z, 10ry); the elastomer joint needs exactly one y DOF there"
    )
    assert _load_error(tmp_path, joint_dofs=("10z", "11ry")) == (
        f"{w}.axes: 10z and 11ry are on different nodes; the elastomer joint's (w, theta) are on one node"
    )
    assert _load_error(tmp_path, extra_model='cylinder_axis = "+z"\n') == (
        f"{w}: cylinder_axis +z is not across both z and ry; the cylinder of axes [z, ry] lies along x: use +x or -x"
    )
    assert _load_error(tmp_path, extra_model='stiffness = [1.0]\n') == (
        f"{w}: unknown key 'stiffness'; expected one of: type, axes, cylinder_axis, material, elastic_modulus, loss_factor, "
        "density, length, diameter, poisson_ratio, elements, cap, cap_diameter, cap_thickness, cap_density"
    )
    assert _load_error(tmp_path, extra_model='density = -3.0\n') == f"{w}.density: expected a positive number (kg/m^3), got -3.0"
    assert _load_error(tmp_path, other=("11z", "11rz")) == (
        f"{w}.axes: other has 11rz opposite 10ry; an elastomer joint between two parts needs the same components on both sides"
    )


def test_cli_simulate_identify_recovers_the_elastomer_joint_exactly(tmp_path):
    p = frame_study(tmp_path)
    assert main(["simulate", str(p), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(p), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    K = _matrix(read_table(tmp_path / "id" / "joint_stiffness.csv"), ["z", "ry"])
    study = load_study(p)
    truth = true_joints(study)[0](np.arange(20.0, 1001.0, 20.0))
    assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8
    d = np.abs(np.diagonal(truth, axis1=1, axis2=2))
    per_term = np.abs(K - truth) / np.sqrt(d[:, :, None] * d[:, None, :])
    assert np.median(per_term) < 1e-8
    # the truth file of `simulate` is the model's joint, the coupling with theta = -ry's sign
    true = _matrix(read_table(tmp_path / "sim" / "true_joint.csv"), ["z", "ry"])
    assert np.abs(true - truth).max() / np.abs(truth).max() < 1e-12
    assert truth[0, 0, 1].real > 0  # quasi-static (20 Hz): a cantilever's k_w_theta < 0; in (z, ry) along +x it is > 0


def test_models_is_the_one_translation(tmp_path):
    """pipeline re-exports the models functions; the same ones serve a [beam] and a [structure] study."""
    import jointid.pipeline as pl
    from jointid import models

    assert pl.free_model is models.free_model and pl.true_joint is models.true_joint and pl.constrained_model is models.constrained_model
    frame = load_study(frame_study(tmp_path))
    assert isinstance(free_model(frame), SparseModel)
    assert [j.name for j in true_joints(frame)] == ["bush"]
    assert type(constrained_model(frame)).__name__ == "JointedModel"
    beam = load_study(beam_study(tmp_path))
    assert len(true_joints(beam)) == 1 and true_joints(beam)[0].dofs == beam.joint.joint_dofs
    assert true_joint(frame).name == "bush"  # a study of one joint, whatever its free structure


def test_cli_recovers_an_elastomer_joint_between_two_parts(tmp_path):
    """Two separate bars along +x, the elastomer joint from node 11 (other, s = 0) to node 10 (dofs, s = L) on (z, ry):
    the 4x4 two-end condensation with both caps is recovered exactly, and it is not [[K, -K], [-K, K]]."""
    s = FrameSection.rectangle(B, B, shear_coefficient=5 / 6)
    nodes = {k: (0.05 * (k - 1), 0.0, 0.0) for k in range(1, 11)} | {k: (0.05 * (k - 1) + 0.03, 0.0, 0.0) for k in range(11, 21)}
    frame = build_frame(nodes, [(k, k + 1, s, ALU) for k in (*range(1, 10), *range(11, 20))])
    p = frame_study(tmp_path, other=("11z", "11ry"), frame=frame,
                    observed=[f"{n}z" for n in (1, 4, 7, 10, 11, 14, 17, 20)], excited=[f"{n}z" for n in (3, 8, 13, 18)])
    assert main(["simulate", str(p), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(p), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    K = _matrix(read_table(tmp_path / "id" / "joint_stiffness.csv"), ["10z", "10ry", "11z", "11ry"])
    f = np.arange(20.0, 1001.0, 20.0)
    fe = elastomer_joint_model({"material": "B", "elements": 8})
    from jointid.dofs import Dof

    truth = elastomer_mount(fe, (Dof(10, "z"), Dof(10, "ry")), (0, 1), -1, (Dof(11, "z"), Dof(11, "ry")))(f)
    np.testing.assert_allclose(true_joints(load_study(p))[0](f), truth, rtol=1e-14, atol=0)
    assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8
    assert np.abs(truth[:, :2, :2] + truth[:, :2, 2:]).max() > 1e-2 * np.abs(truth).max()  # the cylinder's and caps' mass
