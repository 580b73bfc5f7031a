"""Robust joint identification from measured FRFs: weighted receptance coupling, smoothed, with uncertainty.

The default inverse method of jointid. Three steps, each documented where it lives:

1. **Per line** (:mod:`jointid.methods.receptance.coupling_lines`): weighted least squares of
   ``Y[m,e] - H[m,e] = Y[m,n] X Y[n,e]`` for ``X = (Y[n,n] + Du^-1)^-1``, with
   ``Du = Du^T`` by default, weights ``1 / var(H)`` from coherence or a relative
   noise model (:mod:`jointid.methods.receptance.frf_variance`), covariance propagated to Du.
   It needs the free structure's receptance only on m, n and e
   (:class:`~jointid.physics.free_model.FreeModel`), never ``Do[nbar, mbar]``.
2. **Over frequency**, one of two estimators (``smoothing``):

   - ``"structured"`` (:mod:`jointid.methods.receptance.structured_select`): the joint's
     physics over all lines at once, ``Du(w) = g A - w^2 B - w^4 sum_r c_r c_r^T /
     (g mu_r - w^2)`` (one viscoelastic material, its internal modes), fitted by
     maximum likelihood to the per-line estimates with their full covariance,
     order by AIC, Akaike-weighted average of the orders; every term shares ``g``
     and the internal poles, so the rotational term borrows the translational
     term's precision, and a column calibration error is profiled out jointly.
     Used only when it passes its chi^2 test; otherwise the P-spline, with a finding.
   - ``"gcv"`` (:mod:`jointid.methods.receptance.smoothing`): the real and imaginary part of
     each term smoothed on its own by a weighted P-spline, lambda by GCV, which
     lowers the variance by about the number of lines in a correlation band. Its bands are
     widened where the lines err more than their variance (:mod:`.fallback_bands`).

   ``"auto"`` (default) is ``"structured"`` for one symmetric joint of at most
   :data:`AUTO_STRUCTURED_MAX_DOFS` DOFs on the exact per-line path, with at least
   :data:`STRUCTURED_MIN_LINES` lines and noisy data, the joint spline fit
   (:mod:`jointid.methods.receptance.spline_fit`) for one symmetric joint of up to
   :data:`AUTO_SPLINE_MAX_DOFS` DOFs (a 6-DOF mount), else ``"gcv"`` (a study of several
   joints uses ``"gcv"``: :func:`jointid.pipeline.coupling_options`).
   For a weakly seen term (K_theta_theta) it is far more accurate than ``"gcv"``,
   which has only that term's own noisy lines to average; ``benchmarks/structured_fit.py``
   and ``benchmarks/robust_identification.py`` print the default's median error per term
   (the latter on the virtual roving-hammer test, 1 % response and force noise).
   A term whose per-line estimates are already exact to 1e-6 (exact data) is left as
   it is: any smoother could only add its approximation error.
   With ``calibration = "auto"`` (default) a force-calibration error common to each
   excitation column (:mod:`jointid.methods.receptance.column_calibration`) is tested for,
   and corrected with its uncertainty added to the bands when it is significant.
   It is first estimated with the coherence's column-common part split off
   (:func:`~jointid.methods.receptance.frf_variance.column_noise_fraction`); the variance left
   in each value is then measured from the residuals of the corrected per-line fit
   (:func:`~jointid.methods.receptance.column_calibration.residual_variance`), and the
   calibration, the per-line fit and the structured model use those weights.
   A free-model error can look like a column error: smooth column factors absorb much of it,
   the corrected FRFs then pass the model check, and the joint's terms take the rest (a 3-D
   frame with E 2 % off, 9 x 9 FRFs: K_rx_rx 10 times off, flagged reliable). The two differ
   in how alike the columns are: errors of separate hits or force records are independent
   per column, a model error corrects every column alike, varying over frequency. A correction
   whose common varying part is :data:`COMMON_SHAPE_RATIO` times its differences between the
   columns and above :data:`COMMON_SHAPE_MIN_RMS` flags every term on every line, with a finding (``calibration = "columns"``: the
   user says the forces are the cause, and it is not flagged).
3. **Flags**: a term is reliable on a line when its predicted relative standard
   deviation ``sqrt(var Re + var Im) / |K|`` is at most ``max_relative_std``
   (default 10 %), the weighted design is well conditioned, and (diagonal terms)
   the loss factor is not significantly negative (passivity).

When to use which method: this one (``method = "receptance"``) for measured or
noisy FRFs, for any free model that gives a receptance, and whenever per-term
uncertainty matters; the plain per-line Hong & Lee method
(:func:`jointid.methods.hong_lee.inverse.identify_joint`, ``method = "hong-lee"``) to
reproduce the paper, to see its conditioning diagnostics (``cond_A``, ``cond_B``)
or to estimate the unobserved FRFs (rotations) of the constrained structure.
Both recover the joint from exact FRFs to round-off (``benchmarks/readme_figures.py``
prints the default's largest error per term).
"""

