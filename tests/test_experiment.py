"""Virtual roving-hammer experiment: H1 against exact FRFs, accelerometer loading, identification, CLI."""

import csv
import tomllib

import numpy as np
import pytest

from jointid.benchmark import benchmark_study_path
from jointid.cli.main import main
from jointid.physics.modes import natural_modes
from jointid.physics.synthesis import synthesize_frf
from jointid.pipeline import constrained_model, experiment, identify
from jointid.study import parse_study


def _study(**sections):
    d = tomllib.loads(benchmark_study_path().read_text())
    for key, value in sections.items():
        d[key] = {**d.get(key, {}), **value}
    return parse_study(d, "test study")


@pytest.fixture(scope="module")
def exp_modelled():
    """The benchmark's hammer test (seed 0) with the accelerometers in Do (the benchmark's own setting)."""
    study = _study(identification={"model_accelerometers": True})
    return study, experiment(study, seed=0)


@pytest.fixture(scope="module")
def identified_modelled(exp_modelled):
    """The benchmark study's identification from that test's FRFs, as read back from its file (with coherence);
    shared by the two tests below that need exactly this identification."""
    import dataclasses

    study, ex = exp_modelled
    frf = dataclasses.replace(ex.frf, coherence=ex.coherence)
    return frf, identify(study, frf)


def test_h1_matches_exact_frf_within_the_noise(exp_modelled):
    study, ex = exp_modelled
    exact = synthesize_frf(constrained_model(study), ex.frf.frequency, study.measurement.observed_dofs,
                           study.measurement.excited_dofs, kind="accelerance").data
    rel = np.abs(ex.frf.data - exact) / np.abs(exact)
    coh = ex.coherence
    good = coh > 0.95
    assert good.mean() > 0.8
    # random error of H1 magnitude for n averages (Bendat & Piersol): sqrt((1 - g2) / (2 n g2))
    n = min(ex.impact.n_averages)
    sigma = np.sqrt((1 - coh[good]) / (2 * n * coh[good]))
    assert np.median(rel[good]) < 0.015  # measured 0.77%
    assert np.mean(rel[good] <= 4 * sigma) > 0.95  # measured 98.5%
    # noise-free, the same path is exact to the leakage of the windowed record
    clean = experiment(_study(experiment={"force_noise": 0.0, "response_noise": 0.0}))
    rel_clean = np.abs(clean.frf.data - exact) / np.abs(exact)
    assert np.median(rel_clean) < 2e-3


def test_one_versus_seven_accelerometers_shift_resonances_and_antiresonances():
    study = _study()
    beam = study.beam.structure()
    acc = study.accelerometers
    one = beam.with_masses([3], acc.mass, acc.rotary_inertia)
    seven = beam.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
    f1 = natural_modes(one).frequencies_hz[2:6]
    f7 = natural_modes(seven).frequencies_hz[2:6]
    assert np.all(f7 < f1) and np.all((f1 - f7) / f1 > 0.02)  # 35 g on a 398 g beam: 3-6% lower
    grid = study.grid
    h1 = np.abs(synthesize_frf(one, grid, ["3w"], ["3w"]).data[:, 0, 0])
    h7 = np.abs(synthesize_frf(seven, grid, ["3w"], ["3w"]).data[:, 0, 0])

    def antiresonances(h):
        i = np.where((h[1:-1] < h[:-2]) & (h[1:-1] < h[2:]))[0] + 1
        return grid.hz[i]

    a1, a7 = antiresonances(h1), antiresonances(h7)
    assert len(a1) == len(a7) >= 3 and np.all(a7 < a1)


def test_identification_better_with_accelerometers_modelled(exp_modelled, identified_modelled):
    study, ex = exp_modelled
    frf, with_ = identified_modelled
    band = ex.frf.frequency.mask(100, 1000)
    t = ex.truth[:, 0, 0]
    without = identify(_study(identification={"model_accelerometers": False}), frf)
    e_with = np.median(np.abs(with_.term("w", "w") - t)[band] / np.abs(t[band]))
    e_without = np.median(np.abs(without.term("w", "w") - t)[band] / np.abs(t[band]))
    # measured (seeds 0, 1, 2): 0.034 %, 0.058 %, 0.73 % with the masses in Do; 110 %, 120 %, 80 % without
    assert e_with < 0.05
    assert e_without > 3 * e_with


def test_too_short_pulse_is_an_error():
    from jointid.errors import DataError

    with pytest.raises(DataError, match="the 0.5 ms hammer pulse spans 2.0 samples at 4096 Hz; a force window needs at least 4"):
        experiment(_study(experiment={"sample_rate": 4096.0}))


def test_experiment_is_deterministic_with_seed():
    # a short, coarsely sampled test (the CLI test's 2048 Hz and 2 ms pulse): determinism does not depend on the size
    study = _study(experiment={"averages": 1, "duration": 0.5, "sample_rate": 2048.0, "pulse_duration": 0.002},
                   frequency={"start": 20.0, "stop": 400.0})
    a, b, c = experiment(study, seed=3), experiment(study, seed=3), experiment(study, seed=4)
    assert np.array_equal(a.frf.data, b.frf.data)
    assert not np.array_equal(a.frf.data, c.frf.data)


