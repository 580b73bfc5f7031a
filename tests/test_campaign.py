"""``jointid campaign``: tables, counts, resumability, failures, bad manifests (small synthetic campaigns)."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from campaign_data import FREQUENCIES_HZ, manifest_rows, small_campaign, write_manifest
from jointid.campaign import read_manifest, run_campaign
from jointid.campaign.driver import CampaignOptions
from jointid.campaign.store import CACHE_DIR
from jointid.cli.main import main
from jointid.measurement.stepsine import process_stepsine, read_stepsine_csv

ISSUE_KEYS = {"reference_temperature_c", "shift_factors", "wlf", "arrhenius", "modulus"}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A 6-test campaign (3 temperatures x 2 amplitudes, 5 lines each) and its first run (2 worker processes)."""
    root = tmp_path_factory.mktemp("campaign")
    manifest = small_campaign(root / "data")
    out = root / "out"
    rc = main(["campaign", str(manifest), "--out", str(out), "--workers", "2", "--no-plots"])
    return manifest, out, rc


def _cache_entries(out: Path) -> int:
    return len(list((out / CACHE_DIR).glob("*.json")))


def _json(path: Path) -> dict:
    return json.loads(path.read_text(), parse_constant=lambda c: pytest.fail(f"{path}: non-standard JSON {c}"))


def test_end_to_end_tables_counts_and_master_curve(campaign):
    manifest, out, rc = campaign
    assert rc == 0
    rows = manifest_rows(manifest)
    n = len(rows)
    summary = _json(out / "campaign.json")
    assert {k: v for k, v in summary.items() if k != "findings"} == {"tests": n, "computed": n, "reused": 0, "failed": [],
                                                                     "manifest": str(manifest)}
    assert summary["findings"] == _json(out / "master_curve.json")["findings"]  # every finding the terminal prints
    results = pq.read_table(out / "results.parquet")
    assert results.num_rows == n * len(FREQUENCIES_HZ)
    for col in ("manifest_row", "file", "specimen", "temperature_c", "amplitude_m", "preload_n", "batch", "frequency_hz",
                "stiffness_real", "stiffness_imag", "magnitude", "loss_factor", "stiffness_real_std", "amplitude_ok"):
        assert col in results.column_names
    df = results.to_pandas()
    assert list(df["batch"].unique()) == [f"{i:03d}" for i in range(n)]  # free column carried as written (text)
    # every test's lines are exactly what the step-sine processing of its file gives
    for i, row in enumerate(rows, start=1):
        r = process_stepsine(read_stepsine_csv(manifest.parent / row["file"]), parallel_joints=int(row["parallel_joints"]),
                             commanded_amplitude_m=float(row["amplitude_m"]))
        got = df[df["manifest_row"] == i].sort_values("frequency_hz")
        assert got["file"].iloc[0] == row["file"] and got["temperature_c"].iloc[0] == float(row["temperature_c"])
        np.testing.assert_array_equal(got["frequency_hz"], r.frequency_hz)
        np.testing.assert_array_equal(got["stiffness_real"] + 1j * got["stiffness_imag"], r.stiffness)
        np.testing.assert_array_equal(got["loss_factor"], r.stiffness.imag / r.stiffness.real)
        np.testing.assert_array_equal(got["amplitude_ok"], r.amplitude_ok)
    assert df["stiffness_real_std"].isna().all()  # the step-sine method gives no standard deviation: null, not 0
    # the CSV is the same table
    import pandas as pd

    csv = pd.read_csv(out / "results.csv", dtype={"batch": str})
    np.testing.assert_array_equal(csv["stiffness_real"], df["stiffness_real"])
    tests = pq.read_table(out / "tests.parquet").to_pandas()
    assert list(tests["status"]) == ["ok"] * n and list(tests["manifest_row"]) == list(range(1, n + 1))
    assert (tests["lines"] == len(FREQUENCIES_HZ)).all()
    master = _json(out / "master_curve.json")
    assert set(master["specimens"]) == {"S1"}
    s1 = master["specimens"]["S1"]
    assert ISSUE_KEYS <= set(s1)
    assert s1["reference_temperature_c"] == 20.0 and s1["reference_amplitude_m"] == 2e-5
    # tables hold the shift of the master curve
    shifts = {x["temperature_c"]: x["log10_shift"] for x in s1["shift_factors"]}
    assert shifts[20.0] == 0.0
    from jointid.measurement.campaign_synth import CampaignTruth

    truth = CampaignTruth()  # the synthetic campaign's WLF shift (reference 20 C)
    for temp, x in shifts.items():
        assert abs(x - truth.log10_shift(temp)) < 0.1, (temp, x)
    by_t = df.groupby("temperature_c")["log10_shift"].first()  # the results table carries each test's shift
    assert {t: by_t[t] for t in shifts} == pytest.approx({t: x for t, x in shifts.items()}, abs=0.02)
    assert "<img" not in (out / "report.html").read_text()  # --no-plots
    assert _cache_entries(out) == n


