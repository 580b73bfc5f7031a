"""The direct method's honesty on real-world slips (black-box findings, 2026-11-28).

* A reversed phase sign (the force lagging the displacement on every line): the constant-modulus fit reported E with
  a 55 % residual, a campaign's Zener fit K0 +141 % "identified". Now named, no material is identified from it, and a
  campaign leaves such a test out of the master curve with the reason.
* A constant-modulus fit that misses the data by 39 % rms (a modulus rising over the band) was "identified".
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

from campaign_data import small_campaign
from jointid.cli.main import main
from jointid.methods.direct.material_fit import MATERIAL_MISFIT_RMS, fit_material
from jointid.methods.direct.phase_sign import reversed_phase
from jointid.physics.elastomer_joint import ElastomerJoint

REVERSED = ("the force lags the displacement (loss factor Im K21 / Re K21 < 0, median {}) on {} of {} lines, which a "
            "passive elastomer cannot do: a reversed phase sign convention (which channel leads, exp(+jwt) or exp(-jwt))? "
            "fix the export or the phase sign")


def _k21(E=10e6, eta=0.15, f=np.linspace(20.0, 400.0, 20)):
    joint = ElastomerJoint(E, eta, 1100.0)
    _, S, _ = joint._blocked(f, modulus=E * (1 + 1j * eta), density=1100.0)
    return f, -S[:, 2, 0]


def test_a_reversed_phase_is_named_and_no_material_is_identified():
    f, k = _k21()
    assert reversed_phase(k) is None
    said = REVERSED.format(f"{np.median(-k.imag / k.real):.2g}", 20, 20)
    assert reversed_phase(np.conj(k)) == said
    fit = fit_material(f, np.conj(k))
    E, eta, _ = fit.parameters
    assert E.status == eta.status == "not_identified"
    assert E.reason == eta.reason == said
    good = fit_material(f, k)
    assert good.parameters[0].status == "identified" and good.parameters[0].value == pytest.approx(10e6, rel=1e-6)


def test_the_transfer_stiffness_through_the_internal_mode_is_not_a_reversed_phase():
    """K21 of a joint with inertia turns through its internal mode (both parts change sign): its loss factor stays
    positive on most lines, and the fit identifies the material."""
    f, k = _k21(E=2e6, f=np.linspace(25.0, 1500.0, 60))
    assert np.mean(k.imag < 0) > 0.3  # the imaginary part alone would say "reversed"
    assert reversed_phase(k) is None


def test_a_constant_modulus_that_misses_the_data_is_not_identified():
    f = np.linspace(20.0, 400.0, 20)
    k = np.array([_k21(E=10e6 * (fi / 20.0) ** 0.5, f=np.array([fi]))[1][0] for fi in f])  # the modulus grows 4.5x
    fit = fit_material(f, k, signal_noise=0.007)
    assert fit.residual_rms > MATERIAL_MISFIT_RMS
    E, eta, _ = fit.parameters
    said = (f"the constant-modulus model does not fit these data (residual {fit.residual_rms:.0%}, noise ~0.7%): the "
            "modulus depends on frequency; use --zener")
    assert E.status == eta.status == "not_identified" and E.reason == eta.reason == said
    assert fit.warnings[0] == f"E and loss factor not identified: {said}; their values are not reported"  # one line
    assert fit_material(f, k).parameters[0].reason == said.replace(", noise ~0.7%", "")


ZENER = dict(E0=4e6, Einf=40e6, tau=3e-3, alpha=0.5)  # a modulus rising 10x around 1/(2 pi tau) = 53 Hz


def _zener_data(path, conjugate=False):
    """Step-sine blocks (0.5 % noise) of a joint whose modulus is a fractional Zener law, 1-300 Hz."""
    from jointid.measurement.stepsine import write_stepsine_csv
    from jointid.measurement.stepsine_synth import synthesize_stepsine
    from jointid.methods.direct.material_fit import zener_modulus

    z = ZENER
    joint = ElastomerJoint(z["E0"], 0.1, 1100.0, modulus=lambda f: zener_modulus(f, z["E0"], z["Einf"], z["tau"], z["alpha"]))
    freq = np.geomspace(1.0, 300.0, 12)
    stiffness = (lambda f: np.conj(joint.blocked_transfer_stiffness(f))) if conjugate else joint.blocked_transfer_stiffness
    write_stepsine_csv(path, synthesize_stepsine(freq, stiffness, 2.5e-5, force_harmonics={}, seed=1))


def test_the_cli_says_in_one_line_that_a_constant_modulus_does_not_fit_and_prints_the_zener_fit(tmp_path, capsys):
    """A black-box finding: a constant-modulus fit with a 39 % residual was reported as E = 222 +- 25 MPa `identified`;
    with --zener the good fit was printed nowhere."""
    _zener_data(tmp_path / "z.csv")
    assert main(["direct", str(tmp_path / "z.csv"), "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    cap = capsys.readouterr()
    assert ", E not identified, loss factor not identified, " in cap.out
    misfit = re.search(r"jointid direct: warning: E and loss factor not identified: the constant-modulus model does not "
                       r"fit these data \(residual (\d+)%, noise ~(\d\.\d)%\): the modulus depends on frequency; use "
                       r"--zener; their values are not reported\n", cap.err)
    assert misfit and int(misfit[1]) > 10 and 0.5 <= float(misfit[2]) <= 1.0, cap.err  # noise 0.5 % of the peak = 0.7 % rms
    assert cap.err.count("E and loss factor not identified") == 1 and "E not identified:" not in cap.err

    assert main(["direct", str(tmp_path / "z.csv"), "--out", str(tmp_path / "oz"), "--no-plots", "--zener"]) == 0
    cap = capsys.readouterr()
    line = re.search(r"jointid direct: zener: E0 = (\S+) \+- (\S+) MPa, Einf = (\S+) \+- (\S+) MPa, tau = (\S+) \+- "
                     r"(\S+) ms, alpha = (\S+) \+- (\S+), residual (\S+)%\n", cap.out)
    assert line, cap.out
    got = [float(v) for v in line.groups()]
    truth = (ZENER["E0"] / 1e6, ZENER["Einf"] / 1e6, ZENER["tau"] * 1e3, ZENER["alpha"])
    for (value, std), t in zip(zip(got[0:8:2], got[1:8:2]), truth):
        assert abs(value - t) <= 5 * std + 2e-3 * t  # 5 sigma, and the 4-digit print
    assert got[8] < 1.0  # the fit is good: under 1 % rms
    assert ("the modulus depends on frequency; the fractional Zener fit describes them (residual "
            in cap.err) and "use --zener" not in cap.err


def test_a_reversed_phase_identifies_no_zener_parameter(tmp_path, capsys):
    _zener_data(tmp_path / "r.csv", conjugate=True)
    assert main(["direct", str(tmp_path / "r.csv"), "--out", str(tmp_path / "o"), "--no-plots", "--zener"]) == 0
    cap = capsys.readouterr()
    assert "jointid direct: zener: E0 not identified, Einf not identified, tau not identified, alpha not identified" in cap.out
    said = re.escape(REVERSED).replace(r"\{\}", "(.+?)").replace("K21", r"E\*")
    assert re.search("jointid direct: warning: Zener E0, Einf, tau, alpha not identified: " + said + "\n", cap.err), cap.err
    assert "jointid direct: warning: E and loss factor not identified: the force lags the displacement" in cap.err


def _reverse_phase(path: Path) -> None:
    """Each block's force with its quadrature part (to the displacement) negated, ``f' = 2 c x - f`` with ``c =
    <f, x> / <x, x>`` the in-phase part: the force's phase to the displacement changes sign, as a reversed phase
    convention gives it."""
    rows = list(csv.reader(path.open(newline="")))
    head, body = rows[0], rows[1:]
    freq = np.array([float(r[0]) for r in body])
    x = np.array([float(r[2]) for r in body])
    f = np.array([float(r[3]) for r in body])
    for v in np.unique(freq):
        b = freq == v
        c = np.dot(f[b], x[b]) / np.dot(x[b], x[b])
        f[b] = 2.0 * c * x[b] - f[b]
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows([head] + [[r[0], r[1], r[2], repr(float(v))] for r, v in zip(body, f)])


def test_a_campaign_leaves_a_reversed_test_out_of_the_master_curve(tmp_path, capsys):
    manifest = small_campaign(tmp_path / "data", temperatures=(10.0, 20.0, 30.0, 40.0), amplitudes=(2e-5,), extra=False)
    _reverse_phase(tmp_path / "data" / "S1_T40C_A20um_P0N.csv")
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    err = capsys.readouterr().err
    assert "jointid campaign: note: specimen S1: row 4 (40 C): the force lags the displacement (loss factor" in err
    assert "fix the export or the phase sign; left out of the master curve" in err
    import json

    master = json.loads((out / "master_curve.json").read_text())["specimens"]["S1"]
    assert sorted(s["temperature_c"] for s in master["shift_factors"]) == [10.0, 20.0, 30.0]
    import pyarrow.parquet as pq

    tests = pq.read_table(out / "tests.parquet").to_pandas()  # the test is flagged in its own row, with the cause
    assert tests["warning"].isna().tolist() == [True, True, True, False]
    assert re.fullmatch(re.escape(REVERSED).replace(r"\{\}", "(.+?)") + "; left out of the master curve", tests["warning"][3])
    assert tests["log10_shift"].isna().tolist() == [False, False, False, True]


def _block(f=1.0, drift=0.0, cycles=12, spc=32, noise=0.005, seed=0):
    from jointid.measurement.stepsine import StepSineBlock

    rng = np.random.default_rng(seed)
    t = np.arange(cycles * spc) / (spc * f)
    x = 5e-5 * np.cos(2 * np.pi * f * t)
    F = 2 * 5e5 * 5e-5 * np.cos(2 * np.pi * f * t + 0.2) * (1 + drift * t)
    return StepSineBlock(f, t, x + noise * 5e-5 * rng.standard_normal(t.size), F + noise * 50 * rng.standard_normal(t.size))


@pytest.mark.parametrize("seed", range(4))
def test_a_stiffness_drifting_along_the_block_is_flagged_and_noise_alone_is_not(seed):
    """A black-box finding: a force drifting 0.5 %/s (a specimen heating) passed the settling check; K21, the block's
    time average, was 4 % off with nothing said. 0.5 %/s over 12 s: flagged; no drift, 0.5 % noise: not flagged."""
    from jointid.measurement.stepsine import process_block
    from jointid.measurement.stepsine_checks import drift_problem

    drifting = process_block(_block(drift=0.005, seed=seed))
    # (the settling check takes the first cycles, which differ most from the last ones, for the transient)
    assert re.fullmatch(r"block at 1 Hz: stiffness drifting \+[0-9.]+ % over the \d+ settled cycles \(the specimen heating "
                        r"or the machine drifting: not stationary\)", drifting["distortion"]), drifting["distortion"]
    assert process_block(_block(seed=seed))["distortion"] == ""
    assert drift_problem(np.full(12, 1e6 + 0j), 1.0) == ""  # exactly stationary


def test_a_campaign_names_the_lines_it_did_not_use_and_why(tmp_path, capsys):
    """A black-box finding: a clipped block was flagged (amplitude_ok 0) but why was nowhere in a campaign: not on the
    terminal, not in the tests table, not in the report."""
    import pyarrow.parquet as pq

    manifest = small_campaign(tmp_path / "data", temperatures=(10.0, 20.0), amplitudes=(2e-5,), extra=False)
    path = tmp_path / "data" / "S1_T20C_A20um_P0N.csv"
    rows = list(csv.reader(path.open(newline="")))
    first = [r for r in rows[1:] if r[0] == rows[1][0]]
    limit = 0.6 * max(abs(float(r[3])) for r in first)
    for r in first:  # the first block's force clipped at 60 % of its peak (a saturated load cell)
        r[3] = repr(float(np.clip(float(r[3]), -limit, limit)))
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    said = f"specimen S1: row 2 (20 C): lines not used: block at {float(rows[1][0]):g} Hz: force clipped (flat tops on "
    assert f"jointid campaign: note: {said}" in capsys.readouterr().err
    tests = pq.read_table(out / "tests.parquet").to_pandas()
    assert list(tests["lines_not_used"] == "") == [True, False]
    assert (out / "report.html").read_text().count("force clipped (flat tops on") >= 1


def test_tau_at_an_extrapolated_reference_carries_the_shift_laws_error():
    """A black-box finding: with the reference 65 K above the warmest test, tau came with a 0.14 % error against a
    0.6 % miss (z = -4.2): the law's extrapolated offset, common to every shift, was not carried into tau.

    Truth: a fractional Zener stiffness shifted by WLF (c1 9, c2 110 K at 20 C); curves at 0-30 C with 0.5 % complex
    noise; reference 100 C. A common shift error d (decades) scales tau by 10^d, so tau's relative std must be at
    least ln(10) times the moved anchor's shift std, and over 12 noise draws the z-scores of tau stay O(1)."""
    from jointid.measurement.campaign_synth import CampaignTruth
    from jointid.methods.direct.master_curve import TemperatureCurve, build_master_curve
    from jointid.methods.direct.shift_laws import wlf_log10_shift

    truth = CampaignTruth()
    f = np.geomspace(1.0, 100.0, 10)
    tau_100 = truth.tau_s * 10.0 ** wlf_log10_shift(100.0, truth.wlf_c1, truth.wlf_c2, truth.reference_temperature_c)
    z = []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        curves = [TemperatureCurve(t, f, truth.stiffness(f, t, 0.0) * (1 + 0.005 * (rng.standard_normal(f.size)
                                                                                  + 1j * rng.standard_normal(f.size))))
                  for t in (0.0, 10.0, 20.0, 30.0)]
        m = build_master_curve(curves, 100.0)
        assert m.preferred_shift_law == "wlf" and m.reference_temperature_c == 100.0
        tau = m.to_dict()["modulus"]["tau_s"]  # with the shift factors' error (MasterCurve.modulus_covariance)
        anchor_std = next(std for t, _, std in m.shift_factors if t == 30.0)  # the anchor: its shift is the offset
        assert tau["std"] >= math.log(10.0) * anchor_std * tau["value"] * (1 - 1e-6)
        z.append((tau["value"] - tau_100) / tau["std"])
    assert np.max(np.abs(z)) < 4.0 and np.sqrt(np.mean(np.square(z))) < 2.0, z


