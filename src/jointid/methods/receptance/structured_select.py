"""The structured joint estimate: model order by AIC, model averaging, and the test that decides whether it is used.

:func:`structured_estimate` is what the default identification
(:func:`jointid.methods.receptance.coupling.identify_joint_coupling`, ``smoothing = "auto"``
or ``"structured"``) runs instead of per-term smoothing:

1. **Order** by greedy forward selection on Akaike's criterion
   (corrected for small samples, ``AICc = chi^2 + 2 P + 2 P (P + 1) / (N - P - 1)``, N real observations), from ``(0 internal modes, constant modulus g, no residual)``:
   each step fits the neighbours (one more mode, up to :data:`MAX_MODES`; ``+E``; ``g``
   constant -> spline of 4 -> 6) started from the current fit, and moves while AIC
   improves. With a column force calibration estimated as a nuisance, ``g`` stays
   constant: a frequency-dependent ``g`` and a smooth calibration error are nearly
   confounded (with the spline, K_theta_theta loses most of its accuracy).
   For the same reason only orders with the residual term ``E`` are kept then: with
   the calibration free, a model without ``E`` (e.g. a spurious second mode in the
   band instead) fits about as well but pins K_ww to a band several times narrower
   than the data support (its 90 % band misses the truth on most lines, where a model
   with ``E`` holds it).
   With more than :data:`SELECT_MAX_LINES` lines the order is chosen on an evenly
   spaced subset and the retained models are refitted on every line (up to
   :data:`REFIT_MAX_LINES`; above, the subset's fits are evaluated on every line and
   their bands carry only the subset's information: wider than they could be).
2. **Model averaging** (Buckland, Burnham & Augustin 1997): the fits are averaged
   with Akaike weights ``exp(-dAIC / 2)``, and the spread between them is added to
   each term's variance, so the bands carry the uncertainty of the order too (the
   selected model's own bands alone are too narrow: they ignore that the order was
   chosen from the data). ``benchmarks/structured_fit.py`` prints the averaged bands'
   coverage per term.
3. **Test** of membership in the class: the estimate is used only when the
   best model fits the per-line estimates within their covariance,
   ``chi^2/dof <=`` :data:`MAX_CHI2_PER_DOF`, *and* its whitened residuals are white
   over frequency (:mod:`jointid.methods.receptance.structured_membership`: pooled
   autocorrelation at lags 1-4, ``Z <=`` :data:`~jointid.methods.receptance.structured_membership.MAX_WHITENESS_Z`).
   Otherwise (a joint outside the class: several materials, a modulus law the spline
   does not follow, a term with its own frequency law or damping, or a free-model
   error) the caller falls back to per-term smoothing, and :attr:`StructuredEstimate.finding`
   says which test failed and by how much. ``chi^2/dof`` alone has little power against
   a joint just outside the class (a fractional-Zener modulus, two materials in parallel,
   a power law on one term: ``chi^2/dof`` 1.1-1.4, within its tolerance for an estimated
   covariance scale), where the fit is accepted with bands 3-10 times too narrow;
   ``benchmarks/out_of_class.py`` prints both tests' decisions on such joints.
4. **Repeatability**: every start is deterministic (grids of poles and loss angles).
   Before the estimate is rejected, the chosen order is refitted along a second path
   (:func:`polish_best`: its modes added one by one to the 0-mode fit of the same modulus
   basis and residual, from :data:`POLISH_STARTS` pole-grid minima each) and kept when
   its chi^2 is lower, then both tests are rerun: a seed is not rejected for a local minimum
   of the greedy path.

Caveats: the whiteness test assumes independent errors from line to line (module
:mod:`~jointid.methods.receptance.structured_membership`); with strongly correlated
neighbouring lines it rejects joints of the class (the fallback is then conservative).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ...parallel import single_threaded_blas
from .structured_fit import StructuredFit, fit_structured, refit
from .structured_membership import MAX_WHITENESS_Z, Membership, membership

__all__ = ["StructuredEstimate", "structured_estimate", "select_structured", "model_average", "MAX_CHI2_PER_DOF", "MAX_MODES", "SELECT_MAX_LINES", "REFIT_MAX_LINES", "STRUCTURED_MAX_DOFS", "POLE_LIST_FACTOR", "DEGENERATE_BAND_RATIO", "POLISH_STARTS", "polish_best"]

#: The structured estimate is used when its best model's chi^2 per degree of freedom is at most this.
MAX_CHI2_PER_DOF = 1.5
#: Most internal joint modes tried.
MAX_MODES = 3
#: Above this many lines the order is chosen on an evenly spaced subset of this many.
SELECT_MAX_LINES = 600
#: Up to this many lines the models retained on the subset are refitted on every line; above, evaluated there.
REFIT_MAX_LINES = 5000
#: Joints with more DOFs than this are smoothed per term (parameters grow as n^2 per block).
STRUCTURED_MAX_DOFS = 6
#: Internal modes above this multiple of the band's top are described as "far above the band" (they act as a residual).
POLE_LIST_FACTOR = 4.0
#: Pole starts per added mode of the second path tried before the estimate is rejected (:func:`polish_best`).
POLISH_STARTS = 4
#: Models with an Akaike weight below this are left out of the average.
_MIN_WEIGHT = 1e-4
#: Models whose bands are this many times wider than the lowest-AIC model's on some term are left out of the average.
DEGENERATE_BAND_RATIO = 20.0


@dataclass(frozen=True, eq=False)
class StructuredEstimate:
    """Model-averaged structured estimate of a joint, with its diagnostics.

    Attributes
    ----------
    stiffness : ndarray, shape (F, n, n), complex
        ``sum_m w_m Du_m`` (physical units).
    std_real, std_imag : ndarray, shape (F, n, n)
        ``sqrt(sum_m w_m (var_m + (Du_m - Du)^2))`` of each part: within-model and between-model spread.
    weights : dict
        Order ``(n_modes, g_basis, residual)`` -> Akaike weight.
    best : StructuredFit
        The fit with the lowest AIC.
    fits : dict
        Order -> every StructuredFit tried.
    accepted : bool
        ``best.chi2_per_dof <= MAX_CHI2_PER_DOF``, the best fit's residuals white over frequency
        (``membership.passed``) and every value and band finite.
    seconds : float
    membership : Membership or None
        The whiteness test of the best fit's residuals (None: not run).
    """

    stiffness: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    weights: dict
    best: StructuredFit
    fits: dict
    accepted: bool
    seconds: float
    membership: Membership | None = None

    @property
    def shape_only(self) -> bool:
        """Rejected by the whiteness test alone (finite, ``chi^2/dof`` within its limit): kept with wider bands by the caller."""
        finite = bool(np.all(np.isfinite(self.stiffness)) and np.all(np.isfinite(self.std_real)) and np.all(np.isfinite(self.std_imag)))
        return (not self.accepted and finite and self.best.chi2_per_dof <= MAX_CHI2_PER_DOF
                and self.membership is not None and not self.membership.passed)

    @property
    def finding(self) -> str:
        """Why the estimate was rejected (one line naming the test, the class tried and the figures), else ""."""
        if self.accepted:
            return ""
        b = self.best
        cls = f"{b.model.label}; chi^2/dof {b.chi2_per_dof:.2f}"
        if b.chi2_per_dof > MAX_CHI2_PER_DOF:  # the gross misfit first: the residuals are far above the noise
            return (f"the structured joint model does not fit these FRFs (chi^2/dof {b.chi2_per_dof:.2f} > {MAX_CHI2_PER_DOF}: "
                    "not one viscoelastic material, a model error, or FRF errors larger than their coherence says, e.g. hammer "
                    "records without a force window): each term smoothed on its own instead")
        m = self.membership
        if m is not None and not m.passed:
            iu = np.triu_indices(b.model.n)
            i, j = int(iu[0][m.worst_term()]), int(iu[1][m.worst_term()])
            return (f"the structured joint model ({cls}) misses the shape of these FRFs: its residuals are correlated over "
                    f"frequency (whiteness Z {m.z:.1f} > {MAX_WHITENESS_Z}, most in term ({i}, {j})): not one viscoelastic "
                    "material (e.g. a term with its own frequency law or damping, two materials, a modulus law the model does "
                    "not follow) or a free-model error; each term smoothed on its own instead")
        return "the structured joint model gave non-finite values on these FRFs: each term smoothed on its own instead"

    def describe(self) -> str:
        """One line: the chosen model, its internal modes, chi^2/dof and the averaging."""
        poles = self.best.poles_hz()
        top = POLE_LIST_FACTOR * self.best.model.band[1]
        near, far = poles[poles <= top], int(np.sum(poles > top))
        modes = f"; internal modes at {', '.join(f'{p:.0f}' for p in near)} Hz" if near.size else ""
        modes += f"; {far} far above the band" if far else ""
        white = f"; residual whiteness Z {self.membership.z:.1f}" if self.membership is not None else ""
        return (f"structured joint model ({self.best.model.label}{modes}; chi^2/dof {self.best.chi2_per_dof:.3f}{white}), "
                f"Akaike-weighted average of {len(self.weights)} order(s)")


def select_structured(hz, lines, common=None, max_modes: int = MAX_MODES, max_g_basis: int = 6):
    """Greedy forward selection of the order by AIC; returns ``(best, fits)`` with ``fits``: order -> StructuredFit.

    ``max_g_basis`` 1 keeps ``g`` constant (always so when ``common`` is given).
    """
    if common is not None:
        max_g_basis = 1
    fits: dict = {}
    cache: dict = {}  # what every order's fit computes alike (smoothed curves, the first mode's grid start)

    def fit(order, start):
        if order not in fits:
            try:
                fits[order] = fit_structured(hz, lines, order, common=common, start=start, cache=cache)
            except (np.linalg.LinAlgError, ValueError):  # a degenerate start: skip this order
                return None
        return fits[order]

    best = fit((0, 1, False), None)
    if best is None:
        raise np.linalg.LinAlgError("the structured model's linear start failed")
    while True:
        r, k, e = best.model.order
        steps = [(r + 1, k, e)] if r < max_modes else []
        if not e:
            steps.append((r, k, True))
        nk = {1: 4, 4: 6}.get(k)
        if nk is not None and nk <= max_g_basis:
            steps.append((r, nk, e))
        tried = [f for f in (fit(o, best) for o in steps) if f is not None and np.isfinite(f.aic)]
        if not tried:
            break
        nxt = min(tried, key=lambda f: f.aic)
        if nxt.aic >= best.aic:
            break
        best = nxt
    if common is not None:  # only models with the residual term are kept (module docstring)
        r, k, e = best.model.order
        if not e:
            fit((r, k, True), best)
        kept = {o: f for o, f in fits.items() if o[2] and f is not None and np.isfinite(f.aic)}
        if kept:
            fits = kept
            best = min(kept.values(), key=lambda f: f.aic)
    return best, fits


def model_average(fits: dict) -> tuple:
    """Akaike-weighted average of the fits: ``(stiffness, std_real, std_imag, weights)``.

    A fit whose bands are :data:`DEGENERATE_BAND_RATIO` times wider than the lowest-AIC fit's on
    some term (median over lines) is left out: its parameters are not determined by the data (a
    flat direction of its likelihood, e.g. a modulus spline confounded with a mode), which AIC does
    not penalize, and its bands would swamp the average (e.g. K_ww bands wider than the term
    itself around an estimate that is right). A fit with an infinite or undefined band (a term that
    moves along a direction the FRFs do not determine, :func:`~.structured_bands.terms_moving_along`)
    is left out first, the lowest-AIC one too, unless every fit has one.
    """
    ic = {o: f.aic for o, f in fits.items() if f is not None and np.isfinite(f.aic)}
    banded = {o: v for o, v in ic.items() if np.all(np.isfinite(fits[o].std_real)) and np.all(np.isfinite(fits[o].std_imag))}
    ic = banded or ic
    ref = _band_width(fits[min(ic, key=ic.get)])
    with np.errstate(over="ignore"):  # every fit undetermined: the reference is the largest float
        ic = {o: v for o, v in ic.items() if np.all(_band_width(fits[o]) <= DEGENERATE_BAND_RATIO * ref)}
    lo = min(ic.values())
    w = {o: np.exp(-(v - lo) / 2.0) for o, v in ic.items()}
    tot = sum(w.values())
    w = {o: v / tot for o, v in w.items() if v / tot > _MIN_WEIGHT}
    tot = sum(w.values())
    w = {o: v / tot for o, v in w.items()}
    with np.errstate(over="ignore", invalid="ignore"):  # every fit undetermined: infinite bands, as they are
        K = sum(v * fits[o].stiffness for o, v in w.items())
        vr = sum(v * (fits[o].std_real ** 2 + (fits[o].stiffness.real - K.real) ** 2) for o, v in w.items())
        vi = sum(v * (fits[o].std_imag ** 2 + (fits[o].stiffness.imag - K.imag) ** 2) for o, v in w.items())
    return K, np.sqrt(vr), np.sqrt(vi), w


def _band_width(fit: StructuredFit) -> np.ndarray:
    """Median over lines of each term's ``sqrt(std_re^2 + std_im^2) / |K|``, shape (n, n)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(np.median(np.hypot(fit.std_real, fit.std_imag) / np.abs(fit.stiffness), axis=0), nan=np.inf)