from __future__ import annotations

import warnings
from typing import ClassVar, NamedTuple, Sequence

import numpy as np

from ...dofs import Dof, parse_dofs
from ...errors import DataError, IdentificationError
from ...frequency import Frequency
from ...frf import FRF, LEAKAGE_MARK
from ...physics.free_model import UncertainFreeModel, as_free_model
from .column_calibration import estimate_column_calibration, residual_variance
from .coupling_result import CouplingResult
from .column_redundancy import MIN_COLUMN_REDUNDANCY, column_redundancy
from .noise_model_choice import choose_noise_model
from .options import AUTO_SPLINE_MAX_DOFS, AUTO_STRUCTURED_MAX_DOFS, MAX_CONDITION, CouplingOptions
from .coupling_lines import MAX_INVERSE_PERTURBATION, coupling_per_line, inverse_perturbation, relinearize, uses_kronecker
from .force_noise import detect_force_noise
from .junk_lines import junk_lines
from .model_uncertainty import ModelUncertainty, model_uncertainty
from .model_check import SMOOTH_EXCESS_LIMIT, SMOOTH_EXCESS_WITH_FAILED_BAND, ResidualStatistics, check_model, residual_statistics
from .gross_errors import GROSS_COLUMN_ERROR, GrossError, gross_error
from .units_check import units_conclusion
from ..frf_screening import check_visibility, floor_exact_zeros, noise_level_unknown, screen_measured
from .frf_variance import RELATIVE_FLOOR, column_noise_fraction, frf_variance
from ..estimate import Z90, check_layout, term_scale
from ...terms import dof_term_labels, term_names
from .fallback_bands import widen_fallback_bands
from .smoothing import residual_scale, resolution_lines, smooth_series
from .spline_fit import JointSplineFit, fit_joint_spline
from .structured_select import MAX_CHI2_PER_DOF, STRUCTURED_MAX_DOFS, StructuredEstimate, structured_estimate

__all__ = ["identify_joint_coupling", "SMOOTH_MIN_RELATIVE_STD", "MAX_CONDITION", "AUTO_STRUCTURED_MAX_DOFS", "AUTO_SPLINE_MAX_DOFS",
           "STRUCTURED_MIN_LINES"]

#: Terms whose per-line predicted relative standard deviation (median) is below this are not smoothed.
SMOOTH_MIN_RELATIVE_STD = 1e-6
#: Gauss-Newton steps: per-line estimates relinearized around the smoothed estimate, smoothed again.
RELINEARIZATIONS = 2
#: Fewest lines for the structured estimate.
STRUCTURED_MIN_LINES = 20
#: Residual degrees of freedom per line (``m e`` minus the joint's parameters) from which an unknown noise
#: level (coherence identically 1) is measured value by value from the residuals; below, only its scale per line.
RESIDUAL_MIN_REDUNDANCY = 10
#: B-spline functions per column of the coarse calibration estimate the units check makes when there is none.
UNITS_BASIS = 4
#: A column correction whose part common to every column, beyond its mean over frequency, is this many times its
#: differences between the columns is what a free-model error makes (:attr:`~.column_calibration.ColumnCalibration.common_shape_ratio`;
#: measured: a 3-D frame's E 2 % off, 9 x 9 FRFs: 9e4-1e5; virtual hammer tests of the beam with force noise, 0.5-1.4).
COMMON_SHAPE_RATIO = 10.0
#: ... and whose common varying part is at least this large (relative, rms over the lines): the benchmark beam's data
#: from a finer mesh with 1 % force noise got a 0.83 % rms common correction (ratio 45) on 1 of 4 seeds with its joint
#: right to 0.02 %; the frame's E 2 % off 19 %.
COMMON_SHAPE_MIN_RMS = 0.01
#: Fewest residual equations per line (``m e`` minus the joint's parameters) for the units check.
UNITS_MIN_REDUNDANCY = 6
#: The smooth-residual limit of the model check once a column error was found and not applied (it made the free model
#: fit worse): a reason for suspicion (:func:`_calibration_worsens_fit`).
SUSPECT_SMOOTH_EXCESS = SMOOTH_EXCESS_WITH_FAILED_BAND


