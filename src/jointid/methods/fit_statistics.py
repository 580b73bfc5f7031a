"""Standard errors, correlations and identifiability of fitted material parameters.

Covariance from the least-squares Jacobian
------------------------------------------
A fit minimizes ``sum r_i(x)^2`` over the optimizer's parameters ``x`` (here
logarithms or other unbounded transforms of the physical parameters ``p``).
With ``n`` residuals and ``m`` parameters, the residual variance is estimated
as ``s^2 = RSS / (n - m)`` and the covariance of ``x`` as
``cov_x = s^2 (J^T J)^-1`` (``J = dr/dx`` at the solution, evaluated through
the SVD of ``J``, never by forming ``J^T J``). The physical parameters follow
by linear propagation through the transform (delta method):
``cov_p = T cov_x T^T`` with ``T = dp/dx``, e.g. ``T = diag(p)`` for
``p = exp(x)``, so the standard errors come out in the parameter's own units.
A direction of ``x`` the data do not constrain (singular value below
round-off) gives an infinite standard error to every parameter it touches.

These are local, first-order errors that assume the model is right and the
residuals are independent with equal variance: a model error (e.g. a storage
modulus that rises with frequency fitted with a constant one) inflates ``s``
but also biases the values, which the standard errors do not show. Hence the
extra physical checks of :func:`classify`.

Status of a parameter
---------------------
``identified``
    inside its physical bounds with a relative standard error <= 50 %.
``held_at_default``
    the data cannot determine it; the fit holds it at a documented default and
    refits the others (the value is an assumption, not a result).
``fixed``
    held at a value the caller gave.
``not_identified``
    outside its physical bounds or with a relative standard error > 50 %, and
    no default: its value must not be used.
``at_bound``
    the optimizer ran to a limit of the parameter's range (e.g. a relaxation
    time -> 0): the model is not determined by the data there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "IDENTIFIED",
    "HELD_AT_DEFAULT",
    "FIXED",
    "NOT_IDENTIFIED",
    "AT_BOUND",
    "MAX_RELATIVE_STD",
    "ParameterEstimate",
    "jacobian_covariance",
    "propagate_covariance",
    "correlation_matrix",
    "classify",
]

IDENTIFIED = "identified"
HELD_AT_DEFAULT = "held_at_default"
FIXED = "fixed"
NOT_IDENTIFIED = "not_identified"
AT_BOUND = "at_bound"

#: A parameter with a larger relative standard error is not identified.
MAX_RELATIVE_STD = 0.5


def _finite_or_none(x):
    return float(x) if x is not None and math.isfinite(x) else None


@dataclass(frozen=True)
class ParameterEstimate:
    """One fitted (or held) parameter with its standard error and status.

    Parameters
    ----------
    name : str
        Key, e.g. ``"density_kg_m3"``.
    unit : str
        Unit of ``value`` and ``std_error`` (``"Pa"``, ``"-"``, ``"kg/m^3"``, ``"s"``).
    value : float
        Value the model uses: the fitted value, or the held one (for
        ``held_at_default`` / ``fixed``). Meaningless for ``not_identified``
        and ``at_bound`` (kept only so the model can be evaluated).
    std_error : float
        Standard error in ``unit`` (inf if the data do not constrain it, NaN if held).
    status : str
        One of the statuses of the module docstring.
    reason : str
        Why the status is not ``identified`` (empty when it is).
    label : str
        Short human name for messages (default: ``name``), e.g. ``"density"``.
    """

    name: str
    unit: str
    value: float
    std_error: float
    status: str
    reason: str = ""
    label: str = ""

    @property
    def title(self) -> str:
        """``label`` or, if empty, ``name``."""
        return self.label or self.name

    @property
    def identified(self) -> bool:
        """True when the data determine the parameter (status ``identified``)."""
        return self.status == IDENTIFIED

    @property
    def held(self) -> bool:
        """True when the value is an assumption (``held_at_default`` or ``fixed``)."""
        return self.status in (HELD_AT_DEFAULT, FIXED)

    @property
    def relative_std_error(self) -> float:
        """``std_error / |value|`` (inf for a zero value, NaN if held)."""
        if math.isnan(self.std_error):
            return math.nan
        return self.std_error / abs(self.value) if self.value != 0 else math.inf

    def to_dict(self) -> dict:
        """JSON-ready dict: ``value`` only when identified, ``held_value`` when held, never NaN/inf."""
        d = {
            "value": float(self.value) if self.identified else None,
            "std_error": _finite_or_none(self.std_error) if self.identified else None,
            "relative_std_error": _finite_or_none(self.relative_std_error) if self.identified else None,
            "unit": self.unit,
            "status": self.status,
        }
        if self.held:
            d["held_value"] = float(self.value)
        if self.reason:
            d["reason"] = self.reason
        return d

    def describe(self, scale: float = 1.0, unit: str | None = None, digits: int = 4) -> str:
        """Terminal text, e.g. ``"E = 15 +- 0.0034 MPa"``, ``"density held at 1100 kg/m^3"``, ``"E not identified"``.

        Parameters
        ----------
        scale : float
            Divisor of value and standard error (e.g. 1e6 with ``unit="MPa"``).
        unit : str, optional
            Unit shown (default ``self.unit``; ``"-"`` shows none).
        digits : int
            Significant digits of the value.
        """
        u = self.unit if unit is None else unit
        u = "" if u == "-" else f" {u}"
        if self.identified:
            return f"{self.title} = {self.value / scale:.{digits}g} +- {self.std_error / scale:.2g}{u}"
        if self.held:
            return f"{self.title} held at {self.value / scale:.{digits}g}{u} ({self.status.replace('_', ' ')}, not identified)"
        return f"{self.title} {self.status.replace('_', ' ')}"


def jacobian_covariance(jac: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """``s^2 (J^T J)^-1`` with ``s^2 = RSS / (n - m)``, via the SVD of ``J``, shape (m, m).

    Parameters
    ----------
    jac : ndarray, shape (n, m)
        Jacobian of the residuals with respect to the optimizer's parameters.
    residual : ndarray, shape (n,)
        Residuals at the solution.

    Returns
    -------
    ndarray, shape (m, m)
        Covariance of the optimizer's parameters; rows/columns of parameters
        touched by an unconstrained direction (or all, if ``n <= m``) are inf.
    """
    J = np.asarray(jac, dtype=float)
    r = np.asarray(residual, dtype=float).reshape(-1)
    n, m = J.shape
    cov = np.full((m, m), np.inf)
    if n <= m or not np.all(np.isfinite(J)):
        return cov
    s2 = float(r @ r) / (n - m)
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    if sv.size == 0 or sv[0] == 0:
        return cov
    keep = sv > sv[0] * max(n, m) * np.finfo(float).eps * 10
    cov = s2 * (Vt[keep].T / sv[keep] ** 2) @ Vt[keep]
    if not keep.all():
        touched = np.any(np.abs(Vt[~keep]) > 1e-8, axis=0)
        cov[touched, :] = np.inf
        cov[:, touched] = np.inf
    return cov


def propagate_covariance(cov_x: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``T cov_x T^T`` (delta method) keeping inf for parameters that depend on an unconstrained one.

    Parameters
    ----------
    cov_x : ndarray, shape (m, m)
        Covariance of the optimizer's parameters (may hold inf).
    T : ndarray, shape (q, m)
        ``dp/dx`` at the solution.
    """
    cov_x = np.asarray(cov_x, dtype=float)
    T = np.asarray(T, dtype=float)
    bad = ~np.isfinite(np.diag(cov_x))
    c = np.where(np.isfinite(cov_x), cov_x, 0.0)
    out = T @ c @ T.T
    dep = np.any((T[:, bad] != 0), axis=1) if bad.any() else np.zeros(T.shape[0], dtype=bool)
    out[dep, :] = np.inf
    out[:, dep] = np.inf
    return out


