"""Amplitude (Payne effect) and preload dependence of a joint's storage stiffness: Kraus and polynomial fits.

Kraus law
---------
A filled elastomer softens with the dynamic amplitude ``A`` as the filler
network breaks up (Payne effect). Kraus' model of the storage stiffness::

    K'(A) = K'inf + (K'0 - K'inf) / (1 + (A / Ac)^(2 m))

with the small-amplitude stiffness ``K'0``, the large-amplitude stiffness
``K'inf``, the critical amplitude ``Ac`` (peak, m; where half the drop has
happened) and the exponent ``m`` (about 0.5-0.6 for carbon black). The
companion loss law ``K''(A) = K''inf + 2 (K''m - K''inf) (A/Ac)^m / (1 + (A/Ac)^(2m))``
has a maximum ``K''m`` at ``Ac`` and shares ``Ac`` and ``m``
(:func:`fit_kraus_loss`, linear in ``K''inf, K''m`` once they are known).

:func:`fit_kraus` fits the storage law by least squares on relative
residuals ``(K'_model - K') / K'`` (or whitened by given standard errors) in
the unbounded parameters ``(ln K'0, ln K'inf, ln Ac, ln m)``, several
starts, best kept; standard errors are ``s^2 (J^T J)^-1`` propagated to the
physical parameters (:mod:`..fit_statistics`). With 4 parameters, a few
amplitudes leave few degrees of freedom: the errors are then rough, and a
sweep that does not reach both plateaus leaves ``K'0`` or ``K'inf`` (and
``Ac``) not identified - the statuses say so.

Preload
-------
:func:`fit_preload`: a polynomial ``K'(P) = sum_k c_k P^k`` (degree 1 or 2)
by linear least squares with standard errors; ``c_1 / c_0`` is the relative
stiffening per newton.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ...errors import DataError
from ..fit_statistics import (
    IDENTIFIED,
    classify,
    correlation_matrix,
    jacobian_covariance,
    propagate_covariance,
)

__all__ = ["KrausFit", "fit_kraus", "kraus_storage", "KrausLossFit", "fit_kraus_loss", "kraus_loss",
           "PreloadFit", "fit_preload"]


def _f(x) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def kraus_storage(amplitude_m, k0: float, kinf: float, critical_amplitude_m: float, exponent_m: float) -> np.ndarray:
    """Kraus storage stiffness ``K'inf + (K'0 - K'inf) / (1 + (A/Ac)^(2m))``, N/m, shape like ``amplitude_m``."""
    a = np.asarray(amplitude_m, dtype=float) / critical_amplitude_m
    return kinf + (k0 - kinf) / (1.0 + a ** (2.0 * exponent_m))


def kraus_loss(amplitude_m, kinf: float, kmax: float, critical_amplitude_m: float, exponent_m: float) -> np.ndarray:
    """Kraus loss stiffness ``K''inf + 2 (K''m - K''inf) (A/Ac)^m / (1 + (A/Ac)^(2m))``, N/m."""
    a = (np.asarray(amplitude_m, dtype=float) / critical_amplitude_m) ** exponent_m
    return kinf + 2.0 * (kmax - kinf) * a / (1.0 + a**2)


def _check(amplitude_m, values, name, std=None, minimum=4):
    a = np.asarray(amplitude_m, dtype=float).reshape(-1)
    v = np.asarray(values, dtype=float).reshape(-1)
    if a.shape != v.shape:
        raise DataError(f"{name}: {a.size} amplitudes but {v.size} values")
    if not (np.all(np.isfinite(a)) and np.all(a > 0) and np.all(np.isfinite(v)) and np.all(v > 0)):
        raise DataError(f"{name}: amplitudes (m, peak) and stiffnesses (N/m) must be finite and positive")
    if np.unique(a).size < minimum:
        raise DataError(f"{name}: needs at least {minimum} distinct amplitudes, got {np.unique(a).size}")
    if std is None:
        w = 1.0 / v
    else:
        s = np.asarray(std, dtype=float).reshape(-1)
        if s.shape != v.shape or not np.all(np.isfinite(s) & (s > 0)):
            raise DataError(f"{name}: standard errors must be positive and finite, one per amplitude")
        w = 1.0 / s
    return a, v, w, std is not None


