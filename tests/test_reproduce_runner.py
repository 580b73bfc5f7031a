"""The reproduce runner: outputs whole or not at all, failures name the study, config validation."""

import csv
import re
import types

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.errors import StudyError
from jointid.reproduce import runner
from jointid.reproduce.common import StudyOutput
from jointid.reproduce.config import load_config
from jointid.report.html import Table


def _fake_module(fail: bool, data: str = "fake"):
    def run(config, progress):
        progress.total(2)
        progress.update()
        if fail:
            raise ValueError("the joint model diverged at 950 Hz")
        progress.update()
        return StudyOutput("conditioning", "Fake", ("text",), (Table("t", ["a"], [["1"]]),), {data: {"x": [1.0, 2.0]}}, (), (("case", 0.01, 0.002),), ("A finding.",))

    return types.SimpleNamespace(run=run)


def test_failing_study_leaves_previous_output_untouched(tmp_path, monkeypatch):
    out = tmp_path / "out"
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=False))
    runner.run_reproduce(load_config(), out, ["conditioning"], quiet=True)
    previous = (out / "report.html").read_text()
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=True))
    with pytest.raises(runner.StudyFailed, match="study 'conditioning' failed: ValueError: the joint model diverged at 950 Hz; no report was written"):
        runner.run_reproduce(load_config(), out, ["conditioning"], quiet=True)
    assert (out / "report.html").read_text() == previous
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary directory left
    assert sorted(p.name for p in out.iterdir()) == [".jointid-manifest.json", "data", "report.html"]


