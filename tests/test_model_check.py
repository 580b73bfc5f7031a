"""The model check (issue 26 item 1): the coupling residuals per band against the noise see a wrong free model."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from jointid.methods.receptance.model_check import check_model, octave_bands, residual_statistics
from jointid.pipeline import identify, simulate
from jointid.study.parse import parse_study

from study_texts import beam_study_toml

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


def test_octave_bands_merge_short_ones():
    hz = np.arange(5.0, 101.0)  # 5-9, 10-19, 20-39, 40-79, 80-100 Hz
    assert octave_bands(hz) == [(0, 35), (35, 75), (75, 96)]
    assert octave_bands(np.arange(5.0, 15.0)) == [(0, 10)]


def test_noise_alone_gives_a_ratio_near_one():
    """Random residual-space data with a known variance: median chi2 / median second-difference noise ~ 1."""
    rng = np.random.default_rng(2)
    F, m, n, e = 400, 6, 2, 3
    Ymn = rng.standard_normal((F, m, n)) + 1j * rng.standard_normal((F, m, n))
    Yne = rng.standard_normal((F, n, e)) + 1j * rng.standard_normal((F, n, e))
    X = rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n))
    noise = (rng.standard_normal((F, m, e)) + 1j * rng.standard_normal((F, m, e))) * 0.01
    change = Ymn @ (X + X.T) @ Yne + noise
    stats = residual_statistics(Ymn, Yne, change, np.full((F, m, e), 2e-4))
    check = check_model(np.linspace(10.0, 1000.0, F), stats)
    # 400 lines x 15 dof: the medians' ratio is within 20 % of 1 (its scatter is a few %)
    assert check.fits and np.all(np.abs(check.ratio - 1.0) < 0.2), check.ratio


def _study(**beam):
    st = parse_study(tomllib.loads(beam_study_toml(start=5.0, stop=400.0, step=1.0)))
    return dataclasses.replace(st, structure=dataclasses.replace(st.structure, **beam)) if beam else st


@pytest.fixture(scope="module")
def fine_data():
    vt = simulate(_study(elements_per_segment=3))
    rng = np.random.default_rng(11)
    z = (rng.standard_normal(vt.frf.data.shape) + 1j * rng.standard_normal(vt.frf.data.shape)) / np.sqrt(2)
    return dataclasses.replace(vt.frf, data=vt.frf.data * (1 + 0.005 * z))


def test_a_wrong_free_model_is_named_and_flagged(fine_data):
    b = _study().structure
    wrong = _study(elastic_modulus=b.elastic_modulus * 1.02, density=b.density * 0.99)
    r = identify(wrong, fine_data)
    found = [f for f in r.findings() if f.startswith("the free model does not explain these FRFs in ")]
    assert len(found) == 1 and found[0].endswith(
        "the noise): update it from a free-free test (`jointid update`) or correct the structure's model; every term "
        "flagged unreliable there"), r.findings()
    assert r.reliable_terms.mean(axis=0).max() <= 0.05


def test_the_right_free_model_passes(fine_data):
    r = identify(_study(), fine_data)  # the study's own mesh is converged for the receptance method
    assert not any("free model does not explain" in f for f in r.findings()), r.findings()
    assert r.reliable_terms[:, 0, 0].mean() > 0.9
