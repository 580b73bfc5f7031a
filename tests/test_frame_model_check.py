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


def test_the_right_free_model_is_not_flagged_and_no_column_error_is_found(frame):
    """The calibration's F test found a column error that is not there (F 14-16 on 7 of 8 seeds: the test of the
    uncompensated reduction, biased by the noise in the regressor), and the corrected FRFs missed the free model by
    42x the noise at 2-15.5 Hz. The compensated test finds none."""
    from jointid.methods.receptance.column_calibration import CALIBRATION_MIN_F

    right, _, frf, _ = frame
    r = identify(right, frf)
    assert _model_findings(r) == [], r.findings()
    assert r.calibration.f_statistic < CALIBRATION_MIN_F and not r.calibration_applied, r.calibration
    assert not any("force calibration" in f for f in r.findings()), r.findings()
    assert not any("share a random error" in f for f in r.findings()), r.findings()  # no force noise either


def test_per_line_values_whose_inverse_moves_by_half_are_not_trusted(frame):
    """Per line this layout does not determine the mount: its linearized check (one standard deviation moving the
    inverted matrix, evaluated at the noisy estimate) dipped below 1 by chance on a few lines, and 39 of the 185
    diagonal term-lines it kept over 8 seeds were beyond 3 sigma (K_rx_rx 526 % off, predicted 9 %). At 0.5: none."""
    right, _, frf, _ = frame
    r = identify(right, frf)  # smoothing = "none": the per-line values are the result
    d = np.arange(6)
    assert not r.reliable_terms[:, d, d].any()
    assert any("moves the joint's inverse by more than 50 %" in f for f in r.findings()), r.findings()


def test_force_noise_is_found_at_its_level_and_only_where_it_is(frame):
    """The force-noise test projected the residual on the measured columns, whose noise is the residual's own: on
    this frame (column directions with little signal below its first flexible modes) it found 0.1-0.2 % force noise
    in FRFs with response noise only (F 5.7-6.0). On the fitted columns: F 1.0 without, the level with."""
    import jointid.methods.receptance.coupling as coupling

    right, _, frf, _ = frame
    exact = simulate(right).frf
    rng = np.random.default_rng(7)
    F, m, e = exact.data.shape

    def cn(*shape):
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    noisy = dataclasses.replace(exact, data=exact.data * (1 + 0.01 * cn(F, m, e)) / (1 + 0.01 * cn(F, 1, e)))
    tests = []
    real = coupling.detect_force_noise

    def spy(*args, **kwargs):
        tests.append(real(*args, **kwargs))
        return tests[-1]

    coupling.detect_force_noise = spy
    try:
        identify(right, frf)
        identify(right, noisy)
    finally:
        coupling.detect_force_noise = real
    without, with_ = tests
    # F(2 e F, ~2 (|m||e| - p - e) F) ~ 1 +- 0.02 without force noise
    assert abs(without.f_statistic - 1.0) < 0.1 and not without.significant, without.f_statistic
    level = with_.level  # per column, relative
    assert with_.significant and np.all(np.abs(level - 0.01) < 0.004), level


SHARED = ("the force calibration correction is alike on every column and varies over frequency (", " times its differences "
          "between the columns), as an error of the free model makes it, not the forces of separate hits: the free model may "
          "be off, and the joint's terms take what the correction leaves; every term flagged unreliable on every line. "
          "Update the free model from a free-free test (`jointid update`), or set calibration = \"columns\" if the forces are "
          "known to be off so")


def test_a_modulus_2_percent_off_is_flagged_on_every_line(frame):
    """Smooth column factors take up most of E 2 % off (the corrected FRFs pass the model check) and the joint's
    terms the rest: K_rx_rx 10 times off, reliable on 10-12 % of the lines, before the correction's likeness on
    every column flagged it."""
    _, stiff, frf, _ = frame
    r = identify(stiff, frf)
    assert r.calibration_applied and not r.reliable_terms.any()
    shared = [f for f in r.findings() if f.startswith(SHARED[0])]
    assert len(shared) == 1 and SHARED[1] in shared[0], r.findings()
    assert r.calibration.common_shape_ratio > 1e3
    # the force-noise test measures its level from the residuals, which hold the model's error too: no finding may rule
    # a model error out (it said "not a joint or model error")
    force = [f for f in r.findings() if f.startswith("the excitation columns share a random error")]
    assert len(force) == 1 and "not a joint or model error" not in force[0], force
    assert "the free model does not explain these FRFs (see that finding), so part or all of it may be the model's error" in force[0]


def _blocks(study, frf):
    """``(Ymn, Yne, Yme, H)`` of the mount's joint DOFs, receptance."""
    from jointid.physics.free_model import as_free_model
    from jointid.pipeline import free_model

    n = study.joint.joint_dofs
    Y = as_free_model(free_model(study)).receptance(frf.frequency, tuple(frf.responses) + tuple(n), tuple(n) + tuple(frf.references))
    m = len(frf.responses)
    return Y[:, :m, :len(n)], Y[:, m:, len(n):], Y[:, :m, len(n):], frf.to("receptance").data