def identify_joint_coupling(free, measured: FRF, joint_dofs: Sequence, options: CouplingOptions | None = None) -> CouplingResult:
    """Identify a joint's dynamic stiffness from measured FRFs by weighted receptance coupling.

    Parameters
    ----------
    free : Structure or FreeModel
        The free structure (accelerometers included, as in the test); anything with
        ``dofs`` and ``receptance(frequency, rows, cols)``.
    measured : FRF
        Constrained-structure FRFs, any kind (converted exactly to receptance),
        responses m x references e; ``measured.coherence`` (if present) weights them.
    joint_dofs : sequence of Dof or labels
        Joint coordinates n, e.g. ``["10w", "10theta"]``.
    options : CouplingOptions, optional

    Returns
    -------
    CouplingResult

    Raises
    ------
    IdentificationError
        Too few observed or excited coordinates (also once dead channels are left out), a DOF not in the model,
        a 0 Hz line, a dead acquisition, joint DOFs the FRFs cannot see (:mod:`jointid.methods.frf_screening`).
    """
    options = options or CouplingOptions()
    model = as_free_model(free)
    n_dofs = parse_dofs(joint_dofs)
    m_dofs, e_dofs = measured.responses, measured.references
    check_layout(len(n_dofs), m_dofs, e_dofs)
    have = set(model.dofs)
    for what, group in (("joint", n_dofs), ("observed", m_dofs), ("excited", e_dofs)):
        missing = [str(d) for d in group if d not in have]
        if missing:
            raise IdentificationError(f"{what} DOF(s) {missing} are not DOFs of the free model")
    freq = measured.frequency
    if freq.hz[0] <= 0.0:
        raise IdentificationError("the receptance method needs frequencies > 0 Hz (a free structure is singular at 0 Hz); drop the 0 Hz line")
    H = measured.to("receptance").data
    coherence = getattr(measured, "coherence", None)
    Y = model.receptance(freq, tuple(m_dofs) + tuple(n_dofs), tuple(n_dofs) + tuple(e_dofs))  # one call: rows m, n; cols n, e
    nm, nn = len(m_dofs), len(n_dofs)
    Ymn, Yme, Ynn, Yne = (np.ascontiguousarray(b) for b in (Y[:, :nm, :nn], Y[:, :nm, nn:], Y[:, nm:, :nn], Y[:, nm:, nn:]))
    # dead, invisible and degenerate data are found before anything is solved (jointid.methods.frf_screening)
    screen = screen_measured(H, coherence, Yme, m_dofs, e_dofs)
    if screen.findings:
        r, c = screen.rows, screen.cols
        dropped = [str(m_dofs[i]) for i in range(nm) if i not in r] + [str(e_dofs[j]) for j in range(len(e_dofs)) if j not in c]
        if r.size < nn or c.size < nn:
            raise IdentificationError(
                f"after leaving out the dead channel(s) {', '.join(dropped)}, {r.size} observed and {c.size} excited DOFs remain "
                f"for {nn} joint DOFs (each needs at least {nn}): the joint's terms cannot be identified; repeat the measurement "
                "with those channels working"
            )
        m_dofs, e_dofs = tuple(m_dofs[i] for i in r), tuple(e_dofs[j] for j in c)
        H, Ymn, Yne, Yme = H[:, r][:, :, c], Ymn[:, r], Yne[:, :, c], Yme[:, r][:, :, c]
        coherence = None if coherence is None else np.asarray(coherence)[:, r][:, :, c]
        nm = len(m_dofs)
    check_visibility(Ymn, Ynn, Yne, n_dofs)
    notes = list(screen.findings)
    kron = uses_kronecker(freq.size, nm, len(e_dofs), nn, options.symmetric)
    # junk lines (coherence or residual) are left out before the variance model, calibration and smoothing see them
    junk = junk_lines(freq.hz, H, coherence, Ymn, Yne, Yme, options.symmetric, residuals=not kron)
    if junk.finding:
        k = junk.keep
        freq, H, Ymn, Yne, Ynn, Yme = Frequency(freq.hz[k]), H[k], Ymn[k], Yne[k], Ynn[k], Yme[k]
        coherence = None if coherence is None else np.asarray(coherence)[k]
        notes.append(junk.finding)
    variance, source = frf_variance(H, coherence, options.weighting, options.averages)
    variance = floor_exact_zeros(variance, H, RELATIVE_FLOOR)
    measured_H, measured_variance = H, variance  # the joint spline fit's data (it fits its own noise scale)
    # coherence identically 1 carries no noise information: the variance is measured from the residuals of the
    # per-line fit once column errors are removed (below), where each line has the redundancy for it
    unknown = source == "coherence" and noise_level_unknown(coherence)
    params = nn * (nn + 1) // 2 if options.symmetric else nn * nn
    measurable = nm * len(e_dofs) - params >= RESIDUAL_MIN_REDUNDANCY
    floor = False  # no coherence, and the noise is not relative (a hammer's floor): measured like an unknown level
    # the column checks (calibration, units, force noise) and the noise-model choice need equations beyond the joint's
    # terms and the excitation columns' directions (the choice leaves the columns' part of the residuals out)
    columns_checked = kron or column_redundancy(Ymn, Yne, Yme, variance, options.symmetric) >= MIN_COLUMN_REDUNDANCY
    if source == "relative" and options.weighting == "auto" and measurable and not kron and columns_checked:
        choice = choose_noise_model(Ymn, Yne, Yme - H, H, options.symmetric)
        if choice is not None and choice.floor:  # the floor shape weights the calibration, then the variance is measured
            floor = unknown = True
            variance = shape = choice.variance
            notes.append(choice.finding)
    cal, applied = None, False
    if not columns_checked:
        if options.calibration == "columns":
            raise IdentificationError("calibration = 'columns': this layout leaves no residual outside the excitation columns' "
                                      "directions (e.g. observed = excited DOFs, as many as the joint's), so no column error can be "
                                      "estimated; use 'auto' or 'none', or observe more DOFs")
        notes.append(f"this layout ({nm} observed x {len(e_dofs)} excited DOFs for {nn} joint DOFs) leaves no residual outside the "
                     "excitation columns' directions: the force calibration, units and force-noise checks cannot run (the FRFs' "
                     "units and noise model are taken as given); observe more DOFs than the joint has (`jointid design`) to have them")
    if kron:  # many joint DOFs: no full design, no calibration
        if options.calibration == "columns":
            raise IdentificationError(f"calibration = 'columns' needs the full per-line design, too large for {nn} joint DOFs on {freq.size} lines; use 'auto' or 'none'")
    elif options.calibration != "none" and columns_checked:
        # the calibration removes the column-common error: what is left in each value is its
        # variance without the column-common part (frf_variance.column_noise_fraction)
        left = variance * column_noise_fraction(H, coherence) if source == "coherence" and not unknown else variance
        cal = estimate_column_calibration(freq.hz, Ymn, Yne, Yme - H, H, left, options.symmetric, options.calibration_basis)
        applied = cal is not None and (options.calibration == "columns" or cal.significant)
        if applied:  # weights: the variance left once the column error is removed, measured from the residuals
            variance = residual_variance(Ymn, Yne, Yme - cal.apply(H, left)[0], left, options.symmetric)
            if variance is None:
                variance = left
            else:
                cal = estimate_column_calibration(freq.hz, Ymn, Yne, Yme - H, H, variance, options.symmetric, options.calibration_basis) or cal
    checked = _units_check(freq, Ymn, Yne, Yme, H, variance, cal, options, kron, notes, (m_dofs, e_dofs)) if columns_checked else None
    units_flagged = checked is not None  # used as they are (units_check = false): noted, every line flagged
    if unknown and not applied and measurable and not kron:
        measured_var = residual_variance(Ymn, Yne, Yme - H, variance, options.symmetric)
        variance = variance if measured_var is None else measured_var
    if unknown and not floor:
        notes.append("the coherence is identically 1 (one average per excitation, or noise-free data): the FRF noise level "
                     "is unknown, so it was measured from the residuals of the per-line fit"
                     + ("" if measurable or applied else " (its scale per line only: the layout has too few equations per line for more)"))
    variance = floor_exact_zeros(variance, H, RELATIVE_FLOOR)
    common = None
    suspect = False  # a column error found and not applied (it made the fit worse): the model check is stricter
    stats = None  # the model check's residual statistics, when already computed on the FRFs used below
    if applied:
        raw = H, variance
        H, variance = cal.apply(H, variance)
        common = cal.x_covariance
        fit = (_calibration_worsens_fit(freq.hz, Ymn, Yne, Yme, raw, (H, variance), options.symmetric)
               if options.calibration == "auto" and options.model_check and not kron else None)
        if fit is not None and fit.worse:
            (H, variance), common, applied, suspect = raw, None, False, True
            notes.append(f"a force calibration error of the excitation columns was found (F test p = {cal.p_value:.2g}) but "
                         "the corrected FRFs fit the free model worse than the measured ones (its model check fails with it "
                         "and passes without it): not applied")
        if fit is not None and not floor:  # the check below weighs by the same variance: computed once
            stats = fit.raw if fit.worse else fit.corrected
    shared = (applied and options.calibration == "auto" and cal.common_shape_ratio > COMMON_SHAPE_RATIO
              and cal.common_shape_rms > COMMON_SHAPE_MIN_RMS)
    if shared:  # a correction that a free-model error makes: the joint terms would take what it leaves (module docstring)
        notes.append(f"the force calibration correction is alike on every column and varies over frequency ({100 * cal.common_shape_rms:.2g} % "
                     f"rms, {cal.common_shape_ratio:.3g} times its differences between the columns), as an error of the free "
                     "model makes it, not the forces of separate hits: the free model may be off, and the joint's terms take "
                     "what the correction leaves; every term flagged unreliable on every line. Update the free model from a "
                     "free-free test (`jointid update`), or set calibration = \"columns\" if the forces are known to be off so")
        checked = np.ones(freq.size, bool)
    # without coherence, a random error common to each excitation column line by line (force noise) is tested for
    # in the residuals and, when found, weighted by its own covariance (:mod:`.force_noise`)
    force = (detect_force_noise(Ymn, Yne, Yme - H, H, variance, options.symmetric)
             if source == "relative" and not floor and not kron and columns_checked else None)
    force_note = None  # where the force noise's finding is (reworded when the model check finds the free model off)
    if force is not None and force.significant:
        force_note = len(notes)
        notes.append(force.finding)
        lines = force.line_estimates(Ymn, Yne, Ynn, Yme - H, H, variance, options.symmetric, common_x_covariance=common)
    else:
        lines = coupling_per_line(Ymn, Yne, Ynn, Yme - H, variance, options.symmetric, common_x_covariance=common)
    # with a measured variance the check weights by the chosen shape: the running means of the residuals would hold a
    # free-model error as "noise" and hide it
    if stats is None and options.model_check and not kron:
        stats = residual_statistics(Ymn, Yne, Yme - H, shape if floor else variance, options.symmetric)
    proven_wrong = False
    if stats is not None:  # does the free model explain the FRFs, band by band (model_check)?
        check = check_model(freq.hz, stats, smooth_limit=SUSPECT_SMOOTH_EXCESS if suspect else SMOOTH_EXCESS_LIMIT)
        proven_wrong = check.proven_wrong
        if (not check.fits or shared) and not units_flagged:
            # FRFs the free model does not explain: a slip in the data (units, a sign, a dead channel) before the model
            gross = gross_error(Ymn, Yne, Yme, measured_H, measured_variance, options.symmetric, m_dofs, e_dofs)
            if gross is not None:
                checked = _refuse(freq, gross, None, options, notes)
        if force_note is not None and (not check.fits or shared):
            notes[force_note] = force.finding_text(model_fits=False)
        if not check.fits:
            notes.append(check.finding(freq.hz, [f"{r}/{c}" for r, c, mark in measured.marks if mark == LEAKAGE_MARK]))
            checked = check.failed_lines if checked is None else checked | check.failed_lines
    spline = None
    if options.over_frequency(nn) == "spline" and not _exact(lines):  # exact data: the per-line estimates are the answer
        if not options.symmetric:
            raise IdentificationError('smoothing = "spline" fits a symmetric joint; use symmetric = true or another smoothing')
        if proven_wrong or shared:  # every line is flagged anyway: the fit of all lines at once (minutes on a 6-DOF mount) is not run
            why = "the free model does not explain these FRFs (above)" if proven_wrong else "the column correction is one a free-model error makes (above)"
            notes.append(f"the joint spline fit was not run: {why}, so every "
                         "line is flagged whatever the estimate; each term smoothed on its own instead")
        else:
            # the FRFs as measured: the fit of every line at once has its own noise scale, and a column correction
            # estimated line by line would be a second model of the same data
            spline = fit_joint_spline(freq.hz, Ymn, Ynn, Yne, Yme, measured_H, measured_variance, symmetric=True,
                                      initial=lines.stiffness)
            if not spline.converged:
                notes.append("the joint spline fit did not converge on these FRFs (smoothing = \"spline\"): each term "
                             "smoothed on its own instead")
                spline = None
    uncertain = None
    if isinstance(model, UncertainFreeModel) and (model.directions or model.references):  # the free model's error -> the bands
        dY = model.receptance_deviations(freq, tuple(m_dofs) + tuple(n_dofs), tuple(n_dofs) + tuple(e_dofs))
        blocks = [(d[:, :nm, :nn], d[:, nm:, nn:], d[:, nm:, :nn], d[:, :nm, nn:]) for d in dY]

        def uncertain(K):
            return model_uncertainty(Ymn, Yne, Ynn, Yme, blocks, K, variance, options.symmetric, model.described)
    correlation = None if stats is None else (stats.correlation, stats.correlation_z)
    return _finish(freq, n_dofs, lines, source, options, cal, applied, tuple(notes), checked, spline, uncertain, correlation)


