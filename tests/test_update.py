"""Free-structure model updating from a free-free test (``jointid simulate --free``, ``jointid update``)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from jointid import pipeline
from jointid.cli.main import main
from jointid.errors import StudyError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.io.uff import write_uff_frf
from jointid.physics.synthesis import synthesize_frf
from jointid.study import load_study, parse_study
from jointid.study.edit import replace_study_table, replace_study_values

E0, RHO0, ETA0 = 69e9, 2700.0, 0.006
TRUE = {"elastic_modulus": E0 * 1.02, "density": RHO0 * 0.99, "loss_factor": ETA0 * 0.7}

STUDY = f"""# the benchmark beam; the true one is +2 % in E, -1 % in density, -30 % in loss factor
[beam]
length = 0.9144            # m
width = 0.0127
height = 0.0127
elastic_modulus = 69e9     # Pa, nominal
density = 2700.0           # kg/m^3
loss_factor = 0.006
poisson_ratio = 0.33
nodes = 19

[joint]
node = 10

[joint.model]
type = "elastomer"
material = "A"

[measurement]
observed = [1, 3, 6, 9, 12, 15, 19]
excited = [3, 9, 15]

[accelerometers]
mass = 0.005
rotary_inertia = 2.0e-7

[frequency]
start = 5.0
stop = 1000.0
step = 1.0

[identification]
model_accelerometers = true