def test_second_run_recomputes_nothing_and_writes_the_same_tables(campaign, tmp_path, capsys):
    manifest, out, _ = campaign
    before = pq.read_table(out / "results.parquet")
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "2", "--no-plots"]) == 0
    s = _json(out / "campaign.json")
    assert (s["computed"], s["reused"], s["failed"]) == (0, s["tests"], [])
    assert pq.read_table(out / "results.parquet").equals(before)
    printed = capsys.readouterr().out
    assert f"campaign: {s['tests']} tests, {s['tests']} stored by a previous run, 0 to compute" in printed


def test_changed_file_is_recomputed_alone(campaign, tmp_path):
    manifest, out, _ = campaign
    data = tmp_path / "data"
    shutil.copytree(manifest.parent, data)
    work = tmp_path / "out"
    shutil.copytree(out, work)
    rows = manifest_rows(data / "manifest.csv")
    path = data / rows[2]["file"]
    path.write_text(path.read_text().replace("\n", "\n", 1) + "\n")  # same data, new content (a trailing empty line)
    assert main(["campaign", str(data / "manifest.csv"), "--out", str(work), "--no-plots", "--workers", "1"]) == 0
    s = _json(work / "campaign.json")
    assert (s["computed"], s["reused"]) == (1, len(rows) - 1)
    # a changed option (the amplitude tolerance) is a new key for every test
    assert main(["campaign", str(data / "manifest.csv"), "--out", str(work), "--no-plots", "--tolerance", "0.2"]) == 0
    assert _json(work / "campaign.json")["computed"] == len(rows)


def test_progress_lines_when_not_a_terminal(campaign, tmp_path, capsys):
    manifest, _, _ = campaign
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o"), "--workers", "1", "--no-plots"]) == 0
    out = capsys.readouterr().out.splitlines()
    n = len(manifest_rows(manifest))
    assert any(line.startswith(f"campaign: 1/{n} tests done") and "ETA" in line for line in out)
    assert any(line.startswith(f"campaign: {n}/{n} tests done") and line.endswith("done") for line in out)


def test_failing_test_is_listed_exit_1_and_the_others_written(campaign, tmp_path, capsys):
    manifest, _, _ = campaign
    data = tmp_path / "data"
    shutil.copytree(manifest.parent, data)
    rows = manifest_rows(data / "manifest.csv")
    bad = data / rows[1]["file"]
    lines = bad.read_text().splitlines()
    lines[5] = lines[5].split(",")[0] + ",x,1,2"  # time 'x' on data line 5
    bad.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    assert main(["campaign", str(data / "manifest.csv"), "--out", str(out), "--no-plots", "--workers", "2"]) == 1
    s = _json(out / "campaign.json")
    assert s["tests"] == len(rows) and s["computed"] == len(rows)
    assert len(s["failed"]) == 1
    f = s["failed"][0]
    assert (f["row"], f["file"]) == (2, rows[1]["file"])
    assert f["reason"] == f"{bad}: column 'time_s', data line 5: 'x' is not a number"
    err = capsys.readouterr().err.strip().splitlines()
    notes = [line for line in err if line.startswith("jointid campaign: note: ")]
    # the master curve's own findings reach the terminal too (they were in master_curve.json and the report only)
    assert len(notes) == 1 and re.fullmatch(r"jointid campaign: note: specimen S1: master curve: shift law: WLF preferred "
                                            r"\(AIC \S+ vs \S+\)", notes[0]), notes
    assert [line for line in err if line not in notes] == [
        f"jointid campaign: test failed: {data / 'manifest.csv'}: row 2 ({rows[1]['file']}): {f['reason']}"]
    results = pq.read_table(out / "results.parquet").to_pandas()
    assert sorted(results["manifest_row"].unique()) == [1] + list(range(3, len(rows) + 1))
    tests = pq.read_table(out / "tests.parquet").to_pandas()
    assert tests.loc[1, "status"] == "failed" and tests.loc[1, "reason"] == f["reason"]
    # a bad-data failure is a result too: the re-run reuses it (and still exits 1)
    assert main(["campaign", str(data / "manifest.csv"), "--out", str(out), "--no-plots"]) == 1
    assert _json(out / "campaign.json")["computed"] == 0