@dataclass(frozen=True, eq=False)
class KrausFit:
    """Kraus storage law fitted to K'(A).

    Parameters
    ----------
    k0_n_m, kinf_n_m : float
        Small- and large-amplitude storage stiffness, N/m.
    critical_amplitude_m : float
        Ac (peak), m.
    exponent_m : float
        m, dimensionless.
    residual_rms : float
        rms relative residual (of ``(K'_model - K') / K'``).
    parameters : tuple of ParameterEstimate
        The four parameters with standard errors and status.
    correlation : ndarray, shape (4, 4)
        Correlation of (K'0, K'inf, Ac, m); NaN where undefined.
    amplitude_range_m : (float, float)
        Amplitudes fitted, m.
    findings : tuple of str
        One line each (not identified parameters, stiffening instead of softening).
    """

    k0_n_m: float
    kinf_n_m: float
    critical_amplitude_m: float
    exponent_m: float
    residual_rms: float
    parameters: tuple = ()
    correlation: np.ndarray | None = None
    amplitude_range_m: tuple = (math.nan, math.nan)
    findings: tuple = ()

    @property
    def identified(self) -> bool:
        """True when all four parameters are identified."""
        return all(p.identified for p in self.parameters)

    def storage(self, amplitude_m) -> np.ndarray:
        """Fitted K'(A), N/m."""
        return kraus_storage(amplitude_m, self.k0_n_m, self.kinf_n_m, self.critical_amplitude_m, self.exponent_m)

    def to_dict(self) -> dict:
        """JSON form: each parameter ``{"value", "std", "status"}``, identified, residual, amplitude range, findings."""
        d = {p.name: {"value": _f(p.value), "std": _f(p.std_error), "status": p.status} for p in self.parameters}
        d.update({"identified": self.identified, "residual_rms": _f(self.residual_rms),
                  "amplitude_min_m": _f(self.amplitude_range_m[0]), "amplitude_max_m": _f(self.amplitude_range_m[1]),
                  "findings": list(self.findings)})
        return d


