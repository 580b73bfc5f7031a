"""``jointid frf``: virtual-hammer hits on disk -> the FRFs ``experiment()`` computes; rejected hits; bad input."""

from __future__ import annotations

import csv
import tomllib

import numpy as np
import pytest

from jointid.benchmark import benchmark_study_path
from jointid.cli.main import main
from jointid.dofs import Dof
from jointid.errors import DataError
from jointid.hits import frf_from_hits
from jointid.measurement.impact_files import read_impact_uff, write_impact_csv, write_impact_npz, write_impact_uff
from jointid.io.frf_files import read_frf
from jointid.io.uff import read_uff_frf, write_uff_frf
from jointid.measurement.impact import ImpactOptions, ImpactRecord, check_hits, estimate_frfs, rejected_hits_table
from jointid.measurement.virtual_hammer import HammerSettings, simulate_hits
from jointid.pipeline import experiment, virtual_hits
from jointid.study import parse_study

SEED = 3


def _small_study():
    """The benchmark with a short, coarse test (3 x 2 coordinates, 3 hits of 0.5 s at 4096 Hz): fast."""
    d = tomllib.loads(benchmark_study_path().read_text())
    d["experiment"].update(sample_rate=4096.0, duration=0.5, averages=3, pulse_duration=0.001)
    d["measurement"].update(observed=[1, 9, 15], excited=[3, 9])
    d["accelerometers"].update(nodes=[1, 9, 15])
    return parse_study(d, "small test study")


@pytest.fixture(scope="module")
def virtual():
    """The study, ``experiment()``'s result and the very hits it processed (same seed, same draws)."""
    study = _small_study()
    ex = experiment(study, seed=SEED)
    records, _ = virtual_hits(study, seed=SEED)
    return study, ex, records


def _window_flags(study) -> list[str]:
    """The command-line form of the ImpactOptions that ``experiment()`` uses."""
    _, o = virtual_hits(study, seed=SEED)
    ms = 1e3
    return [
        "--force-window-ms", f"{ms * o.force_window_s!r}", "--pretrigger-ms", f"{ms * o.force_pretrigger_s!r}",
        "--force-taper-ms", f"{ms * o.force_taper_s!r}", "--exp-tau-ms", f"{ms * (o.exp_tau_s or 0.0)!r}",
        "--band-hz", f"{o.band_hz[0]!r}", f"{o.band_hz[1]!r}",
    ]


def _write(fmt: str, records, tmp_path) -> list[str]:
    if fmt == "npz":
        return [str(write_impact_npz(tmp_path / f"hits_{r.reference}.npz", r)) for r in records]
    if fmt == "csv":
        return [str(write_impact_csv(tmp_path / "hits.csv", records))]
    return [str(write_impact_uff(tmp_path / "hits.uff", records))]


@pytest.mark.parametrize("fmt", ["npz", "csv", "uff"])
def test_frf_reproduces_experiment_frfs_from_files(fmt, virtual, tmp_path, capsys):
    study, ex, records = virtual
    files = _write(fmt, records, tmp_path)
    out = tmp_path / "out"
    assert main(["frf", *files, "--out", str(out), "--n-nodes", "19", *_window_flags(study)]) == 0
    printed = capsys.readouterr().out
    assert "excited node 3w: 3 average(s) (3 hit(s), 0 rejected)" in printed
    assert "excited node 9w: 3 average(s) (3 hit(s), 0 rejected)" in printed
    frf, coh = read_uff_frf(out / "frf.uff", n_nodes=19, coherence=True)
    assert read_frf(out / "frf.uff", n_nodes=19).kind == "accelerance"
    ref = ex.frf
    assert frf.responses == ref.responses and frf.references == ref.references
    np.testing.assert_allclose(frf.frequency.hz, ref.frequency.hz, rtol=1e-12)
    rel = np.abs(frf.data - ref.data) / np.abs(ref.data)
    # npz and CSV (repr floats) carry the samples exactly: measured 4.9e-12 (the UFF58 FRF file's 12 digits);
    # UFF58 time records keep 12 digits per sample: measured 4.5e-10 at the deepest anti-resonance
    assert rel.max() < {"npz": 1e-10, "csv": 1e-10, "uff": 5e-9}[fmt]
    # the coherence records are in the same file, aligned with the FRFs
    assert coh is not None and coh.shape == frf.shape
    np.testing.assert_allclose(coh, ex.coherence, atol=1e-9)
    assert 0.5 < np.median(coh) <= 1.0
    rows = list(csv.reader((out / "rejected_hits.csv").open()))
    assert rows == [["excited_dof", "hit", "check", "channel", "value", "threshold", "unit", "time_s", "reason"]]
    assert (out / "frf.png").stat().st_size > 10_000


