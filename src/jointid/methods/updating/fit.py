"""Free-structure model updating: fit a free model's parameters to FRFs measured on the free (suspended) structure.

Before a joint is identified, the free beam's FE model ``Do`` should be
updated from a free-free test: a small error in the beam's E gives a far
larger error in the joint terms, the rotational one most (the model-error study
of ``jointid reproduce``, :mod:`jointid.reproduce.model_error`, prints the
figures per term before and after updating).

Residuals
---------
For every measured FRF value ``H_d`` (any kind, any subset of the model's
translational DOFs) and the model's ``H_m(p)`` of the same kind, the complex
log residual

    r = w * ln(H_m / H_d) = w * (ln|H_m| - ln|H_d|  +  j (arg H_m - arg H_d)),

split into its real part (log-magnitude) and imaginary part (phase, wrapped to
(-pi, pi]), is minimized in least squares. A relative error of the data is an
additive error of ``ln H``, so every line counts alike whatever the FRF's
level. With coherence ``g^2`` the weight is ``w = sqrt(g^2 / (1 - g^2))``
(the H1 estimate's relative variance is ``(1 - g^2) / (n_avg g^2)``; the
scale is taken from the residuals), else ``w = 1``.

Why the FRFs and not only natural frequencies
----------------------------------------------
The natural frequencies of a uniform beam depend on ``E / rho`` only. The FRF
level does not: below the first elastic mode (and between modes) a free-free
accelerance follows its mass line, set by the beam's mass (``rho``) and the
known sensors; the resonances then give ``E``. Fitting the FRFs themselves
separates ``E`` and ``rho``.

The loss factor ``eta`` of a lightly damped free beam acts only within a few
half-power bandwidths ``eta f_r`` of each resonance: the band must contain
resonances, and the frequency step should not be much coarser than those
bandwidths (with 1 Hz lines the benchmark's ``eta = 0.0042`` gives 0.3 Hz at
79 Hz, one line at best, but 2.9 Hz at 700 Hz, several lines). Off resonance,
hysteretic damping only tilts the phase by about ``eta`` times the elastic
modes' share of the FRF: on virtual data with exact phase a band just below
the first resonance still determines ``eta``, but a real test's phase errors
(sensors, conditioning, ~0.01 rad) are of the size of that tilt, so trust
``eta`` only from a band with resonances. Far below the first resonance
(5-20 Hz on the benchmark) the FRF is the rigid-body mass line and ``eta`` is
reported as not determined. On a virtual free-free test with resonances in the
band (1 % noise, data from a finer mesh than the model) E, rho and eta of a
model +2 / -1 / -30 % off are recovered within two standard errors
(``tests/test_update.py``).

Two stages
----------
1. **Frequency alignment.** Far from the data, the log residual has a local
   minimum for every resonance the model's peaks pass over (the peaks are
   narrower than the initial frequency error). The measured peaks (maxima of
   ``sum |H|^2`` over the FRFs, above its running median) are matched to the
   initial model's natural frequencies by scanning one frequency scale
   ``s`` (0.7-1.4), refined per mode by parabolic interpolation;
   ``E <- E s^2`` (or ``rho <- rho / s^2`` when E is not fitted).
2. **FRF fit.** :func:`scipy.optimize.least_squares` (trust region) on
   ``x = 1 + ln(p / p0)`` (every parameter at unit scale; the offset gives the
   trust region an initial radius of ~1 in ``ln p``), within per-parameter
   bounds (e.g. ``p0 / 5 .. 5 p0`` for E), Jacobian by finite differences
   (steps 1e-5 in ``ln p``, 1e-3 for the loss factor). The model's FRFs come
   from the refined modal sum (:func:`~jointid.physics.synthesis.receptance_modal_refined`: one dense
   eigen-solution per evaluation, accurate at low frequency through the rigid-body modes) up to
   :data:`MODAL_UPDATE_DOFS` DOFs, above from a banded solve per line
   (:mod:`jointid.physics.banded_receptance`: no eigen-solution per evaluation).

Judging the fit (:mod:`.check`): when the updated model leaves a misfit
far above the data's noise, or the resonances misaligned, the FRFs are not a
free-free test of this structure (e.g. the jointed structure's): one finding,
and no parameter is reported as determined.

Statistics (:mod:`..fit_statistics`): ``cov_x = s^2 (J^T J)^-1``,
``s^2 = RSS / (n - m)``; ``std(p) = p std(x)``. A parameter is determined when
it stays inside its bounds with a relative standard error <= 50 %; otherwise
it is held at its initial value (reported as not determined, never as a
value) and the others are refitted. The standard errors assume the model is
right and the residuals independent: a model error (e.g. an unmodelled
suspension, a wrong sensor mass) biases the values beyond them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ...errors import DataError, ModelError
from ...frf import FRF, kind_factor
from ...physics.banded_receptance import receptance_banded
from ...physics.free_model import StructureModel
from ...physics.modes import natural_modes
from ...physics.structure import Structure
from ...physics.synthesis import choose_method
from .check import judge_update_fit, refuse_unit_factor
from ..fit_statistics import (
    AT_BOUND,
    HELD_AT_DEFAULT,
    IDENTIFIED,
    NOT_IDENTIFIED,
    ParameterEstimate,
    classify,
    correlation_matrix,
    jacobian_covariance,
)

from .resonances import frequency_scale
from .parameters import (
    DEFAULT_MAX_EVALUATIONS,
    DEFAULT_PARAMETERS,
    DEFAULT_STRUCTURE_PARAMETERS,
    PARAMETERS,
    STRUCTURE_PARAMETERS,
    check_parameter_names,
)

__all__ = [
    "PARAMETERS", "DEFAULT_PARAMETERS", "STRUCTURE_PARAMETERS", "DEFAULT_STRUCTURE_PARAMETERS", "ModelFamily", "StructureFamily",
    "UpdateOptions", "UpdateResult", "update_free_model", "check_parameter_names",
]

#: Beams up to this many DOFs are evaluated by the refined modal sum (one dense eigen-solution, then array
#: operations over the lines: ~2x faster than a banded LU per line on the tests' 38-DOF beam over 1000 lines, the
#: same estimates to 3e-10); larger ones by the banded LU per line (O(N b^2) each, no O(N^3) eigen-solution).
MODAL_UPDATE_DOFS = 400
#: Every parameter name any model family knows: name -> (unit, bounds as ratios of the initial value, label).
_ALL_PARAMETERS = {**PARAMETERS, **STRUCTURE_PARAMETERS}
#: Finite-difference step of the Jacobian in ln p: small enough for sharp resonances (a step of 1e-5
#: in ln E moves a 1 kHz resonance by 0.005 Hz), large against the model's round-off (with the rigid-body
#: modes split off, see :mod:`jointid.physics.banded_receptance`); the loss factor acts smoothly and weakly
#: off resonance.
_DIFF_STEP = {"loss_factor": 1e-3}
_DEFAULT_DIFF_STEP = 1e-5


@dataclass(frozen=True)
class UpdateOptions:
    """Options of :func:`update_free_model`.

    Parameters
    ----------
    parameters : sequence of str
        Names from :data:`PARAMETERS` to fit (default :data:`DEFAULT_PARAMETERS`).
    max_evaluations : int
        Model evaluations allowed to the least-squares fit (not counting the
        Jacobian's); more means the fit did not converge (an error).
    align_frequencies : bool
        Run stage 1 (frequency alignment) first.
    """

    parameters: tuple[str, ...] = DEFAULT_PARAMETERS
    max_evaluations: int = DEFAULT_MAX_EVALUATIONS
    align_frequencies: bool = True

    def __post_init__(self) -> None:
        names = tuple(self.parameters)
        object.__setattr__(self, "parameters", names)
        check_parameter_names(names, known=_ALL_PARAMETERS)
        if not (isinstance(self.max_evaluations, int) and self.max_evaluations >= 1):
            raise ModelError(f"max_evaluations must be an integer >= 1, got {self.max_evaluations!r}")


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """An updated free model: parameters with standard errors, correlation, FRFs before/after.

    Attributes
    ----------
    parameters : tuple of ParameterEstimate
        One per parameter asked for, in that order; ``status`` ``identified``
        (``value`` and ``std_error`` in the parameter's unit), or
        ``held_at_default`` / ``at_bound`` (not determined by the data: held at
        its initial value, which ``value`` then holds; never a result).
    initial : dict
        Name -> initial value.
    values : dict
        Name -> value of the updated model (fitted or held).
    correlation : ndarray, shape (p, p)
        Correlation of the determined parameters, in the order of ``fitted``.
    fitted : tuple of str
        Names of the parameters of the final fit.
    residual_before, residual_after : float
        RMS of ``|ln(H_m / H_d)|`` over every value (unweighted): initial and updated model.
    frequency_scale : float
        Stage 1's frequency scale ``s`` (1.0 when not run).
    evaluations : int
        Model evaluations of the final fit.
    measured, initial_model, updated_model : FRF
        The data and both models' FRFs on the same lines, DOFs and kind (``updated_model``:
        the fit's, also when ``finding`` rejected it).
    finding : str or None
        Set when the updated model does not fit the FRFs (a misfit far above their noise,
        or resonances left misaligned; :func:`~jointid.methods.updating.check.judge_update_fit`):
        these are not a free-free test of this structure, every parameter is then reported
        as not determined and ``values`` are the initial ones.
    """

    parameters: tuple[ParameterEstimate, ...]
    initial: dict
    values: dict
    correlation: np.ndarray
    fitted: tuple[str, ...]
    residual_before: float
    residual_after: float
    frequency_scale: float
    evaluations: int
    measured: FRF
    initial_model: FRF
    updated_model: FRF
    notes: tuple[str, ...] = field(default=())
    finding: str | None = None

    def parameter(self, name: str) -> ParameterEstimate:
        """The estimate of ``name``."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def determined(self) -> dict:
        """Name -> fitted value, for the parameters the data determine only."""
        return {p.name: p.value for p in self.parameters if p.identified}

    def uncertainty(self) -> dict:
        """The fit's ``[uncertainty]`` table: name -> standard error of each determined parameter (in the order of
        :attr:`fitted`), and ``"correlation"`` (their correlation) when more than one; empty when none is determined."""
        by_name = {p.name: p for p in self.parameters}
        names = [k for k in self.fitted if k in by_name and by_name[k].identified]
        if not names:
            return {}
        out: dict = {k: float(by_name[k].std_error) for k in names}
        if len(names) > 1:
            idx = [self.fitted.index(k) for k in names]
            C = np.asarray(self.correlation, float)[np.ix_(idx, idx)]
            out["correlation"] = [[float(v) for v in row] for row in C]
        return out

    def describe(self) -> list[str]:
        """One line per parameter, e.g. ``"E = 7.038e+10 +- 1.2e+06 Pa (initial 6.9e+10, +2.0 %)"``; the finding first."""
        out = [self.finding] if self.finding else []
        for p in self.parameters:
            p0 = self.initial[p.name]
            if p.identified:
                out.append(f"{p.describe(digits=6)} (initial {p0:.6g}, {100 * (p.value / p0 - 1):+.2f} %)")
            else:
                out.append(f"{p.title} not determined by these FRFs ({p.reason}); kept at the initial {p0:.6g}")
        return out

    def to_dict(self) -> dict:
        """JSON-ready: ``parameters`` {name: value, std, initial, unit, status[, reason]}, ``residual``, ``correlation``."""
        params = {}
        for p in self.parameters:
            d = {
                "value": float(p.value) if p.identified else None,
                "std": float(p.std_error) if p.identified and math.isfinite(p.std_error) else None,
                "initial": float(self.initial[p.name]),
                "unit": p.unit,
                "status": "determined" if p.identified else "not_determined",
            }
            if p.reason:
                d["reason"] = p.reason
            params[p.name] = d
        corr = [[None if not math.isfinite(v) else float(v) for v in row] for row in self.correlation]
        f = self.measured.frequency.hz
        return {
            "parameters": params,
            "residual": {
                "before": float(self.residual_before),
                "after": float(self.residual_after),
                "definition": "rms over every FRF value of |ln(H_model / H_measured)| (relative error)",
            },
            "correlation": {"parameters": list(self.fitted), "matrix": corr},
            "frequency_scale_stage1": float(self.frequency_scale),
            "evaluations": int(self.evaluations),
            "frf": {
                "kind": self.measured.kind,
                "responses": [str(d) for d in self.measured.responses],
                "references": [str(d) for d in self.measured.references],
                "lines": int(f.size),
                "frequency_hz": [float(f[0]), float(f[-1])],
                "coherence_weighted": self.measured.coherence is not None,
            },
            "notes": list(self.notes),
            "finding": self.finding,
        }

    def plot(self, pairs: Sequence[tuple] | None = None):
        """FRF overlay (measured, initial model, updated model); returns the matplotlib Figure."""
        from ...plots.updating import plot_update

        return plot_update(self.measured, self.initial_model, self.updated_model, pairs=pairs)


class ModelFamily:
    """A free model as a function of its parameters: what :func:`update_free_model` fits.

    Subclass it for a model that is not rebuilt as a :class:`Structure`
    (e.g. :class:`jointid.methods.updating.scaled_matrices.ScaledMatrixFamily`). A
    plain ``build(values) -> Structure`` callable is wrapped by :class:`StructureFamily`.

    Attributes
    ----------
    frequency_parameters : tuple of (str, int)
        Stage 1 (frequency alignment): the parameters that scale every natural
        frequency, each with the power ``q`` such that the frequencies scale by
        ``s`` when the parameter is multiplied by ``s**q`` (E: 2, density: -2);
        the first one fitted is moved.
    described : str
        What the FRFs must be a free-free test of, for messages ("this beam with these sensors").
    dof_hint : str
        What to do when a measured DOF is not in the model.
    """

    frequency_parameters: tuple[tuple[str, int], ...] = ()
    described: str = "this structure"
    dof_hint: str = "measure at the model's DOFs"

    def dofs(self, values: Mapping[str, float]) -> Sequence:
        """Every DOF of the model (for the check of the measured DOFs)."""
        raise NotImplementedError

    def receptance(self, values: Mapping[str, float], frequency, rows, cols) -> np.ndarray:
        """Receptance ``Y[rows, cols]`` for ``values`` on ``frequency`` (Frequency), shape (F, r, c), complex."""
        raise NotImplementedError

    def natural_frequencies_hz(self, values: Mapping[str, float], top_hz: float) -> np.ndarray:
        """Natural frequencies (Hz, at least up to ``top_hz``; rigid-body modes ~0) for ``values``."""
        raise NotImplementedError


class StructureFamily(ModelFamily):
    """``build(values) -> Structure`` (the free beam path) as a :class:`ModelFamily`; FRFs by the modal sum or a banded solve."""

    frequency_parameters = (("elastic_modulus", 2), ("density", -2))
    described = "this beam with these sensors"
    dof_hint = "measure at the beam's nodes"

    def __init__(self, build: Callable[[Mapping[str, float]], Structure]) -> None:
        self.build = build

    def dofs(self, values):
        return self.build(values).dofs

    def receptance(self, values, frequency, rows, cols):
        structure = self.build(values)
        Y = None
        if len(structure.dofs) > MODAL_UPDATE_DOFS or choose_method(structure) != "modal":
            Y = receptance_banded(structure, frequency, rows, cols)
        if Y is None:
            Y = StructureModel(structure).receptance(frequency, rows, cols)
        return Y

    def natural_frequencies_hz(self, values, top_hz):
        return natural_modes(self.build(values)).frequencies_hz


def _model_frf(family: ModelFamily, values: Mapping[str, float], measured: FRF) -> FRF:
    Y = family.receptance(values, measured.frequency, measured.responses, measured.references)
    factor = kind_factor(measured.frequency.omega, "receptance", measured.kind)
    return FRF(measured.frequency, Y * factor[:, None, None], measured.responses, measured.references, measured.kind)


def _weights(measured: FRF) -> np.ndarray:
    if measured.coherence is None:
        return np.ones(measured.shape)
    g2 = np.clip(measured.coherence, 1e-3, 1.0 - 1e-6)
    w = np.sqrt(g2 / (1.0 - g2))
    return w / np.median(w)


def update_free_model(
    build: "Callable[[Mapping[str, float]], Structure] | ModelFamily",
    initial: Mapping[str, float],
    measured: FRF,
    options: UpdateOptions | None = None,
) -> UpdateResult:
    """Fit the parameters of a free structure to its measured FRFs (see the module docstring).

    Parameters
    ----------
    build : callable or ModelFamily
        ``build(values) -> Structure``: the free structure (no joints; a fixed
        mesh, so the model is smooth in the parameters) for a mapping with a
        value for every name in ``initial``; or a :class:`ModelFamily` giving
        the model's receptance for such a mapping directly.
    initial : mapping of str to float
        Initial value of every parameter :data:`PARAMETERS` (or
        :data:`STRUCTURE_PARAMETERS`) knows that ``build`` uses; those in
        ``options.parameters`` are fitted.
    measured : FRF
        Free-free FRFs (any kind) between translational DOFs of the model, no 0 Hz line.
    options : UpdateOptions, optional

    Returns
    -------
    UpdateResult

    Raises
    ------
    ModelError
        A parameter to fit has no positive initial value.
    DataError
        An FRF value that is zero or not finite; a DOF the model does not have;
        the fit did not converge within ``options.max_evaluations``.
    """
    options = options or UpdateOptions()
    names = options.parameters
    init = {k: float(v) for k, v in initial.items()}
    for n in names:
        if n not in init:
            raise ModelError(f"the model has no parameter {n!r} to fit (it has {', '.join(init)})")
        if not (math.isfinite(init[n]) and init[n] > 0):
            raise ModelError(
                f"cannot fit {n} from an initial value of {init[n]:g}: the fit scales a positive initial value; give {n} > 0"
            )
    if not np.all(np.isfinite(measured.data)) or np.any(measured.data == 0):
        i, j, k = (int(v[0]) for v in np.nonzero(~np.isfinite(measured.data) | (measured.data == 0)))
        raise DataError(
            f"FRF ({measured.responses[j]}, {measured.references[k]}) is zero or not finite at "
            f"{measured.frequency.hz[i]:g} Hz; the update fits log|H| and phase: remove that line"
        )
    family = build if isinstance(build, ModelFamily) else StructureFamily(build)
    model_dofs = set(family.dofs(init))
    missing = [str(d) for d in (*measured.responses, *measured.references) if d not in model_dofs]
    if missing:
        raise DataError(f"the free model has no DOF {missing[0]} for the measured FRFs; {family.dof_hint}")
    weights = _weights(measured)
    data_log = np.log(measured.data)
    notes = []

    def log_ratio(values: Mapping[str, float]) -> np.ndarray:
        return log_ratio_of(_model_frf(family, values, measured))

    def log_ratio_of(model: FRF) -> np.ndarray:
        lr = np.log(model.data) - data_log
        return lr.real + 1j * np.angle(np.exp(1j * lr.imag))

    initial_model = _model_frf(family, init, measured)
    initial_residual = log_ratio_of(initial_model)
    refuse_unit_factor(initial_residual, family.described)  # a slip in the file's units: refused before the fit
    before = float(np.sqrt(np.mean(np.abs(initial_residual) ** 2)))

    start = dict(init)
    scale = 1.0
    moved = [(n, q) for n, q in family.frequency_parameters if n in names]
    if options.align_frequencies and moved:
        scale, matched = frequency_scale(measured, family.natural_frequencies_hz(init, float(measured.frequency.hz[-1])))
        if matched:
            n, q = moved[0]
            start[n] = init[n] * scale**q
            notes.append(f"stage 1: {matched} resonances matched, frequency scale {scale:.5f}")
        else:
            scale = 1.0
            notes.append("stage 1: no resonance matched in the band; the FRF fit starts from the initial values")

    fitted = list(names)
    held: dict[str, ParameterEstimate] = {}
    while True:
        fit, cov_x = _fit(log_ratio, weights, init, start, fitted, options.max_evaluations, family.described)
        values = dict(init)
        values.update({n: init[n] for n in held})
        x = fit.x
        for n, xi in zip(fitted, x):
            values[n] = init[n] * math.exp(xi - 1.0)
        estimates = {}
        newly_held = []
        for i, n in enumerate(fitted):
            unit, (lo, hi), label = _ALL_PARAMETERS[n]
            std = values[n] * math.sqrt(cov_x[i, i]) if math.isfinite(cov_x[i, i]) else math.inf
            est = classify(n, unit, values[n], std, (init[n] * lo, init[n] * hi), label=label)
            if fit.active_mask[i] != 0:
                est = ParameterEstimate(n, unit, values[n], std, AT_BOUND, f"the fit ran to its bound ({lo:g}-{hi:g} x initial)", label)
            estimates[n] = est
            if est.status != IDENTIFIED:
                newly_held.append(n)
        if not newly_held or len(newly_held) == len(fitted):
            break
        for n in newly_held:
            e = estimates[n]
            held[n] = ParameterEstimate(n, e.unit, init[n], math.nan, HELD_AT_DEFAULT, e.reason, e.label)
            notes.append(f"{n}: not determined ({e.reason}); held at its initial value {init[n]:.6g}, others refitted")
        fitted = [n for n in fitted if n not in newly_held]
        start = {**start, **{n: init[n] for n in newly_held}}
    if len(newly_held) == len(fitted) and newly_held:
        for n in newly_held:
            e = estimates[n]
            held[n] = ParameterEstimate(n, e.unit, init[n], math.nan, e.status if e.status == AT_BOUND else HELD_AT_DEFAULT, e.reason, e.label)
            values[n] = init[n]
        fitted = []
        corr = np.zeros((0, 0))
    else:
        corr = correlation_matrix(cov_x)
    final = tuple(held[n] if n in held else estimates[n] for n in names)
    updated_model = _model_frf(family, values, measured)
    residual = log_ratio_of(updated_model)
    after = float(np.sqrt(np.mean(np.abs(residual) ** 2)))
    finding = None
    if fitted:  # does the model explain the data at all? (jointed FRFs, another structure, wrong units)
        model_hz = family.natural_frequencies_hz(values, float(measured.frequency.hz[-1]))
        finding = judge_update_fit(residual, measured, model_hz, family.described, initial=initial_residual)
    if finding is not None:
        final = tuple(
            ParameterEstimate(p.name, p.unit, init[p.name], math.nan, NOT_IDENTIFIED, "the updated model does not fit these FRFs", p.label)
            for p in final
        )
        values = dict(init)
        notes.append(finding)
    return UpdateResult(
        final, init, values, corr, tuple(fitted), before, after, scale, int(fit.nfev),
        measured, initial_model, updated_model, tuple(notes), finding,
    )


def _fit(log_ratio, weights, init, start, fitted, max_evaluations, described):
    """One least-squares fit of ``fitted`` (ln of ratio to ``init``) from ``start``; returns (result, cov_x)."""
    # x = 1 + ln(p / p0): unit scale, and an initial trust region of ~1 in ln p (least_squares starts with
    # a radius |x0|: about the start's own distance from p0, which would make it creep towards a -30 % eta)
    lo = np.array([1.0 + math.log(_ALL_PARAMETERS[n][1][0]) for n in fitted])
    hi = np.array([1.0 + math.log(_ALL_PARAMETERS[n][1][1]) for n in fitted])
    x0 = np.clip(np.array([1.0 + math.log(start[n] / init[n]) for n in fitted]), lo + 1e-9, hi - 1e-9)

    def residual(x):
        values = dict(start)
        values.update({n: init[n] * math.exp(xi - 1.0) for n, xi in zip(fitted, x)})
        r = weights * log_ratio(values)
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    steps = np.array([_DIFF_STEP.get(n, _DEFAULT_DIFF_STEP) for n in fitted])
    fit = least_squares(
        residual, x0, bounds=(lo, hi), method="trf", x_scale=1.0, diff_step=steps, max_nfev=max_evaluations,
        xtol=1e-8, ftol=1e-6, gtol=1e-10,
    )
    if fit.status <= 0:
        raise DataError(
            f"the update did not converge in {max_evaluations} model evaluation{'s' if max_evaluations != 1 else ''} (fitting {', '.join(fitted)}); "
            f"check that the FRFs are a free-free test of {described}, or allow more evaluations"
        )
    return fit, jacobian_covariance(fit.jac, fit.fun)
