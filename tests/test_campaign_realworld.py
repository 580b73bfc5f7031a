"""``jointid campaign`` on files as labs write them: unit-suffixed column names, a column it cannot map, a master curve
that leaves temperatures out (black-box findings 2, 6, 7; small synthetic campaigns)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from campaign_data import manifest_rows, small_campaign
from jointid.measurement.stepsine_files import unit_column
from jointid.cli import campaign as campaign_cli
from jointid.cli.main import main


def _rewrite(path: Path, header: str, x_factor: float = 1.0, f_factor: float = 1.0) -> None:
    """Give a step-sine file the header ``header`` and its displacement and force columns times the factors."""
    lines = path.read_text().splitlines()
    body = [f"{f},{t},{float(x) * x_factor!r},{float(y) * f_factor!r}" for f, t, x, y in (ln.split(",") for ln in lines[1:])]
    path.write_text("\n".join([header, *body]) + "\n")


def _copy(manifest: Path, to: Path) -> Path:
    shutil.copytree(manifest.parent, to)
    return to / manifest.name


def test_unit_suffixes_have_exact_factors():
    assert unit_column("force", "force_kN") == 1e3 and unit_column("force", "force_mN") == 1e-3
    assert unit_column("displacement", "displacement_mm") == 1e-3 and unit_column("displacement", "Displacement [um]") == 1e-6
    assert unit_column("displacement", "displacement (\u00b5m)") == 1e-6 and unit_column("time", "time_ms") == 1e-3
    assert unit_column("force", "force (lbf)") == 4.4482216152605 and unit_column("frequency", "frequency_kHz") == 1e3
    # a unit it does not know, another quantity or no separator: not a guess
    assert unit_column("force", "force_MN") is None and unit_column("force", "forcekN") is None
    assert unit_column("force", "displacement_mm") is None and unit_column("force", "force_kgf") is None


def test_one_file_in_mm_and_kn_is_read_exactly_and_the_terminal_says_so(tmp_path, capsys):
    """A black-box finding: a file whose columns carry their units (displacement_mm, force_kN) failed, and the advice
    (--column) could not be followed in a campaign; a global --column would break the campaign's SI files anyway. The
    converted campaign gives the SI campaign's stiffness to the rounding of the conversion, and the counts agree."""
    manifest = small_campaign(tmp_path / "si", temperatures=(10.0, 20.0), amplitudes=(2e-5,), extra=False)
    args = ["--workers", "1", "--no-plots"]
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o_si"), *args]) == 0
    si_out = capsys.readouterr().out.strip().splitlines()
    assert re.fullmatch(r"campaign: 2 tests \(2 computed, 0 reused, 0 failed\), 1 master curve\(s\); wrote .*", si_out[-1])
    units = _copy(manifest, tmp_path / "units")
    rows = manifest_rows(units)
    _rewrite(units.parent / rows[0]["file"], "frequency_hz,time_s,displacement_mm,force_kN", 1e3, 1e-3)
    assert main(["campaign", str(units), "--out", str(tmp_path / "o_units"), *args]) == 0
    captured = capsys.readouterr()
    assert ("jointid campaign: note: specimen S1: row 1 (10 C): columns converted to SI: displacement_mm x 0.001 (to m), "
            "force_kN x 1000 (to N)") in captured.err.splitlines()
    out = captured.out.strip().splitlines()
    assert out[0].startswith("campaign: 2 tests, 0 stored by a previous run, 2 to compute")
    assert out[-1].startswith("campaign: 2 tests (2 computed, 0 reused, 0 failed), 1 master curve(s); wrote ")
    si = pq.read_table(tmp_path / "o_si" / "results.parquet").to_pandas()
    conv = pq.read_table(tmp_path / "o_units" / "results.parquet").to_pandas()
    np.testing.assert_allclose(conv["stiffness_real"], si["stiffness_real"], rtol=1e-12)
    np.testing.assert_allclose(conv["stiffness_imag"], si["stiffness_imag"], rtol=0, atol=1e-12 * si["magnitude"].max())
    tests = pq.read_table(tmp_path / "o_units" / "tests.parquet").to_pandas()
    assert list(tests["columns_converted"]) == ["displacement_mm x 0.001 (to m), force_kN x 1000 (to N)", ""]
    shifts = [s["log10_shift"] for s in json.loads((tmp_path / "o_units" / "master_curve.json").read_text())
              ["specimens"]["S1"]["shift_factors"]]
    assert len(shifts) == 2  # both temperatures superposed: the converted file is the same test


