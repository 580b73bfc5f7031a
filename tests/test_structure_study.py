"""[structure] studies: several 6-DOF mounts identified at once, end to end through the CLI (simulate -> UFF58 -> identify -> CSV)."""

from __future__ import annotations

import csv
import json
import re
import textwrap

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.dofs import Dof
from jointid.errors import StudyError
from jointid.physics.mount import MountModel
from jointid.study import load_study
from structure_model import MOUNT_A, MOUNT_B, labels, structure_table, write_grounded_study, write_model


def _list(xs) -> str:
    return "[" + ", ".join(f'"{x}"' for x in xs) + "]"


def grounded_study(tmp_path, observed=None, excited=None, extra="") -> "Path":
    observed = observed or [l for n in (1, 2, 4, 5, 6, 7, 9, 10) for l in labels(n, ("x", "y", "z"))]
    excited = excited or [l for n in (2, 4, 5, 7, 9) for l in labels(n, ("x", "y", "z"))]
    return write_grounded_study(tmp_path, observed, excited, extra=extra)


def between_study(tmp_path) -> "Path":
    mass, dofs = write_model(tmp_path, 10, breaks=(5,))  # two parts: nodes 1-5 and 6-10
    observed = [l for n in (1, 2, 4, 5, 6, 7, 9, 10) for l in labels(n, ("x", "y", "z"))]
    excited = [l for n in (1, 3, 5, 6, 8, 10) for l in labels(n, ("x", "y", "z"))]
    text = structure_table(mass, dofs) + textwrap.dedent(f"""
        [[joint]]
        name = "link"
        dofs = {_list(labels(5))}
        other = {_list(labels(6))}
        """) + MOUNT_A.format(n=5) + textwrap.dedent(f"""
        [measurement]
        observed = {_list(observed)}
        excited = {_list(excited)}

        [identification]
        smoothing = "none"

        [frequency]
        start = 10.0
        stop = 400.0
        step = 20.0
        """)
    p = tmp_path / "study.toml"
    p.write_text(text)
    return p


def read_table(path) -> dict:
    rows = list(csv.DictReader(open(path)))
    return {k: np.array([float(r[k]) if r[k] not in ("true", "false") else r[k] == "true" for r in rows]) for k in rows[0]}


def _matrix(table: dict, labels_: list[str]) -> np.ndarray:
    n = len(labels_)
    K = np.empty((table["frequency_hz"].size, n, n), dtype=complex)
    for a, la in enumerate(labels_):
        for b, lb in enumerate(labels_):
            K[:, a, b] = table[f"K_{la}_{lb}_real"] + 1j * table[f"K_{la}_{lb}_imag"]
    return K


def _mount_truth(f, node, stiffness, couplings, eta, growth, fref=100.0, exponent=1.0, other=None):
    """Independent truth: K0 from the numbers of the study text, K(f) = K0 (1 + g (f/fref)^a)(1 + j eta)."""
    comp = ["x", "y", "z", "rx", "ry", "rz"]
    K0 = np.diag(stiffness)
    for a, b, v in couplings:
        K0[comp.index(a), comp.index(b)] = K0[comp.index(b), comp.index(a)] = v
    s = (1 + growth * (f / fref) ** exponent) * (1 + 1j * eta)
    K = s[:, None, None] * K0
    if other:
        K = np.block([[K, -K], [-K, K]])
    return K