def fit_kraus(amplitude_m, storage_n_m, storage_std=None) -> KrausFit:
    """Fit the Kraus law ``K'(A) = K'inf + (K'0 - K'inf) / (1 + (A/Ac)^(2m))`` to storage stiffness vs amplitude.

    Parameters
    ----------
    amplitude_m : array_like, shape (A,)
        Displacement amplitudes (peak), m; at least 4 distinct (5 leave one degree of freedom).
    storage_n_m : array_like, shape (A,)
        Storage stiffness K' at one frequency and temperature, N/m.
    storage_std : array_like, shape (A,), optional
        1-sigma of K', N/m (weights; default: equal relative weights).

    Returns
    -------
    KrausFit

    Raises
    ------
    DataError
        Mismatched shapes, non-positive values, fewer than 4 amplitudes.
    """
    a, v, w, _ = _check(amplitude_m, storage_n_m, "Kraus fit")
    amin, amax = float(a.min()), float(a.max())

    def unpack(p):
        return math.exp(p[0]), math.exp(p[1]), math.exp(p[2]), math.exp(p[3])

    def resid(p):
        return (kraus_storage(a, *unpack(p)) - v) * w

    def jac(p):
        K0, Kinf, Ac, m = unpack(p)
        la = np.log(a / Ac)
        u = np.exp(2.0 * m * la)
        D = 1.0 + u
        g = (K0 - Kinf) * 2.0 * m * u / D**2
        return np.column_stack([K0 / D, Kinf * (1.0 - 1.0 / D), g, -g * la]) * w[:, None]

    order = np.argsort(a)
    vs, as_ = v[order], a[order]
    k0, kinf = float(vs[0]), float(vs[-1])
    half = 0.5 * (k0 + kinf)
    # amplitude where the storage crosses half-way (log interpolation on the monotone envelope)
    try:
        ac = float(10 ** np.interp(-half, -vs, np.log10(as_))) if k0 > kinf else math.sqrt(amin * amax)
    except ValueError:
        ac = math.sqrt(amin * amax)
    best = None
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for m0 in (0.3, 0.6, 1.2):
            for acs in (1.0, 0.3, 3.0):
                for widen in (1.0, 1.25):  # plateaus beyond the sweep
                    k0s, kis = (k0 * widen, kinf / widen) if k0 > kinf else (k0 / widen, kinf * widen)
                    p0 = np.log([k0s, kis, ac * acs, m0])
                    sol = least_squares(resid, p0, jac=jac, method="lm", xtol=1e-14, ftol=1e-14, max_nfev=4000)
                    if np.all(np.isfinite(sol.fun)) and (best is None or sol.cost < best.cost):
                        best = sol
    if best is None:
        raise DataError("Kraus fit: the optimizer found no finite solution")
    K0, Kinf, Ac, m = unpack(best.x)
    cov = propagate_covariance(jacobian_covariance(best.jac, best.fun), np.diag([K0, Kinf, Ac, m]))
    se = np.sqrt(np.diag(cov))
    spec = [("k0_n_m", "N/m", K0, (0.0, math.inf), "K'0"), ("kinf_n_m", "N/m", Kinf, (0.0, math.inf), "K'inf"),
            ("critical_amplitude_m", "m", Ac, (amin / 10.0, amax * 10.0), "Ac"), ("exponent_m", "-", m, (0.05, 5.0), "m")]
    params = tuple(classify(n, u, val, float(s), b, label=lab) for (n, u, val, b, lab), s in zip(spec, se))
    findings = [f"Kraus {p.title} {p.status.replace('_', ' ')}: {p.reason}" for p in params if p.status != IDENTIFIED]
    if K0 < Kinf:
        findings.append("the storage stiffness rises with amplitude: not a Payne (softening) effect")
    if a.size - 4 < 2:
        findings.append(f"{a.size} amplitudes for 4 Kraus parameters: {a.size - 4} degree(s) of freedom, the standard errors are rough")
    rr = (kraus_storage(a, K0, Kinf, Ac, m) - v) / v
    return KrausFit(K0, Kinf, Ac, m, float(np.sqrt(np.mean(rr**2))), params, correlation_matrix(cov),
                    (amin, amax), tuple(findings))


@dataclass(frozen=True, eq=False)
class KrausLossFit:
    """Kraus loss law ``K''(A)`` with ``Ac`` and ``m`` taken from the storage fit.

    Parameters
    ----------
    kinf_n_m, kmax_n_m : float
        ``K''inf`` and the peak ``K''m``, N/m.
    kinf_std, kmax_std : float
        Their standard errors, N/m.
    critical_amplitude_m, exponent_m : float
        Shared with the storage fit.
    residual_rms : float
        rms relative residual.
    """

    kinf_n_m: float
    kmax_n_m: float
    kinf_std: float
    kmax_std: float
    critical_amplitude_m: float
    exponent_m: float
    residual_rms: float

    def loss(self, amplitude_m) -> np.ndarray:
        """Fitted K''(A), N/m."""
        return kraus_loss(amplitude_m, self.kinf_n_m, self.kmax_n_m, self.critical_amplitude_m, self.exponent_m)

    def to_dict(self) -> dict:
        """JSON form (None where not finite)."""
        return {"kinf_n_m": {"value": _f(self.kinf_n_m), "std": _f(self.kinf_std)},
                "kmax_n_m": {"value": _f(self.kmax_n_m), "std": _f(self.kmax_std)},
                "critical_amplitude_m": _f(self.critical_amplitude_m), "exponent_m": _f(self.exponent_m),
                "residual_rms": _f(self.residual_rms)}