class _CalibratedFit(NamedTuple):
    """Whether a column correction makes the free model fit worse, and the model check's residual statistics of the
    corrected and the measured FRFs (:func:`_calibration_worsens_fit`; None: not computed)."""

    worse: bool
    corrected: ResidualStatistics | None
    raw: ResidualStatistics | None


def _calibration_worsens_fit(hz, Ymn, Yne, Yme, raw: tuple, corrected: tuple, symmetric: bool) -> _CalibratedFit:
    """Whether the calibrated FRFs fail the model check (:func:`~.model_check.check_model`) while the measured ones pass it.

    A correction that makes the free model fit worse is not one: on a 3-D frame with its right free model (9 x 9 FRFs,
    1 % relative noise) the calibration's F test came out 14-16 with no column error on 7 of 8 seeds, and the corrected
    FRFs missed the free model by 42x the noise at 2-15.5 Hz. A column error found and then not applied is a reason
    for suspicion: the measured FRFs must then pass with the lower smooth-residual limit
    (:data:`SUSPECT_SMOOTH_EXCESS`, also used by the model check that follows): with E 2 % off on that frame their
    smooth excess was 0.046-0.081, with the right model 0.001. ``raw``, ``corrected``: ``(H, variance)`` each. The
    statistics are returned for the model check that follows (computed once).
    """
    fixed = residual_statistics(Ymn, Yne, Yme - corrected[0], corrected[1], symmetric)
    if fixed is None or check_model(hz, fixed).fits:
        return _CalibratedFit(False, fixed, None)
    measured = residual_statistics(Ymn, Yne, Yme - raw[0], raw[1], symmetric)
    worse = measured is not None and check_model(hz, measured, smooth_limit=SUSPECT_SMOOTH_EXCESS).fits
    return _CalibratedFit(worse, fixed, measured)


