"""Fractional-derivative Zener model of a complex modulus, fitted with standard errors and bound checks.

``E*(w) = (E0 + Einf (j w tau)^alpha) / (1 + (j w tau)^alpha)`` with relaxed
modulus ``E0``, unrelaxed modulus ``Einf > E0``, relaxation time ``tau`` and
fractional order ``0 < alpha < 1``. The fit (``scipy.optimize.least_squares``,
relative complex residuals ``(E_model - E) / |E|``) runs on unbounded
parameters ``x = (log E0, log(Einf/E0 - 1), log tau, logit alpha)``; the
standard errors are ``s^2 (J^T J)^-1`` in ``x`` propagated through that
transform (:mod:`jointid.methods.fit_statistics`).

When the data show no relaxation in the band (e.g. a constant complex
modulus), the optimizer runs to a limit: ``tau -> 0`` with ``Einf -> inf``
(the model degenerates to a power law ``E0 + c (j w)^alpha``), or the
relaxation frequency ``1/(2 pi tau)`` leaves the band, or ``alpha`` reaches 0
or 1. Such parameters get the status ``at_bound`` and :attr:`ZenerFit.warnings`
says so; their values must not be used. A modulus whose loss factor ``Im E* / Re E*`` is
negative on most lines (a reversed phase sign, :mod:`.phase_sign`) identifies no parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ...errors import DataError
from ..fit_statistics import (
    AT_BOUND,
    IDENTIFIED,
    NOT_IDENTIFIED,
    ParameterEstimate,
    classify,
    correlation_matrix,
    jacobian_covariance,
    propagate_covariance,
)
from .phase_sign import reversed_phase

__all__ = ["ZenerFit", "fit_zener", "zener_modulus", "ZENER_LIMITS"]

#: Limits beyond which a Zener parameter counts as run to a bound: relaxation frequency
#: more than ``band_factor`` above the top or below the bottom of the band, ``Einf/E0``
#: outside (1 + ratio_min, ratio_max), ``alpha`` within ``alpha_margin`` of 0 or 1.
ZENER_LIMITS = {"band_factor": 1e3, "ratio_min": 1e-6, "ratio_max": 1e4, "alpha_margin": 1e-3}
#: Largest |log-parameter| the fit evaluates (exp(700) ~ 1e304, finite in double precision).
_MAX_EXPONENT = 700.0


def zener_modulus(f_hz, E0: float, Einf: float, tau_s: float, alpha: float) -> np.ndarray:
    """Fractional-derivative Zener modulus ``(E0 + Einf (j w tau)^alpha) / (1 + (j w tau)^alpha)``, Pa, shape (F,)."""
    s = (1j * 2.0 * np.pi * np.asarray(f_hz, dtype=float) * tau_s) ** alpha
    return (E0 + Einf * s) / (1.0 + s)


@dataclass(frozen=True, eq=False)
class ZenerFit:
    """Fractional-derivative Zener model of the complex modulus.

    Parameters
    ----------
    E0 : float
        Relaxed (static) modulus, Pa.
    Einf : float
        Unrelaxed (high-frequency) modulus, Pa.
    tau_s : float
        Relaxation time, s.
    alpha : float
        Fractional order, 0 < alpha < 1.
    residual_rms : float
        rms relative complex residual of the fit.
    parameters : tuple of ParameterEstimate
        E0, Einf, tau, alpha with standard errors (Pa, Pa, s, -) and status.
    correlation : ndarray, shape (4, 4)
        Correlation of (E0, Einf, tau, alpha); NaN where undefined.
    """

    E0: float
    Einf: float
    tau_s: float
    alpha: float
    residual_rms: float
    parameters: tuple = ()
    correlation: np.ndarray | None = None

    @property
    def identified(self) -> bool:
        """True when every parameter is identified."""
        return all(p.identified for p in self.parameters)

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per reason a parameter is not identified (run to a bound, undetermined, a reversed phase)."""
        out: dict[tuple, list] = {}
        for p in self.parameters:
            if not p.identified:
                out.setdefault((p.status, p.reason), []).append(p.title)
        return tuple(f"Zener {', '.join(t)} {status.replace('_', ' ')}: {reason}" for (status, reason), t in out.items())

    def modulus(self, f_hz) -> np.ndarray:
        """E*(f), Pa, complex, shape (F,) (usable as ``ElastomerJoint(modulus=...)``)."""
        return zener_modulus(f_hz, self.E0, self.Einf, self.tau_s, self.alpha)

    def to_dict(self) -> dict:
        """JSON-ready dict: values only for identified parameters, statuses, correlation (null where undefined)."""
        names = [p.name for p in self.parameters]
        corr = None
        if self.correlation is not None:
            corr = [[float(c) if math.isfinite(c) else None for c in row] for row in self.correlation]
        return {
            "parameters": {p.name: p.to_dict() for p in self.parameters},
            "correlation": {"order": names, "matrix": corr},
            "residual_rms": self.residual_rms,
            "identified": self.identified,
        }


