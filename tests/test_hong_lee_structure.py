"""The plain Hong & Lee method on a small 3-D model read as matrices: exact recovery, and its size limit."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointid.dofs import parse_dofs
from jointid.errors import ModelError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.methods.hong_lee.inverse import InverseOptions, identify_joint, rotation_scale
from jointid.physics.jointed_model import JointedModel
from jointid.physics.mount import MountModel
from jointid.physics.sparse_model import SparseModel
from jointid.physics.structure import ComplexStiffness

from structure_model import chain_matrices, labels


def _article():
    M, K, dofs = chain_matrices(10)
    free = SparseModel(M, K, dofs, 0.002)
    joint = parse_dofs(labels(1))
    rng = np.random.default_rng(1)
    B = rng.standard_normal((6, 6))
    k = np.array([2e5, 3e5, 4e5, 300.0, 400.0, 500.0])
    K0 = np.diag(k) + 0.1 * np.sqrt(np.outer(k, k)) * (B + B.T) / 4 * (1 - np.eye(6))
    mount = MountModel(joint, K0, 0.1, 0.5, 100.0, 1.0)
    return free, joint, mount, JointedModel(free, [ComplexStiffness(joint, mount, "mount")])


def test_hong_lee_recovers_a_6dof_mount_from_translations_on_a_model_read_as_matrices():
    free, joint, mount, article = _article()
    f = Frequency(np.arange(10.0, 300.0, 2.0))
    obs = parse_dofs([f"{n}{c}" for n in (1, 2, 3, 5) for c in "xyz"])  # 12 translations >= 6 joint DOFs
    exc = parse_dofs([f"{n}{c}" for n in (1, 3, 4) for c in "xyz"])
    frf = FRF(f, article.receptance(f, obs, exc), obs, exc, "receptance")
    result = identify_joint(free.to_dense(), frf, joint, InverseOptions(symmetric=True))
    truth = mount(f.hz)
    d = np.sqrt(np.abs(np.diagonal(truth, axis1=1, axis2=2)))
    err = np.abs(result.stiffness - truth) / (d[:, :, None] * d[:, None, :])
    assert err.max() < 1e-8
    # the couplings are real terms of this mount, recovered as well as the diagonal
    assert np.abs(truth[:, 0, 4]).min() > 1e-3 * d[:, 0].min() * d[:, 4].min()


def test_rotation_scale_of_a_model_without_coordinates_comes_from_its_stiffness():
    free, *_ = _article()
    s = free.to_dense()
    k = np.abs(np.diagonal(s.K).real)
    rot = np.array([d.unit == "rad" for d in s.dofs])
    assert rotation_scale(s) == pytest.approx(np.sqrt(np.median(k[rot]) / np.median(k[~rot])), rel=1e-12)


def test_dense_structure_refuses_a_model_too_large_for_hong_lee():
    free, *_ = _article()
    with pytest.raises(ModelError) as exc:
        free.to_dense(max_dofs=50)
    assert str(exc.value) == (
        "the model has 60 DOFs; the plain Hong & Lee method needs the dense 60 x 60 Do[nbar, mbar] on every line "
        'and is limited to 50 DOFs: use method = "receptance"'
    )


def test_hong_lee_identifies_two_6dof_mounts_of_a_structure_study_through_the_cli(tmp_path):
    from jointid.cli.main import main
    from test_structure_study import _matrix, _mount_truth, grounded_study, read_table

    study = grounded_study(tmp_path)
    study.write_text(study.read_text().replace('smoothing = "none"', 'method = "hong-lee"\nsymmetric = true'))
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")]) == 0
    f = np.arange(10.0, 401.0, 20.0)
    truth = _mount_truth(f, 1, [3e6, 2e6, 4e6, 3e3, 2.5e3, 1.5e3], [("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5)],
                         0.12, 0.3, 100.0, 0.8)
    K = _matrix(read_table(tmp_path / "id" / "joint_stiffness_front.csv"), ["x", "y", "z", "rx", "ry", "rz"])
    assert np.abs(K - truth).max() / np.abs(truth).max() < 1e-8
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    assert summary["method"] == "hong-lee" and set(summary["joints"]) == {"front", "rear"}
    assert (tmp_path / "id" / "joint_stiffness_rear.png").exists()


def test_hong_lee_on_a_model_too_large_for_it_is_one_line(tmp_path, capsys, monkeypatch):
    import jointid.physics.sparse_model as sparse_model
    from jointid.cli.main import main
    from test_structure_study import grounded_study

    study = grounded_study(tmp_path)
    study.write_text(study.read_text().replace('smoothing = "none"', 'method = "hong-lee"'))
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    capsys.readouterr()
    monkeypatch.setattr(sparse_model, "DENSE_STRUCTURE_MAX_DOFS", 50)
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"jointid identify: error: {study}: [identification].method = 'hong-lee': the model has 60 DOFs; the plain Hong & Lee "
        'method needs the dense 60 x 60 Do[nbar, mbar] on every line and is limited to 50 DOFs: use method = "receptance"'
    )
    assert not (tmp_path / "id").exists()
