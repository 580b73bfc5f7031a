"""``jointid direct``: outputs, per-joint values, flags; bad input writes nothing and exits non-zero."""

import csv
import json

import numpy as np
import pytest

import jointid.cli.main as cli_main
from jointid.physics.elastomer_joint import MATERIALS, ElastomerJoint
from jointid.measurement.stepsine import write_stepsine_csv
from jointid.measurement.stepsine_synth import synthesize_stepsine

F = np.arange(25.0, 601.0, 25.0)
AMP = 2.5e-5


@pytest.fixture
def main(monkeypatch):
    """The real ``jointid`` entry point, with ``direct`` registered if the lead has not yet done so."""
    if "direct" not in cli_main.COMMANDS:
        monkeypatch.setattr(cli_main, "COMMANDS", tuple(cli_main.COMMANDS) + ("direct",))
    return cli_main.main


def _data(path, material="B", ratio=None, seed=0):
    joint = ElastomerJoint.from_material(material)
    ratio = np.where(F >= 550, 0.9, 1.0) if ratio is None else ratio
    blocks = synthesize_stepsine(F, joint.blocked_transfer_stiffness, AMP, amplitude_ratio=ratio, seed=seed,
                                 displacement_noise=0.01, force_noise=0.01)
    write_stepsine_csv(path, blocks)
    return joint


def _strict_load(path):
    """Parse with a strict JSON parser: NaN/Infinity are errors."""
    def refuse(name):
        raise ValueError(f"{path}: non-standard JSON constant {name}")

    return json.loads(path.read_text(), parse_constant=refuse)


