"""Elastomer material parameters from the direct test's complex stiffness K21(f).

Three levels, from the simplest:

1. :func:`static_estimate` (:mod:`jointid.methods.direct.material_static`) -- the quasi-static stiffness ``k`` (storage part
   averaged over the lowest test frequencies, per joint) gives the naive shear
   modulus ``G = k L / A`` and ``E = 2 G (1 + nu)`` (nu = 0.49). For a short
   cylinder (L = d) the guided Timoshenko stiffness is only about 0.64 GA/L,
   so this under-reads G; the estimate also reports ``G / guided_ratio``, the
   value corrected with the joint model's static limit.
2. :func:`fit_material` -- least squares (``scipy.optimize.least_squares``
   on log-parameters, relative complex residuals ``(K_model - K) / |K|``) of
   a constant E, loss factor and density so that the FE joint model
   (:class:`~jointid.physics.elastomer_joint.ElastomerJoint`, blocked transfer
   stiffness) reproduces the measured K21 over the band. Every parameter gets
   a standard error (``s^2 (J^T J)^-1`` propagated to its own unit) and a
   status: the density is held at a default when the band lies too far
   below the joint's internal mode (or it leaves the rubber range), and a
   parameter outside its physical range or with > 50 % relative error is
   ``not_identified`` (:mod:`jointid.methods.fit_statistics`).
3. :func:`complex_modulus_per_line` (:mod:`jointid.methods.direct.modulus_per_line`) -- E*(f) per line with the density fixed,
   by a vectorized complex Newton iteration on ``K21(E*) = K_measured``
   (the derivative ``dS/dE* = U^T (K_ref / E_ref) U`` of the condensed matrix
   is exact); :func:`~jointid.methods.direct.zener_fit.fit_zener` (re-exported here)
   fits a fractional-derivative Zener model
   ``E*(w) = (E0 + Einf (j w tau)^alpha) / (1 + (j w tau)^alpha)`` to it.

This module holds level 2 and re-exports the others, so ``from
jointid.methods.direct.material_fit import ...`` reaches every fit. Every result is
a frozen dataclass with ``to_dict()`` for JSON.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from ...errors import DataError, ModelError
from ..fit_statistics import (
    FIXED,
    HELD_AT_DEFAULT,
    MAX_RELATIVE_STD,
    NOT_IDENTIFIED,
    ParameterEstimate,
    classify,
    correlation_matrix,
    jacobian_covariance,
    propagate_covariance,
)
from ...physics.elastomer_joint import DEFAULT_DIAMETER_M, DEFAULT_LENGTH_M, DEFAULT_POISSON, ElastomerJoint
from .material_static import StaticEstimate, as_band_arrays, joint_template, static_estimate
from .modulus_per_line import ComplexModulus, complex_modulus_per_line
from .phase_sign import reversed_phase
from .zener_fit import ZenerFit, fit_zener, zener_modulus

__all__ = [
    "StaticEstimate",
    "MaterialFit",
    "ComplexModulus",
    "ZenerFit",
    "static_estimate",
    "fit_material",
    "complex_modulus_per_line",
    "fit_zener",
    "zener_modulus",
    "inertia_fraction",
    "PHYSICAL_BOUNDS",
    "DEFAULT_DENSITY",
    "MIN_INERTIA_FRACTION",
    "MATERIAL_MISFIT_RMS",
    "MISFIT_REMEDY",
    "misfit_message",
]



# ---------------------------------------------------------------- constant E, eta, rho
#: Physically plausible ranges for an elastomer: E' in Pa, loss factor (upper end exclusive), density in kg/m^3.
PHYSICAL_BOUNDS = {"elastic_modulus_pa": (0.1e6, 500e6), "loss_factor": (0.0, 2.0), "density_kg_m3": (800.0, 2000.0)}
#: Density held when the data cannot determine it (mid-range rubber), kg/m^3.
DEFAULT_DENSITY = 1100.0
#: The density is identified only if inertia changes the model's K21 by at least this fraction
#: somewhere in the band (see :func:`inertia_fraction`).
MIN_INERTIA_FRACTION = 0.25

_UNITS = {"elastic_modulus_pa": "Pa", "loss_factor": "-", "density_kg_m3": "kg/m^3"}
_NAMES = ("elastic_modulus_pa", "loss_factor", "density_kg_m3")


@dataclass(frozen=True, eq=False)
class MaterialFit:
    """Constant complex modulus and density fitted to K21 over a band, with standard errors and status.

    ``elastic_modulus_pa``, ``loss_factor`` and ``density_kg_m3`` are the
    values the fitted model (:attr:`joint`) uses; whether each is a result
    is in :attr:`parameters` (status ``identified``, ``held_at_default``,
    ``fixed`` or ``not_identified``, with the reason). Report a value only
    when its status is ``identified``.

    Parameters
    ----------
    elastic_modulus_pa : float
        Storage Young's modulus E', Pa.
    loss_factor : float
        eta.
    density_kg_m3 : float
        rho, kg/m^3 (the held value when it is not identified).
    parameters : tuple of ParameterEstimate
        (E', eta, rho) with standard errors in Pa, -, kg/m^3 and status.
    correlation : ndarray, shape (3, 3)
        Correlation of (E', eta, rho) of the final fit; NaN for a held parameter.
    residual_rms : float
        rms of the relative complex residual ``|K_model - K| / |K|``.
    inertia_fraction : float
        Largest ``|K21(rho) / K21(rho -> 0) - 1|`` over the band (see :func:`inertia_fraction`).
    frequency_hz : ndarray, shape (F,)
        Lines fitted, Hz.
    measured, fitted : ndarray, shape (F,), complex
        Measured and model K21 per joint, N/m.
    joint : ElastomerJoint
        The joint model with the fitted (or held) material.
    success : bool
        Optimizer convergence flag.
    nfev : int
        Model evaluations (all fits).
    """

    elastic_modulus_pa: float
    loss_factor: float
    density_kg_m3: float
    parameters: tuple
    correlation: np.ndarray
    residual_rms: float
    inertia_fraction: float
    frequency_hz: np.ndarray
    measured: np.ndarray
    fitted: np.ndarray
    joint: ElastomerJoint
    success: bool
    nfev: int

    @property
    def shear_modulus_pa(self) -> float:
        """G' = E' / (2 (1 + nu)), Pa."""
        return self.elastic_modulus_pa / (2.0 * (1.0 + self.joint.poisson_ratio))

    def parameter(self, name: str) -> ParameterEstimate:
        """The estimate of ``"elastic_modulus_pa"``, ``"loss_factor"`` or ``"density_kg_m3"``."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def relative_std(self) -> tuple:
        """Relative standard errors of (E', eta, rho); NaN for a held parameter, inf if unconstrained."""
        return tuple(p.relative_std_error for p in self.parameters)

    @property
    def identified(self) -> bool:
        """True when no parameter is ``not_identified`` (held ones are allowed)."""
        return all(p.identified or p.held for p in self.parameters)

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per parameter that is not a result of the data (held or not identified), with the reason."""
        out: dict[tuple, list] = {}  # parameters not reported for one reason share one line ("E and loss factor ...")
        for p in self.parameters:
            if p.identified:
                continue
            key = (p.status, p.reason) if not p.held else (p.status, p.reason, p.name)
            out.setdefault(key, []).append(p)
        lines = []
        for (status, reason, *_), ps in out.items():
            held = f"; held at {ps[0].value:g} {ps[0].unit}" if ps[0].held else (
                "; their values are not reported" if len(ps) > 1 else "; its value is not reported")
            lines.append(f"{' and '.join(p.title for p in ps)} {status.replace('_', ' ')}: {reason}{held}")
        return tuple(lines)

    def to_dict(self) -> dict:
        """JSON-ready dict: every parameter with standard error and status (value null unless identified)."""
        par = {p.name: p.to_dict() for p in self.parameters}
        g = self.parameter("elastic_modulus_pa").to_dict()
        scale = 1.0 / (2.0 * (1.0 + self.joint.poisson_ratio))
        shear = {k: (v * scale if isinstance(v, float) and k in ("value", "std_error", "held_value") else v) for k, v in g.items()}
        corr = [[float(c) if math.isfinite(c) else None for c in row] for row in self.correlation]
        mode = float(self.joint.modes("blocked", 1).frequency_hz[0])
        return {
            "parameters": par,
            "shear_modulus_pa": shear,
            "correlation": {"order": list(_NAMES), "matrix": corr},
            "residual_rms": self.residual_rms,
            "inertia_fraction": self.inertia_fraction,
            "lines": int(self.frequency_hz.size),
            "band_hz": [float(self.frequency_hz.min()), float(self.frequency_hz.max())],
            "blocked_internal_mode_hz": mode if self.parameter("density_kg_m3").identified and self.parameter("elastic_modulus_pa").identified else None,
            "poisson_ratio": self.joint.poisson_ratio,
            "length_m": self.joint.length_m,
            "diameter_m": self.joint.diameter_m,
            "elements": int(self.joint.elements),
            "success": bool(self.success),
            "nfev": int(self.nfev),
            "warnings": list(self.warnings),
            "standard_errors": "s^2 (J^T J)^-1 with s^2 = RSS / (2F - p) on the relative complex residuals, "
            "propagated from the log-parameters to Pa, -, kg/m^3 (first order; assumes the constant-modulus model is right)",
        }


def inertia_fraction(joint: ElastomerJoint, frequency_hz, elastic_modulus_pa: float, loss_factor: float, density_kg_m3: float) -> float:
    """How much the elastomer's inertia changes K21 over the band: ``max_f |K21(rho) / K21(rho -> 0) - 1|``.

    The blocked transfer stiffness of a massless cylinder is the static one at
    every line; the mass raises it as about ``(pi^2 / 6) (f / f_mode)^2``
    below the first blocked internal mode ``f_mode`` (and faster as ``f``
    approaches ``f_mode``). A storage modulus that rises with
    frequency (rubber: 1.2-2x from 10 Hz to 1 kHz) raises K21 the same way,
    so the density is only separable from it when inertia is a large part of
    K21 somewhere in the band.

    Parameters
    ----------
    joint : ElastomerJoint
        Template (geometry, nu, mesh).
    frequency_hz : array_like, shape (F,)
        Band, Hz.
    elastic_modulus_pa, loss_factor, density_kg_m3 : float
        Material of the evaluation.
    """
    f = np.asarray(frequency_hz, dtype=float).reshape(-1)
    Ec = elastic_modulus_pa * (1.0 + 1j * loss_factor)
    _, S, _ = joint._blocked(f, modulus=Ec, density=density_kg_m3)
    _, S0, _ = joint._blocked(f, modulus=Ec, density=density_kg_m3 * 1e-9)
    return float(np.max(np.abs(S[:, 2, 0] / S0[:, 2, 0] - 1.0)))


def _fit(tpl: ElastomerJoint, f: np.ndarray, k: np.ndarray, x0: np.ndarray, density: float | None):
    """Least squares on log(E, eta[, rho]); returns (values (3,), cov (3, 3) in own units, solution)."""
    scale = np.abs(k)

    def values(x):
        v = np.exp(x)
        return (v[0], v[1], v[2] if density is None else density)

    def resid(x):
        E, eta, rho = values(x)
        _, S, _ = tpl._blocked(f, modulus=E * (1.0 + 1j * eta), density=rho)
        r = (-S[:, 2, 0] - k) / scale
        return np.concatenate([r.real, r.imag])

    sol = least_squares(resid, x0, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    vals = np.array(values(sol.x), dtype=float)
    m = sol.x.size
    cov = np.full((3, 3), np.nan)
    # p = exp(x): dp/dx = diag(p) (delta method), in Pa, -, kg/m^3
    cov[:m, :m] = propagate_covariance(jacobian_covariance(sol.jac, sol.fun), np.diag(vals[:m]))
    return vals, cov, sol


#: A constant-modulus fit whose relative rms residual exceeds this does not describe the data: E and eta are not
#: identified (a frequency-dependent modulus over the band: the Zener fit is the model; measured K21 scatter is ~1 %).
MATERIAL_MISFIT_RMS = 0.1
#: What the misfit message advises (the command line's option; ``jointid direct --zener`` replaces it by its fit).
MISFIT_REMEDY = "use --zener"


def misfit_message(residual: float, signal_noise: float | None = None) -> str:
    """The line saying that the constant-modulus model does not fit (``residual > MATERIAL_MISFIT_RMS``).

    Parameters
    ----------
    residual : float
        rms relative complex residual ``|K_model - K| / |K|`` of the constant-modulus fit.
    signal_noise : float, optional
        The test's noise: rms residual of the sine fits over the rms fundamental (median over the
        lines, :attr:`~jointid.measurement.stepsine.StepSineResult.force_residual`); shown for scale.
    """
    noise = "" if signal_noise is None or not math.isfinite(signal_noise) else f", noise ~{signal_noise:.1%}"
    return (f"the constant-modulus model does not fit these data (residual {residual:.0%}{noise}): "
            f"the modulus depends on frequency; {MISFIT_REMEDY}")


def fit_material(
    frequency_hz,
    stiffness,
    joint: ElastomerJoint | None = None,
    initial: tuple[float, float, float] | None = None,
    length_m: float = DEFAULT_LENGTH_M,
    diameter_m: float = DEFAULT_DIAMETER_M,
    poisson_ratio: float = DEFAULT_POISSON,
    static_lines: int = 2,
    density_kg_m3: float | None = None,
    default_density_kg_m3: float = DEFAULT_DENSITY,
    bounds: dict | None = None,
    max_relative_std: float = MAX_RELATIVE_STD,
    min_inertia_fraction: float = MIN_INERTIA_FRACTION,
    signal_noise: float | None = None,
) -> MaterialFit:
    """Fit constant E', eta and rho so the FE joint model reproduces K21 (per joint), with standard errors.

    Procedure: (1) least squares of E', eta, rho (log-parameters, relative
    complex residuals); (2) each parameter is ``identified`` if it lies in
    its physical range (``bounds``: E' 0.1-500 MPa, 0 <= eta < 2, rho
    800-2000 kg/m^3) with a relative standard error <= ``max_relative_std``;
    the density also needs inertia to change K21 by >= ``min_inertia_fraction``
    somewhere in the band (:func:`inertia_fraction`, evaluated with the
    smaller of the fitted and the default density, so an inflated density
    cannot vouch for itself); (3) if the density fails, it is held at
    ``default_density_kg_m3`` and E', eta are refitted (status
    ``held_at_default``); E' or eta that fail are ``not_identified``.
    Standard errors: ``s^2 (J^T J)^-1``, ``s^2 = RSS / (2F - p)``, propagated
    from the log-parameters (:mod:`jointid.methods.fit_statistics`).

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines to fit, Hz (F >= 2; drop flagged lines first).
    stiffness : array_like, shape (F,), complex
        Measured K21 per joint, N/m.
    joint : ElastomerJoint, optional
        Template giving geometry, nu, kappa and mesh (its material is ignored);
        default: a cylinder ``length_m`` x ``diameter_m`` with ``poisson_ratio``.
    initial : (E Pa, eta, rho kg/m^3), optional
        Starting point; default: E from the static limit of the model, eta the
        mean loss factor of the lowest lines, rho = the default density.
    length_m, diameter_m, poisson_ratio : float
        Geometry of the default template.
    static_lines : int
        Lowest lines used for the default starting point.
    density_kg_m3 : float, optional
        Known density, kg/m^3: held (status ``fixed``), only E' and eta are fitted.
    default_density_kg_m3 : float
        Density held when the data cannot determine it, kg/m^3.
    bounds : dict, optional
        Overrides of :data:`PHYSICAL_BOUNDS` (name -> (low, high)).
    max_relative_std : float
        Largest relative standard error of an identified parameter.
    min_inertia_fraction : float
        Smallest inertia share of K21 in the band for the density to be identified.
    signal_noise : float, optional
        The test's relative noise (sine-fit residual over the fundamental), quoted when the
        constant-modulus model does not fit (:func:`misfit_message`): E' and eta are then
        ``not_identified`` (residual above :data:`MATERIAL_MISFIT_RMS`), as they are for a
        reversed phase (:mod:`.phase_sign`).

    Returns
    -------
    MaterialFit
    """
    f, k = as_band_arrays(frequency_hz, stiffness)
    if f.size < 2:
        raise DataError(f"fitting E, eta and rho needs at least 2 lines, got {f.size}")
    bnd = {**PHYSICAL_BOUNDS, **(bounds or {})}
    tpl = joint_template(joint, length_m, diameter_m, poisson_ratio)
    if initial is None:
        st = static_estimate(f, k, lines=min(static_lines, f.size), length_m=tpl.length_m, diameter_m=tpl.diameter_m, poisson_ratio=tpl.poisson_ratio)
        k_unit = tpl.static_guided_stiffness().real / tpl._static_modulus().real  # N/m per Pa
        initial = (st.stiffness_n_m / k_unit, max(st.loss_factor, 1e-3), default_density_kg_m3)
    E0, eta0, rho0 = (float(v) for v in initial)
    if not (E0 > 0 and eta0 > 0 and rho0 > 0):
        raise ModelError(f"initial (E, eta, rho) must be positive, got {initial!r}")
    if density_kg_m3 is not None and not density_kg_m3 > 0:
        raise ModelError(f"density must be positive (kg/m^3), got {density_kg_m3!r}")
    nfev = 0
    rho_param = None
    if density_kg_m3 is None and f.size >= 2:
        with np.errstate(over="ignore", invalid="ignore"):
            vals, cov, sol = _fit(tpl, f, k, np.log([E0, eta0, rho0]), None)
        nfev += sol.nfev
        rho_param = classify("density_kg_m3", "kg/m^3", vals[2], math.sqrt(cov[2, 2]), bnd["density_kg_m3"], max_relative_std, label="density")
        if rho_param.identified:
            rho_check = min(vals[2], default_density_kg_m3)
            frac = inertia_fraction(tpl, f, vals[0], vals[1], rho_check)
            if frac < min_inertia_fraction:
                rho_param = replace(rho_param, status=NOT_IDENTIFIED, reason=(
                    f"inertia changes K21 by only {frac:.0%} over the band (< {min_inertia_fraction:.0%}): the band lies far below "
                    "the joint's internal mode, where a storage modulus rising with frequency mimics the mass"))
    if rho_param is None or not rho_param.identified:
        held = default_density_kg_m3 if density_kg_m3 is None else float(density_kg_m3)
        with np.errstate(over="ignore", invalid="ignore"):
            vals, cov, sol = _fit(tpl, f, k, np.log([E0, eta0]), held)
        nfev += sol.nfev
        if density_kg_m3 is None:
            rho_param = ParameterEstimate("density_kg_m3", "kg/m^3", held, math.nan, HELD_AT_DEFAULT, rho_param.reason, "density")
        else:
            rho_param = ParameterEstimate("density_kg_m3", "kg/m^3", held, math.nan, FIXED, "given by the caller", "density")
    E, eta, rho = (float(v) for v in vals)
    params = (
        classify("elastic_modulus_pa", "Pa", E, math.sqrt(cov[0, 0]), bnd["elastic_modulus_pa"], max_relative_std, label="E"),
        classify("loss_factor", "-", eta, math.sqrt(cov[1, 1]), bnd["loss_factor"], max_relative_std, upper_inclusive=False, label="loss factor"),
        rho_param,
    )
    fitted_joint = tpl.with_material(E, eta, rho)
    _, S, _ = tpl._blocked(f, modulus=E * (1.0 + 1j * eta), density=rho)
    kf = -S[:, 2, 0]
    residual = float(np.sqrt(np.mean(np.abs((kf - k) / k) ** 2)))
    # a material fitted to a reversed phase (:mod:`.phase_sign`) or that misses the data is not the data's material
    why = reversed_phase(k) or (misfit_message(residual, signal_noise) if residual > MATERIAL_MISFIT_RMS else None)
    if why is not None:
        params = tuple(replace(p, status=NOT_IDENTIFIED, reason=why) for p in params[:2]) + params[2:]  # E, eta; rho as it is
    frac = inertia_fraction(tpl, f, E, eta, rho)
    return MaterialFit(
        E, eta, rho, params, correlation_matrix(cov), residual, frac,
        f, k, kf, fitted_joint, bool(sol.success), int(nfev),
    )
