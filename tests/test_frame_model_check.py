"""The model check and the column calibration on a 3-D frame with a 6-DOF mount (9 x 9 translational FRFs).

A user's black-box test found both ways wrong: the right free model flagged on every line (a finer column
calibration taken over a coarser one that explained less than none, which then made 2-15.5 Hz 42x the noise),
and E 2 % off let rotational terms 3-10 times off through as reliable (a band at 5.8x, the others 1.1-1.4x).
"""

from __future__ import annotations

import dataclasses
import textwrap

import numpy as np
import pytest
import scipy.sparse as sp

from jointid.io.matrix_files import write_free_matrices
from jointid.physics import FrameSection, Material, build_frame
from jointid.pipeline import identify, simulate
from jointid.study.parse import load_study

from structure_model import toml_list

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")
MEASURED = [f"{g}{c}" for g in (3, 5, 10) for c in ("x", "y", "z")]


def _frame_study(folder, e_factor=1.0, smoothing="none"):
    """A steel rectangle with a post (108 DOFs), a grounded 6-DOF mount at grid 1, x y z of grids 3, 5, 10
    (``smoothing`` None: the default estimator)."""
    folder.mkdir()
    steel = Material(210e9 * e_factor, 7850.0, loss_factor=0.002, poisson_ratio=0.3)
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.8, 0.0, 0.0), 3: (0.8, 0.5, 0.0), 4: (0.0, 0.5, 0.0), 5: (0.8, 0.0, 0.3)}
    tube, box = FrameSection.circle(0.04, 0.032), FrameSection.rectangle(0.03, 0.05)
    frame = build_frame(nodes, [(1, 2, tube, steel, 4), (2, 3, box, steel, 4), (3, 4, tube, steel, 4), (4, 1, box, steel, 4),
                                (2, 5, tube, steel, 2)])
    write_free_matrices(folder / "model", sp.csr_matrix(frame.mass), sp.csr_matrix(frame.stiffness), frame.dofs, format="mtx")
    (folder / "study.toml").write_text(textwrap.dedent(f"""\
        [structure]
        mass = "model_M.mtx"
        stiffness = "model_K.mtx"
        dofs = "model_dofs.csv"
        loss_factor = 0.002

        [[joint]]
        name = "mount"
        dofs = {toml_list(f"1{c}" for c in COMPONENTS)}
        [joint.model]
        type = "mount"
        stiffness = [3e6, 2e6, 4e6, 8e3, 6e3, 5e3]
        couplings = [["1x", "1ry", 2e4], ["1y", "1rx", -1.5e4], ["1x", "1y", 4e5]]
        loss_factor = 0.1
        growth = 0.2
        reference_frequency = 50.0
        exponent = 1.0

        [measurement]
        observed = {toml_list(MEASURED)}
        excited = {toml_list(MEASURED)}

        [frequency]
        start = 2.0
        stop = 150.0
        step = 0.5
        """) + ("" if smoothing is None else f'\n[identification]\nsmoothing = "{smoothing}"\n'))
    return load_study(folder / "study.toml")


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    root = tmp_path_factory.mktemp("frame")
    right = _frame_study(root / "right")
    test = simulate(right)
    rng = np.random.default_rng(2)  # seed 1 happened not to find a column error; 2-8 did
    z = (rng.standard_normal(test.frf.data.shape) + 1j * rng.standard_normal(test.frf.data.shape)) / np.sqrt(2)
    frf = dataclasses.replace(test.frf, data=test.frf.data * (1 + 0.01 * z))
    return right, _frame_study(root / "stiff", e_factor=1.02), frf, _frame_study(root / "stiff_default", 1.02, None)


def _model_findings(r):
    return [f for f in r.findings() if f.startswith("the free model does not explain")]


def test_the_right_free_model_is_not_flagged_and_no_column_error_is_corrected(frame):
    """The calibration's F test finds a column error that is not there (14-16 on 7 of 8 seeds), and the corrected
    FRFs miss the free model by 42x the noise at 2-15.5 Hz: such a correction is not applied, and a note says why."""
    right, _, frf, _ = frame
    r = identify(right, frf)
    assert _model_findings(r) == [], r.findings()
    assert not r.calibration_applied
    assert any(f.startswith("a force calibration error of the excitation columns was found (F test p = ") and f.endswith(
        "but the corrected FRFs fit the free model worse than the measured ones (its model check fails with it and passes "
        "without it): not applied") for f in r.findings()), r.findings()
    assert r.reliable_terms[:, 0, 0].any()