def test_two_grounded_mounts_recovered_exactly_through_the_cli(tmp_path):
    study = grounded_study(tmp_path)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    out = tmp_path / "id"
    assert not (out / "joint_stiffness.csv").exists()
    comp = ["x", "y", "z", "rx", "ry", "rz"]
    for name, truth in (
        ("front", _mount_truth(np.arange(10.0, 401.0, 20.0), 1, [3e6, 2e6, 4e6, 3e3, 2.5e3, 1.5e3],
                               [("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5)], 0.12, 0.3, 100.0, 0.8)),
        ("rear", _mount_truth(np.arange(10.0, 401.0, 20.0), 10, [1.5e6, 2.5e6, 3e6, 2e3, 3e3, 2e3],
                              [("z", "rz", 1e4), ("rx", "ry", 300.0)], 0.08, 0.5)),
    ):
        table = read_table(out / f"joint_stiffness_{name}.csv")
        assert "K_x_ry_imag" in table and "K_rz_rz_real" in table
        K = _matrix(table, comp)
        assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8
        # the simulator's own truth file agrees with the independent one
        true = _matrix(read_table(tmp_path / "sim" / f"true_joint_{name}.csv"), comp)
        assert np.abs(true - truth).max() / np.abs(truth).max() < 1e-14
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["joints"]) == {"front", "rear"}
    assert summary["joints"]["front"]["file"] == "joint_stiffness_front.csv"
    assert summary["joints"]["rear"]["units"]["K_x_ry"] == "N/rad"
    assert summary["cross_joint_ratio"] < 1e-8
    assert len(summary["joint_dofs"]) == 12


def test_mount_between_two_parts_recovered_exactly_through_the_cli(tmp_path):
    study = between_study(tmp_path)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")]) == 0
    assert (tmp_path / "id" / "joint_stiffness.png").is_file() and (tmp_path / "id" / "joint_matrix.png").is_file()
    table = read_table(tmp_path / "id" / "joint_stiffness.csv")
    names = labels(5) + labels(6)
    assert "K_5x_6x_real" in table and "K_x_x_real" not in table
    K = _matrix(table, names)
    f = np.arange(10.0, 401.0, 20.0)
    truth = _mount_truth(f, 5, [3e6, 2e6, 4e6, 3e3, 2.5e3, 1.5e3], [("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5)],
                         0.12, 0.3, 100.0, 0.8, other=True)
    assert K.shape[1:] == (12, 12)
    assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    assert summary["joints"]["link"]["other"] == labels(6)
    assert summary["cross_joint_ratio"] == 0.0


def test_uff58_round_trip_keeps_3d_directions_and_flips_negative_codes(tmp_path):
    import pyuff

    from jointid.frf import FRF
    from jointid.frequency import Frequency
    from jointid.io.uff import read_uff_frf, write_uff_frf

    f = Frequency.from_range(10.0, 20.0, 5.0)
    data = np.arange(1, 1 + 3 * 2 * 2).reshape(3, 2, 2) * (1 + 0.5j)
    frf = FRF(f, data, ["12x", "40rz"], ["12y", "3z"], "receptance")
    p = write_uff_frf(tmp_path / "a.uff", frf, kind="receptance")
    sets = pyuff.UFF(str(p)).read_sets()
    assert [(s["rsp_dir"], s["ref_dir"]) for s in sets[1:]] == [(1, 2), (1, 3), (6, 2), (6, 3)]
    back = read_uff_frf(p, axis=None)
    assert back.responses == (Dof(12, "x"), Dof(40, "rz")) and back.references == (Dof(12, "y"), Dof(3, "z"))
    np.testing.assert_allclose(back.data, data, rtol=1e-11)
    # a response measured along -X: the same FRF with the sign flipped
    sets[1]["rsp_dir"] = -1
    sets[1]["data"] = -sets[1]["data"]
    q = tmp_path / "b.uff"
    pyuff.UFF(str(q)).write_sets(sets, mode="add")
    np.testing.assert_allclose(read_uff_frf(q, axis=None).data, data, rtol=1e-11)


def test_mount_model_is_passive_and_grows_with_frequency():
    dofs = (Dof(1, "x"), Dof(1, "ry"))
    m = MountModel(dofs, np.array([[1e6, 1e4], [1e4, 1e3]]), loss_factor=0.1, growth=0.5, reference_frequency=100.0, exponent=1.0)
    K = m([0.0, 100.0, 200.0])
    np.testing.assert_allclose(K[1], 1.5 * (1 + 0.1j) * np.array([[1e6, 1e4], [1e4, 1e3]]))
    assert np.all(np.linalg.eigvalsh(K.imag) >= 0) and np.abs(K[2]).max() > np.abs(K[0]).max()
    two = MountModel(dofs, np.array([[1e6, 1e4], [1e4, 1e3]]), other=(Dof(2, "x"), Dof(2, "ry")))([50.0])
    np.testing.assert_allclose(two[0, :2, :2], -two[0, :2, 2:])
    np.testing.assert_allclose(two[0] @ np.ones(4), 0.0, atol=1e-9)  # rigid motion of both sides: no force


def _error(tmp_path, text_edit) -> str:
    p = grounded_study(tmp_path)
    p.write_text(text_edit(p.read_text()))
    with pytest.raises(StudyError) as exc:
        load_study(p)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg.removeprefix(f"{p}: ")


def test_structure_study_errors_are_one_exact_line(tmp_path):
    assert _error(tmp_path, lambda t: t.replace('"10x", "10y"', '"99x", "10y"')) == (
        "[[joint]] 'rear'.dofs: DOF 99x is not in the structure (model_dofs.csv) (it has 60 DOFs, nodes 1..10)"
    )
    assert _error(tmp_path, lambda t: t.replace('dofs = ["10x"', 'dofs = ["1x"')) == (
        "[[joint]] 'rear': DOF 1x is already in joint 'front'; a DOF belongs to one joint only"
    )
    few = 'observed = ["1x", "2x", "3x", "4x", "5x", "6x", "7x", "8x", "9x", "10x", "1y"]'
    assert _error(tmp_path, lambda t: re.sub(r"observed = \[.*\]", few, t)) == (
        "[measurement].observed: 11 observed DOFs for 12 joint DOFs (all joints together); observe at least as many DOFs as there are joint DOFs"
    )
    assert _error(tmp_path, lambda t: re.sub(r"excited = \[.*\]", 'excited = ["2x", "2y"]', t)) == (
        "[measurement].excited: 2 excited DOFs for 12 joint DOFs (all joints together); excite at least as many DOFs as there are joint DOFs"
    )
    assert _error(tmp_path, lambda t: t.replace('mass = "model.npz"', 'mass = "model.npz"\n[beam]\nlength = 1.0')) == (
        "give either [beam] (the beam factory) or [structure] (matrix files), not both"
    )
    assert _error(tmp_path, lambda t: t.replace('"1x", "1y"', '"1x", "1q"', 1)) == (
        "[[joint]] 'front'.dofs: cannot read a DOF from '1q'; write it as '<node><direction>', e.g. '10w', '10theta', '101z', "
        "'101rx' or '1995001s'"
    )
    assert _error(tmp_path, lambda t: t.replace('dofs = "model_dofs.csv"', 'dofs = "nope.csv"')) == (
        f"[structure].dofs: {tmp_path / 'nope.csv'}: DOF list not found"
    )
    assert _error(tmp_path, lambda t: t.replace('["1x", "1ry", 2e4]', '["1x", "2ry", 2e4]')) == (
        "[[joint]] 'front' [joint.model].couplings: DOF 2ry is not one of the joint's dofs (1x, 1y, 1z, 1rx, 1ry, 1rz)"
    )
    assert _error(tmp_path, lambda t: t.replace('[measurement]', '[accelerometers]\nmass = 0.01\nnodes = [99]\n[measurement]')) == (
        "[accelerometers].nodes: node 99 has no DOF in the structure (model_dofs.csv)"
    )


def test_unreadable_matrix_is_one_line_naming_the_key(tmp_path, capsys):
    p = grounded_study(tmp_path)
    p.write_text(p.read_text().replace('stiffness = "model.npz"', 'stiffness = "model.npz:KK"'))
    assert main(["simulate", str(p), "--out", str(tmp_path / "sim")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"jointid simulate: error: {p}: [structure].stiffness: {tmp_path / 'model.npz'}") and "KK" in err
    assert "\n" not in err


def test_not_positive_definite_mount_and_beam_only_commands(tmp_path, capsys):
    p = grounded_study(tmp_path)
    p.write_text(p.read_text().replace('["1x", "1ry", 2e4]', '["1x", "1ry", 2e7]'))
    assert main(["simulate", str(p), "--out", str(tmp_path / "sim")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"jointid simulate: error: {p}: [[joint]] 'front' [joint.model]: the mount stiffness (diagonal and couplings) "
                          "is not positive definite (smallest eigenvalue")
    assert main(["modes", str(p), "--out", str(tmp_path / "u")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"jointid modes: error: {p}: `jointid modes` needs a [beam] study; the modes of a [structure] come with its FRFs "
        "(`jointid simulate --free`)"
    )


def test_woodbury_constrained_receptance_matches_a_dense_solve_with_a_singular_joint():
    from jointid.physics.sparse_model import SparseModel
    from jointid.physics.jointed_model import JointedModel
    from jointid.physics.structure import ComplexStiffness
    from structure_model import chain_matrices

    M, K, dofs = chain_matrices(6, breaks=(3,))
    eta, f = 0.01, np.array([15.0, 80.0, 230.0])
    free = SparseModel(M, K, dofs, eta, method="direct")
    n = labels(3) + labels(4)
    K0 = np.diag([2e6, 1e6, 3e6, 2e3, 1e3, 3e3]) * (1 + 0.1j)
    Du = np.tile(np.block([[K0, -K0], [-K0, K0]]), (f.size, 1, 1))  # singular (rigid relative motion)
    m, e = labels(1, ("x", "z")) + labels(6, ("y",)), labels(2, ("x",)) + labels(5, ("rz",))
    H = JointedModel(free, [ComplexStiffness(n, lambda fh: np.broadcast_to(Du[0], (fh.size, 12, 12)), "between")]).receptance(f, m, e)
    idx = dofs.indices
    D = K.toarray() * (1 + 1j * eta)
    ni = idx(n)
    D[np.ix_(ni, ni)] += Du[0]
    for a, fa in enumerate(f):
        ref = np.linalg.solve(D - (2 * np.pi * fa) ** 2 * M.toarray(), np.eye(D.shape[0]))[np.ix_(idx(m), idx(e))]
        assert np.abs(H[a] - ref).max() / np.abs(ref).max() < 1e-10


def test_term_names_never_collide_and_split_per_joint():
    from jointid.terms import dof_term_labels, stiffness_columns
    from jointid.frequency import Frequency

    one = [Dof(7, c) for c in ("x", "y", "rz")]
    two = [Dof(1, "x"), Dof(2, "x")]
    assert dof_term_labels(one) == ["x", "y", "rz"] and dof_term_labels(two) == ["1x", "2x"]
    assert dof_term_labels([Dof(10, "w"), Dof(10, "theta")]) == ["w", "theta"]
    cols = stiffness_columns(Frequency.from_range(1.0, 2.0, 1.0), two, np.ones((2, 2, 2)))
    assert list(cols) == ["frequency_hz", "K_1x_1x_real", "K_1x_1x_imag", "K_1x_2x_real", "K_1x_2x_imag",
                          "K_2x_1x_real", "K_2x_1x_imag", "K_2x_2x_real", "K_2x_2x_imag"]


def test_point_map_and_flipped_axis_of_a_real_export(tmp_path):
    """[measurement.points] maps file ids to model nodes; a record along -Y is read sign-flipped as y."""
    import pyuff

    from jointid.pipeline import identify, read_measured, simulate
    from jointid.io.uff import write_uff_frf

    study_path = grounded_study(tmp_path)
    nodes = (1, 2, 4, 5, 6, 7, 9, 10)
    points = "\n[measurement.points]\n" + "\n".join(f"{1000 + n} = {n}" for n in nodes) + "\n"
    study_path.write_text(study_path.read_text().replace("\n[identification]", points + "\n[identification]"))
    study = load_study(study_path)
    test = simulate(study)
    write_uff_frf(tmp_path / "model.uff", test.frf)
    sets = pyuff.UFF(str(tmp_path / "model.uff")).read_sets()
    for s in sets[1:]:
        s["rsp_node"] += 1000
        s["ref_node"] += 1000
        if s["rsp_dir"] == 2:
            s["rsp_dir"], s["data"] = -2, -s["data"]
    pyuff.UFF(str(tmp_path / "export.uff")).write_sets(sets, mode="add")
    measured = read_measured(study, tmp_path / "export.uff")
    np.testing.assert_allclose(measured.select(test.frf.responses, test.frf.references).data, test.frf.data, rtol=1e-10)
    K = identify(study, measured).stiffness
    assert np.abs(K - test.truth).max() / np.abs(test.truth).max() < 1e-8


def test_single_joint_table_in_a_structure_study_is_one_joint(tmp_path):
    p = between_study(tmp_path)
    p.write_text(p.read_text().replace("[[joint]]", "[joint]"))
    study = load_study(p)
    assert [j.name for j in study.joints] == ["link"] and len(study.joint_dofs) == 12
    assert study.beam is None and len(study.joints) == 1 and study.joint.name == "link"
    assert study.measurement.observed_dofs[:3] == (Dof(1, "x"), Dof(1, "y"), Dof(1, "z"))
    from jointid.models import true_joint

    K = true_joint(study)([100.0])[0]
    assert K.shape == (12, 12) and K[0, 4] == pytest.approx(1.3 * (1 + 0.12j) * 2e4)  # growth 0.3 at the reference frequency


def test_structured_smoothing_with_several_joints_is_refused_in_one_line(tmp_path, capsys):
    study = grounded_study(tmp_path)
    text = study.read_text()
    assert 'smoothing = "none"' in text
    study.write_text(text.replace('smoothing = "none"', 'smoothing = "structured"'))
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    capsys.readouterr()
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"jointid identify: error: {study}: [identification].smoothing = \"structured\" fits the model of one joint of one "
                   "material, and this study identifies 2 joints together: use \"auto\" or \"gcv\""]


def test_exact_frfs_of_a_mount_with_absent_couplings_give_the_exact_joint_by_default(tmp_path):
    """One 6-DOF mount, default estimator: exact FRFs are recognised as exact (a term's std judged on its scale, an absent
    coupling on its two DOFs') and the per-line values are the answer. Judged by |K|, the zero couplings looked noisy,
    the spline fit ran, and its bias at the band's edge (10 % on K_rx_rx at 10 Hz) was printed as 0.006 % predicted."""
    text = grounded_study(tmp_path).read_text()
    text = text[:text.index('[[joint]]\nname = "rear"')] + text[text.index("[measurement]"):]
    text = text.replace('smoothing = "none"', 'smoothing = "auto"')
    study = tmp_path / "one_mount.toml"
    study.write_text(text)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    assert summary["estimator"].startswith("per-line estimates"), summary["estimator"]
    comp = ["x", "y", "z", "rx", "ry", "rz"]
    truth = _mount_truth(np.arange(10.0, 401.0, 20.0), 1, [3e6, 2e6, 4e6, 3e3, 2.5e3, 1.5e3],
                         [("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5)], 0.12, 0.3, 100.0, 0.8)
    K = _matrix(read_table(tmp_path / "id" / "joint_stiffness.csv"), comp)
    # exact data through a 16-digit binary UFF: round-off of the per-line solve (condition ~1e4-1e6) x eps
    assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8


def test_per_line_values_beyond_their_linearization_are_flagged_with_a_finding(tmp_path):
    """A layout observing and exciting x only: the per-line values of a 6-DOF mount's other terms come from an inverse
    that one standard deviation of the coupling estimate moves by far more than itself (their linearized std,
    evaluated at the noisy estimate, was small: K_y_y 98 % off was flagged reliable). Every term of those lines is
    flagged, with one finding; exact FRFs of a layout that sees every direction are not touched."""
    x_only = grounded_study(tmp_path, observed=labels(1, ("x",)) + [f"{n}x" for n in range(2, 11)],
                            excited=[f"{n}x" for n in range(2, 9)]).read_text()
    x_only = x_only[:x_only.index('[[joint]]\nname = "rear"')] + x_only[x_only.index("[measurement]"):]
    study = tmp_path / "x_only.toml"
    study.write_text(x_only)
    assert main(["simulate", str(study), "--noise", "0.01", "--seed", "2", "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"),
                 "--no-plots"]) == 0
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    found = [f for f in summary["findings"] if "moves the joint's inverse by more than 50 %" in f]
    assert len(found) == 1 and found[0].startswith("on 20 of 20 lines one standard deviation"), found
    table = read_table(tmp_path / "id" / "joint_stiffness.csv")
    assert not np.any(table["reliable"])