def _units_check(freq: Frequency, Ymn, Yne, Yme, H, variance, cal, options: CouplingOptions, kron: bool, notes: list,
                 dofs: tuple) -> np.ndarray | None:
    """Refuse FRFs off by one gross factor in every column (:mod:`.units_check`) or by a gross error that one slip explains
    (:mod:`.gross_errors`: a column off by more than :data:`~.gross_errors.GROSS_COLUMN_ERROR` starts that search too),
    or (``units_check = False``) note it and return every line as flagged (else None). The column calibration's
    estimate is used when there is one. ``dofs``: the observed and the excited DOFs, named in the conclusion."""
    F, m, n = Ymn.shape
    if kron or m * Yne.shape[2] - n * (n + 1) // 2 < UNITS_MIN_REDUNDANCY:  # too few equations: a column factor trades with X
        return None
    if cal is None:  # not estimated (calibration = "none", or too few lines for its basis): a coarse one for the check
        cal = estimate_column_calibration(freq.hz, Ymn, Yne, Yme - H, H, variance, options.symmetric, UNITS_BASIS)
    units = units_conclusion(cal)
    gross_column = cal is not None and cal.significant and float(np.max(np.median(np.abs(cal.error), axis=0))) > GROSS_COLUMN_ERROR
    if units is None and not gross_column:
        return None
    gross = gross_error(Ymn, Yne, Yme, H, variance, options.symmetric, *dofs)
    if gross is None and units is None:
        return None
    if units is not None and gross is not None and gross.kind == "units":  # the units check's own conclusion names it
        gross = None
    return _refuse(freq, gross, units, options, notes)