def test_a_modulus_2_percent_off_is_flagged_on_every_line(frame):
    _, stiff, frf, _ = frame
    r = identify(stiff, frf)
    found = _model_findings(r)
    assert len(found) == 1 and found[0].endswith("every term flagged unreliable on every line"), r.findings()
    assert not r.reliable_terms.any()
    cal = [f for f in r.findings() if f.startswith("force calibration error of the excitation columns")]
    assert len(cal) == 1 and "as alike on every column as a free model whose stiffness or mass is off" in cal[0], cal


def test_a_file_whose_points_are_numbered_otherwise_names_some_of_them(frame, tmp_path):
    """Every record at a DOF the study does not have (points 1003, 1005, 1010 for grids 3, 5, 10): the refusal shows
    some of the file's DOFs and where to map them."""
    from jointid.dofs import Dof
    from jointid.errors import DataError
    from jointid.io.frf_files import write_frf
    from jointid.pipeline import read_measured

    right, _, frf, _ = frame
    renamed = dataclasses.replace(frf, responses=tuple(Dof(d.node + 1000, d.direction) for d in frf.responses),
                                  references=tuple(Dof(d.node + 1000, d.direction) for d in frf.references))
    path = write_frf(tmp_path / "renamed.uff", renamed)
    with pytest.raises(DataError) as err:
        read_measured(right, path)
    assert str(err.value).endswith(
        "skipped 81 records: 81 at DOFs not in the study (the file's DOFs include 1003x, 1003y, 1003z, 1005x, 1005y, 1005z, "
        "...: if the file numbers its points otherwise, map them to the model's nodes in the study's [measurement.points])"), err.value


def test_the_default_estimator_does_not_fit_all_lines_when_every_line_is_flagged_anyway(frame):
    """The joint spline fit of a 6-DOF mount took 8-20 minutes on a free model 2 % off, for estimates flagged on every
    line: it is not run then, and a finding says so."""
    _, _, frf, stiff = frame
    r = identify(stiff, frf)
    assert r.spline is None and not r.reliable_terms.any()
    assert ("the joint spline fit was not run: the free model does not explain these FRFs (above), so every line is "
            "flagged whatever the estimate; each term smoothed on its own instead") in r.findings()


def test_the_headline_of_a_6_dof_mount_also_counts_the_diagonal_terms(monkeypatch):
    """Couplings near zero are never reliable relative to themselves: "0% of lines reliable" said nothing of the
    mount's own stiffnesses; the headline adds the lines where every diagonal term is reliable."""
    from types import SimpleNamespace

    import jointid.cli.identify as cli_identify
    from jointid.frequency import Frequency

    monkeypatch.setattr(cli_identify, "term_lines", lambda result, study: [])
    terms = np.ones((4, 6, 6), bool)
    terms[:, 0, 4] = terms[:, 4, 0] = False  # a zero coupling: never reliable
    terms[3, 2, 2] = False  # K_z_z unreliable on the last line
    result = SimpleNamespace(frequency=Frequency(np.array([10.0, 20.0, 30.0, 40.0])), joint_dofs=tuple(range(6)),
                             reliable=terms.all(axis=(1, 2)), reliable_terms=terms, describe_estimator=lambda: "x",
                             findings=lambda: [])
    first = cli_identify.identification_lines(result, SimpleNamespace(joints=(0,)))[0]
    assert first == ("identified 6x6 joint stiffness on 4 lines (10-40 Hz); 0% of lines reliable on every term, 75% on "
                     "every diagonal term")
    terms[:, 0, 4] = terms[:, 4, 0] = True
    result = SimpleNamespace(**{**vars(result), "reliable": terms.all(axis=(1, 2))})  # couplings reliable: no second figure
    assert cli_identify.identification_lines(result, SimpleNamespace(joints=(0,)))[0] == (
        "identified 6x6 joint stiffness on 4 lines (10-40 Hz); 75% of lines reliable")
