"""The units check (issue 26 item 4, issue 28): FRFs off by one gross factor in every column are refused, one conclusion."""

from __future__ import annotations

import dataclasses
import re
import tomllib

import numpy as np
import pytest

from jointid.errors import DataError
from jointid.methods.receptance.column_calibration import ColumnCalibration
from jointid.methods.receptance.coupling import CouplingOptions
from jointid.methods.receptance.units_check import units_conclusion
from jointid.pipeline import identify, simulate
from jointid.study.parse import parse_study

from study_texts import beam_study_toml

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

REFUSAL_TAIL = (": give the file's units (UFF dataset 164 / unit labels; a CSV file is read in SI units), check the study's "
                "free model, or set [identification] units_check = false to use them as they are")


def _cal(factors, F=40) -> ColumnCalibration:
    """A calibration whose column j is off by ``factors[j]`` on every line (measured = true * factor)."""
    eps = np.broadcast_to(np.asarray(factors, float) - 1.0, (F, len(factors))).astype(complex)
    delta = eps / (1.0 + eps)
    return ColumnCalibration(delta, np.zeros((F, 3, 3), complex), 1e3, 0.0, 16)  # F test: significant


def test_a_common_unit_factor_is_named():
    g = 9.80665
    assert units_conclusion(_cal([1 / g] * 3)) == "the FRFs look scaled by 1/9.81 in every excitation column (g/N read as m/s^2/N?)"
    assert units_conclusion(_cal([g * 1.02, g, g / 1.02])) == (
        "the FRFs look scaled by 9.81 in every excitation column (values in m/s^2/N labelled g, or converted from g twice?)")
    assert units_conclusion(_cal([1000.0] * 3)).startswith("the FRFs look scaled by 1000 in every excitation column (mm/s^2/N")


def test_a_gross_factor_without_a_unit_and_small_or_unequal_ones():
    assert units_conclusion(_cal([3.0] * 3)) == (
        "the FRFs look scaled by 3 in every excitation column (wrong units, or a wrong sensor sensitivity?)")
    assert units_conclusion(_cal([1.3] * 3)) is None  # a hammer sensitivity error: corrected by the calibration
    assert units_conclusion(_cal([9.81, 1.0, 1.0])) is None  # one column: not a units problem of the file
    assert units_conclusion(_cal([1.3, 1.6, 2.2])) is None
    assert units_conclusion(_cal([1.6, 2.0, 1.7])) is None  # force sensitivities wrong per column: corrected, not refused
    assert units_conclusion(None) is None


def test_every_column_grossly_off_without_a_common_factor_is_a_wrong_model_or_units():
    """A free model with a dimension in mm read as m predicts FRFs off by a different gross factor per column."""
    text = ("the FRFs are off by factors {}-{} in the excitation columns from what the free model predicts (no unit factor, and "
            "far beyond a force calibration error): the free model (the study's dimensions, material or their units), the "
            "FRFs' units, the force sensors' sensitivities or a record's sign or direction (its direction code in the file; a "
            "beam study's `--axis`, `[measurement] axis`) are wrong")
    assert units_conclusion(_cal([1000.0, 1300.0, 1150.0])) == text.format(1000, 1300)
    assert units_conclusion(_cal([0.05, 0.1, 0.08])) == text.format(0.05, 0.1)


def test_a_study_with_the_beam_width_in_mm_is_refused():
    """The black-box finding: on the benchmark with 1 % noise, width = 12.7 (mm typed as m) was "corrected" as a
    1.2e5 % force calibration error (columns 1042-1347x off, no common factor) and K_w_w flagged reliable 2700x off.
    Now one line naming the free model."""
    from jointid.benchmark import benchmark_study

    study = benchmark_study()
    vt = simulate(study)
    rng = np.random.default_rng(1)
    z = (rng.standard_normal(vt.frf.data.shape) + 1j * rng.standard_normal(vt.frf.data.shape)) / np.sqrt(2)
    frf = dataclasses.replace(vt.frf, data=vt.frf.data * (1 + 0.01 * z))
    wrong = dataclasses.replace(study, structure=dataclasses.replace(study.structure, width=12.7))
    with pytest.raises(DataError) as exc:
        identify(wrong, frf)
    assert re.fullmatch(r"the FRFs are off by factors (\d+)-(\d+) in the excitation columns .* force sensors' sensitivities "
                        r"or a record's sign or direction \(its direction code in the file; a beam study's `--axis`, "
                        r"`\[measurement\] axis`\) are wrong" + re.escape(REFUSAL_TAIL),
                        str(exc.value))


@pytest.fixture(scope="module")
def beam():
    study = parse_study(tomllib.loads(beam_study_toml(start=5.0, stop=200.0, step=5.0)))
    vt = simulate(study)
    rng = np.random.default_rng(3)
    z = (rng.standard_normal(vt.frf.data.shape) + 1j * rng.standard_normal(vt.frf.data.shape)) / np.sqrt(2)
    return study, dataclasses.replace(vt.frf, data=vt.frf.data * (1 + 0.005 * z))


def test_unlabelled_g_per_newton_is_refused_with_one_line(beam):
    study, frf = beam
    with pytest.raises(DataError) as exc:
        identify(study, dataclasses.replace(frf, data=frf.data / 9.80665))
    assert str(exc.value) == "the FRFs look scaled by 1/9.81 in every excitation column (g/N read as m/s^2/N?)" + REFUSAL_TAIL


def test_units_check_false_uses_them_and_flags_every_term(beam):
    study, frf = beam
    r = identify(study, dataclasses.replace(frf, data=frf.data * 9.80665), CouplingOptions(units_check=False))
    assert not r.reliable_terms.any()
    assert ("the FRFs look scaled by 9.81 in every excitation column (values in m/s^2/N labelled g, or converted from g "
            "twice?): used as they are (units_check = false); every term flagged unreliable") in r.findings()
    assert not any(f.startswith("K_") for f in r.findings())  # the flags' reason is the units, said once


def test_si_data_pass_the_check(beam):
    study, frf = beam
    r = identify(study, frf)
    assert r.reliable_terms[:, 0, 0].mean() > 0.9
    assert not any("scaled by" in f for f in r.findings())


def test_the_study_key_units_check_reaches_the_estimator(beam):
    """``[identification] units_check = false`` in a study file: the same as the option (the pipeline passes it on)."""
    study, frf = beam
    text = beam_study_toml(start=5.0, stop=200.0, step=5.0)
    off = parse_study(tomllib.loads(text.replace("[identification]", "[identification]\nunits_check = false")
                                    if "[identification]" in text else text + "\n[identification]\nunits_check = false\n"))
    assert off.identification.units_check is False and study.identification.units_check is True
    r = identify(off, dataclasses.replace(frf, data=frf.data * 9.80665))
    assert not r.reliable_terms.any() and any("used as they are (units_check = false)" in f for f in r.findings())
