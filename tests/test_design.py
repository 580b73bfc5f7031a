"""Test design (``jointid design``): predicted covariance, search, ranking against noisy identifications, CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from jointid.benchmark import benchmark_study, benchmark_study_path
from jointid.cli.design import verdict
from jointid.cli.main import main
from jointid.design import design_study, study_sensors, with_layout
from jointid.frf import FRF
from jointid.methods.receptance.coupling_lines import coupling_per_line
from jointid.methods.design.layout import LayoutPredictor
from jointid.physics.free_model import StructureModel
from jointid.pipeline import coupling_options, free_model, identify, simulate, true_joint

MODEL3 = ((1, 3, 6, 9, 12, 15, 19), (3, 9, 15))


def coarse(step: float = 5.0):
    """The benchmark over 100-1000 Hz on a coarser grid (fast)."""
    st = benchmark_study()
    return dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, step=step))


@pytest.fixture(scope="module")
def design5():
    """Design on the benchmark, 7 observed x 3 excited of nodes 1..19, 5 Hz grid, the rotational term only."""
    return design_study(coarse(5.0), 7, 3, weights={"K_w_w": 0, "K_w_theta": 0}, search_lines=30, monte_carlo=2)


def test_prediction_is_the_identifications_covariance_and_sensors_move_with_the_layout():
    # an independent path: the test article synthesized with its sensors moved, and
    # coupling_per_line's covariance (variance / scale) on those exact FRFs
    st = coarse(20.0)
    obs, exc = (2, 5, 8, 11, 14, 17, 19), (4, 12)
    moved = with_layout(st, obs, exc)
    assert moved.accelerometers.nodes == obs and moved.measurement.excited == exc
    pred = LayoutPredictor(free_model(st, with_accelerometers=False), true_joint(st), st.joint.joint_dofs, st.grid,
                           range(1, 20), 0.01, study_sensors(st))
    test = simulate(moved)
    H = test.frf.to("receptance").data
    assert np.max(np.abs(pred.exact_receptance(obs, exc) / H - 1)) < 1e-7
    fm = StructureModel(free_model(moved))  # the identification's model: sensors at the new observed nodes
    m, e, n = moved.measurement.observed_dofs, moved.measurement.excited_dofs, st.joint.joint_dofs
    f = st.grid
    lines = coupling_per_line(fm.receptance(f, m, n), fm.receptance(f, n, e), fm.receptance(f, n, n),
                              fm.receptance(f, m, e) - H, (0.01 * np.abs(H)) ** 2)
    expected = lines.variance / lines.scale[:, None, None]
    assert np.max(np.abs(pred.variance(obs, exc) / expected - 1)) < 1e-5
    rel = pred.relative_std(obs, exc)
    assert rel.shape == (f.hz.size, 3)
    np.testing.assert_allclose(rel[:, 2], np.sqrt(expected[:, 1, 1]) / np.abs(test.truth[:, 1, 1]), rtol=1e-5)
    # ten times the noise, ten times the standard deviation
    pred10 = LayoutPredictor(free_model(st, with_accelerometers=False), true_joint(st), st.joint.joint_dofs, st.grid,
                             range(1, 20), 0.1, study_sensors(st))
    np.testing.assert_allclose(pred10.relative_std(obs, exc), 10 * rel, rtol=1e-9)


def test_sensors_not_on_the_observed_nodes_stay_put():
    st = coarse(20.0)
    fixed = dataclasses.replace(st, accelerometers=dataclasses.replace(st.accelerometers, nodes=(1, 19)))
    assert study_sensors(st).nodes is None and study_sensors(fixed).nodes == (1, 19)
    assert with_layout(fixed, (2, 4, 6), (8, 10)).accelerometers.nodes == (1, 19)
    moved = with_layout(fixed, (2, 4, 6), (8, 10))
    pred = LayoutPredictor(free_model(st, with_accelerometers=False), true_joint(st), st.joint.joint_dofs, st.grid,
                           range(1, 20), 0.01, study_sensors(fixed))
    H = simulate(moved).frf.to("receptance").data
    assert np.max(np.abs(pred.exact_receptance((2, 4, 6), (8, 10)) / H - 1)) < 1e-7


def test_design_on_the_benchmark_beats_model_3_on_the_rotational_term(design5):
    d = design5
    assert len(d.observed) == 7 and len(d.excited) == 3
    assert set(d.observed) | set(d.excited) <= set(range(1, 20))
    assert (d.current_observed, d.current_excited) == MODEL3
    chosen, model3 = d.median(), d.median(current=True)
    assert chosen["K_theta_theta"] <= model3["K_theta_theta"]
    assert d.criterion <= d.current_criterion
    # not predicted worse than Model 3 in any scenario (relative/additive noise, with/without column calibration)
    names = [sc.name for sc in d.scenarios]
    # the additive scenario is the study's hammer test: 1 % response noise / sqrt(5 averages x 5 Hz x 2 s)
    assert d.scenarios[1].level == pytest.approx(0.01 / np.sqrt(50), rel=1e-12)
    assert names == ["relative, smoothed", "additive, 0.14 %, smoothed", "relative, smoothed, calibrated",
                     "additive, 0.14 %, smoothed, calibrated"]
    cur = d.scenario_medians(True)
    for name, med in d.scenario_medians().items():
        assert med["K_theta_theta"] <= cur[name]["K_theta_theta"], name
    # the column calibration's common error dominates the rotational term (smoothing does not reduce it)
    assert cur["relative, smoothed, calibrated"]["K_theta_theta"] > 3 * cur["relative, smoothed"]["K_theta_theta"]
    # the search evaluated each layout once, and re-ranked its best on every line
    assert [s for s, _ in d.history][-2:] == ["re-rank", "monte carlo"] and 300 < d.evaluations < 3000
    assert d.ranked[0][1:] == (d.observed, d.excited) and len(d.ranked) == 30
    js = d.to_dict()
    assert js["chosen"]["observed"] == list(d.observed) and js["current"]["excited"] == [3, 9, 15]
    assert set(js["chosen"]["median_relative_std"]) == {"K_w_w", "K_w_theta", "K_theta_theta"}
    assert set(js["chosen"]["scenarios"]) == set(names) and len(js["search"]["alternatives"]) == 5
    json.dumps(js, allow_nan=False)


def _column_error(shape, rng, level=0.005):
    """A smooth complex calibration error per excitation column (four cosines over the band), shape (F, 1, e)."""
    F, _, e = shape
    u = np.linspace(0.0, 1.0, F)
    eps = sum(level * (rng.standard_normal(e) + 1j * rng.standard_normal(e)) / np.sqrt(2) * np.cos(np.pi * k * u)[:, None]
              for k in range(4))
    return 1.0 + eps[:, None, :]


def test_noisy_identifications_confirm_the_predicted_ranking(design5):
    # the estimator the design predicts (each term smoothed, smoothing = "gcv"; column calibration when it finds
    # a column error), 4 new seeds each:
    # (a) 1 % complex relative noise on exact FRFs, (b) the same and a smooth 1 % column error per hit column
    st = coarse(5.0)
    GCV = dataclasses.replace(coupling_options(st), smoothing="gcv")
    errors = {}
    for name, layout in (("chosen", (design5.observed, design5.excited)), ("model3", MODEL3)):
        s = with_layout(st, *layout)
        test = simulate(s)
        per_seed = {"noise": [], "column": []}
        for seed in range(100, 104):  # not the design's Monte Carlo seeds (0, 1)
            rng = np.random.default_rng(seed)
            d = test.frf.data
            noisy = d * (1 + 0.01 * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)) / np.sqrt(2))
            for key, data in (("noise", noisy), ("column", noisy * _column_error(d.shape, rng))):
                r = identify(s, FRF(test.frequency, data, test.frf.responses, test.frf.references, test.frf.kind), GCV)
                assert r.calibration_applied == (key == "column")
                per_seed[key].append(np.median(np.abs(r.stiffness[:, 1, 1] / test.truth[:, 1, 1] - 1)))
        errors[name] = {k: np.median(v) for k, v in per_seed.items()}
    for key in ("noise", "column"):
        assert errors["chosen"][key] <= errors["model3"][key], (key, errors)
    # the calibration's common error: what the design predicted is what the estimator made, within 2x
    pred = design5.scenario_medians()["relative, smoothed, calibrated"]["K_theta_theta"]
    assert 0.5 < errors["chosen"]["column"] / pred < 2.0, (errors, pred)


def test_weights_put_the_rotational_term_first():
    st = coarse(20.0)
    only = design_study(st, 4, 2, candidates=range(1, 20, 2), weights={"K_w_w": 0, "K_w_theta": 0}, search_lines=16)
    assert only.weights == {"K_w_w": 0.0, "K_w_theta": 0.0, "K_theta_theta": 1.0}
    assert only.criterion == pytest.approx(only.median()["K_theta_theta"], rel=1e-12)
    assert set(only.observed) | set(only.excited) <= set(range(1, 20, 2))


def test_plot_has_one_log_panel_per_term(design5):
    fig = design5.plot()
    axes = fig.axes
    assert [a.get_title().split(" ")[0] for a in axes] == ["K_w_w", "K_w_theta", "K_theta_theta"]
    assert all(a.get_yscale() == "log" for a in axes)
    assert len(axes[2].get_lines()) == 4  # chosen and current, each with its median


def _coarse_study_file(tmp_path):
    text = benchmark_study_path().read_text(encoding="utf-8")
    text = text.replace("start = 5.0", "start = 100.0").replace("step = 1.0", "step = 20.0")
    p = tmp_path / "study.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_cli_writes_design_json_and_plot(tmp_path, capsys):
    study = _coarse_study_file(tmp_path)
    out = tmp_path / "out"
    code = main(["design", str(study), "--out", str(out), "--observed", "3", "--excited", "2",
                 "--candidates", "1,4..7,10,13,16,19", "--weights", "K_theta_theta=4", "--search-lines", "16"])
    assert code == 0
    js = json.loads((out / "design.json").read_text())
    assert len(js["chosen"]["observed"]) == 3 and len(js["chosen"]["excited"]) == 2
    assert js["candidates"] == [1, 4, 5, 6, 7, 10, 13, 16, 19]
    assert set(js["chosen"]["observed"] + js["chosen"]["excited"]) <= set(js["candidates"])
    assert js["current"]["observed"] == list(MODEL3[0]) and js["weights"]["K_theta_theta"] == 4.0
    assert js["noise"] == 0.01 and js["band_hz"] == [100.0, 1000.0] and js["lines"] == 46
    assert (out / "design.png").stat().st_size > 0
    printed = capsys.readouterr().out
    assert "chosen layout : observed" in printed and "current layout: observed 1,3,6,9,12,15,19; excited 3,9,15" in printed
    assert "  greedy observed: " in printed and "  re-rank: " in printed  # a progress line per step
    med, cur = js["chosen"]["median_relative_std"], js["current"]["median_relative_std"]
    for t in ("K_w_w", "K_w_theta", "K_theta_theta"):  # per term: both figures and the verdict
        row = next(line for line in printed.splitlines() if line.strip().startswith(t + " "))
        assert f"{100 * med[t]:.3g} %" in row and f"{100 * cur[t]:.3g} %" in row
        assert verdict(med[t], cur[t]) in row
    assert verdict(0.01, 0.02) == "better (2x lower)" and verdict(0.03, 0.02) == "worse (1.5x higher)"
    assert verdict(0.02, 0.0201) == "same"


@pytest.mark.parametrize("extra, message", [
    (["--candidates", "1..25"], "candidates: node 20 is not a node of the beam (nodes 1..19)"),
    (["--candidates", "0,3,5"], "candidates: node 0 is not a node of the beam (nodes 1..19)"),
    (["--candidates", "a..b"], "--candidates: expected node numbers and ranges like 1..19 or 1,3,5..9, got 'a..b'"),
    (["--observed", "1"], "observed: 1 node cannot identify the 2 joint DOFs; choose at least 2"),
    (["--excited", "1"], "excited: 1 node cannot identify the 2 joint DOFs; choose at least 2"),
    (["--excited", "30"], "excited: 30 nodes asked for but there are only 19 candidate nodes; choose at most 19"),
    (["--candidates", "1..5"], "observed: 7 nodes asked for but there are only 5 candidate nodes; choose at most 5"),
    (["--weights", "K_rot=2"], "weights: unknown term 'K_rot'; expected one of K_w_w, K_w_theta, K_theta_theta"),
    (["--weights", "K_theta_theta"], "--weights: expected TERM=WEIGHT pairs like K_theta_theta=4,K_w_w=1, got 'K_theta_theta'"),
    (["--weights", "K_w_w=-1"], "weights: K_w_w = -1.0; expected a number >= 0"),
    (["--noise", "0"], "--noise: expected a relative FRF noise level > 0 (0.01 = 1 %), got 0"),
])
def test_bad_input_is_one_line_exit_2_and_no_output(tmp_path, capsys, extra, message):
    out = tmp_path / "out"
    assert main(["design", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert err == f"jointid design: error: {message}\n"
    assert not out.exists()


def test_monte_carlo_coherence_is_the_noisy_frfs_so_its_variance_is_the_simulated_one(monkeypatch):
    # a measured coherence comes from the same records as H1: |H1|^2 (1 - g^2) / g^2 is the noise power whatever the
    # noise did to H1. A coherence from the exact H made that estimate var |H_noisy|^2 / |H|^2: near anti-resonances a
    # random factor, down to ~0 (weights 1e3-1e4 too large, a 6-DOF mount's rotations 20-300 % off on one seed in four)
    from jointid.methods.design import check

    st = coarse(20.0)
    obs, exc = MODEL3
    pred = LayoutPredictor(free_model(st, with_accelerometers=False), true_joint(st), st.joint.joint_dofs, st.grid,
                           range(1, 20), 0.01, study_sensors(st), noise_model="additive")
    seen, identify_frf = [], check.identify_joint_coupling

    def capture(model, frf, joint_dofs, options):
        seen.append(frf)
        return identify_frf(model, frf, joint_dofs, options)

    monkeypatch.setattr(check, "identify_joint_coupling", capture)
    check.monte_carlo_errors(pred, obs, exc, 2)
    var = pred.frf_variance(pred.exact_receptance(obs, exc))
    assert len(seen) == 2 and not np.allclose(seen[0].data, seen[1].data)
    for frf in seen:
        g2 = frf.coherence
        a = var / np.abs(frf.data) ** 2  # (1 - g^2) / g^2 in exact arithmetic
        implied = np.abs(frf.data) ** 2 * (1 - g2) / g2
        # rounding: 1 / (1 + a) and 1 - g^2 lose about eps (1 + 1 / a) relative, a few operations each
        tol = 8 * np.finfo(float).eps * (1 + 1 / a)
        assert np.all(np.abs(implied / var - 1) <= tol)