def fit_kraus_loss(amplitude_m, loss_n_m, storage_fit: KrausFit) -> KrausLossFit:
    """Fit ``K''(A) = K''inf + 2 (K''m - K''inf) (A/Ac)^m / (1 + (A/Ac)^(2m))`` with Ac, m of ``storage_fit``.

    Linear least squares in ``(K''inf, K''m)`` on relative residuals; standard
    errors ``s^2 (J^T J)^-1`` (conditional on Ac and m).

    Parameters
    ----------
    amplitude_m : array_like, shape (A,)
        Amplitudes (peak), m (at least 3).
    loss_n_m : array_like, shape (A,)
        Loss stiffness K'' (imaginary part), N/m, > 0.
    storage_fit : KrausFit
        Supplies Ac and m.
    """
    a, v, w, _ = _check(amplitude_m, loss_n_m, "Kraus loss fit", minimum=3)
    x = (a / storage_fit.critical_amplitude_m) ** storage_fit.exponent_m
    g = 2.0 * x / (1.0 + x**2)
    A = np.column_stack([1.0 - g, g]) * w[:, None]
    p, *_ = np.linalg.lstsq(A, v * w, rcond=None)
    r = v * w - A @ p
    se = np.sqrt(np.diag(jacobian_covariance(-A, r)))
    return KrausLossFit(float(p[0]), float(p[1]), float(se[0]), float(se[1]), storage_fit.critical_amplitude_m,
                        storage_fit.exponent_m, float(np.sqrt(np.mean(r**2))))


@dataclass(frozen=True, eq=False)
class PreloadFit:
    """Polynomial storage stiffness vs static preload.

    Parameters
    ----------
    coefficients : ndarray, shape (degree + 1,)
        ``c_0, c_1, ...`` of ``K'(P) = sum c_k P^k`` (N/m, N/m/N, ...).
    std : ndarray, shape (degree + 1,)
        Standard errors of the coefficients.
    residual_rms : float
        rms residual, N/m.
    preload_range_n : (float, float)
        Preloads fitted, N.
    """

    coefficients: np.ndarray
    std: np.ndarray
    residual_rms: float
    preload_range_n: tuple

    def storage(self, preload_n) -> np.ndarray:
        """Fitted K'(P), N/m."""
        return np.polynomial.polynomial.polyval(np.asarray(preload_n, dtype=float), self.coefficients)

    def to_dict(self) -> dict:
        """JSON form: coefficients (ascending powers) with std, relative slope ``c_1 / c_0`` (1/N), residual, range."""
        c, s = self.coefficients, self.std
        return {"coefficients": [_f(x) for x in c], "std": [_f(x) for x in s],
                "relative_slope_per_n": _f(c[1] / c[0]) if c.size > 1 and c[0] != 0 else None,
                "residual_rms_n_m": _f(self.residual_rms),
                "preload_min_n": _f(self.preload_range_n[0]), "preload_max_n": _f(self.preload_range_n[1])}


def fit_preload(preload_n, storage_n_m, degree: int = 1) -> PreloadFit:
    """Least-squares polynomial ``K'(P) = sum_k c_k P^k`` of the storage stiffness vs preload, with standard errors.

    Parameters
    ----------
    preload_n : array_like, shape (P,)
        Static preloads, N (at least ``degree + 2`` distinct, so the error is estimated).
    storage_n_m : array_like, shape (P,)
        Storage stiffness, N/m.
    degree : int
        1 (linear) or 2 (quadratic).

    Returns
    -------
    PreloadFit
    """
    if degree not in (1, 2):
        raise DataError(f"preload fit: degree must be 1 or 2, got {degree!r}")
    p = np.asarray(preload_n, dtype=float).reshape(-1)
    v = np.asarray(storage_n_m, dtype=float).reshape(-1)
    if p.shape != v.shape or not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
        raise DataError(f"preload fit: {p.size} preloads and {v.size} stiffnesses, all finite, are needed")
    if np.unique(p).size < degree + 2:
        raise DataError(f"preload fit: degree {degree} needs at least {degree + 2} distinct preloads, got {np.unique(p).size}")
    V = np.polynomial.polynomial.polyvander(p, degree)
    c, *_ = np.linalg.lstsq(V, v, rcond=None)
    r = v - V @ c
    se = np.sqrt(np.diag(jacobian_covariance(-V, r)))
    return PreloadFit(c, se, float(np.sqrt(np.mean(r**2))), (float(p.min()), float(p.max())))
