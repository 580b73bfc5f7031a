"""CLI round trip: simulate -> identify recovers the joint; bad input is one line."""

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from jointid.cli.main import main
from study_texts import beam_study_toml

STUDY = beam_study_toml("growth = 0.5\nreference_frequency = 100.0\nexponent = 0.5\n")


def _table(path):
    rows = list(csv.DictReader(open(path)))
    return rows[0].keys(), {k: np.array([r[k] for r in rows]) for k in rows[0]}


def test_simulate_identify_round_trip(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")]) == 0
    cols, got = _table(tmp_path / "id" / "joint_stiffness.csv")
    assert list(cols) == [
        "frequency_hz",
        "K_w_w_real", "K_w_w_imag", "K_w_theta_real", "K_w_theta_imag",
        "K_theta_w_real", "K_theta_w_imag", "K_theta_theta_real", "K_theta_theta_imag",
        *(f"K_{t}_{p}_std" for t in ("w_w", "w_theta", "theta_w", "theta_theta") for p in ("real", "imag")),
        "reliable_w_w", "reliable_w_theta", "reliable_theta_w", "reliable_theta_theta", "reliable",
    ]
    _, true = _table(tmp_path / "sim" / "true_joint.csv")
    assert np.array_equal(got["frequency_hz"].astype(float), true["frequency_hz"].astype(float))
    for term in ("w_w", "w_theta", "theta_w", "theta_theta"):
        k = got[f"K_{term}_real"].astype(float) + 1j * got[f"K_{term}_imag"].astype(float)
        t = true[f"K_{term}_real"].astype(float) + 1j * true[f"K_{term}_imag"].astype(float)
        assert np.max(np.abs(k - t) / np.abs(t)) < 1e-6, term
    assert set(got["reliable"]) == {"1"}  # 0/1: numpy reads true/false as NaN
    assert np.genfromtxt(tmp_path / "id" / "joint_stiffness.csv", delimiter=",", names=True)["reliable"].tolist() == [1.0] * 200
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    assert summary["lines"] == 200 and summary["units"]["K_w_theta"] == "N/rad"
    assert summary["method"] == "receptance" and summary["findings"] == []  # exact FRFs: every term determined
    assert (tmp_path / "id" / "joint_stiffness.png").stat().st_size > 20000


def test_identify_uses_the_study_band_on_the_files_grid(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    narrow = tmp_path / "narrow.toml"
    narrow.write_text(STUDY.replace("start = 5.0", "start = 100.0").replace("stop = 1000.0", "stop = 200.0").replace("step = 5.0", "step = 1.0"))
    assert main(["identify", str(narrow), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    _, got = _table(tmp_path / "id" / "joint_stiffness.csv")
    f = got["frequency_hz"].astype(float)
    assert f[0] == 100.0 and f[-1] == 200.0 and f.size == 21  # the file's 5 Hz grid, not the study's step
    assert not (tmp_path / "id" / "joint_stiffness.png").exists()


@pytest.mark.parametrize(
    "edit, message",
    [
        (("observed = [1, 3, 6, 9, 12, 15, 19]", "observed = [3]"), "1 observed coordinate(s) for 2 joint DOFs"),
        (("excited  = [3, 9, 15]", "excited  = [9]"), "1 excited coordinate(s) for 2 joint DOFs"),
        (("observed = [1, 3, 6, 9, 12, 15, 19]", "observed = [1, 3, 5]"), "the FRF file {frf} has no response at 5w"),
    ],
)
def test_identify_bad_layout_is_one_line(tmp_path, edit, message):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text(STUDY.replace(*edit))
    r = subprocess.run(
        [sys.executable, "-m", "jointid.cli.main", "identify", str(bad), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")],
        capture_output=True, text=True,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and message.format(frf=tmp_path / "sim" / "frf.uff") in r.stderr
    assert not (tmp_path / "id").exists() or not any((tmp_path / "id").iterdir())


def test_identify_noisy_frfs_reports_the_structured_estimator(tmp_path, capsys):
    """An elastomer joint (one material: in the structured model's class) from 1 % noisy FRFs."""
    study = tmp_path / "study.toml"
    head, model = STUDY.split("[joint.model]\n")
    study.write_text(head + '[joint.model]\ntype = "elastomer"\nmaterial = "B"\n\n[measurement]' + model.split("[measurement]", 1)[1])
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim"), "--noise", "0.01", "--seed", "4"]) == 0
    capsys.readouterr()
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    out = capsys.readouterr().out.splitlines()
    line = next(x for x in out if x.startswith("estimator: "))
    assert line.startswith("estimator: structured joint model (") and "Akaike-weighted average of" in line
    est = json.loads((tmp_path / "id" / "summary.json").read_text())["diagnostics"]["estimator"]
    assert est["estimator"] == "structured" and est["structured"]["accepted"]
    assert 0.7 < est["structured"]["chi2_per_dof"] < 1.5
    assert abs(sum(est["structured"]["akaike_weights"].values()) - 1.0) < 1e-9
    assert est["description"] == line[len("estimator: "):]