def test_a_column_it_cannot_map_names_the_campaign_options_which_then_work(tmp_path, capsys):
    """The failure names the column, the columns present and how to map it in a campaign; following it works."""
    manifest = small_campaign(tmp_path / "si", temperatures=(10.0, 20.0), amplitudes=(2e-5,), extra=False)
    data = _copy(manifest, tmp_path / "disp")
    rows = manifest_rows(data)
    for r in rows:
        _rewrite(data.parent / r["file"], "frequency_hz,time_s,disp,force_N,force_kN", 1e3)
        text = (data.parent / r["file"]).read_text().splitlines()  # force_kN: the force column again, in kN
        (data.parent / r["file"]).write_text("\n".join([text[0]] + [f"{ln},{float(ln.split(',')[3]) * 1e-3!r}"
                                                                     for ln in text[1:]]) + "\n")
    args = ["campaign", str(data), "--out", str(tmp_path / "o"), "--workers", "1", "--no-plots"]
    assert main(args) == 1
    failed = json.loads((tmp_path / "o" / "campaign.json").read_text())["failed"]
    path = (data.parent / rows[0]["file"]).resolve()
    assert failed[0]["reason"] == (
        f"{path}: missing column 'displacement_m' (columns present: frequency_hz, time_s, disp, force_N, force_kN); name it "
        "displacement_m or displacement_UNIT (a unit jointid converts: m, mm, um, \u00b5m, \u03bcm, nm, in), or map it for "
        "every file of the campaign with --column displacement=NAME --scale displacement=FACTOR_TO_SI")
    assert len(failed) == 2
    capsys.readouterr()
    assert main(args + ["--column", "displacement=disp", "--scale", "displacement=1e-3"]) == 1  # force: two candidates
    failed = json.loads((tmp_path / "o" / "campaign.json").read_text())["failed"]
    assert failed[0]["reason"].startswith(f"{path}: missing column 'force_n' (2 columns could be it: force_N, force_kN) "
                                          "(columns present: ")
    capsys.readouterr()
    assert main(args + ["--column", "displacement=disp", "--scale", "displacement=1e-3", "--column", "force=force_N"]) == 0
    si_args = ["campaign", str(manifest), "--out", str(tmp_path / "o_si"), "--workers", "1", "--no-plots"]
    assert main(si_args) == 0
    si = pq.read_table(tmp_path / "o_si" / "results.parquet").to_pandas()
    mapped = pq.read_table(tmp_path / "o" / "results.parquet").to_pandas()
    np.testing.assert_allclose(mapped["stiffness_real"], si["stiffness_real"], rtol=1e-12)


def test_a_master_curve_that_leaves_temperatures_out_says_so_in_its_last_line_and_notes(tmp_path, capsys, monkeypatch):
    """A black-box finding: the terminal said "1 master curve(s)", exit 0, when the curve had left temperatures out;
    every master-curve finding is a note (prefixed by the specimen), the first MAX_PRINTED_NOTES of them."""
    manifest = small_campaign(tmp_path / "data", temperatures=(-40.0, 10.0, 20.0, 30.0), amplitudes=(2e-5,), extra=False)
    monkeypatch.setattr(campaign_cli, "MAX_PRINTED_NOTES", 1)
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    captured = capsys.readouterr()
    findings = json.loads((out / "master_curve.json").read_text())["findings"]
    assert len(findings) >= 2 and findings[0].startswith("specimen S1: master curve: -40 deg C: its curve does not overlap")
    assert captured.err.strip().splitlines() == [
        f"jointid campaign: note: {findings[0]}",
        f"jointid campaign: note: ... and {len(findings) - 1} more in {out}/campaign.json (findings) and report.html"]
    assert json.loads((out / "campaign.json").read_text())["findings"] == findings  # every one, the terminal's text
    assert captured.out.strip().splitlines()[-1].startswith(
        "campaign: 4 tests (4 computed, 0 reused, 0 failed), 1 master curve(s) (specimen S1: 3 of 4 temperatures "
        "superposed; see the notes); wrote ")
