"""The noise-robustness study of ``jointid reproduce``: helpers, physics on one case, the report section."""

import csv

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.errors import StudyError
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.pipeline import coupling_options, free_model, identify, simulate, true_joint
from jointid.reproduce import noise_robustness as nr
from jointid.reproduce.common import add_noise
from jointid.reproduce.config import load_config
from jointid.reproduce.runner import parse_only


def _config(tmp_path, text):
    p = tmp_path / "c.toml"
    p.write_text(text)
    return load_config(p)


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    p = tmp_path_factory.mktemp("cfg") / "c.toml"
    p.write_text("[frequency]\nstart = 5.0\nstop = 1000.0\nstep = 5.0\n"
                 "[noise_robustness]\nlevels = [0.01]\nseeds = 1\nlayouts = [\"model_3\"]\njoint_nodes = [10]\n")
    return load_config(p)


def test_term_errors_and_band_hits_on_a_constructed_case():
    truth = np.zeros((4, 2, 2), complex)
    truth[:] = [[1e5 + 1e4j, 2e3 - 1e2j], [2e3 - 1e2j, 20 + 2j]]
    k = truth * 1.1
    assert np.allclose(nr.term_errors(k, truth), 0.1)
    # real parts off by 0, 1, 2, 3 sigma; imaginary parts by 3, 1.6, 1.7, 0 sigma (sigma = 1 everywhere)
    est = truth + (np.array([0.0, 1.0, 2.0, 3.0]) + 1j * np.array([3.0, 1.6, 1.7, 0.0]))[:, None, None]
    ones = np.ones((4, 2, 2))
    hits = nr.within_band(est, ones, ones, truth)
    assert hits.shape == (2, 4, 3)
    assert hits[0, :, 0].tolist() == [True, True, False, False]
    assert hits[1, :, 2].tolist() == [False, True, False, True]
    assert np.allclose(hits.mean(axis=1), 0.5)  # coverage per part and term
    assert nr.within_band(est, 0.5 * ones, 0.5 * ones, truth).mean(axis=1)[:, 0].tolist() == [0.25, 0.25]


def test_cached_free_model_and_exact_frfs_match_the_pipeline(coarse):
    case = nr.Case("model_3", 1, "B")
    study = nr.case_study(coarse, case)
    m = study.measurement
    f = study.grid
    assert (f.hz[0], f.hz[-1], f.hz.size) == (100.0, 1000.0, 181)
    cached = nr.CachedReceptance(free_model(study), f, [*m.observed_dofs, *study.joint.joint_dofs, *m.excited_dofs])
    frf, truth = nr.exact_frf(cached, true_joint(study), f, m.observed_dofs, m.excited_dofs)
    test = simulate(study)
    assert np.abs(frf.data - test.frf.data).max() < 1e-9 * np.abs(test.frf.data).max()
    assert np.array_equal(truth, test.truth) and frf.responses == test.frf.responses and frf.kind == "accelerance"
    noisy = add_noise(frf, 0.01, np.random.default_rng(3))
    # per line, unweighted: the two receptance paths' difference (< 1e-9 above, ~1e-13 measured) amplified by the
    # per-line conditioning (<= ~1e4 here); the default's structured fit stops at a relative cost change of 1e-6
    # (ftol), which moves its parameters by at most ~sqrt(2 ftol) = 1.4e-3 of their standard deviations: two runs from
    # FRFs that differ in the last bits agree to that, not to the bits (they differ between BLAS kernels and threads)
    raw = CouplingOptions(weighting="none", smoothing="none")
    via_cache = identify_joint_coupling(cached, noisy, study.joint.joint_dofs, raw)
    via_pipeline = identify(study, noisy, raw)
    assert np.abs(via_cache.stiffness - via_pipeline.stiffness).max() <= 1e-9 * np.abs(via_pipeline.stiffness).max()
    via_cache = identify_joint_coupling(cached, noisy, study.joint.joint_dofs, coupling_options(study))
    via_pipeline = identify(study, noisy)
    d = via_cache.stiffness - via_pipeline.stiffness
    assert np.all(np.abs(d.real) <= 1.5e-3 * via_pipeline.std_real + 1e-12 * np.abs(via_pipeline.stiffness).max())
    assert np.all(np.abs(d.imag) <= 1.5e-3 * via_pipeline.std_imag + 1e-12 * np.abs(via_pipeline.stiffness).max())