def test_a_temperature_typed_in_kelvin_is_flagged_in_its_row_and_the_shifts_name_their_reference(tmp_path):
    """A black-box finding: with 30 C typed as 303.15, the tables gave plain shift numbers relative to a temperature
    other than the requested reference, and nothing in the rows said so."""
    import pyarrow.parquet as pq

    manifest = small_campaign(tmp_path / "data", temperatures=(10.0, 20.0, 30.0, 40.0), amplitudes=(2e-5,), extra=False)
    rows = list(csv.reader(manifest.open(newline="")))
    col = rows[0].index("temperature_c")
    assert float(rows[3][col]) == 30.0
    rows[3][col] = "303.15"
    with manifest.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots",
                 "--reference-temperature", "30"]) == 0
    tests = pq.read_table(out / "tests.parquet").to_pandas().sort_values("temperature_c")
    assert tests["temperature_c"].tolist() == [10.0, 20.0, 40.0, 303.15]
    assert tests["shift_reference_c"].tolist() == [20.0] * 4  # 30 C not measured, no law: the nearest (first of 20, 40)
    s20, s40, s303 = tests["log10_shift"].tolist()[1:]
    assert s20 == 0.0 and s40 < s303 < 0  # 303.15 "C" is the 30 C curve: between 20 and 40 C on the frequency axis
    said = (f"the shift factor rises with the temperature from 40 to 303.15 deg C ({s40:+.3f} -> {s303:+.3f} decades): "
            "one of the two temperatures is wrong (typed in K?); no shift law was fitted")
    assert tests["warning"].isna().tolist() == [True, True, False, False]
    assert tests["warning"].tolist()[2:] == [said, said]
    results = pq.read_table(out / "results.parquet").to_pandas()
    assert (results["shift_reference_c"] == 20.0).all()


def test_a_shift_law_through_every_shift_factor_exactly_is_said_to_be_untested():
    """A black-box finding: an Arrhenius law through the one shift factor left (the others did not overlap) was
    'preferred' with nothing said; it missed the 5 C shift by 0.3 decades."""
    from jointid.measurement.campaign_synth import CampaignTruth
    from jointid.methods.direct.master_curve import TemperatureCurve, build_master_curve

    truth = CampaignTruth()
    f = np.geomspace(1.0, 100.0, 10)
    m = build_master_curve([TemperatureCurve(t, f, truth.stiffness(f, t, 0.0)) for t in (20.0, 30.0)], 20.0)
    assert m.preferred_shift_law == "arrhenius"
    assert ("shift law: Arrhenius has as many constants as shift factors (1) and passes through them exactly: the data "
            "do not test it; its shifts between and beyond the temperatures are the law's, not the data's") in m.findings
    m3 = build_master_curve([TemperatureCurve(t, f, truth.stiffness(f, t, 0.0)) for t in (10.0, 20.0, 30.0, 40.0)], 20.0)
    assert not any("passes through them exactly" in x for x in m3.findings)