def _refuse(freq: Frequency, gross: GrossError | None, units: str | None, options: CouplingOptions, notes: list) -> np.ndarray:
    """Raise the DataError of a gross error (its explanation, else the units check's conclusion ``units``), or
    (``units_check = False``) note it and return every line as flagged."""
    if gross is not None:
        what, fix = gross.conclusion, "; or set [identification] units_check = false to use the FRFs as they are"
    else:
        what, fix = units, (": give the file's units (UFF dataset 164 / unit labels; a CSV file is read in SI units), check "
                            "the study's free model, or set [identification] units_check = false to use them as they are")
    if options.units_check:
        raise DataError(what + fix)
    notes.append(f"{what}: used as they are (units_check = false); every term flagged unreliable")
    return np.ones(freq.size, bool)


def _structured(freq: Frequency, lines, options: CouplingOptions, cal, applied) -> tuple[StructuredEstimate | None, str]:
    """The structured estimate when the options and the data call for it (module docstring), else None and why not."""
    if options.smoothing not in ("auto", "structured"):
        return None, ""
    n = lines.stiffness.shape[1]
    limit = AUTO_STRUCTURED_MAX_DOFS if options.smoothing == "auto" else STRUCTURED_MAX_DOFS
    why = ""
    if n > limit:
        why = f"the joint has {n} DOFs (the structured model is used for at most {limit})"
    elif not options.symmetric:
        why = "symmetric = false (the structured model is symmetric)"
    elif lines.x_covariance is None:
        why = "the per-line covariance is not formed for this many joint DOFs"
    elif freq.size < STRUCTURED_MIN_LINES:
        why = f"{freq.size} lines (the structured model needs at least {STRUCTURED_MIN_LINES})"
    elif applied and cal.x_factor is None:
        why = "the column calibration has no factor for it"
    elif _exact(lines):
        return None, ""  # exact data: the per-line estimates are the answer
    if why:
        return None, (f"smoothing = \"structured\" not used: {why}; each term smoothed on its own instead" if options.smoothing == "structured" else "")
    try:
        return structured_estimate(freq.hz, lines, cal.x_factor if applied else None), ""
    except (np.linalg.LinAlgError, ValueError):  # singular covariances: per-term smoothing
        return None, "the structured joint model could not be fitted (singular per-line covariances): each term smoothed on its own instead"