def test_default_beats_hong_lee_and_raw_receptance_at_1_percent(coarse):
    r = nr.run_case(coarse, nr.Case("model_3", 10, "A"), index=0)
    assert r.levels == (0.01,) and r.errors["hong-lee"].shape == (1, 1, 181, 3)
    for k in ("receptance", "receptance-raw"):
        assert np.median(r.exact[k], axis=0).max() < 1e-8  # exact FRFs: the joint back to round-off
    assert np.median(r.exact["hong-lee"][:, 2]) > 0.05  # the grid model's discretization error
    default, raw, hl = (r.median(k)[0] for k in ("receptance", "receptance-raw", "hong-lee"))
    assert default[2] < hl[2] / 10 and default[2] < 0.2  # K_thetatheta: smoothing and weighting win by far
    assert np.all(default < raw) and np.all(raw < hl)
    assert np.all(r.p90("receptance") >= r.median("receptance"))
    cov = r.coverage("receptance")
    assert cov.shape == (1, 2, 3) and np.all((cov >= 0) & (cov <= 1))
    # K_ww bands roughly calibrated. One realization: the structured fit's errors are correlated over all lines,
    # so a single run's coverage scatters widely (measured here 0.71 / 0.61, re / im); over 50 seeds
    # (benchmarks/robust_identification.py, A node 10) it is 0.91 / 0.93
    assert cov[0, :, 0].min() > 0.5 and cov[0].mean() > 0.75
    assert "hong-lee" not in r.inside


def test_noise_robustness_section_figures_and_data(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[frequency]\nstart = 5.0\nstop = 1000.0\nstep = 20.0\n"
                   "[noise_robustness]\nlevels = [0.01]\nseeds = 1\nlayouts = [\"model_3\"]\njoint_nodes = [1]\n")
    assert parse_only("noise-robustness") == ("noise-robustness",)
    out = tmp_path / "o"
    assert main(["reproduce", "--only", "noise-robustness", "--config", str(cfg), "--quiet", "--out", str(out)]) == 0
    html = (out / "report.html").read_text()
    assert "Robustness to FRF noise" in html and "band coverage" in html and html.count("data:image/png;base64,") == 3
    assert "1 realization per level" in html
    assert sorted(p.name for p in (out / "figures").iterdir()) == [
        "noise_robustness_bands_material_a.png", "noise_robustness_bands_material_b.png", "noise_robustness_error_vs_noise.png",
    ]
    rows = list(csv.DictReader((out / "data" / "noise_robustness.csv").open()))
    assert len(rows) == 2 * 1 * 3  # cases x levels x methods
    for row in rows:
        cov = [row[f"{t}_coverage_{p}"] for t, _, _ in nr.TERMS for p in ("real", "imag")]
        if row["method"] == "hong-lee":
            assert cov == ["nan"] * 6
        else:
            assert all(0.0 <= float(c) <= 1.0 for c in cov)
        assert float(row["K_ww_p90"]) >= float(row["K_ww_median"]) > 0


@pytest.mark.parametrize("text, message", [
    ("[noise_robustness]\nseeds = 0\n", "[noise_robustness].seeds: expected an integer >= 1, got 0"),
    ("[noise_robustness]\nlevels = [0.01, -0.1]\n", "[noise_robustness].levels: entry 2 (-0.1) is outside 0-1"),
    ("[noise_robustness]\nlevels = [0.0]\n", "[noise_robustness].levels: expected a positive number, got 0.0"),
    ("[noise_robustness]\nlevels = []\n", "[noise_robustness].levels: expected a non-empty list of positive numbers (relative noise rms), got []"),
    ("[noise_robustness]\nlayouts = [\"model_9\"]\n", "[noise_robustness].layouts: expected a non-empty list of layout names out of model_1, model_2, model_3, got ['model_9']"),
    ("[noise_robustness]\njoint_nodes = [0]\n", "[noise_robustness].joint_nodes: expected a non-empty list of beam nodes 1..19, got [0]"),
    ("[noise_robustness]\nrepeats = 3\n", "[noise_robustness]: unknown key 'repeats'; expected levels, seeds, layouts, joint_nodes"),
])
def test_noise_robustness_config_errors(tmp_path, text, message):
    with pytest.raises(StudyError) as exc:
        _config(tmp_path, text)
    assert str(exc.value) == f"{tmp_path / 'c.toml'}: {message}"


def test_noise_robustness_config_keys(tmp_path):
    cfg = _config(tmp_path, "[layouts.model_4]\nobserved = [2, 5]\nexcited = [2, 5]\n"
                            "[noise_robustness]\nlevels = [0.03, 0.01]\nseeds = 5\nlayouts = [\"model_4\"]\njoint_nodes = [19]\n")
    assert (cfg.robustness_levels, cfg.robustness_seeds, cfg.robustness_layouts, cfg.robustness_joint_nodes) == ((0.01, 0.03), 5, ("model_4",), (19,))
    assert [c.label(cfg) for c in nr.cases(cfg)] == ["Model 4, beam end (node 19), Material A", "Model 4, beam end (node 19), Material B"]
    default = load_config(None)
    assert (default.robustness_levels, default.robustness_seeds) == ((0.003, 0.01, 0.03), 1)  # the quick default
    assert len(nr.cases(default)) == 8
    assert load_config(None, seeds=4).robustness_seeds == 4  # --seeds N
    p = tmp_path / "s.toml"
    p.write_text("[noise_robustness]\nseeds = 5\n")
    assert load_config(p).robustness_seeds == 5 and load_config(p, seeds=2).robustness_seeds == 2  # --seeds overrides the file
    with pytest.raises(StudyError, match="^--seeds: expected an integer >= 1, got 0$"):
        load_config(None, seeds=0)