@pytest.mark.parametrize("column,value,message", [
    ("temperature_c", "warm", "row 2 (line 3), column 'temperature_c': expected a number (degrees C), got 'warm'"),
    ("amplitude_m", "-1e-5", "row 2 (line 3), column 'amplitude_m': expected a positive displacement amplitude (m, peak), got '-1e-5'"),
    ("file", "nowhere.csv", "row 2 (line 3), column 'file': {dir}/nowhere.csv does not exist; give the test's data file relative to the manifest"),
    ("kind", "guess", "row 2 (line 3), column 'kind': expected one of direct, identify, got 'guess'"),
    ("parallel_joints", "two", "row 2 (line 3), column 'parallel_joints': expected an integer >= 1 (joints loaded in parallel), got 'two'"),
    ("specimen", "", "row 2 (line 3), column 'specimen': empty; name the specimen"),
])
def test_bad_manifest_row_one_line_exit_2_nothing_computed(campaign, tmp_path, capsys, column, value, message):
    manifest, _, _ = campaign
    rows = manifest_rows(manifest)
    for r in rows:
        r.setdefault("kind", "direct")
    rows[1][column] = value
    m = write_manifest(manifest.parent / f"bad_{column}.csv", rows)
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"jointid campaign: error: {m}: " + message.format(dir=manifest.parent)]
    assert not out.exists()  # validated before anything was computed or created


@pytest.mark.parametrize("column", ["status", "term"])
def test_a_free_column_named_like_a_computed_one_is_refused_before_computing(campaign, tmp_path, capsys, column):
    """A free column of the name of a column jointid computes (was: internal error, ArrowInvalid, after computing)."""
    manifest, _, _ = campaign
    rows = manifest_rows(manifest)
    for r in rows:
        r[column] = "7"
    m = write_manifest(manifest.parent / f"named_{column}.csv", rows)
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"jointid campaign: error: {m} line 1: column {column!r} is one jointid computes into its tables; rename it (e.g. "
        "with a prefix)"]
    assert not out.exists()


def test_a_free_column_named_like_a_tests_result_is_refused_and_the_tests_kept(campaign, tmp_path, capsys):
    """``median_loss_factor`` (a direct test's result in tests.csv) as a free column: one line, exit 2; the computed
    tests stay in the cache, so the rerun with the column renamed computes nothing again."""
    manifest, _, _ = campaign
    rows = manifest_rows(manifest)
    for r in rows:
        r["median_loss_factor"] = "0.2"
    m = write_manifest(manifest.parent / "named_result.csv", rows)
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out), "--no-plots", "--workers", "1"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"jointid campaign: error: {m}: column 'median_loss_factor' is a result jointid writes for each test (tests.csv); "
        "rename it in the manifest (the computed tests are kept: a rerun reuses them)"]
    for r in rows:
        r["their_loss_factor"] = r.pop("median_loss_factor")
    m = write_manifest(manifest.parent / "renamed_result.csv", rows)
    result = run_campaign(m, out, CampaignOptions(plots=False), workers=1, stream=open(os.devnull, "w"))
    assert (result.summary["computed"], result.summary["reused"]) == (0, len(rows))