def _median_relative_std(variance: np.ndarray, value: np.ndarray) -> float:
    """Median over lines of ``sqrt(variance) / |value|`` of one term (NaN when no line has one)."""
    with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN: a layout without redundancy
        return float(np.nanmedian(np.sqrt(variance) / np.abs(value)))


def _exact(lines) -> bool:
    """Every term's per-line estimates are exact to :data:`SMOOTH_MIN_RELATIVE_STD` (median std relative to the term's
    scale, :func:`~jointid.methods.estimate.term_scale`: a zero coupling is judged on its two DOFs' scale; NaN: not
    exact). (Relative to ``|K|`` a mount's absent couplings made exact FRFs look noisy, and the spline fit's bias at the
    band's edges -- 10 % on K_rx_rx at 10 Hz -- replaced the exact per-line values.)"""
    n = lines.stiffness.shape[1]
    scale = term_scale(lines.stiffness)
    return all(_median_relative_std(lines.variance[:, a, b], scale[:, a, b]) <= SMOOTH_MIN_RELATIVE_STD
               for a in range(n) for b in range(a, n))


def _finish(freq: Frequency, n_dofs, lines, source: str, options: CouplingOptions, cal=None, applied=False, data_notes=(),
            checked=None, spline: JointSplineFit | None = None, uncertain=None,
            residual_correlation: tuple[float, float] | None = None) -> CouplingResult:
    """Estimate over frequency (the joint spline fit, the structured model, or each term smoothed and relinearized),
    propagate the variance (and ``uncertain(K)``'s: the free model's parameter uncertainty,
    :mod:`.model_uncertainty`), set the flags (every term unreliable on the ``checked`` lines: the units or the model
    check failed there); ``residual_correlation``: the model check's lag-1 correlation of the residuals and its z-score
    (:class:`~.model_check.ResidualStatistics`), kept for the findings."""
    structured, note = _structured(freq, lines, options, cal, applied)
    fallback_note = ""
    if spline is not None:  # every line at once, on the FRFs as measured: its covariance from the Jacobian
        K, var_re, var_im = spline.stiffness, spline.std_real ** 2, spline.std_imag ** 2
        labels = dof_term_labels(n_dofs)
        a, b = np.triu_indices(len(n_dofs))
        edf = {f"K_{labels[i]}_{labels[j]}": (None if spline.term_basis is None else float(spline.term_basis[t]))
               for t, (i, j) in enumerate(zip(a, b))}
    elif structured is not None and structured.accepted:
        K, edf = structured.stiffness, {}
        var_re, var_im = structured.std_real ** 2, structured.std_imag ** 2
    else:
        K, var_re, var_im, edf, scales = _smooth_terms(freq, n_dofs, lines, options)
        for _ in range(RELINEARIZATIONS if any(v is not None for v in edf.values()) else 0):
            lines_k = relinearize(lines, K)
            K, var_re, var_im, edf, scales = _smooth_terms(freq, n_dofs, lines_k, options)
        if not (structured is not None and structured.shape_only):  # lines erring more than their variance (fallback_bands)
            misfit = structured is not None and not structured.accepted and structured.best.chi2_per_dof > MAX_CHI2_PER_DOF
            half = {name: resolution_lines(freq.size, e) for name, e in edf.items() if e is not None}
            wide = widen_fallback_bands(K, var_re, var_im, scales, half, structured.stiffness if misfit else None, options.symmetric)
            var_re, var_im = wide.var_real, wide.var_imag
            fallback_note = wide.finding()
        if structured is not None and structured.shape_only:
            # residuals correlated over frequency, misfit within chi^2: out of the class, or noise correlated between
            # lines (leakage). The structured estimate is kept with bands that hold its difference from each term
            # smoothed on its own: var = max(var_structured, var_smoothed + (K_structured - K_smoothed)^2) per part
            # (the nonparametric fit unbiased: the band keeps its level for any bias of the structured one)
            Ks = structured.stiffness
            var_re = np.maximum(structured.std_real ** 2, var_re + (Ks.real - K.real) ** 2)
            var_im = np.maximum(structured.std_imag ** 2, var_im + (Ks.imag - K.imag) ** 2)
            K, edf = Ks, {}
    if uncertain is not None:
        mu: ModelUncertainty = uncertain(K)
        var_re, var_im = var_re + mu.variance_real, var_im + mu.variance_imag
        said = mu.finding(freq.hz, term_names(n_dofs), var_re, var_im)
        data_notes = tuple(data_notes) + ((said,) if said else ())
    std_re, std_im = np.sqrt(np.maximum(var_re, 0.0)), np.sqrt(np.maximum(var_im, 0.0))  # round-off of a singular design can go below 0
    diag = np.arange(lines.stiffness.shape[1])
    passive = ~(K[:, diag, diag].imag < -Z90 * std_im[:, diag, diag])
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.hypot(std_re, std_im) / term_scale(K)
    reliable = (rel <= options.threshold(term_names(n_dofs))[None]) & (lines.condition <= MAX_CONDITION)[:, None, None]
    reliable[:, diag, diag] &= passive
    per_line = (spline is None and not (structured is not None and (structured.accepted or structured.shape_only))
                and all(v is None for v in edf.values()))
    if per_line:  # the per-line values are the result: their linearized variance must hold (inverse_perturbation)
        eta = inverse_perturbation(lines)
        if eta is not None and np.any(eta > MAX_INVERSE_PERTURBATION):
            far = eta > MAX_INVERSE_PERTURBATION
            reliable &= ~far[:, None, None]
            finite = eta[np.isfinite(eta)]
            top = f"up to {finite.max():.2g}x" if finite.size else "no finite estimate"
            data_notes = tuple(data_notes) + (
                f"on {int(far.sum())} of {far.size} lines one standard deviation of the coupling estimate moves the "
                f"joint's inverse by more than {100 * MAX_INVERSE_PERTURBATION:.0f} % ({top}): "
                "the per-line values and their predicted errors do not hold there (the FRFs see some of the "
                "joint's directions too weakly there), so every term is flagged unreliable on those lines; observe the joint's DOFs "
                "in every direction (`jointid design`) or let the terms be smoothed (smoothing = \"auto\")",)
    if checked is not None:
        reliable &= ~checked[:, None, None]
    return CouplingResult(
        freq, tuple(n_dofs), K, std_re, std_im, lines.stiffness, np.sqrt(np.maximum(lines.variance + (lines.common_variance if lines.common_variance is not None else 0.0), 0.0)),
        reliable, passive, lines.condition, lines.scale, source, edf, options, cal, applied, structured, note, data_notes, checked,
        spline, residual_correlation, fallback_note,
    )


