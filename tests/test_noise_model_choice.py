"""FRFs without coherence: relative noise keeps the relative weights; a noise floor (a hammer test's response noise) is
recognized and its variance measured from the residuals, instead of weighting anti-resonances as if they were exact."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from jointid.methods.receptance.noise_model_choice import choose_noise_model, floor_shape
from jointid.methods.receptance.options import CouplingOptions
from jointid.pipeline import identify, simulate
from jointid.reproduce.noise_robustness import term_errors
from jointid.study import parse_study
from study_texts import beam_study_toml


@pytest.fixture(scope="module")
def case():
    study = parse_study(tomllib.loads(beam_study_toml(start=5.0, stop=400.0, step=1.0)))
    return study, simulate(study)


def _noisy(frf, sd, seed):
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2)
    return dataclasses.replace(frf, data=frf.data + sd * z)


def _choice(study, frf):
    from jointid.pipeline import free_model
    from jointid.physics.free_model import as_free_model

    model = as_free_model(free_model(study))  # the study's free model, accelerometers included as identify has it
    frf = frf.to("receptance")
    m, e, n = frf.responses, frf.references, study.joint.joint_dofs
    Y = model.receptance(frf.frequency, tuple(m) + tuple(n), tuple(n) + tuple(e))
    k, j = len(m), len(n)
    return choose_noise_model(Y[:, :k, :j], Y[:, k:, j:], Y[:, :k, j:] - frf.data, frf.data)


def test_relative_noise_keeps_the_relative_model(case):
    study, vt = case
    frf = _noisy(vt.frf, 0.005 * np.abs(vt.frf.data), 1)
    assert not _choice(study, frf).floor
    assert not any("no coherence" in f for f in identify(study, frf).findings())


def test_a_noise_floor_is_found_and_measured_and_beats_relative_weights(case):
    study, vt = case
    frf = _noisy(vt.frf, 0.005 * np.sqrt(floor_shape(vt.frf.data)), 2)  # 0.5 % of the line's largest response
    c = _choice(study, frf)
    assert c.floor and c.relative - c.floored > 0
    auto = identify(study, frf)
    assert any(f.startswith("the FRF file has no coherence and its noise is not relative to |H|: it has a floor")
               for f in auto.findings())
    forced = identify(dataclasses.replace(study, identification=dataclasses.replace(study.identification, weighting="relative")), frf)
    e_auto = np.median(term_errors(auto.stiffness, vt.truth[np.isin(vt.frf.frequency.hz, auto.frequency.hz)]), axis=0)
    e_rel = np.median(term_errors(forced.stiffness, vt.truth[np.isin(vt.frf.frequency.hz, forced.frequency.hz)]), axis=0)
    assert e_auto[2] < e_rel[2] / 3  # K_theta_theta: weights that follow the noise, not |H|


def test_noise_free_data_choose_nothing(case):
    study, vt = case
    assert _choice(study, vt.frf) is None


def test_the_choice_on_blocks_of_lines_agrees_with_every_line(case, monkeypatch):
    """Above CHOICE_LINES the evidence is blocks of consecutive lines: the same decisions on both kinds of noise."""
    import jointid.methods.receptance.noise_model_choice as nm

    study, vt = case
    relative = _noisy(vt.frf, 0.005 * np.abs(vt.frf.data), 3)
    floor = _noisy(vt.frf, 0.005 * np.sqrt(floor_shape(vt.frf.data)), 4)
    monkeypatch.setattr(nm, "CHOICE_LINES", 100)  # 396 lines: 20 blocks of 5
    assert not _choice(study, relative).floor and _choice(study, floor).floor