def test_missing_column_and_empty_manifest(tmp_path, capsys):
    m = tmp_path / "m.csv"
    m.write_text("file,specimen,temperature_c,amplitude_m\na.csv,S1,20,1e-5\n")
    assert main(["campaign", str(m), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"jointid campaign: error: {m}: missing column 'preload_n' (columns present: file, specimen, temperature_c, amplitude_m); "
        "a manifest needs file, specimen, temperature_c, amplitude_m, preload_n")
    m.write_text("file,specimen,temperature_c,amplitude_m,preload_n\n")
    assert main(["campaign", str(m), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == f"jointid campaign: error: {m}: no tests; add one row per test after the header"


@pytest.mark.parametrize("option,message", [
    (["--workers", "0"], "--workers must be >= 1, got 0"),
    (["--reference-temperature", "-300"], "--reference-temperature must be a temperature in degrees C, got -300.0"),
    (["--tolerance", "0"], "--tolerance must be a positive fraction (e.g. 0.05), got 0.0"),
])
def test_bad_options_one_line_exit_2(campaign, tmp_path, capsys, option, message):
    manifest, _, _ = campaign
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o"), *option]) == 2
    assert capsys.readouterr().err.strip() == f"jointid campaign: error: {message}"
    assert not (tmp_path / "o").exists()


def test_simulated_crash_keeps_finished_tests(campaign, tmp_path):
    """A run that dies after 3 tests wrote nothing but the 3 stored results; the re-run computes only the rest."""
    manifest, out_full, _ = campaign
    n = len(manifest_rows(manifest))
    out = tmp_path / "out"
    done = []

    class Crash(Exception):
        pass

    def die(outcome):
        done.append(outcome)
        if len(done) == 3:
            raise Crash

    with pytest.raises(Crash):
        run_campaign(manifest, out, CampaignOptions(plots=False), workers=1, on_done=die, stream=open(os.devnull, "w"))
    assert _cache_entries(out) == 3
    assert not (out / "results.parquet").exists() and not (out / "campaign.json").exists()
    result = run_campaign(manifest, out, CampaignOptions(plots=False), workers=2, stream=open(os.devnull, "w"))
    assert (result.summary["computed"], result.summary["reused"]) == (n - 3, 3)
    assert pq.read_table(out / "results.parquet").equals(pq.read_table(out_full / "results.parquet"))


def test_sigkill_mid_run_resumes(campaign, tmp_path):
    """A real ``kill -9`` of a campaign after its first test: the re-run reuses what was stored and computes the rest."""
    manifest, out_full, _ = campaign
    n = len(manifest_rows(manifest))
    out = tmp_path / "out"
    jointid = Path(sys.executable).parent / "jointid"
    proc = subprocess.Popen([str(jointid), "campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"],
                            stdout=subprocess.PIPE, text=True, start_new_session=True,
                            env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
    try:
        for line in proc.stdout:
            if line.startswith(f"campaign: 1/{n} tests done"):
                os.killpg(proc.pid, signal.SIGKILL)
                break
    finally:
        proc.wait(timeout=60)
    stored = _cache_entries(out)
    assert 1 <= stored, "the first finished test was not stored"
    assert not (out / "campaign.json").exists() or stored == n
    result = run_campaign(manifest, out, CampaignOptions(plots=False), workers=1, stream=open(os.devnull, "w"))
    assert (result.summary["computed"], result.summary["reused"]) == (n - stored, stored)
    assert pq.read_table(out / "results.parquet").equals(pq.read_table(out_full / "results.parquet"))


def _descendants(pid: int) -> set[int]:
    """Processes whose parent chain leads to ``pid`` (from /proc)."""
    parents = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                parents[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc (Linux)")
def test_sigkilled_campaign_leaves_no_worker_processes(campaign, tmp_path):
    """``kill -9`` of the campaign process alone: its pool's worker processes notice and exit (no orphans)."""
    manifest, _, _ = campaign
    n = len(manifest_rows(manifest))
    jointid = Path(sys.executable).parent / "jointid"
    proc = subprocess.Popen([str(jointid), "campaign", str(manifest), "--out", str(tmp_path / "o"), "--workers", "2", "--no-plots"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
    children: set[int] = set()
    try:
        for line in proc.stdout:
            if line.startswith("campaign: ") and "tests done" in line:
                children = _descendants(proc.pid)
                proc.kill()  # SIGKILL to the campaign process only
                break
    finally:
        proc.wait(timeout=60)
    try:
        assert children, f"no worker processes seen (a {n}-test campaign on 2 workers)"
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(_alive(p) for p in children):
            time.sleep(0.2)
        assert not [p for p in children if _alive(p)]
    finally:
        for p in children:  # never leave them behind, even when the test fails
            if _alive(p):
                os.kill(p, signal.SIGKILL)


def test_tampered_cache_entry_is_recomputed(campaign, tmp_path):
    manifest, out_full, _ = campaign
    out = tmp_path / "out"
    shutil.copytree(out_full, out)
    entry = sorted((out / CACHE_DIR).glob("*.json"))[0]
    entry.write_text(entry.read_text().replace('"ok":true', '"ok":false', 1))
    result = run_campaign(manifest, out, CampaignOptions(plots=False), workers=1, stream=open(os.devnull, "w"))
    assert result.summary["computed"] == 1 and result.summary["failed"] == []


def test_manifest_api(campaign):
    manifest, _, _ = campaign
    m = read_manifest(manifest)
    assert m.extra_columns == ("batch",)
    assert [t.row for t in m.tests] == list(range(1, len(m.tests) + 1))
    t = m.tests[0]
    assert t.kind == "direct" and t.parallel_joints == 2 and t.file.is_file() and t.value("batch") == "000"


def test_a_users_results_csv_is_refused_before_any_test_runs(campaign, tmp_path, capsys):
    """A file of one of the campaign's output names that jointid did not write: one line, exit 2, no test computed."""
    manifest, _, _ = campaign
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("my own table\n")
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"jointid campaign: error: {out / 'results.csv'} exists and was not written by jointid; move it or choose another --out"]
    assert sorted(p.name for p in out.iterdir()) == ["results.csv"] and not (out / CACHE_DIR).exists()


def test_a_tolerance_that_leaves_the_modulus_undetermined_is_reported_not_an_internal_error(tmp_path, capsys):
    """``--tolerance 1e-4`` rejects most lines of two example tests: the Zener fit's search went to exp() overflow
    (internal error, OverflowError); now the fit ends and says its parameters are not identified."""
    data = tmp_path / "data"
    data.mkdir()
    assert main(["direct", "--example", str(data / "t1.csv")]) == 0
    lines = (data / "t1.csv").read_text().splitlines(keepends=True)
    lines[1] = lines[1].rstrip("\n") + "1\n"  # the last digit of one force sample: not the same test (that is refused)
    (data / "t2.csv").write_text("".join(lines))
    m = data / "m.csv"
    m.write_text("file,specimen,temperature_c,amplitude_m,preload_n\nt1.csv,S1,20,2.5e-5,0\nt2.csv,S1,40,2.5e-5,0\n")
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out), "--workers", "1", "--no-plots", "--tolerance", "0.0001"]) == 0, \
        capsys.readouterr().err
    modulus = _json(out / "master_curve.json")["specimens"]["S1"]["modulus"]
    assert modulus["identified"] is False
    assert {modulus[k]["status"] for k in ("K0_n_m", "Kinf_n_m", "tau_s", "alpha")} <= {"not_identified", "at_bound"}


def test_one_data_file_in_two_rows_is_refused(campaign, tmp_path, capsys):
    """The same file twice (a copy-paste row) would count twice in the specimen's fits: one line, exit 2."""
    manifest, _, _ = campaign
    rows = manifest_rows(manifest)
    rows[2] = {**rows[2], "file": rows[0]["file"]}
    m = write_manifest(manifest.parent / "twice.csv", rows)
    assert main(["campaign", str(m), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"jointid campaign: error: {m}: rows 1 (line 2) and 3 (line 4) both use {Path(rows[0]['file']).name} as a direct "
        "test; a repeated test needs its own data file: remove one row"]
    assert not (tmp_path / "o").exists()


def test_a_temperature_left_out_of_the_master_curve_has_no_shift_and_the_terminal_says_why(tmp_path, capsys):
    """A black-box finding: temperatures the master curve left out (curves that do not overlap) still got a
    ``log10_shift`` in the tables, from a law that could only extrapolate to them (0.3 decades off), and why they were
    left out was only in master_curve.json and the report."""
    manifest = small_campaign(tmp_path / "data", temperatures=(-40.0, 10.0, 20.0, 30.0), amplitudes=(2e-5,), extra=False)
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    df = pq.read_table(out / "results.parquet").to_pandas()
    assert df.loc[df["temperature_c"] == -40.0, "log10_shift"].isna().all()
    assert df.loc[df["temperature_c"] == -40.0, "reduced_frequency_hz"].isna().all()
    assert df.loc[df["temperature_c"] != -40.0, "log10_shift"].notna().all()
    err = capsys.readouterr().err
    assert "jointid campaign: note: specimen S1: master curve: -40 deg C: its curve does not overlap the others; left out" in err
    assert any(f.startswith("specimen S1: master curve: -40 deg C") for f in _json(out / "master_curve.json")["findings"])


def test_the_same_test_listed_twice_is_refused_naming_both_rows(tmp_path, capsys):
    """A black-box finding: a test copied under another name and listed again was counted twice in the master curve
    (its bands too narrow), and the counts disagreed (4 to compute, 5 computed)."""
    manifest = small_campaign(tmp_path / "data", temperatures=(10.0, 20.0), amplitudes=(2e-5,), extra=False)
    rows = manifest_rows(manifest)
    shutil.copy(manifest.parent / rows[1]["file"], manifest.parent / "copy.csv")
    write_manifest(manifest, rows + [{**rows[1], "file": "copy.csv"}])
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o"), "--workers", "1", "--no-plots"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"jointid campaign: error: {manifest}: row 3 (line 4, copy.csv) has the same content (SHA-256) as row 2 (line 3, "
        f"{rows[1]['file']}): one test listed twice would count twice in the master curve and the fits (bands too narrow); "
        "remove one of the rows")
    assert not (tmp_path / "o" / "results.parquet").exists()


def test_files_with_their_own_column_names_and_units_are_read_as_direct_reads_one(tmp_path, capsys):
    """A black-box finding: the message said "map it with --column QUANTITY=NAME", which ``jointid campaign`` did not
    have. Files in mm and kN read with --column/--scale give the SI files' stiffness (to the rounding of the unit
    conversion: a few eps relative)."""
    manifest = small_campaign(tmp_path / "si", temperatures=(10.0, 20.0), amplitudes=(2e-5,), extra=False)
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o_si"), "--workers", "1", "--no-plots"]) == 0
    other = tmp_path / "mm"
    other.mkdir()
    shutil.copy(manifest, other / manifest.name)
    for row in manifest_rows(manifest):
        text = (manifest.parent / row["file"]).read_text().splitlines()
        lines = ["frequency_hz,time_s,disp_mm,force_kN"] + [
            f"{f},{t},{float(x) * 1e3!r},{float(y) * 1e-3!r}" for f, t, x, y in (line.split(",") for line in text[1:])]
        (other / row["file"]).write_text("\n".join(lines) + "\n")
    args = ["campaign", str(other / manifest.name), "--out", str(tmp_path / "o_mm"), "--workers", "1", "--no-plots"]
    assert main(args) == 1  # without the mapping every test fails, naming the column
    assert "missing column 'displacement_m'" in capsys.readouterr().err
    assert main(args + ["--column", "displacement=disp_mm", "--column", "force=force_kN", "--scale", "displacement=1e-3",
                        "--scale", "force=1e3"]) == 0
    si = pq.read_table(tmp_path / "o_si" / "results.parquet").to_pandas()
    mm = pq.read_table(tmp_path / "o_mm" / "results.parquet").to_pandas()
    np.testing.assert_allclose(mm["stiffness_real"], si["stiffness_real"], rtol=1e-12)
    np.testing.assert_allclose(mm["stiffness_imag"], si["stiffness_imag"], rtol=1e-12, atol=1e-12 * si["magnitude"].max())