[truth]                    # the data: a finer mesh than the model's 8 elements per segment
elastic_modulus = {TRUE['elastic_modulus']!r}
density = {TRUE['density']!r}
loss_factor = {TRUE['loss_factor']!r}
elements_per_segment = 16
"""


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """simulate --free (1 % noise) -> update, through the CLI, once for the module."""
    tmp = tmp_path_factory.mktemp("update")
    study = tmp / "study.toml"
    study.write_text(STUDY)
    assert main(["simulate", str(study), "--free", "--noise", "0.01", "--seed", "1", "--out", str(tmp / "sim")]) == 0
    assert main(["update", str(study), "--frf", str(tmp / "sim" / "free_frf.uff"), "--out", str(tmp / "upd")]) == 0
    return tmp


def test_update_recovers_beam_from_noisy_free_free_test_within_two_std(chain):
    report = json.loads((chain / "upd" / "update.json").read_text())
    params = report["parameters"]
    assert list(params) == ["elastic_modulus", "density", "loss_factor"]
    tolerance = {"elastic_modulus": 0.003, "density": 0.003, "loss_factor": 0.10}
    for name, p in params.items():
        assert p["status"] == "determined"
        assert p["initial"] == {"elastic_modulus": E0, "density": RHO0, "loss_factor": ETA0}[name]
        assert abs(p["value"] / TRUE[name] - 1) < tolerance[name], name
        assert abs(p["value"] - TRUE[name]) <= 2 * p["std"], name
        assert 0 < p["std"] < 0.01 * p["value"]
    # the residual drops to the noise: 1 % complex noise is an rms |ln(1 + n)| of ~0.01
    assert report["residual"]["before"] > 0.3
    assert 0.009 < report["residual"]["after"] < 0.011
    corr = np.array(report["correlation"]["matrix"], dtype=float)
    assert corr.shape == (3, 3) and np.allclose(np.diag(corr), 1.0)
    truth = json.loads((chain / "sim" / "true_structure.json").read_text())
    assert truth["elements_per_segment"] == 16 and truth["density"] == TRUE["density"]


def test_updated_study_keeps_the_text_and_carries_the_values(chain):
    text = (chain / "upd" / "updated_study.toml").read_text()
    assert text.startswith("# Updated by `jointid update` on ")
    assert "free_frf.uff" in text.splitlines()[0]
    assert "# the benchmark beam; the true one is" in text  # the user's comments survive
    assert "elastic_modulus = 69e9" not in text and "(was 69e9) | Pa, nominal" in text
    updated = load_study(chain / "upd" / "updated_study.toml")
    report = json.loads((chain / "upd" / "update.json").read_text())
    for name, p in report["parameters"].items():
        assert getattr(updated.beam, name) == p["value"]
    original = load_study(chain / "study.toml")
    assert replace(updated, structure=original.beam, source=original.source, uncertainty=None) == original
    # the fit's standard errors and correlation, for identify's bands
    names = list(report["parameters"])
    assert list(updated.uncertainty.std) == names
    for name, p in report["parameters"].items():
        assert updated.uncertainty.std[name] == p["std"]
    assert np.array_equal(np.array(updated.uncertainty.correlation), np.array(report["correlation"]["matrix"], dtype=float))
    assert (chain / "upd" / "update.png").stat().st_size > 10_000


def _median_errors(result, truth, f_hz):
    keep = np.isin(f_hz, result.frequency.hz)
    t = truth[keep]
    band = (result.frequency.hz >= 100) & (result.frequency.hz <= 1000)
    return [
        float(np.median(np.abs(result.stiffness[band, i, j] - t[band, i, j]) / np.abs(t[band, i, j])))
        for i, j in ((0, 0), (0, 1), (1, 1))
    ]


def _constrained_test(study, frequency, noise, seed):
    """The true test article on its joint, by receptance coupling of the free true beam (exact, fast on a fine mesh)."""
    from jointid.physics.banded_receptance import receptance_banded

    beam = pipeline.free_model(study, with_accelerometers=True)
    m, e, n = study.measurement.observed_dofs, study.measurement.excited_dofs, study.joint.joint_dofs
    Y = receptance_banded(beam, frequency, m + n, e + n)
    k = pipeline.true_joint(study)(frequency.hz)
    # Y*[m,e] = Y[m,e] - Y[m,n] (Y[n,n] + K^-1)^-1 Y[n,e]
    X = np.linalg.inv(Y[:, len(m):, len(e):] + np.linalg.inv(k))
    H = Y[:, :len(m), :len(e)] - Y[:, :len(m), len(e):] @ X @ Y[:, len(m):, :len(e)]
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    return FRF(frequency, H * (1 + noise * z), m, e, "receptance").to("accelerance"), k


def test_identification_with_updated_model_is_as_good_as_with_the_exact_model(chain):
    study = load_study(chain / "study.toml")
    updated = load_study(chain / "upd" / "updated_study.toml")
    true = pipeline.true_study(study)
    exact = replace(study, structure=replace(true.beam, elements_per_segment=None), truth=None)  # true values, model mesh
    f = Frequency.from_range(5.0, 1000.0, 4.0)
    noisy, truth = _constrained_test(true, f, 0.01, seed=3)
    exact_frf, _ = _constrained_test(true, f, 0.0, seed=3)
    direct = synthesize_frf(pipeline.constrained_model(true), f[::50], exact_frf.responses, exact_frf.references, kind="accelerance", method="direct")
    assert np.max(np.abs(exact_frf.data[::50] / direct.data - 1)) < 1e-6  # the coupling is right
    err_exact = _median_errors(pipeline.identify(exact, noisy), truth, f.hz)
    err_updated = _median_errors(pipeline.identify(updated, noisy), truth, f.hz)
    print("median error exact / updated model:", err_exact, err_updated)
    for term, e, u in zip(("K_w_w", "K_w_theta", "K_theta_theta"), err_exact, err_updated):
        assert u <= 1.5 * e, f"{term}: updated {u:.3g} vs exact {e:.3g}"
    assert err_exact[2] < 0.1  # the exact model itself identifies every term (1 % noise)


# ---------------------------------------------------------------------------- bad input: one line, exit 2, no output
def test_free_free_file_with_a_point_off_the_beam_is_refused(chain, capsys):
    f = Frequency.from_range(5.0, 1000.0, 1.0)
    bad = chain / "bad.uff"
    write_uff_frf(bad, FRF(f, np.ones((f.size, 2, 1)), ["3w", "25w"], ["3w"], "accelerance"))
    out = chain / "out_bad_point"
    assert main(["update", str(chain / "study.toml"), "--frf", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"jointid update: error: record 3 of {bad} (function type 4, response node 25 dir 3, reference node 3 dir 3): "
        "response node 25 is outside the beam (nodes 1..19); if the file numbers its points otherwise, "
        "map them to beam nodes (the study's [measurement.points])\n"
    )
    assert not out.exists()


def test_unknown_parameter_is_refused(chain, capsys):
    out = chain / "out_bad_name"
    args = ["update", str(chain / "study.toml"), "--frf", str(chain / "sim" / "free_frf.uff"), "--out", str(out)]
    assert main(args + ["--parameters", "elastic_modulus,youngs_modulus"]) == 2
    assert capsys.readouterr().err == (
        "jointid update: error: --parameters: unknown parameter 'youngs_modulus'; expected any of elastic_modulus, "
        "density, loss_factor, shear_coefficient, accelerometers.mass, accelerometers.rotary_inertia\n"
    )
    assert not out.exists()


def test_fit_that_does_not_converge_is_refused(chain, capsys):
    out = chain / "out_no_convergence"
    args = ["update", str(chain / "study.toml"), "--frf", str(chain / "sim" / "free_frf.uff"), "--out", str(out)]
    assert main(args + ["--max-evaluations", "2"]) == 2
    assert capsys.readouterr().err == (
        "jointid update: error: the update did not converge in 2 model evaluations (fitting elastic_modulus, density, "
        "loss_factor); check that the FRFs are a free-free test of this beam with these sensors, or allow more evaluations\n"
    )
    assert not out.exists()


# ---------------------------------------------------------------------------- what the data can and cannot determine
def test_loss_factor_below_the_first_resonance_is_not_determined():
    """Far below the first elastic mode (~75 Hz with the sensors) a free-free FRF is its mass line: eta is invisible.

    (Hysteretic damping also tilts the phase off resonance, by ~eta times the elastic modes' share of the FRF:
    up to 60 Hz that determines eta to ~1 % on exact-phase virtual data, a real test's phase errors would not.)
    """
    study = parse_study(_data(start=5.0, stop=20.0))
    result = pipeline.update(study, pipeline.simulate_free(study, noise=0.01, seed=2))
    eta = result.parameter("loss_factor")
    assert not eta.identified
    assert result.values["loss_factor"] == ETA0  # held at the study's value, not reported as a result
    assert result.to_dict()["parameters"]["loss_factor"]["value"] is None
    assert any(line.startswith("loss factor not determined by these FRFs") for line in result.describe())
    # the mass line still gives the density
    rho = result.parameter("density")
    assert rho.identified and abs(rho.value / TRUE["density"] - 1) < 0.003


def _data(**frequency):
    import tomllib

    data = tomllib.loads(STUDY)
    data["frequency"].update(frequency)
    return data


def test_truth_section_is_validated_and_applied():
    data = _data()
    data["truth"]["density"] = -1.0
    with pytest.raises(StudyError) as exc:
        parse_study(data, "s.toml")
    assert str(exc.value) == "s.toml: [truth].density: expected a positive number (kg/m^3), got -1.0"
    data["truth"] = {"young": 1.0}
    with pytest.raises(StudyError, match=r"\[truth\]: unknown key 'young'; expected one of: elastic_modulus, density, loss_factor, elements_per_segment"):
        parse_study(data)
    study = parse_study(_data())
    true = study.true_study()
    assert true.beam.elastic_modulus == TRUE["elastic_modulus"] and true.beam.elements_per_segment == 16
    assert true.beam.poisson_ratio == study.beam.poisson_ratio and true.truth is None
    assert study.beam.elastic_modulus == E0  # the model is the study's [beam]


def test_simulate_free_is_the_free_beam_with_its_sensors():
    study = parse_study(_data(start=5.0, stop=300.0))
    frf = pipeline.simulate_free(study)
    # below the first elastic mode the driving point accelerance tends to the rigid-body mass line: 1/m + x^2/J
    beam = study.true_study().beam
    m_beam = beam.density * beam.width * beam.height * beam.length
    acc = study.accelerometers
    xs = np.array([(n - 1) * beam.length / 18 for n in acc.nodes])
    m = m_beam + acc.mass * len(xs)
    xc = (acc.mass * xs.sum() + m_beam * beam.length / 2) / m
    J = m_beam * beam.length**2 / 12 + m_beam * (beam.length / 2 - xc) ** 2 + acc.mass * ((xs - xc) ** 2).sum() + acc.rotary_inertia * len(xs)
    x3 = 2 * beam.length / 18
    mass_line = 1 / m + (x3 - xc) ** 2 / J
    assert frf("3w", "3w")[0].real == pytest.approx(mass_line, rel=0.01)
    noisy = pipeline.simulate_free(study, noise=0.01, seed=4)
    rel = np.abs(noisy.data / frf.data - 1)
    assert 0.007 < np.sqrt(np.mean(rel**2)) < 0.013


def test_replace_study_values_refuses_what_it_cannot_edit_in_place():
    text = "[beam]\nbeam_note = 1\n# E below\nelastic_modulus = 1.0 # Pa\n"
    out = replace_study_values(text, {"elastic_modulus": 2.5, "density": 3.0}, ["from a test"])
    assert out == ("# from a test\n[beam]\ndensity = 3.0  # jointid update (was not set)\nbeam_note = 1\n# E below\n"
                   "elastic_modulus = 2.5  # jointid update (was 1.0) | Pa\n")
    with pytest.raises(StudyError) as exc:
        replace_study_values("beam = { elastic_modulus = 1.0 }\n", {"elastic_modulus": 2.0}, source="x.toml")
    assert str(exc.value) == "x.toml: no [beam] table header to write elastic_modulus into (inline tables are not edited); set it by hand"


def test_model_error_study_shows_errors_before_and_after_updating(tmp_path):
    from jointid.reproduce import model_error
    from jointid.reproduce.common import material_joint, study_beam, terms_of
    from jointid.reproduce.config import load_config

    cfg_file = tmp_path / "coarse.toml"
    cfg_file.write_text("[frequency]\nstart = 5.0\nstop = 1000.0\nstep = 2.0\n")
    cfg = load_config(cfg_file)
    f, lay, joint = cfg.grid, cfg.layouts["model_3"], material_joint(cfg, "A")
    frf = synthesize_frf(study_beam(cfg).with_joint(joint), f, [f"{n}w" for n in lay.observed], [f"{n}w" for n in lay.excited], kind="accelerance")
    rows, summary, cols, result = model_error.updating_comparison(cfg, frf, terms_of(joint(f.hz)), lay, f.mask(100, 1000))
    nominal, updated = rows
    assert nominal[:4] == ["nominal (E x 1.02, rho x 0.99)", "+2 %", "-1 %", "+0 %"]
    pct = lambda s: abs(float(s.rstrip(" %")))  # noqa: E731
    assert pct(updated[1]) < 0.05 and pct(updated[2]) < 0.05  # E and density from the free-free test
    for before, after in zip(nominal[4:], updated[4:]):  # translational, coupling, rotational median errors
        assert pct(after) < pct(before) / 20
    assert [p.name for p in result.parameters] == ["elastic_modulus", "density", "loss_factor"]
    assert {"translational_nominal_real", "rotational_updated_imag"} <= set(cols)


def test_coherence_weights_the_fit():
    """Every other line noisy (20 %) and flagged by its coherence: the weighted fit trusts the clean lines."""
    study = parse_study(_data(start=5.0, stop=150.0))
    exact = pipeline.simulate_free(study)
    rng = np.random.default_rng(7)
    noisy = np.zeros(exact.shape, bool)
    noisy[::2] = True
    z = (rng.standard_normal(exact.shape) + 1j * rng.standard_normal(exact.shape)) / np.sqrt(2)
    data = exact.data * (1 + np.where(noisy, 0.2, 0.005) * z)
    fits = {}
    for name, coherence in (("plain", None), ("weighted", np.where(noisy, 0.2, 0.9999))):
        measured = FRF(exact.frequency, data, exact.responses, exact.references, exact.kind, coherence)
        fits[name] = {p.name: p for p in pipeline.update(study, measured).parameters}
    for name in ("elastic_modulus", "density"):
        w, p = fits["weighted"][name], fits["plain"][name]
        assert w.std_error < p.std_error / 10
        assert abs(w.value - TRUE[name]) < 3 * w.std_error
        assert abs(w.value / TRUE[name] - 1) < 1e-4


def test_simulate_free_with_truth_from_another_study(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(STUDY.replace("stop = 1000.0", "stop = 200.0"))
    other = tmp_path / "other.toml"
    other.write_text(STUDY.replace("elastic_modulus = 69e9     # Pa, nominal", "elastic_modulus = 71e9").split("[truth]")[0])
    assert main(["simulate", str(study), "--free", "--truth", str(other), "--out", str(tmp_path / "sim")]) == 0
    truth = json.loads((tmp_path / "sim" / "true_structure.json").read_text())
    assert truth["elastic_modulus"] == 71e9 and truth["density"] == RHO0 and truth["noise"] == 0.0
    other.write_text(STUDY.replace("nodes = 19", "nodes = 21"))
    assert main(["simulate", str(study), "--free", "--truth", str(other), "--out", str(tmp_path / "sim2")]) == 2
    assert capsys.readouterr().err.endswith(
        f"error: {other}: [beam].nodes = 21 differs from the 19 of {study}; the true beam needs the same grid of nodes\n"
    )
    assert not (tmp_path / "sim2").exists()


def test_simulate_and_simulate_free_keep_each_others_files_in_one_out(tmp_path):
    """The jointed test's frf.uff and true_joint.csv stay when the free-free test is simulated into the same --out
    (and the other way round): each is its own output set (before, --free removed them as its stale files)."""
    study = tmp_path / "study.toml"
    study.write_text(STUDY.replace("stop = 1000.0", "stop = 200.0"))
    out = tmp_path / "sim"
    assert main(["simulate", str(study), "--out", str(out)]) == 0
    jointed = {p.name: p.read_bytes() for p in out.iterdir() if p.name in ("frf.uff", "true_joint.csv")}
    assert set(jointed) == {"frf.uff", "true_joint.csv"}
    assert main(["simulate", str(study), "--free", "--out", str(out)]) == 0
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.name in jointed} == jointed
    free = (out / "free_frf.uff").read_bytes()
    assert main(["simulate", str(study), "--out", str(out)]) == 0
    assert (out / "free_frf.uff").read_bytes() == free


def test_a_free_free_test_of_the_structure_gives_no_finding(chain):
    report = json.loads((chain / "upd" / "update.json").read_text())
    assert report["finding"] is None and all(p["status"] == "determined" for p in report["parameters"].values())


def test_noise_level_is_the_median_misfit_of_white_noise_and_ignores_a_smooth_misfit():
    from jointid.frequency import Frequency
    from jointid.methods.updating.check import NOISE_FACTOR, judge_update_fit, noise_level

    rng = np.random.default_rng(4)
    F, s = 4000, 0.01
    noise = s * (rng.standard_normal((F, 3, 2)) + 1j * rng.standard_normal((F, 3, 2)))
    # |noise| is Rayleigh(s): median s sqrt(2 ln 2); the estimate's standard error ~ 1.5 % at 24 000 values
    assert noise_level(noise) == pytest.approx(s * np.sqrt(2 * np.log(2)), rel=0.05)
    smooth = 0.3 * np.sin(np.linspace(0, 3 * np.pi, F))[:, None, None] * np.ones((1, 3, 2))
    assert noise_level(noise + smooth) == pytest.approx(noise_level(noise), rel=0.02)
    frf = FRF(Frequency(np.linspace(5, 1000, F)), np.ones((F, 3, 2), complex), ("1w", "2w", "3w"), ("1w", "2w"), "accelerance")
    assert judge_update_fit(noise, frf, None, "this beam") is None  # a fit down to the noise
    misfit = judge_update_fit(noise + smooth, frf, None, "this beam")
    assert misfit.startswith("these FRFs do not look like a free-free test of the study's structure (this beam): after the update "
                             "a typical value is still off by ")
    assert NOISE_FACTOR * noise_level(noise + smooth) < np.median(np.abs(noise + smooth))


def test_update_on_a_structure_study_given_its_jointed_frfs_reports_a_finding(tmp_path, capsys):
    """The spring chain on a grounded mount: the jointed structure's FRFs are no free-free test; nothing is determined."""
    from structure_model import labels, write_model

    write_model(tmp_path, 4)
    (tmp_path / "s.toml").write_text(
        '[structure]\nmass = "model.npz"\nstiffness = "model.npz"\ndofs = "model_dofs.csv"\nloss_factor = 0.01\n'
        '[[joint]]\nname = "j"\ndofs = ["2z", "2ry"]\n[joint.model]\ntype = "mount"\nstiffness = [1e6, 1e3]\n'
        f'[measurement]\nobserved = {labels(1) + labels(4)!r}\nexcited = ["1x", "1z", "4y", "4z"]\n'
        "[frequency]\nstart = 5.0\nstop = 100.0\nstep = 5.0\n"
    )
    assert main(["simulate", str(tmp_path / "s.toml"), "--out", str(tmp_path / "sim")]) == 0
    capsys.readouterr()
    assert main(["update", str(tmp_path / "s.toml"), "--frf", str(tmp_path / "sim" / "frf.uff"), "--no-plots", "--out", str(tmp_path / "u")]) == 0
    out = capsys.readouterr()
    assert out.out.startswith("these FRFs do not look like a free-free test of the study's structure (this structure): ")
    assert "Warning" not in out.err
    report = json.loads((tmp_path / "u" / "update.json").read_text())
    assert report["finding"] and all(p["status"] == "not_determined" for p in report["parameters"].values())


def test_resonances_left_misaligned_are_a_finding_even_when_the_misfit_is_small():
    from jointid.frequency import Frequency
    from jointid.methods.updating.check import MAX_FREQUENCY_SHIFT, judge_update_fit

    f = np.arange(5.0, 1000.0, 0.5)
    modes = np.array([150.0, 410.0, 800.0])
    H = sum(1.0 / (fr**2 - f**2 + 1j * 0.01 * fr**2) for fr in modes)  # three lightly damped modes
    frf = FRF(Frequency(f), H[:, None, None], ("1w",), ("1w",), "receptance")
    quiet = np.zeros((f.size, 1, 1), complex)
    assert judge_update_fit(quiet, frf, modes * 1.003, "this beam") is None  # within the 2 % tolerance
    finding = judge_update_fit(quiet, frf, modes / 1.05, "this beam")
    assert MAX_FREQUENCY_SHIFT == 0.02 and finding.startswith(
        "these FRFs do not look like a free-free test of the study's structure (this beam): the measured resonances lie +5 % "
        "from the updated model's (3 matched)")


def test_a_parameter_name_with_a_dot_is_written_as_one_key():
    """``accelerometers.mass`` in [uncertainty] is one quoted key (bare, TOML reads it as a dotted table, and the
    update of the accelerometers' mass could never be written: "could not write [uncertainty] ...")."""
    import tomllib

    text = "[beam]\nnodes = 19\n"
    out = replace_study_table(text, "uncertainty", {"accelerometers.mass": 6e-8, "elastic_modulus": 1e8})
    assert out.endswith('[uncertainty]\n"accelerometers.mass" = 6e-08\nelastic_modulus = 100000000.0\n')
    assert tomllib.loads(out)["uncertainty"] == {"accelerometers.mass": 6e-8, "elastic_modulus": 1e8}


@pytest.mark.parametrize("factor, label, study, when", [
    (1.0 / 9.80665, "1/9.81", "study.toml", "after the update"),  # the initial model off: the update runs first
    (1000.0, "1000", "upd/updated_study.toml", "with the initial model"),  # the initial model right: refused before it
    (1.0 / 2.2046226218487757, "1/2.20", "upd/updated_study.toml", "with the initial model"),  # E, density x2.2 would fit
])
def test_free_free_frfs_off_by_a_unit_factor_are_refused_naming_it(chain, capsys, tmp_path, factor, label, study, when):
    """A free-free test exported in g (or mm/s^2) without unit labels (a blind test, 2026-11-28): update exited 0 and wrote
    an 'updated' study with the initial values, saying only 'check ... its units'. Now one line with the factor, exit 2,
    nothing written. Where the initial model explains the data but for the factor, before any fit: a factor within the
    parameters' bounds (lbm, 1/2.20) would otherwise be taken up by E and the density scaled together."""
    import dataclasses

    from jointid.io.uff import read_uff_frf, write_uff_frf

    frf = read_uff_frf(chain / "sim" / "free_frf.uff")
    scaled = tmp_path / "scaled.uff"
    write_uff_frf(scaled, dataclasses.replace(frf, data=frf.data * factor), kind=frf.kind)
    capsys.readouterr()
    assert main(["update", str(chain / study), "--frf", str(scaled), "--out", str(tmp_path / "upd")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jointid update: error: these FRFs do not look like a free-free test of the study's structure "
                          f"(this beam with these sensors): every value is off by one factor, {label} (")
    assert f" % {when}): give" in err
    assert err.endswith("give the file's units (UFF dataset 164 / unit labels; a CSV file is read in SI units)")
    assert len(err.splitlines()) == 1 and not (tmp_path / "upd").exists()


def test_unit_factor_of_a_residual_needs_one_factor_on_every_value():
    from jointid.methods.updating.check import unit_factor_of

    rng = np.random.default_rng(2)
    noise = 0.01 * (rng.standard_normal((500, 3, 2)) + 1j * rng.standard_normal((500, 3, 2)))
    assert unit_factor_of(noise - np.log(1.0 / 9.80665), 0.01)[0] == "1/9.81"   # H_measured = H / 9.81
    assert unit_factor_of(noise - np.log(9.80665), 0.01)[0] == "9.81"
    assert unit_factor_of(noise - np.log(3.0), 0.01) is None                    # no unit is a factor 3
    wavy = noise - np.log(1.0 / 9.80665) + 0.5 * np.sin(np.arange(500))[:, None, None]  # a model misfit on top
    assert unit_factor_of(wavy, 0.01) is None