def test_double_hit_is_rejected_and_listed(virtual, tmp_path, capsys):
    study, ex, records = virtual
    rec = records[1]  # excited node 9w
    assert rec.reference == Dof(9, "w")
    force = rec.force.copy()
    fs = rec.sample_rate_hz
    k = int(0.1 * fs)  # a second pulse at 0.1 s: 4 samples, 40% of the first peak
    force[1, k:k + 4] += 0.4 * np.abs(force[1]).max() * np.sin(np.pi * (np.arange(4) + 0.5) / 4)
    bad = ImpactRecord(force, rec.responses, fs, rec.response_dofs, rec.reference)
    files = [str(write_impact_npz(tmp_path / "n3.npz", records[0])), str(write_impact_npz(tmp_path / "n9.npz", bad))]
    out = tmp_path / "out"
    assert main(["frf", *files, "--out", str(out), "--no-plots", *_window_flags(study)]) == 0
    printed = capsys.readouterr().out
    assert "excited node 9w: 2 average(s) (3 hit(s), 1 rejected)" in printed
    assert "rejected: excited node 9w, hit 1: double hit: a second force pulse at t = 0.1" in printed
    with (out / "rejected_hits.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 1
    row = rows[0]
    assert (row["excited_dof"], row["hit"], row["check"], row["channel"], row["unit"]) == (
        "9w", "1", "double_hit", "force", "fraction of peak")
    assert float(row["threshold"]) == 0.1
    peak2 = np.abs(force[1, k:k + 4]).max() / np.abs(force[1]).max()
    assert float(row["value"]) == pytest.approx(peak2, rel=1e-12) and 0.3 < peak2 < 0.5
    assert float(row["time_s"]) == pytest.approx((k + int(np.argmax(np.abs(force[1, k:k + 4])))) / fs, abs=1e-12)
    assert row["reason"].startswith("double hit: a second force pulse at t = 0.1")
    assert not (out / "frf.png").exists()
    # the 9w column is the average of hits 0 and 2 only, the 3w column is untouched
    frf = read_frf(out / "frf.uff")
    _, opts = virtual_hits(study, seed=SEED)
    kept = ImpactRecord(rec.force[[0, 2]], rec.responses[[0, 2]], fs, rec.response_dofs, rec.reference)
    expect = estimate_frfs([records[0], kept], opts).h1
    assert np.abs(frf.data - expect).max() / np.abs(expect).max() < 1e-9
    assert np.abs(frf.data[:, :, 1] - ex.frf.data[:, :, 1]).max() / np.abs(ex.frf.data[:, :, 1]).max() > 1e-4


def test_overload_rows_give_value_and_threshold(virtual):
    _, _, records = virtual
    rec = records[0]
    peaks = np.abs(rec.force).max(axis=1)
    clip = float(np.sort(peaks)[1]) / 0.99  # the largest hit and the middle one reach 99% of it
    bad = check_hits(rec, ImpactOptions(force_clip_n=clip))
    table = rejected_hits_table(bad)
    over = sorted(np.flatnonzero(peaks >= 0.99 * clip))
    assert table["hit"] == over and set(table["check"]) == {"overload"} and set(table["unit"]) == {"N"}
    np.testing.assert_allclose(table["value"], peaks[over], rtol=0)
    np.testing.assert_allclose(table["threshold"], 0.99 * clip, rtol=1e-15)


def test_h2_and_kind_options(virtual, tmp_path, capsys):
    study, ex, records = virtual
    files = _write("npz", records, tmp_path)
    out = tmp_path / "out"
    assert main(["frf", *files, "--out", str(out), "--no-plots", "--estimator", "h2", "--kind", "receptance",
                 *_window_flags(study)]) == 0
    assert "H2 accelerance" in capsys.readouterr().out
    frf = read_frf(out / "frf.uff")
    assert frf.kind == "receptance"
    h2 = ex.impact.to_frf("h2").to("receptance").data
    assert np.abs(frf.data - h2).max() / np.abs(h2).max() < 1e-9
    assert np.abs(frf.data - ex.frf.to("receptance").data).max() / np.abs(h2).max() > 1e-6  # H2 is not H1


def test_api_default_band_skips_0_hz(virtual):
    _, _, records = virtual
    res = frf_from_hits(records)
    r0 = records[0]
    assert res.frf.frequency.hz[0] == r0.sample_rate_hz / r0.n_samples
    assert res.frf.frequency.hz[-1] == r0.sample_rate_hz / 2


def test_uff_time_records_without_reference(virtual, tmp_path):
    import pyuff

    _, _, records = virtual
    short = [ImpactRecord(r.force[:2, :512], r.responses[:2, :, :512], r.sample_rate_hz, r.response_dofs, r.reference)
             for r in records]
    sets = pyuff.UFF(str(write_impact_uff(tmp_path / "one.uff", short[1]))).read_sets()
    for s in sets:  # as acquisition systems write time records: no reference
        s["ref_node"], s["ref_dir"] = 0, 0
    p = tmp_path / "noref.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    (back,) = read_impact_uff(p)
    assert back.reference == Dof(9, "w") and back.response_dofs == short[1].response_dofs
    assert back.sample_rate_hz == 4096.0  # the 6-digit UFF increment 2.44141e-04 s, snapped to the integer rate
    np.testing.assert_allclose(back.force, short[1].force, rtol=1e-10, atol=0)
    # two excited nodes sharing load case numbers cannot be told apart without a reference
    sets = pyuff.UFF(str(write_impact_uff(tmp_path / "two.uff", short))).read_sets()
    for s in sets:
        s["ref_node"], s["ref_dir"] = 0, 0
    q = tmp_path / "ambiguous.uff"
    pyuff.UFF(str(q)).write_sets(sets, mode="add")
    with pytest.raises(DataError, match=r"load case 0: time records without a reference \(direction 0\) and force "
                                        r"records at \['3w', '9w'\]"):
        read_impact_uff(q)


def _err(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.strip()


def test_bad_input_exits_2_with_one_line(virtual, tmp_path, capsys):
    study, ex, records = virtual
    out = tmp_path / "out"
    missing = tmp_path / "nope.npz"
    assert main(["frf", str(missing), "--out", str(out)]) == 2
    assert _err(capsys) == f"jointid frf: error: hits file {missing} does not exist"
    wrong = tmp_path / "wrong.csv"
    wrong.write_text("frequency_hz,response,reference,real,imag\n10,1w,3w,1.0,0.0\n")
    assert main(["frf", str(wrong), "--out", str(out)]) == 2
    assert _err(capsys).startswith(f"jointid frf: error: {wrong}: header must be 'excited_node,hit,time_s,force_n,")
    frf_file = write_uff_frf(tmp_path / "an_frf.uff", ex.frf)
    assert main(["frf", str(frf_file), "--out", str(out)]) == 2
    assert _err(capsys) == f"jointid frf: error: {frf_file}: no UFF58 time-response records (function type 1)"
    header_only = tmp_path / "header_only.csv"
    header_only.write_text(wrong.read_text().splitlines()[0].replace("frequency_hz,response,reference,real,imag",
                                                                      "excited_node,hit,time_s,force_n,1w") + "\n")
    assert main(["frf", str(header_only), "--out", str(out)]) == 2
    assert _err(capsys) == (f"jointid frf: error: {header_only}: no hit in the file (no time samples, or none at the given "
                            "points/axis); give each excited node's hits as time samples of the force and the responses")
    txt = tmp_path / "hits.txt"
    txt.write_text("x")
    assert main(["frf", str(txt), "--out", str(out)]) == 2
    assert "cannot tell the layout of hits file" in _err(capsys)
    files = _write("npz", records, tmp_path)
    assert main(["frf", *files, "--out", str(out), "--n-nodes", "8"]) == 2
    assert _err(capsys) == (f"jointid frf: error: {files[0]}: excited node 3w: DOF(s) 9w, 15w outside the beam "
                            "(nodes 1..8); check the node numbers or --n-nodes")
    assert main(["frf", *files, "--out", str(out), "--exp-tau-ms", "-5"]) == 2
    assert _err(capsys) == "jointid frf: error: --exp-tau-ms: expected a number > 0 (ms), got -5"
    assert main(["frf", files[0], files[0], "--out", str(out)]) == 2
    assert "excited node 3w is also in" in _err(capsys)
    assert not out.exists()  # nothing written on error