def test_a_users_report_is_refused_before_any_study_runs(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("my notes")
    ran = []
    monkeypatch.setattr(runner, "load_study_module", lambda name: ran.append(name) or _fake_module(fail=False))
    assert main(["reproduce", "--out", str(out), "--only", "conditioning"]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == f"jointid reproduce: error: {out / 'report.html'} exists and was not written by jointid; move it or choose another --out"
    assert ran == [] and captured.out == ""  # refused before the studies were even planned
    assert (out / "report.html").read_text() == "my notes" and sorted(p.name for p in out.iterdir()) == ["report.html"]


def test_successful_run_replaces_its_own_output_only(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "stale.csv").write_text("a user's file")  # not jointid's: kept
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=False))
    res = runner.run_reproduce(load_config(), out, ["conditioning"], quiet=True)
    html = res.report.read_text()
    assert "A finding." in html and "<table>" in html
    assert (out / "data" / "fake.csv").read_text().splitlines() == ["x", "1.0", "2.0"]
    # a second run that writes other data files: the first run's fake.csv is stale and goes
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=False, data="other"))
    runner.run_reproduce(load_config(), out, ["conditioning"], quiet=True)
    assert sorted(p.name for p in (out / "data").iterdir()) == ["other.csv"]
    assert (out / "stale.csv").read_text() == "a user's file"
    assert sorted(p.name for p in out.iterdir()) == [".jointid-manifest.json", "data", "report.html", "stale.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_cli_failure_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=True))
    assert main(["reproduce", "--out", str(tmp_path / "o"), "--only", "conditioning", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "study 'conditioning' failed" in err
    assert not (tmp_path / "o").exists()


def test_only_and_config_validation(tmp_path):
    assert runner.parse_only("model-error,conditioning") == ("conditioning", "model-error")
    with pytest.raises(StudyError, match="--only: unknown study 'modal'"):
        runner.parse_only("modal")
    bad = tmp_path / "c.toml"
    bad.write_text("[noise]\nexperimnt = 0.02\n")
    with pytest.raises(StudyError, match=r"\[noise\]: unknown key 'experimnt'"):
        load_config(bad)
    bad.write_text("[layouts.model_1]\nobserved = [5, 40]\n")
    with pytest.raises(StudyError, match=r"\[layouts.model_1\].observed: expected a non-empty list of beam nodes 1..19"):
        load_config(bad)
    good = tmp_path / "g.toml"
    good.write_text("seed = 3\n[frequency]\nstep = 5.0\n[materials.A]\nloss_factor = 0.2\n[layouts.model_2]\nobserved = [2, 8, 12, 18]\n")
    c = load_config(good)
    assert c.seed == 3 and c.grid.size == 200 and c.materials["A"].loss_factor == 0.2 and c.materials["A"].density == 1200.0
    assert c.layouts["model_2"].observed == (2, 8, 12, 18) and c.layouts["model_2"].excited == (3, 7, 13, 17)


@pytest.mark.parametrize(
    "text, message",
    [
        ("layouts = 3\n", "[layouts]: expected a table, got 3"),
        ("[materials]\nA = 5\n", "[materials.A]: expected a table, got 5"),
        ("seed = -1\n", "seed: expected an integer >= 0, got -1"),
        ("[frequency]\nstart = 0.0\n", "[frequency].start: expected a positive number, got 0.0"),
        ("[direct]\nstart = 700.0\n", "[direct]: start must be below stop"),
        ("[direct]\nparallel_joints = 2.5\n", "[direct].parallel_joints: expected an integer >= 1, got 2.5"),
    ],
)
def test_bad_config_names_the_key(tmp_path, text, message):
    p = tmp_path / "c.toml"
    p.write_text(text)
    with pytest.raises(StudyError) as e:
        load_config(p)
    assert str(e.value) == f"{p}: {message}"


def test_parallel_run_gives_the_serial_numbers_and_one_progress_line_per_study(tmp_path, capsys):
    """Noise realizations and studies on 2 processes: the same CSVs and figures as in one process.

    Every task runs on one BLAS thread in either case, so the arithmetic is the same; the bits can still differ
    where OpenBLAS's kernels depend on the arrays' memory alignment (a fresh worker against a process that ran
    other tasks), and the structured fit amplifies such differences up to its stopping tolerance (relative cost
    change 1e-6: parameters within ~1e-3 sigma, i.e. at most ~1e-4 of a value here). So numbers agree within
    rtol 1e-6 (measured: identical with one BLAS thread, 1e-13 with two), a coverage fraction within one line
    (an estimate at a band edge may cross it), figures pixel for pixel but for a few anti-aliased ones.
    """
    cfg = tmp_path / "c.toml"
    cfg.write_text("[frequency]\nstart = 5.0\nstop = 1000.0\nstep = 20.0\n"
                   "[noise_robustness]\nlevels = [0.01]\nlayouts = [\"model_3\"]\njoint_nodes = [1]\n")
    args = ["reproduce", "--only", "noise-robustness", "--config", str(cfg), "--seeds", "2"]
    assert main(args + ["--out", str(tmp_path / "one"), "--jobs", "1"]) == 0
    capsys.readouterr()
    assert main(args + ["--out", str(tmp_path / "two"), "--jobs", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()  # stdout is not a terminal here: the lines are there all the same
    assert lines[0] == "running 1 study as 4 tasks on 2 processes (noise-robustness: 2 noise realizations per level; --seeds N for more)"
    assert re.fullmatch(r"\[1/1\] noise-robustness: \d+\.\d s \(CPU \d+\.\d s\)", lines[1]), lines
    assert re.fullmatch(r"wrote .*report\.html \(1 study, \d+\.\d s on 2 processes\)", lines[2]) and len(lines) == 3
    one, two = tmp_path / "one", tmp_path / "two"
    for sub in ("data", "figures"):
        names = sorted(p.name for p in (one / sub).iterdir())
        assert names == sorted(p.name for p in (two / sub).iterdir()) and names
    for name in sorted(p.name for p in (one / "data").iterdir()):
        a, b = (list(csv.reader((d / "data" / name).open())) for d in (one, two))
        assert a[0] == b[0] and len(a) == len(b), name
        for ra, rb in zip(a[1:], b[1:]):
            for col, x, y in zip(a[0], ra, rb):
                try:
                    x, y = float(x), float(y)
                except ValueError:
                    assert x == y, (name, col)
                    continue
                if np.isnan(x) or np.isnan(y):  # no band (Hong-Lee, raw): empty in both
                    assert np.isnan(x) and np.isnan(y), (name, col, x, y)
                    continue
                tol = 1.0 / 49 if col.endswith(("coverage_real", "coverage_imag")) else 1e-6 * max(abs(x), abs(y))
                assert abs(x - y) <= tol, (name, col, x, y)
    from matplotlib.image import imread

    for name in sorted(p.name for p in (one / "figures").iterdir()):
        x, y = imread(one / "figures" / name), imread(two / "figures" / name)
        assert x.shape == y.shape and np.mean(np.any(x != y, axis=-1)) < 1e-3, name
    html = (two / "report.html").read_text()
    assert "2 noise realizations per level and case" in html and "2 noise realizations per level" in html


def test_quiet_prints_only_the_result_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "load_study_module", lambda name: _fake_module(fail=False))
    assert main(["reproduce", "--out", str(tmp_path / "o"), "--only", "conditioning", "--quiet"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith("wrote ")