def test_the_column_error_test_is_not_biased_by_the_noise_in_the_regressor(frame):
    """With no column error the compensated test's F is about 1 (the uncompensated reduction gave 12-22 here), the
    directions the regressor's own noise dominates (the first functions, where the joint's six DOFs take up any
    column scale) are left out, and a real 3 % error of one column is found."""
    from jointid.methods.receptance import column_calibration as cc

    right, _, frf, _ = frame
    Ymn, Yne, Yme, H = _blocks(right, frf)
    hz = frf.frequency.hz
    shares = []
    real = cc.noise_shares

    def spy(N, noise):
        out = real(N, noise)
        shares.append(out[0])
        return out

    cc.noise_shares = spy
    try:
        none = cc.estimate_column_calibration(hz, Ymn, Yne, Yme - H, H, np.abs(H) ** 2, True, 16)
    finally:
        cc.noise_shares = real
    # F(k ~ 280, ~1.7e4) with no column error: 1 +- 0.09 (1 sigma)
    assert 0.7 < none.f_statistic < 1.3 and not none.significant, none
    assert 1 <= np.sum(shares[0] > cc.EIV_MAX_NOISE_SHARE) <= 10 and shares[0].max() > 0.8, shares[0][-12:]
    bad = H.copy()
    bad[:, :, 4] *= 1.03
    found = cc.estimate_column_calibration(hz, Ymn, Yne, Yme - bad, bad, np.abs(bad) ** 2, True, 16)
    median = np.median(found.error.real, axis=0)
    assert found.significant and abs(median[4] - 0.03) < 0.003 and np.all(np.abs(np.delete(median, 4)) < 0.003), median


def test_noise_shares_are_the_generalized_eigenvalues():
    from jointid.methods.receptance.column_calibration import noise_shares

    N = np.diag([4.0, 1.0, 2.0]).astype(complex)
    noise = np.diag([1.0, 0.5, 0.1]).astype(complex)
    shares, V = noise_shares(N, noise)
    assert np.allclose(shares, [0.05, 0.25, 0.5], rtol=0, atol=1e-14)
    assert np.allclose(V.conj().T @ N @ V, np.eye(3), atol=1e-13) and np.allclose(V.conj().T @ noise @ V, np.diag(shares), atol=1e-13)
    rot = np.linalg.qr(np.arange(9.0).reshape(3, 3) + np.eye(3) * 5)[0]
    assert np.allclose(noise_shares(rot @ N @ rot.T, rot @ noise @ rot.T)[0], shares, rtol=0, atol=1e-13)  # basis-independent
    with pytest.raises(np.linalg.LinAlgError):
        noise_shares(-N, noise)


def test_the_common_shape_ratio_tells_independent_column_errors_from_alike_ones():
    from jointid.methods.receptance.column_calibration import ColumnCalibration

    rng = np.random.default_rng(0)
    f = np.linspace(0.0, 1.0, 400)
    shape = np.sin(2 * np.pi * 3 * f)[:, None]
    independent = np.column_stack([0.01 * np.sin(2 * np.pi * (3 + k) * f + k) for k in range(9)])
    cal = lambda d: ColumnCalibration(d.astype(complex), None, 10.0, 0.0, 16)  # noqa: E731
    # 9 independent errors: their mean has 1/9 of their variance, so e |mean|^2 / spread ~ 1
    assert cal(independent).common_shape_ratio < 2.0
    alike = 0.02 * shape * (1 + 0.05 * rng.standard_normal((1, 9)))
    assert cal(alike).common_shape_ratio > 1e3 and abs(cal(alike).common_shape_rms - 0.02 / np.sqrt(2)) < 1e-3
    constant = 0.02 + 0.002 * rng.standard_normal((400, 9))  # one hammer's sensitivity error: common but constant
    assert cal(constant).common_shape_ratio < 2.0
    assert np.isnan(cal(independent[:, :1]).common_shape_ratio)


def test_a_column_correction_that_makes_the_fit_worse_is_recognized(frame):
    """The guard behind the F test: corrected FRFs that fail the model check while the measured ones pass it."""
    from jointid.methods.receptance.coupling import _calibration_worsens_fit

    right, _, frf, _ = frame
    Ymn, Yne, Yme, H = _blocks(right, frf)
    hz = frf.frequency.hz
    var = np.abs(H) ** 2
    smooth = 0.03 * np.sin(2 * np.pi * hz / 60.0)[:, None, None]  # a 3 % column "correction" alike on every column
    verdict = _calibration_worsens_fit(hz, Ymn, Yne, Yme, (H, var), (H * (1 - smooth), var * np.abs(1 - smooth) ** 2), True)
    assert verdict.worse and verdict.raw is not None and verdict.corrected is not None
    assert not _calibration_worsens_fit(hz, Ymn, Yne, Yme, (H, var), (H, var), True).worse


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
    assert ("the joint spline fit was not run: the column correction is one a free-model error makes (above), so every "
            "line is flagged whatever the estimate; each term smoothed on its own instead") in r.findings(), r.findings()


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
