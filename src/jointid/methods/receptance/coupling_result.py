"""The receptance estimator's result: a :class:`~jointid.methods.estimate.JointEstimate` with per-term bands and flags.

Made by :func:`jointid.methods.receptance.coupling.identify_joint_coupling`; what made its
stiffness (the joint spline fit, the structured model, per-term smoothing or the per-line
estimates), the per-line fit, the calibration and the data checks are kept for the findings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ...dofs import Dof
from ...frequency import Frequency
from ...terms import term_names
from ..estimate import JointEstimate
from .column_calibration import CALIBRATION_BASIS, ColumnCalibration
from .model_check import CORRELATED_RESIDUAL_Z
from .options import MAX_CONDITION, CouplingOptions
from .spline_fit import JointSplineFit
from .structured_select import StructuredEstimate

__all__ = ["CouplingResult", "GROSS_CALIBRATION_ERROR", "SAME_ERROR_SPREAD", "SAME_ERROR_MIN"]

#: A median column calibration error above this (relative) is reported as a units or sensitivity problem.
GROSS_CALIBRATION_ERROR = 0.1
#: Column errors whose spread (max - min) is below this fraction of their median are "alike on every column": a free
#: model's stiffness or mass off by about as much makes them so too.
SAME_ERROR_SPREAD = 0.3
#: ... and each above this (relative): below it, force noise alone makes such errors.
SAME_ERROR_MIN = 0.01


@dataclass(frozen=True, eq=False)
class CouplingResult(JointEstimate):
    """The receptance estimator's :class:`~jointid.methods.estimate.JointEstimate`: per-term uncertainty and reliability.

    Attributes
    ----------
    frequency : Frequency
    joint_dofs : tuple of Dof
    stiffness : ndarray, shape (F, n, n), complex
        The estimate (smoothed unless ``smoothing="none"``): N/m, N/rad, N*m/m, N*m/rad.
    std_real, std_imag : ndarray, shape (F, n, n)
        1-sigma standard deviation of the real and imaginary part of each term.
    per_line : ndarray, shape (F, n, n), complex
        The per-line weighted least-squares estimate before smoothing.
    per_line_std : ndarray, shape (F, n, n)
        Its standard deviation ``sqrt(E|dK|^2)``.
    reliable_terms : ndarray of bool, shape (F, n, n)
    passive : ndarray of bool, shape (F, n)
        Loss factor of each diagonal term not significantly negative.
    condition : ndarray, shape (F,)
        Condition number of the weighted design per line.
    residual_scale : ndarray, shape (F,)
        Residual variance factor (chi^2 per degree of freedom; ~1 when the weights' scale is right).
    weighting : str
        The FRF variance model used.
    smoothing_edf : dict
        Term name -> effective degrees of freedom of the smoother (real part), or None if not smoothed.
    options : CouplingOptions
    calibration : ColumnCalibration or None
        The excitation columns' force-calibration error, if it was estimated.
    calibration_applied : bool
        The FRFs were corrected by it (its uncertainty is in the bands).
    structured : StructuredEstimate or None
        The structured joint model's estimate when it was fitted (``structured.accepted``:
        it is the result; else the P-spline is, and :meth:`findings` says why).
    estimator_note : str
        Why the structured model was not fitted when it was asked for or failed (a finding), else "".
    data_notes : tuple of str
        What the data screening found (:mod:`jointid.methods.frf_screening`): channels and junk lines left out, an
        unknown noise level, FRFs used as they are despite the units check, the free model's misfit per band.
    checked_unreliable : ndarray of bool, shape (F,), or None
        Lines flagged unreliable on every term by the units or the model check (a data note says why).
    spline : JointSplineFit or None
        The joint spline fit of every term over all lines (``smoothing = "spline"``): it is the result.
    residual_correlation : (float, float) or None
        Lag-1 correlation over frequency of the per-line fit's whitened residuals and its z-score
        (:class:`~jointid.methods.receptance.model_check.ResidualStatistics`); None when the model check did not run.
    fallback_note : str
        Which smoothed terms' bands were widened because their lines err more than their variance, and how
        (:class:`~jointid.methods.receptance.fallback_bands.FallbackWidening`), else "".
    """

    std_real: np.ndarray
    std_imag: np.ndarray
    per_line: np.ndarray
    per_line_std: np.ndarray
    reliable_terms: np.ndarray
    passive: np.ndarray
    condition: np.ndarray
    residual_scale: np.ndarray
    weighting: str
    smoothing_edf: dict
    options: CouplingOptions
    calibration: ColumnCalibration | None = None
    calibration_applied: bool = False
    structured: StructuredEstimate | None = None
    estimator_note: str = ""
    data_notes: tuple[str, ...] = ()
    checked_unreliable: np.ndarray | None = None
    spline: JointSplineFit | None = None
    residual_correlation: tuple[float, float] | None = None
    fallback_note: str = ""

    method: ClassVar[str] = "receptance"

    def line_estimates(self) -> np.ndarray:
        """The per-line weighted least-squares estimates before smoothing, (F, n, n)."""
        return self.per_line

    @property
    def estimator(self) -> str:
        """What made :attr:`stiffness`: ``"spline"``, ``"structured"``, ``"gcv"`` (P-spline per term) or ``"per-line"``."""
        if self.spline is not None:
            return "spline"
        if self.structured is not None and (self.structured.accepted or self.structured.shape_only):
            return "structured"
        return "gcv" if any(v is not None for v in self.smoothing_edf.values()) else "per-line"

    def describe_estimator(self) -> str:
        """One line: what made :attr:`stiffness` (the structured model's order, internal modes and chi^2/dof)."""
        name = self.estimator
        if name == "spline":
            return self.spline.describe()
        if name == "structured":
            return self.structured.describe()
        if name == "gcv":
            return "each term smoothed over frequency on its own (P-spline, lambda by GCV)"
        return "per-line estimates (not smoothed)"

    def estimator_summary(self) -> dict:
        """JSON-ready: ``estimator``, ``description`` and, when fitted, the structured model's diagnostics."""
        out = {"estimator": self.estimator, "description": self.describe_estimator()}
        out.update(self._structured_summary())
        if self.spline is not None:
            sp = self.spline
            out["spline"] = {"n_basis": int(sp.n_basis), "chi2_per_dof": float(sp.chi2_per_dof), "converged": bool(sp.converged),
                             "aic_and_chi2_per_dof": {str(k): [float(v[0]), float(v[1])] for k, v in sp.criterion.items()},
                             "bias_band_n_basis": sp.bias_basis}
        return out

    def _structured_summary(self) -> dict:
        out = {}
        st = self.structured
        if st is not None:
            out["structured"] = {
                "accepted": st.accepted,
                "best_order": {"internal_modes": st.best.model.n_modes, "modulus_basis": st.best.model.g_basis, "residual": st.best.model.residual},
                "chi2_per_dof": st.best.chi2_per_dof,
                "whiteness_z": None if st.membership is None else float(st.membership.z),
                "internal_modes_hz": [float(v) for v in st.best.poles_hz()],
                "akaike_weights": {st.fits[o].model.label: float(w) for o, w in st.weights.items()},
                "seconds": st.seconds,
            }
        return out

    def subset(self, indices) -> "CouplingResult":
        """The result on a subset of the joint DOFs (e.g. one of several joints identified together).

        Every (F, n, n) array is cut to the ``indices`` block and ``passive`` to
        those diagonal terms; per-line diagnostics (condition, residual scale,
        calibration) are those of the joint estimate. Term names follow the
        subset's own DOFs (:func:`~jointid.terms.dof_term_labels`).
        """
        idx = np.asarray(list(indices), dtype=int)
        blk = np.ix_(np.arange(self.stiffness.shape[0]), idx, idx)
        dofs = tuple(self.joint_dofs[i] for i in idx)
        old = {(a, b): name for a, b, name in self.term_names()}
        edf = {}
        for a, b, name in term_names(dofs):
            key = old[(int(idx[a]), int(idx[b]))]
            if key in self.smoothing_edf:
                edf[name] = self.smoothing_edf[key]
        return CouplingResult(
            self.frequency, dofs, self.stiffness[blk], self.std_real[blk], self.std_imag[blk], self.per_line[blk],
            self.per_line_std[blk], self.reliable_terms[blk], self.passive[:, idx], self.condition, self.residual_scale,
            self.weighting, edf, self.options, self.calibration, self.calibration_applied, self.structured, self.estimator_note,
            self.data_notes, self.checked_unreliable, self.spline, fallback_note=self.fallback_note,
        )

    def options_summary(self) -> dict:
        """JSON-ready: symmetric, smoothing, weighting (the variance model used), averages, max_relative_std, calibration."""
        o = self.options
        return {"symmetric": o.symmetric, "smoothing": o.smoothing, "weighting": self.weighting, "averages": o.averages,
                "max_relative_std": o.max_relative_std, "calibration": o.calibration, "units_check": o.units_check,
                "model_check": o.model_check}

    def diagnostics(self) -> dict:
        """JSON-ready: the estimator that made the result (structured model's orders), largest condition, residual scale."""
        return {
            "estimator": self.estimator_summary(),
            "max_condition": float(np.max(self.condition)),
            "median_residual_scale": float(np.nanmedian(self.residual_scale)) if np.isfinite(self.residual_scale).any() else None,
            "smoothing_edf": {k: (None if v is None else float(v)) for k, v in self.smoothing_edf.items()},
        }

    def _correlated_residuals(self) -> str:
        """Why a whiteness rejection may not be the joint's: the FRFs' own residuals correlated over frequency, else ""."""
        if self.residual_correlation is None:
            return ""
        rho, z = self.residual_correlation
        if not (np.isfinite(z) and z > CORRELATED_RESIDUAL_Z):
            return ""
        return (f"the FRFs' residuals to the free model are themselves correlated over frequency (lag-1 correlation "
                f"{rho:.2f}, {z:.0f} standard deviations above 0, its value for errors independent from line to line): the "
                "FRFs' errors are shared by neighbouring lines (an impact test's window or leakage bias, FRFs smoothed or "
                "interpolated onto a finer grid) or the free model is slightly off: the structured model's whiteness test cannot "
                "tell these from a joint outside its class, so its bands are kept wide; longer records with less windowing (or a "
                "step-sine test), FRFs on their measured grid, or an updated free model (`jointid update`) would tighten them")

    def findings(self) -> list[str]:
        """One line per term that the FRFs cannot determine on some lines, naming the bands and the predicted error."""
        f = self.frequency.hz
        out = list(self.data_notes)
        st = self.structured
        if st is not None and st.shape_only:
            out.append(st.finding.replace("; each term smoothed on its own instead",
                                          "; the structured estimate is kept with bands that hold its difference from each "
                                          "term smoothed on its own"))
            said = self._correlated_residuals()
            if said:
                out.append(said)
        elif st is not None and not st.accepted:  # why: chi^2, non-finite values
            out.append(st.finding)
        if self.estimator_note:
            out.append(self.estimator_note)
        if self.fallback_note:
            out.append(self.fallback_note)
        cal = self.calibration
        if cal is not None and self.calibration_applied:
            eps = 100 * np.median(np.abs(cal.error), axis=0)
            why = f"F test p = {cal.p_value:.2g}" if self.options.calibration == "auto" else 'calibration = "columns"'
            if cal.n_basis > CALIBRATION_BASIS:  # a finer basis than the default, taken because the data ask for it (column_calibration)
                knots = (f[-1] - f[0]) / max(cal.n_basis - 3, 1)
                why += (f"; varying over frequency on a {knots:.2g} Hz knot spacing ({cal.n_basis} functions per column, "
                        "the finest the data ask for), as the noise of a short force window does")
            out.append(
                "force calibration error of the excitation columns (median " + ", ".join(f"{v:.2g} %" for v in eps)
                + f"; {why}): corrected, its uncertainty is in the bands"
                + ("; more than force noise makes: check the hammer's sensitivity per column and the FRFs' units (a file "
                   "in g/N without unit labels is read as (m/s^2)/N)" if eps.max() > 100 * GROSS_CALIBRATION_ERROR else "")
                + _flipped_columns(cal.error)
                + ("; as alike on every column as a free model whose stiffness or mass is off by about as much makes it "
                   "(`jointid update` tells them apart)"
                   if eps.size > 1 and eps.min() > 100 * SAME_ERROR_MIN and np.ptp(eps) < SAME_ERROR_SPREAD * np.median(eps) else "")
            )
        rel = self.relative_std
        limit = self.options.threshold(self.term_names())  # max_relative_std, or a term's own target below it
        said = np.zeros(f.size, bool) if self.checked_unreliable is None else self.checked_unreliable  # those lines' finding is the check's
        ill = (self.condition > MAX_CONDITION) & ~said
        if ill.any():
            out.append(f"the FRFs do not separate the joint's terms {_where(f, ill)} (per-line condition number up to "
                       f"{np.max(self.condition[ill]):.2g} > {MAX_CONDITION:.0e}): every term flagged unreliable there, whatever its "
                       "predicted error; a layout that sees the joint there: `jointid design`")
        done = set()
        for a, b, name in self.term_names():
            if (b, a) in done:
                continue
            done.add((a, b))
            bad = ~self.reliable_terms[:, a, b] & ~said & ~ill
            if not bad.any():
                continue
            median = np.nanmedian(rel[bad, a, b]) if np.isfinite(rel[bad, a, b]).any() else np.nan
            where = _where(f, bad)
            err = f"predicted error {100 * median:.2g} %" if np.isfinite(median) else "no uncertainty: the layout has no redundancy"
            if limit[a, b] < self.options.max_relative_std:  # the study's own target for this term
                out.append(f"{name}: above its target {100 * limit[a, b]:.2g} % {where} ({err}, {100 * bad.mean():.0f} % of lines): "
                           "a layout that reaches it: `jointid design`")
            else:
                out.append(f"{name}: not identifiable from these FRFs {where} ({err}, {100 * bad.mean():.0f} % of lines)")
        return out


def _where(f: np.ndarray, lines: np.ndarray) -> str:
    """Where ``lines`` (bool, per line) are, for a finding: "on every line", "in a-b Hz, ..." or "on N scattered lines"."""
    if lines.all():
        return "on every line"
    edges = np.flatnonzero(np.diff(np.r_[0, lines.astype(int), 0]))
    spans = [(f[s], f[e - 1]) for s, e in zip(edges[::2], edges[1::2]) if e - s >= max(2, f.size // 100)]
    if not spans:
        return f"on {int(lines.sum())} scattered lines"
    return "in " + ", ".join(f"{lo:g}-{hi:g} Hz" for lo, hi in spans[:4]) + (" ..." if len(spans) > 4 else "")


def _flipped_columns(error: np.ndarray) -> str:
    """"; column(s) 2 ... the negative of ..." for excitation columns whose median error is -200 % (measured = -true)."""
    med = np.median(error.real, axis=0), np.median(error.imag, axis=0)
    flipped = [j + 1 for j in range(error.shape[1]) if abs(med[0][j] + 2.0) < 0.2 and abs(med[1][j]) < 0.2]
    if not flipped:
        return ""
    which = ", ".join(str(j) for j in flipped)
    return (f"; excitation column{'s' if len(flipped) > 1 else ''} {which} (in the study's order) measured the negative of "
            "what the free model predicts: a flipped sign of the hammer or of the responses' direction in that column")