def _subset(lines, common, idx):
    sub = SimpleNamespace(stiffness=lines.stiffness[idx], variance=lines.variance[idx], x=lines.x[idx],
                          x_covariance=lines.x_covariance[idx], Ynn=lines.Ynn[idx])
    return sub, (None if common is None else common[idx])


def structured_estimate(hz, lines, common=None) -> StructuredEstimate:
    """Fit, select and average the structured joint model (module docstring).

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    lines : LineEstimates
        Per-line coupling estimates on the exact path, symmetric (``x``, ``x_covariance``, ``Ynn``).
    common : ndarray, shape (F, p, k), complex, optional
        Factor of the column calibration's error common to all lines, profiled out.

    Returns
    -------
    StructuredEstimate

    Raises
    ------
    numpy.linalg.LinAlgError
        No structured model could be fitted (singular covariances).
    """
    t0 = time.perf_counter()
    # small matrices: BLAS threads only contend (as in methods/smoothing); a degenerate
    # candidate (a pole at infinity) must not abort the run: non-finite results are checked below
    with single_threaded_blas(), np.errstate(all="ignore"):
        return _estimate(np.asarray(hz, float), lines, common, t0)


def polish_best(hz, lines, fits: dict, common=None, n_starts: int = POLISH_STARTS) -> dict:
    """``fits`` with the lowest-AIC order refitted along a second path when that reaches a lower chi^2.

    The greedy search grows each order from its neighbour (e.g. ``(3, 6, +E)`` from
    ``(3, 6)``, whose modes were placed with a constant modulus): the modes it inherits can
    sit in a local minimum. The second path fits ``(0 modes, g, E)`` of the same modulus
    basis and residual and adds the modes one by one, each from every local minimum of the
    pole grid (``n_starts``); the fit with the lower chi^2 is kept. Deterministic (grid starts).
    On the beam's out-of-class joints it lowered chi^2 by 4-10 % on 3 of 5 seeds tried (two materials in parallel: chi^2/dof 1.30-1.38 -> 1.16-1.27 over 50 seeds).
    """
    ok = {o: f for o, f in fits.items() if f is not None and np.isfinite(f.aic)}
    if not ok:
        return fits
    best = min(ok.values(), key=lambda f: f.aic)
    r, k, e = best.model.order
    if r == 0:
        return fits
    try:
        f0 = ok.get((0, k, e)) or fit_structured(hz, lines, (0, k, e), common=common, start=ok.get((0, 1, False)))
        alt = fit_structured(hz, lines, (r, k, e), common=common, start=f0, n_starts=n_starts)
    except (np.linalg.LinAlgError, ValueError):
        return fits
    if not (np.isfinite(alt.aic) and alt.chi2 < best.chi2):
        return fits
    return {**fits, (r, k, e): alt}