def _bound_reasons(f: np.ndarray, E0: float, Einf: float, tau: float, a: float) -> dict:
    lim = ZENER_LIMITS
    out = {}
    fpos = f[f > 0]
    fmin, fmax = (float(fpos.min()), float(fpos.max())) if fpos.size else (1.0, 1.0)
    fc = 1.0 / (2.0 * math.pi * tau) if tau > 0 else math.inf
    if fc > lim["band_factor"] * fmax:
        out["tau_s"] = f"tau ran to 0: the relaxation frequency 1/(2 pi tau) lies more than {lim['band_factor']:g}x above the band's top {fmax:g} Hz (no relaxation seen in the band)"
    elif fc < fmin / lim["band_factor"]:
        out["tau_s"] = f"tau ran to infinity: the relaxation frequency lies more than {lim['band_factor']:g}x below the band's bottom {fmin:g} Hz"
    ratio = Einf / E0 - 1.0
    if ratio > lim["ratio_max"]:
        out["Einf_pa"] = f"Einf ran to infinity (Einf/E0 > {lim['ratio_max']:g}): the unrelaxed modulus is not seen in the band"
    elif ratio < lim["ratio_min"]:
        out["Einf_pa"] = "Einf ran to E0: no relaxation strength in the band"
    if a < lim["alpha_margin"]:
        out["alpha"] = "alpha ran to 0"
    elif a > 1.0 - lim["alpha_margin"]:
        out["alpha"] = "alpha ran to 1"
    return out


def fit_zener(frequency_hz, modulus_pa, initial: tuple[float, float, float, float] | None = None,
              modulus_bounds_pa: tuple[float, float] = (0.1e6, 500e6)) -> ZenerFit:
    """Least-squares fit of a fractional Zener model to E*(f) (relative complex residuals).

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz (F >= 3: four real parameters from 2F real residuals).
    modulus_pa : array_like, shape (F,), complex
        E*(f), Pa.
    initial : (E0, Einf, tau, alpha), optional
        Starting point; default: several starts spread over the band, best kept.
    modulus_bounds_pa : (low, high)
        Physical range of the relaxed modulus E0, Pa.

    Returns
    -------
    ZenerFit
        With per-parameter standard errors (Pa, Pa, s, -), status and correlation.
    """
    f = np.asarray(frequency_hz, dtype=float).reshape(-1)
    E = np.asarray(modulus_pa, dtype=complex).reshape(-1)
    if f.shape != E.shape:
        raise DataError(f"frequency ({f.size} lines) and modulus ({E.size} values) differ in length")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(E))) or np.any(E == 0):
        raise DataError("the complex modulus has zero or non-finite values; drop unconverged lines before the Zener fit")
    if f.size < 3:
        raise DataError(f"a Zener fit needs at least 3 lines, got {f.size}")
    w = np.abs(E)

    def unpack(p):  # exponents held below exp's overflow (a far step is then a huge residual, rejected, not an error)
        q = np.clip(p, -_MAX_EXPONENT, _MAX_EXPONENT)
        E0 = math.exp(q[0])
        return E0, E0 * (1.0 + math.exp(q[1])), math.exp(q[2]), 1.0 / (1.0 + math.exp(-q[3]))

    def resid(p):
        r = (zener_modulus(f, *unpack(p)) - E) / w
        return np.concatenate([r.real, r.imag])

    if initial is not None:
        E0, Einf, tau, a = initial
        starts = [np.array([math.log(E0), math.log(max(Einf / E0 - 1.0, 1e-6)), math.log(tau), math.log(a / (1 - a))])]
    else:
        e_lo = float(np.abs(E[np.argmin(f)]))
        fpos = f[f > 0] if np.any(f > 0) else np.array([1.0])
        starts = []
        for ratio in (0.5, 2.0, 5.0):
            for fc in (fpos.min(), math.sqrt(fpos.min() * fpos.max()), fpos.max()):
                for a in (0.3, 0.6):
                    starts.append(np.array([math.log(0.8 * e_lo), math.log(ratio), math.log(1.0 / (2 * math.pi * fc)), math.log(a / (1 - a))]))
    best = None
    with np.errstate(over="ignore", invalid="ignore"):
        for p0 in starts:
            sol = least_squares(resid, p0, method="lm", xtol=1e-12, ftol=1e-12, max_nfev=4000)
            if best is None or sol.cost < best.cost:
                best = sol
    E0, Einf, tau, a = unpack(best.x)
    rr = np.abs(zener_modulus(f, E0, Einf, tau, a) - E) / w
    # covariance of x, propagated to (E0, Einf, tau, alpha)
    cov_x = jacobian_covariance(best.jac, best.fun)
    T = np.zeros((4, 4))
    T[0, 0] = E0
    T[1, 0], T[1, 1] = Einf, E0 * math.exp(best.x[1])
    T[2, 2] = tau
    T[3, 3] = a * (1.0 - a)
    cov = propagate_covariance(cov_x, T)
    se = np.sqrt(np.diag(cov))
    at_bound = _bound_reasons(f, E0, Einf, tau, a)
    spec = [("E0_pa", "Pa", E0, modulus_bounds_pa, "E0"), ("Einf_pa", "Pa", Einf, None, "Einf"),
            ("tau_s", "s", tau, None, "tau"), ("alpha", "-", a, None, "alpha")]
    params = []
    for (name, unit, value, bounds, label), s in zip(spec, se):
        if name in at_bound:
            params.append(ParameterEstimate(name, unit, value, float(s), AT_BOUND, at_bound[name], label))
            continue
        p = classify(name, unit, value, float(s), bounds, label=label)
        if p.status == IDENTIFIED and at_bound:
            # a parameter of a degenerate model is not determined either, whatever its local error
            p = ParameterEstimate(name, unit, value, float(s), NOT_IDENTIFIED,
                                  "another Zener parameter ran to a bound; the model is degenerate on this band", label)
        params.append(p)
    why = reversed_phase(E, "E*")  # a force lagging the displacement: no material (module phase_sign)
    if why is not None:
        params = [ParameterEstimate(p.name, p.unit, p.value, p.std_error, NOT_IDENTIFIED, why, p.label) for p in params]
    return ZenerFit(E0, Einf, tau, a, float(np.sqrt(np.mean(rr**2))), tuple(params), correlation_matrix(cov))