def _read(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_direct_writes_stiffness_fit_and_plot(tmp_path, main, capsys):
    joint = _data(tmp_path / "data.csv")
    out = tmp_path / "out"
    assert main(["direct", str(tmp_path / "data.csv"), "--out", str(out), "--amplitude", str(AMP)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".jointid-manifest.json", "direct_fit.json", "direct_stiffness.csv", "direct_stiffness.png", "report.html"]
    rows = _read(out / "direct_stiffness.csv")
    assert list(rows[0]) == ["frequency_hz", "stiffness_real", "stiffness_imag", "magnitude", "loss_factor", "amplitude_ratio", "amplitude_ok"]
    f = np.array([float(r["frequency_hz"]) for r in rows])
    k = np.array([float(r["stiffness_real"]) + 1j * float(r["stiffness_imag"]) for r in rows])
    truth = joint.blocked_transfer_stiffness(f)  # per joint: the CLI divided by 2
    assert np.max(np.abs(np.abs(k) / np.abs(truth) - 1)) < 0.005
    assert [r["amplitude_ok"] for r in rows] == ["0" if x >= 550 else "1" for x in f]
    fit = _strict_load(out / "direct_fit.json")
    m = MATERIALS["B"]
    par = fit["fit"]["parameters"]
    assert all(p["status"] == "identified" for p in par.values()) and fit["warnings"] == []
    assert abs(par["elastic_modulus_pa"]["value"] / m.E - 1) < 0.01
    assert abs(par["loss_factor"]["value"] / m.eta - 1) < 0.01
    assert abs(par["density_kg_m3"]["value"] / m.rho - 1) < 0.01
    assert 0 < par["density_kg_m3"]["std_error"] < 0.01 * m.rho
    assert fit["flagged_lines_hz"] == [550.0, 575.0, 600.0]
    assert fit["static"]["elastic_modulus_pa"] == pytest.approx(2 * fit["static"]["shear_modulus_pa"] * 1.49)
    assert (out / "direct_stiffness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    cap = capsys.readouterr()
    assert "E = " in cap.out and "density = " in cap.out and cap.err == ""


def test_single_joint_median_amplitude_and_mapping(tmp_path, main):
    joint = _data(tmp_path / "data.csv", material="A", ratio=np.ones_like(F))
    rows = _read(tmp_path / "data.csv")
    with open(tmp_path / "mm.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["f", "t", "x_mm", "F_N"])
        for r in rows:
            w.writerow([r["frequency_hz"], r["time_s"], float(r["displacement_m"]) * 1e3, r["force_n"]])
    out = tmp_path / "o"
    argv = ["direct", str(tmp_path / "mm.csv"), "--out", str(out), "--parallel-joints", "1", "--no-plots",
            "--column", "frequency=f", "--column", "time=t", "--column", "displacement=x_mm", "--column", "force=F_N",
            "--scale", "displacement=1e-3"]
    assert main(argv) == 0
    assert not (out / "direct_stiffness.png").exists()
    rows = _read(out / "direct_stiffness.csv")
    k = np.array([float(r["magnitude"]) for r in rows])
    assert np.max(np.abs(k / (2 * np.abs(joint.blocked_transfer_stiffness(F))) - 1)) < 0.005
    fit = _strict_load(out / "direct_fit.json")
    assert fit["commanded_amplitude_source"] == "median achieved amplitude"
    assert all(r["amplitude_ok"] == "1" for r in rows)


def _block_rows(f, cycles=5.3, spc=40):
    n = int(cycles * spc)
    t = np.arange(n) / (spc * f)
    return [[f, a, 1e-5 * np.cos(2 * np.pi * f * a), 2.0 * np.cos(2 * np.pi * f * a + 0.1)] for a in t]


@pytest.mark.parametrize(
    "case, message",
    [
        ("missing_column", "missing column 'force_n'"),
        ("short", "block at 100 Hz: only 1.5 cycles"),
        ("truncated", "the file ends inside the block at 100 Hz (1.47 cycles, every other block 5.27 or more): the file is "
                      "cut short; copy the whole file again"),
        ("cut_line", "line 637, the last one, is incomplete (2 of 4 values): the file is cut short; copy the whole file again"),
        ("zero", "block at 100 Hz: the displacement is zero"),
        ("nan", "block at 100 Hz: displacement_m has 1 NaN"),
        ("unsorted", "block at 100 Hz: time is not strictly increasing"),
    ],
)
def test_bad_input_one_line_nonzero_exit_no_output(tmp_path, main, capsys, case, message):
    good = _block_rows(50.0) + _block_rows(75.0)
    bad = _block_rows(100.0)
    header = ["frequency_hz", "time_s", "displacement_m", "force_n"]
    if case == "missing_column":
        header = header[:3]
        bad = [r[:3] for r in bad]
        good = [r[:3] for r in good]
    elif case == "short":  # a short block first: the block's own check (last in the file it reads as a truncation)
        good, bad = bad[:60], good
    elif case == "truncated":
        bad = bad[:60]
    elif case == "cut_line":
        bad[-1] = bad[-1][:2]
    elif case == "zero":
        bad = [[r[0], r[1], 0.0, r[3]] for r in bad]
    elif case == "nan":
        bad[7][2] = "nan"
    elif case == "unsorted":
        bad[7], bad[8] = bad[8], bad[7]
    path = tmp_path / "bad.csv"
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(str(v) for v in r) for r in good + bad) + "\n")
    out = tmp_path / "out"
    out.mkdir()
    code = main(["direct", str(path), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0
    assert len(err) == 1 and message in err[0]
    assert list(out.iterdir()) == []  # no output, no temporary file


def test_too_few_lines_at_amplitude(tmp_path, main, capsys):
    _data(tmp_path / "data.csv", ratio=np.ones_like(F))
    out = tmp_path / "out"
    assert main(["direct", str(tmp_path / "data.csv"), "--out", str(out), "--amplitude", "1e-4"]) != 0
    assert "reached the commanded amplitude" in capsys.readouterr().err
    assert not out.exists()


def test_low_band_density_is_held_and_never_printed(tmp_path, main, capsys):
    # Material A (internal mode ~1.2 kHz) tested at 10-200 Hz only: the density is not identified
    f = np.arange(10.0, 201.0, 10.0)
    joint = ElastomerJoint.from_material("A")
    write_stepsine_csv(tmp_path / "low.csv", synthesize_stepsine(f, joint.blocked_transfer_stiffness, AMP, seed=3,
                                                                 displacement_noise=0.01, force_noise=0.01))
    out = tmp_path / "out"
    assert main(["direct", str(tmp_path / "low.csv"), "--out", str(out), "--no-plots"]) == 0
    cap = capsys.readouterr()
    assert "density held at 1100 kg/m^3 (held at default, not identified)" in cap.out
    assert "density = " not in cap.out
    err = cap.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jointid direct: warning: density held at default: inertia changes K21 by only")
    d = _strict_load(out / "direct_fit.json")
    rho = d["fit"]["parameters"]["density_kg_m3"]
    assert rho["value"] is None and rho["status"] == "held_at_default" and rho["held_value"] == 1100.0
    assert d["warnings"] == [err[0].removeprefix("jointid direct: warning: ")]
    assert d["complex_modulus"]["density_used_kg_m3"] == 1100.0
    assert abs(d["fit"]["parameters"]["elastic_modulus_pa"]["value"] / 15e6 - 1) < 0.005
    # the figure's legend marks the density as held; the lower panel is the loss factor (Re K21 > 0)
    from jointid.methods.direct.material_fit import fit_material
    from jointid.measurement.stepsine import process_stepsine, read_stepsine_csv
    from jointid.plots.direct import plot_direct_stiffness

    res = process_stepsine(read_stepsine_csv(tmp_path / "low.csv"))
    fig = plot_direct_stiffness(res, fit_material(res.frequency_hz, res.stiffness))
    ax_m, ax_e = fig.axes
    assert ax_e.get_ylabel() == "loss factor (-)"
    labels = [ln.get_label() for ln in ax_m.get_lines()]
    assert labels[-1] == "FE joint model: E = 15 MPa, eta = 0.0999, rho held at 1100 kg/m^3"
    assert ax_m.get_lines()[-1].get_zorder() > ax_m.get_lines()[0].get_zorder()


def test_example_data_round_trip_through_the_internal_mode(tmp_path, main, capsys):
    ex = tmp_path / "example.csv"
    assert main(["direct", "--example", str(ex)]) == 0
    assert f"wrote example step-sine data to {ex}" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["direct", str(ex), "--out", str(out), "--zener", "--no-plots"]) == 0
    cap = capsys.readouterr()
    d = _strict_load(out / "direct_fit.json")
    par = d["fit"]["parameters"]
    m = MATERIALS["B"]
    for key, true in (("elastic_modulus_pa", m.E), ("loss_factor", m.eta), ("density_kg_m3", m.rho)):
        assert par[key]["status"] == "identified"
        assert abs(par[key]["value"] / true - 1) < 0.005
    # the example's modulus is constant: a Zener fit has no relaxation to see and says so
    assert d["zener"]["parameters"]["tau_s"]["status"] == "at_bound"
    assert d["zener"]["parameters"]["tau_s"]["value"] is None
    assert "jointid direct: warning: Zener tau at bound: tau ran to 0" in cap.err
    # past the internal mode (~925 Hz) the lower panel shows the phase, not a loss factor running to infinity
    from jointid.measurement.stepsine import process_stepsine
    from jointid.measurement.stepsine_synth import example_stepsine
    from jointid.plots.direct import plot_direct_stiffness

    fig = plot_direct_stiffness(process_stepsine(example_stepsine()))
    phase = fig.axes[1].get_lines()[0].get_ydata()
    assert fig.axes[1].get_ylabel() == "phase of K21 (deg)"
    assert phase[0] == pytest.approx(np.degrees(np.arctan(0.15)), abs=1.0) and -200 < phase[-1] < -150


@pytest.mark.parametrize("argv, message", [
    (["direct", "--out", "o"], "give DATA.csv and --out DIR"),
    (["direct", "data.csv"], "give DATA.csv and --out DIR"),
    (["direct", "data.csv", "--example", "x.csv"], "--example OUT.csv writes example data only"),
    (["direct", "data.csv", "--out", "o", "--density", "-3"], "--density must be the elastomer density in kg/m^3"),
])
def test_argument_errors(tmp_path, main, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert list(tmp_path.iterdir()) == []


def test_summary_json_is_strict_with_non_finite_values_as_null():
    from jointid.io.json_files import json_text

    text = json_text({"a": float("inf"), "b": [1.0, float("nan")], "c": {"d": np.float64(2.0)}})

    def refuse(name):
        raise ValueError(name)

    d = json.loads(text, parse_constant=refuse)
    assert d["a"] is None and d["b"] == [1.0, None] and d["c"] == {"d": 2.0}
    assert d["non_finite_values"] == "2 value(s) were NaN or infinite and are written as null: a, b[1]"


def test_example_twice_replaces_its_own_file_and_refuses_a_users(tmp_path, main, capsys, monkeypatch):
    """--example goes through the output manifest: a re-run replaces the file jointid wrote, never a user's file."""
    monkeypatch.chdir(tmp_path)
    assert main(["direct", "--example", "ex.csv"]) == 0
    first = (tmp_path / "ex.csv").read_bytes()
    assert main(["direct", "--example", "ex.csv"]) == 0  # issue 24: the second run said jointid did not write it
    assert (tmp_path / "ex.csv").read_bytes() == first
    assert main(["direct", "--example", "other.csv"]) == 0  # another example file is another set: both stay
    assert sorted(p.name for p in tmp_path.iterdir()) == [".jointid-manifest.json", "ex.csv", "other.csv"]
    capsys.readouterr()
    (tmp_path / "mine.csv").write_text("a user's data\n")
    (tmp_path / "ex.csv").write_text("edited by the user\n")
    for name, why in (("mine.csv", "exists and was not written by jointid"), ("ex.csv", "was changed after jointid wrote it")):
        assert main(["direct", "--example", name]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [f"jointid direct: error: {name} {why}; move it or give --example another file name"]
    assert (tmp_path / "mine.csv").read_text() == "a user's data\n" and (tmp_path / "ex.csv").read_text() == "edited by the user\n"


def test_clipped_blocks_are_named_on_the_terminal_and_in_the_summary(tmp_path, main, capsys):
    """Every 3rd block's force clipped at 30 % of its peak: one line says how many lines were not used and why."""
    from dataclasses import replace

    from jointid.measurement.stepsine import write_stepsine_csv
    from jointid.measurement.stepsine_synth import example_stepsine

    blocks = list(example_stepsine())[:24]  # 25-600 Hz
    for i in range(0, len(blocks), 3):
        F = blocks[i].force_n
        blocks[i] = replace(blocks[i], force_n=np.clip(F, -0.3 * np.abs(F).max(), 0.3 * np.abs(F).max()))
    write_stepsine_csv(tmp_path / "clipped.csv", blocks)
    assert main(["direct", str(tmp_path / "clipped.csv"), "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    out = capsys.readouterr().out
    assert "jointid direct: 8 of 24 lines not used: clipped or distorted (block at 25 Hz: force clipped" in out
    summary = json.loads((tmp_path / "out" / "direct_fit.json").read_text())
    assert summary["distorted_lines_hz"] == [25.0 + 75.0 * k for k in range(8)]