def _select(hz, lines, common):
    """``(fits, data)``: the selection's fits and the lines they were fitted on (every line, or an even subset)."""
    F = hz.size
    if F > SELECT_MAX_LINES:
        idx = np.unique(np.round(np.linspace(0, F - 1, SELECT_MAX_LINES)).astype(int))
        sub, sub_common = _subset(lines, common, idx)
        data = (hz[idx], sub, sub_common)
    else:
        data = (hz, lines, common)
    return select_structured(*data)[1], data


def _on_every_line(fits, data, hz, lines, common) -> dict:
    """The averaged fits on every line: as they are, refitted there, or (above :data:`REFIT_MAX_LINES`) evaluated there."""
    if data[0].size == hz.size:
        return fits
    _, _, _, w = model_average(fits)
    if hz.size <= REFIT_MAX_LINES:
        return {o: refit(fits[o], hz, lines, common) for o in w}
    return {o: fits[o].at(hz) for o in w}  # the subset's fits: bands from the subset's information only


def _decide(fits, hz, lines, common, t0) -> StructuredEstimate:
    K, sr, si, w = model_average(fits)
    best = fits[max(w, key=w.get)]
    finite = bool(np.all(np.isfinite(K)) and np.all(np.isfinite(sr)) and np.all(np.isfinite(si)))
    member = membership(best, hz, lines, common)
    ok = finite and best.chi2_per_dof <= MAX_CHI2_PER_DOF and member.passed
    return StructuredEstimate(K, sr, si, w, best, fits, bool(ok), time.perf_counter() - t0, member)


def _estimate(hz, lines, common, t0) -> StructuredEstimate:
    fits, data = _select(hz, lines, common)
    est = _decide(_on_every_line(fits, data, hz, lines, common), hz, lines, common, t0)
    if est.accepted:
        return est
    # before rejecting: the chosen order along a second path (a seed must not be rejected for a local minimum)
    polished = polish_best(*data[:2], fits, data[2])
    if polished is fits:
        return est
    return _decide(_on_every_line(polished, data, hz, lines, common), hz, lines, common, t0)
