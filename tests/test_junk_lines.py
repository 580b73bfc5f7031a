"""Junk lines (issue 26 item 4): lines whose coherence or residual says they are junk are left out, with one finding."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from jointid.methods.receptance.junk_lines import find_junk_lines
from jointid.methods.receptance.model_check import ResidualStatistics
from jointid.pipeline import identify, simulate
from jointid.study.parse import parse_study

from study_texts import beam_study_toml

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


def test_low_coherence_lines_are_left_out():
    hz = np.arange(1.0, 101.0)
    g = np.full((100, 3, 2), 0.99)
    g[3:7] = 0.2  # 4-7 Hz
    junk = find_junk_lines(hz, g, None)
    assert np.array_equal(np.flatnonzero(~junk.keep), [3, 4, 5, 6])
    assert junk.finding == ("4 lines at 4-7 Hz left out as junk: coherence 0.2 (median; 0.99 on the other lines) (they would "
                            "pull the calibration and the smoothing on the good lines)")


def test_a_residual_far_above_the_noise_is_junk_only_where_the_model_fits():
    hz = np.arange(1.0, 101.0)
    chi2, noise = np.ones(100), np.ones(100)
    chi2[[49, 80]] = 100.0
    junk = find_junk_lines(hz, None, ResidualStatistics(chi2, noise))
    assert np.array_equal(np.flatnonzero(~junk.keep), [49, 80])
    assert junk.finding.startswith("2 lines at 50 Hz, 81 Hz left out as junk: residual 100x the noise")
    chi2[64:] = 30.0  # the free model misfits 65-100 Hz: a high residual there is the model's, nothing is junk
    assert find_junk_lines(hz, None, ResidualStatistics(chi2, noise)).keep.all()


def test_too_much_junk_is_not_left_out():
    g = np.full((50, 2, 2), 0.99)
    g[:20] = 0.1  # 40 % of the lines: the data as a whole are poor
    assert find_junk_lines(np.arange(1.0, 51.0), g, None).keep.all()


def test_junk_lines_pull_nothing_on_the_good_lines():
    """With the junk lines at 1-4 Hz the result on 5-150 Hz is the one of the same data without them."""
    study0 = parse_study(tomllib.loads(beam_study_toml(start=0.0, stop=150.0, step=1.0)))
    study5 = dataclasses.replace(study0, frequency=dataclasses.replace(study0.frequency, start=5.0))
    vt = simulate(study0)
    rng = np.random.default_rng(5)
    shape = vt.frf.data.shape
    z = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    hz = vt.frf.frequency.hz
    bad = (hz >= 1) & (hz <= 4)
    level = np.where(bad, 2.0, 0.005)[:, None, None]
    coherence = np.broadcast_to(np.where(bad, 0.2, 1 / (1 + 0.005**2))[:, None, None], shape).copy()
    frf = dataclasses.replace(vt.frf, data=vt.frf.data * (1 + level * z), coherence=coherence)
    junk = identify(study0, frf)
    good = identify(study5, frf.band(5.0, 150.0))
    assert np.array_equal(junk.frequency.hz, good.frequency.hz)
    assert junk.findings()[0].startswith("4 lines at 1-4 Hz left out as junk: coherence 0.2")
    scale = np.abs(good.stiffness).max(axis=0)
    assert np.max(np.abs(junk.stiffness - good.stiffness) / scale) < 1e-9


def test_lines_where_nothing_was_measured_are_left_out_whatever_their_number():
    """Every FRF value exactly 0 on 40 % of the lines (a zeroed block): their floored variance gave them nearly full
    weight, K_w_w came out 0.002x the truth on the good lines, flagged reliable. They are left out, and the result
    on the other lines is the one of the same data without them."""
    study0 = parse_study(tomllib.loads(beam_study_toml(start=5.0, stop=150.0, step=1.0)))
    vt = simulate(study0)
    rng = np.random.default_rng(6)
    shape = vt.frf.data.shape
    z = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    hz = vt.frf.frequency.hz
    zero = (hz >= 40) & (hz < 100)
    frf = dataclasses.replace(vt.frf, data=np.where(zero[:, None, None], 0.0, vt.frf.data * (1 + 0.005 * z)))
    assert zero.mean() > 0.4
    with_zeros = identify(study0, frf)
    assert np.array_equal(with_zeros.frequency.hz, hz[~zero])
    assert with_zeros.findings()[0].startswith(f"{zero.sum()} lines at 40-99 Hz left out as junk: every FRF value exactly 0 "
                                               f"on {zero.sum()} of them (nothing measured there)")
    kept = dataclasses.replace(frf, frequency=type(frf.frequency)(hz[~zero]), data=frf.data[~zero])
    without = identify(study0, kept)
    scale = np.abs(without.stiffness).max(axis=0)
    assert np.max(np.abs(with_zeros.stiffness - without.stiffness) / scale) < 1e-9