def test_cli_experiment_is_the_identify_path_on_its_own_file(tmp_path, capsys):
    """`jointid experiment` prints exactly what `jointid identify` prints on its frf.uff, and errors over the study's band."""
    text = (benchmark_study_path().read_text().replace("duration = 2.0", "duration = 1.0").replace("averages = 5", "averages = 3")
            .replace("start = 5.0", "start = 20.0").replace("stop = 1000.0", "stop = 200.0")
            .replace("sample_rate = 8192.0", "sample_rate = 2048.0").replace("pulse_duration = 0.0005", "pulse_duration = 0.002"))
    study = tmp_path / "s.toml"
    study.write_text(text)
    assert main(["experiment", str(study), "--out", str(tmp_path / "o"), "--seed", "1", "--no-plots"]) == 0
    printed = capsys.readouterr().out.splitlines()
    for name in ("frf.uff", "true_joint.csv", "joint_stiffness.csv", "summary.json", "experiment_errors.csv", "report.html"):
        assert (tmp_path / "o" / name).exists(), name
    rows = list(csv.DictReader(open(tmp_path / "o" / "experiment_errors.csv")))
    assert list(rows[0]) == ["frequency_hz", "translational_magnitude_error", "translational_relative_error",
                             "translational_loss_factor_error", "K_w_w_relative_error", "K_theta_theta_relative_error",
                             "coherence_min", "reliable"]
    f = np.array([float(r["frequency_hz"]) for r in rows])
    err = np.array([float(r["translational_relative_error"]) for r in rows])
    assert f[0] == 20.0 and f[-1] == 200.0 and np.allclose(np.diff(f), 1.0)  # the study's band on the 1 s record's 1 Hz grid
    assert {r["reliable"] for r in rows} <= {"0", "1"}
    # the errors are over the study's band (issue 28: a 20-400 Hz study said "over 100-1000 Hz")
    head = next(x for x in printed if x.startswith("error against the true joint"))
    assert head.startswith("error against the true joint over the study's band 20-200 Hz (181 lines)")
    ww = next(x for x in printed if x.startswith("K_w_w: median ") and "90th percentile" in x)
    assert ww == f"K_w_w: median {100 * np.median(err):.3g} %, 90th percentile {100 * np.percentile(err, 90):.3g} %"
    # `jointid identify` on the file experiment wrote prints the same per-term medians, findings and estimator
    assert main(["identify", str(study), "--frf", str(tmp_path / "o" / "frf.uff"), "--out", str(tmp_path / "i"), "--no-plots"]) == 0
    identified = capsys.readouterr().out.splitlines()

    def shared(lines):  # everything after the "wrote ..." summary line, up to experiment's own error lines
        body = [x for x in lines if not x.startswith(("identified ", "rejected: ", "error against"))]
        return [x for x in body if "90th percentile" not in x]

    terms = [x for x in shared(identified) if x.startswith("K_") and "median |K|" in x]
    assert [x.split(":")[0] for x in terms] == ["K_w_w", "K_w_theta", "K_theta_theta"]
    assert shared(printed) == shared(identified)
    assert [x.split("; wrote")[0] for x in printed if x.startswith("identified ")] == \
           [x.split("; wrote")[0] for x in identified if x.startswith("identified ")]
    assert ww in (tmp_path / "o" / "report.html").read_text()  # the report of a virtual test gives its error against the truth
    assert "error against the true joint" not in (tmp_path / "i" / "report.html").read_text()
    a = (tmp_path / "o" / "joint_stiffness.csv").read_text()
    assert a == (tmp_path / "i" / "joint_stiffness.csv").read_text()  # the same numbers, bit for bit


def test_noise_free_periodic_experiment_matches_exact_frfs():
    # a periodic test has no leakage and keeps the hysteretic model's non-causal
    # precursor, so H1 (5 hits of +-10% amplitude, sub-sample trigger jitter) is the
    # model's FRF up to the force window's cut of the band-limited force's ringing
    study = _study(experiment={"force_noise": 0.0, "response_noise": 0.0})
    ex = experiment(study, periodic=True)
    frf = ex.frf.band(100, 1000)
    exact = synthesize_frf(constrained_model(study), frf.frequency, study.measurement.observed_dofs,
                           study.measurement.excited_dofs, kind="accelerance").data
    rel = np.abs(frf.data / exact - 1)
    assert ex.impact.exp_tau_s is None
    assert np.median(rel) < 1e-6 and rel.max() < 1e-5  # measured 3.4e-7, 2.8e-6 (transient 2 s: 4.4e-4, 0.34)


def test_hammer_data_whose_lines_share_leakage_keep_the_structured_estimate_with_wider_bands(exp_modelled,
                                                                                            identified_modelled):
    """The benchmark's hammer test (5-1000 Hz, seed 0, as read back from its file with coherence): neighbouring lines
    share leakage, so the structured fit's residuals are not white (Z ~ 75) while chi^2/dof passes. The structured
    estimate is kept -- falling back to per-term smoothing cost 20x (K_ww 0.58 %) to 500x (K_theta_theta 59 %) -- with
    bands that hold its difference from that fallback, and the finding says so. Measured: 0.031 % / 0.12 %."""
    study, ex = exp_modelled  # the benchmark study as it is: its accelerometers are in Do
    assert study == _study() and study.experiment.seed == 0
    _, r = identified_modelled
    assert r.estimator == "structured" and not r.structured.accepted and r.structured.shape_only
    err = np.median(np.abs(r.stiffness - ex.truth) / np.abs(ex.truth), axis=0)
    assert err[0, 0] < 0.002 and err[1, 1] < 0.01, err
    assert any("misses the shape of these FRFs" in f and f.endswith(
        "the structured estimate is kept with bands that hold its difference from each term smoothed on its own")
        for f in r.findings())