def _smooth_terms(freq: Frequency, n_dofs, lines, options: CouplingOptions):
    """Smoothed stiffness, the variance of its real and imaginary parts (scaled where the residuals exceed it:
    :func:`.smoothing.residual_scale`), the smoother's edf per term and, per smoothed term, ``(a, b, largest scale)``."""
    F, n, _ = lines.stiffness.shape
    K = lines.stiffness.copy()
    var_re = lines.variance / 2.0  # circular errors: half in each part
    var_im = lines.variance / 2.0
    edf: dict = {}
    scales: dict = {}
    # symmetric: the upper triangle carries every term (mirrored); otherwise each entry on its own
    pairs = [(a, b) for a in range(n) for b in range(a if options.symmetric else 0, n)]
    labels = dof_term_labels(n_dofs)
    scale = term_scale(lines.stiffness)  # as _exact judges: an absent coupling on its two DOFs' scale
    for a, b in pairs:
        name = f"K_{labels[a]}_{labels[b]}"
        y, v = lines.stiffness[:, a, b], lines.variance[:, a, b]
        if options.smoothing == "none" or F < 8 or not _median_relative_std(v, scale[:, a, b]) > SMOOTH_MIN_RELATIVE_STD:
            edf[name] = None
            continue
        re = smooth_series(freq.hz, y.real, v / 2.0, options.n_basis)
        im = smooth_series(freq.hz, y.imag, v / 2.0, options.n_basis)
        edf[name] = re.edf
        # the posterior variance scaled where the residuals say the lines err more than their variance
        sr, si = residual_scale(y.real, v / 2.0, re), residual_scale(y.imag, v / 2.0, im)
        vr, vi = re.variance * sr, im.variance * si
        scales[name] = (a, b, float(max(sr.max(), si.max())))
        for i, j in {(a, b), (b, a)} if options.symmetric else {(a, b)}:
            K[:, i, j] = re.value + 1j * im.value
            var_re[:, i, j], var_im[:, i, j] = vr, vi
    if lines.common_variance is not None:  # common to all lines: smoothing does not reduce it
        var_re = var_re + lines.common_variance / 2.0
        var_im = var_im + lines.common_variance / 2.0
    return K, var_re, var_im, edf, scales