def correlation_matrix(cov: np.ndarray) -> np.ndarray:
    """Correlation ``cov_ij / sqrt(cov_ii cov_jj)``; NaN where a variance is inf or zero, shape (m, m)."""
    cov = np.asarray(cov, dtype=float)
    sd = np.sqrt(np.diag(cov))
    ok = np.isfinite(sd) & (sd > 0)
    corr = np.full(cov.shape, np.nan)
    idx = np.flatnonzero(ok)
    corr[np.ix_(idx, idx)] = cov[np.ix_(idx, idx)] / np.outer(sd[idx], sd[idx])
    return corr


def classify(name: str, unit: str, value: float, std_error: float, bounds: tuple[float, float] | None,
             max_relative_std: float = MAX_RELATIVE_STD, upper_inclusive: bool = True, label: str = "") -> ParameterEstimate:
    """Status ``identified`` or ``not_identified`` from the physical bounds and the relative standard error.

    Parameters
    ----------
    name, unit, label : str
        Parameter key, unit and short human name.
    value, std_error : float
        Fitted value and standard error (same unit).
    bounds : (low, high) or None
        Physically plausible range (inclusive; the upper end exclusive when
        ``upper_inclusive`` is False).
    max_relative_std : float
        Largest acceptable ``std_error / |value|``.
    """
    value = float(value)
    std_error = float(std_error)
    if not math.isfinite(value):
        return ParameterEstimate(name, unit, value, std_error, NOT_IDENTIFIED, "the fit did not give a finite value", label)
    if bounds is not None:
        lo, hi = bounds
        outside = value < lo or (value > hi if upper_inclusive else value >= hi)
        if outside:
            close = "]" if upper_inclusive else ")"
            return ParameterEstimate(name, unit, value, std_error, NOT_IDENTIFIED,
                                     f"the fitted value lies outside the physical range [{lo:g}, {hi:g}{close} {unit}", label)
    rel = std_error / abs(value) if value != 0 else math.inf
    if not rel <= max_relative_std:
        what = "the data do not constrain it" if not math.isfinite(rel) else f"relative standard error {rel:.0%} > {max_relative_std:.0%}"
        return ParameterEstimate(name, unit, value, std_error, NOT_IDENTIFIED, what, label)
    return ParameterEstimate(name, unit, value, std_error, IDENTIFIED, "", label)
