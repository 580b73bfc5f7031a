"""``[identification.targets]``: a term is flagged reliable only where its predicted error is within its target, with a
finding that names the target and points to `jointid design`; bad targets are refused in one line."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from jointid.errors import IdentificationError, StudyError
from jointid.methods.receptance.options import CouplingOptions
from jointid.pipeline import identify, simulate
from jointid.study import parse_study
from jointid.terms import term_names
from jointid.dofs import parse_dofs
from study_texts import beam_study_toml


def _study(targets: str = ""):
    text = beam_study_toml(start=5.0, stop=200.0, step=5.0)
    if targets:
        text += "\n[identification.targets]\n" + targets + "\n"
    return parse_study(tomllib.loads(text))


@pytest.fixture(scope="module")
def data():
    study = _study()
    vt = simulate(study)
    rng = np.random.default_rng(3)
    z = (rng.standard_normal(vt.frf.data.shape) + 1j * rng.standard_normal(vt.frf.data.shape)) / np.sqrt(2)
    return dataclasses.replace(vt.frf, data=vt.frf.data * (1 + 0.005 * z))


def test_a_target_flags_exactly_the_lines_whose_predicted_error_exceeds_it(data):
    plain = identify(_study(), data)
    rel = plain.relative_std[:, 1, 1]
    target = float(np.median(rel))  # half the lines above it
    r = identify(_study(f"K_theta_theta = {target!r}"), data)
    assert np.array_equal(r.stiffness, plain.stiffness)  # a target changes the flags, not the estimate
    assert np.array_equal(r.reliable_terms[:, 1, 1], plain.reliable_terms[:, 1, 1] & (rel <= target))
    assert np.array_equal(r.reliable_terms[:, 0, 0], plain.reliable_terms[:, 0, 0])  # other terms untouched
    line = next(f for f in r.findings() if f.startswith("K_theta_theta:"))
    assert line.startswith(f"K_theta_theta: above its target {100 * target:.2g} % ")
    assert line.endswith("a layout that reaches it: `jointid design`")


def test_the_mirror_name_is_the_same_term_and_bad_targets_are_refused_in_one_line():
    assert _study("K_theta_w = 0.01").identification.targets == (("K_w_theta", 0.01),)
    with pytest.raises(StudyError) as exc:
        _study("K_x_x = 0.01")
    assert str(exc.value) == ("<study>: [identification.targets]: 'K_x_x' is not a term of the joint; expected one of: "
                              "K_w_w, K_w_theta, K_theta_theta")
    with pytest.raises(StudyError) as exc:
        _study("K_w_w = 0")
    assert str(exc.value) == "<study>: [identification.targets].K_w_w: expected a relative error > 0 (0.002 = 0.2 %), got 0"
    names = term_names(parse_dofs(["10w", "10theta"]))
    with pytest.raises(IdentificationError) as exc:
        CouplingOptions(targets=(("K_q_q", 0.1),)).threshold(names)
    assert str(exc.value) == "targets: 'K_q_q' is not a term of the joint; expected one of: K_w_w, K_w_theta, K_theta_theta"
    thr = CouplingOptions(max_relative_std=0.1, targets=(("K_w_theta", 0.02), ("K_w_w", 0.5))).threshold(names)
    assert np.array_equal(thr, [[0.1, 0.02], [0.02, 0.1]])  # a target above max_relative_std does not loosen it
