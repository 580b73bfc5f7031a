"""Every command's --out: a checkout survives `reproduce --out .`, a file is refused, user files survive."""

import subprocess

import pytest

from jointid.cli.main import main
from jointid.io.output_dir import MANIFEST_NAME, OutputSet
from study_texts import beam_study_toml
from test_output_dir import snapshot

STUDY = beam_study_toml(start=20.0, step=20.0)


def _git(cwd, *args):
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True, text=True).stdout


def test_reproduce_into_a_git_checkout_keeps_everything(tmp_path, monkeypatch, capsys):
    repo = tmp_path / "repo"
    repo.mkdir()
    _git(repo, "init", "-q")
    (repo / "analysis.py").write_text("print('mine')\n")
    (repo / "data").mkdir()
    (repo / "data" / "measured.csv").write_text("f,x\n1,2\n")  # a user directory reproduce also writes into
    _git(repo, "add", ".")
    _git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "init")
    before = snapshot(repo)
    monkeypatch.chdir(repo)
    coarse = tmp_path / "coarse.toml"  # outside the checkout: what is written, not the numbers, is tested here
    coarse.write_text("[frequency]\nstart = 5.0\nstop = 1000.0\nstep = 20.0\n")
    for _ in range(2):  # twice: the second run replaces its own files only
        assert main(["reproduce", "--out", ".", "--only", "conditioning", "--quiet", "--config", str(coarse)]) == 0
    after = snapshot(repo)
    assert {k: v for k, v in after.items() if k in before} == before  # .git and every file untouched
    new = sorted(k for k in set(after) - set(before))
    status = _git(repo, "status", "--porcelain", "-uall").splitlines()
    assert status == [
        "?? .jointid-manifest.json",
        "?? data/conditioning_condition_numbers.csv",
        "?? data/conditioning_model_1_translational.csv",
        "?? data/conditioning_model_2_translational.csv",
        "?? figures/conditioning_condition_numbers.png",
        "?? figures/conditioning_translational.png",
        "?? report.html",
    ]
    assert new == sorted(["figures"] + [s[3:] for s in status])
    _git(repo, "fsck", "--no-progress")
    assert "wrote report.html" in capsys.readouterr().out


@pytest.mark.parametrize("command", [["reproduce", "--only", "conditioning", "--quiet"], ["modes"], ["simulate"]])
def test_out_naming_a_file_is_refused(tmp_path, monkeypatch, capsys, command):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("my notes\n")
    assert main([*command, "--out", "notes.txt"]) == 2
    assert capsys.readouterr().err == f"jointid {command[0]}: error: --out notes.txt is a file; give a directory\n"
    assert (tmp_path / "notes.txt").read_text() == "my notes\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_user_file_survives_two_runs_and_no_plots_removes_the_png(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    sim, out = tmp_path / "sim", tmp_path / "out"
    assert main(["simulate", str(study), "--out", str(sim)]) == 0
    out.mkdir()
    (out / "notes.md").write_text("my notes")
    assert main(["identify", str(study), "--frf", str(sim / "frf.uff"), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "joint_stiffness.csv", "joint_stiffness.png", "notes.md", "report.html", "summary.json"]
    assert main(["identify", str(study), "--frf", str(sim / "frf.uff"), "--out", str(out), "--no-plots"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "joint_stiffness.csv", "notes.md", "report.html", "summary.json"]
    assert (out / "notes.md").read_text() == "my notes"
    # identify into the simulation's directory keeps the FRF file it reads (another command's output)
    assert main(["identify", str(study), "--frf", str(sim / "frf.uff"), "--out", str(sim), "--no-plots"]) == 0
    assert sorted(p.name for p in sim.iterdir()) == [MANIFEST_NAME, "frf.uff", "joint_stiffness.csv", "report.html", "summary.json", "true_joint.csv"]
    # a file of another command's set with the same name (report.html) is replaced, and the run says so
    capsys.readouterr()
    example = tmp_path / "stepsine.csv"
    assert main(["direct", "--example", str(example)]) == 0
    assert main(["direct", str(example), "--out", str(out), "--no-plots"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if ": note: " in line]
    assert notes == [f"jointid direct: note: replaced report.html in {out}, written there before by `jointid identify` "
                     "(use another --out to keep both)"]
    assert (out / "notes.md").read_text() == "my notes" and (out / "joint_stiffness.csv").is_file()


def test_identify_failure_leaves_dir_exactly_as_before(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["simulate", str(study), "--out", str(out)]) == 0
    (out / "mine.txt").write_text("user")
    bad = tmp_path / "bad.csv"
    bad.write_text("frequency_hz,response,reference,real,imag\n")
    before = snapshot(out)
    assert main(["identify", str(study), "--frf", str(bad), "--out", str(out)]) == 2
    assert str(bad) in capsys.readouterr().err
    assert snapshot(out) == before


def test_clash_with_a_user_file_is_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "modes.csv").write_text("my own table")
    assert main(["modes", "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"jointid modes: error: {out / 'modes.csv'} exists and was not written by jointid; move it or choose another --out\n"
    )
    assert sorted(p.name for p in out.iterdir()) == ["modes.csv"] and (out / "modes.csv").read_text() == "my own table"


def test_second_run_while_one_writes_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    with OutputSet(out, "modes"):  # another run holds the directory
        assert main(["modes", "--out", str(out), "--no-plots"]) == 2
    assert capsys.readouterr().err == (
        f"jointid modes: error: --out {out} is being written by another jointid run; wait for it to finish or choose another --out\n"
    )
    assert main(["modes", "--out", str(out), "--no-plots"]) == 0


def test_a_stop_after_the_output_was_committed_says_it_is_complete(tmp_path, monkeypatch, capsys):
    """SIGINT while the files are renamed into place is held until the set is complete: the line says so (it said
    "no partial output was written", and the user took the previous outputs for intact)."""
    import os
    import signal

    from test_output_dir import signal_at_rename

    out = tmp_path / "out"
    assert main(["modes", "--out", str(out)]) == 0
    signal_at_rename(monkeypatch, "modes.csv", signal.SIGINT)
    capsys.readouterr()
    assert main(["modes", "--out", str(out)]) == 130
    assert capsys.readouterr().err.splitlines()[-1] == f"jointid modes: interrupted; its output in {out} was complete before it stopped"
