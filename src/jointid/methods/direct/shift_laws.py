"""Time-temperature shift laws (WLF, Arrhenius) fitted to measured shift factors with their covariance.

A horizontal shift factor ``aT`` maps a test at temperature ``T`` and
frequency ``f`` onto the reduced frequency ``f_r = f aT`` at the reference
temperature ``Tref`` (``aT > 1`` below ``Tref``: a colder elastomer behaves
like a warmer one at a higher frequency). Two laws:

* WLF (Williams-Landel-Ferry), ``log10 aT = -c1 (T - Tref) / (c2 + T - Tref)``
  with ``c1`` (decades) and ``c2`` (K) at ``Tref``; valid above the glass
  transition; ``c2 + T - Tref`` must stay positive over the data (a pole
  inside the range means the fit is meaningless there);
* Arrhenius, ``log10 aT = Ea / (R ln 10) (1/T - 1/Tref)`` (absolute
  temperatures, ``R = 8.314462618 J/(mol K)``), one activation energy ``Ea``.

Both are fitted by generalized least squares: the residuals
``s - law(T)`` are whitened with the Cholesky factor of the shift factors'
covariance (chained shift factors are correlated), so ``chi2`` is the
whitened residual sum of squares. The parameter covariance is
``(J^T J)^-1`` of the whitened problem, inflated by the Birge ratio
``max(1, chi2 / dof)`` when the law does not fit within the stated errors.
Without a covariance the residuals are unweighted and the covariance is
``s^2 (J^T J)^-1`` (:func:`~jointid.methods.fit_statistics.jacobian_covariance`).
The laws are compared by ``AIC = chi2 + 2 k`` (k fitted parameters);
the lower one is preferred (:func:`preferred_law`).

When the reference temperature was not measured, the shift factors are only
known up to a constant; ``free_offset=True`` accounts for that constant ``o``
(``s = law(T) + o``; :meth:`WLFFit.log10_shift` leaves it out): fitted as a
parameter, or, when one shift factor has zero variance (the anchor of chained
shifts, ``s = 0`` there), fixed by it, ``o = -law(T_anchor)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ...errors import DataError
from ..fit_statistics import jacobian_covariance

__all__ = ["WLFFit", "ArrheniusFit", "fit_wlf", "fit_arrhenius", "preferred_law", "moved_shift_covariance", "wlf_log10_shift",
           "arrhenius_log10_shift", "wlf_undetermined", "GAS_CONSTANT", "KELVIN", "WLF_CURVATURE_Z", "WLF_CURVATURE_Z_EXACT",
           "WLF_SPAN_OF_C2",
           "TYPICAL_WLF_C2_K"]

#: Molar gas constant, J/(mol K).
GAS_CONSTANT = 8.314462618
#: 0 deg C in K.
KELVIN = 273.15
#: Standard errors at which the shift factors must see the curvature of ``log10 aT`` over ``T`` (the one thing that
#: sets c2; a straight line is WLF's c2 -> infinity) for a WLF law to be taken as determined.
WLF_CURVATURE_Z = 3.0
#: A WLF law with as many constants as shift factors passes through them exactly: no residual tests the shift factors'
#: stated errors (first-order estimates of chained shifts), so its curvature must be seen at this many standard errors
#: (a fluke of 5 is one in 1.7 million even when the errors are understated by half).
WLF_CURVATURE_Z_EXACT = 5.0
#: The span of temperatures advised is at least this fraction of :data:`TYPICAL_WLF_C2_K`: the slope of
#: ``log10 aT`` then changes by 50 % or more across them, a curvature no small error of a shift factor fakes.
WLF_SPAN_OF_C2 = 0.25
#: c2 (K) for the advice on the temperature span to measure: the order of elastomers' c2 near room temperature
#: (c2 = 51.6 K + Tref - Tg with Tg around -50 deg C).
TYPICAL_WLF_C2_K = 100.0


def _f(x) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def wlf_log10_shift(temperature_c, c1: float, c2: float, reference_temperature_c: float):
    """WLF ``log10 aT = -c1 (T - Tref) / (c2 + T - Tref)`` (decades; temperatures deg C, c2 K)."""
    x = np.asarray(temperature_c, dtype=float) - reference_temperature_c
    out = -c1 * x / (c2 + x)
    return float(out) if out.ndim == 0 else out


def arrhenius_log10_shift(temperature_c, activation_energy_j_mol: float, reference_temperature_c: float):
    """Arrhenius ``log10 aT = Ea / (R ln 10) (1/T - 1/Tref)`` (decades; temperatures deg C, Ea J/mol)."""
    t = np.asarray(temperature_c, dtype=float) + KELVIN
    out = activation_energy_j_mol / (GAS_CONSTANT * math.log(10.0)) * (1.0 / t - 1.0 / (reference_temperature_c + KELVIN))
    return float(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class WLFFit:
    """WLF law fitted to shift factors.

    Parameters
    ----------
    c1, c2 : float
        WLF constants at ``reference_temperature_c`` (decades, K).
    c1_std, c2_std : float
        Standard errors (inf when the data do not determine them).
    correlation : float
        Correlation of c1 and c2 (NaN when undefined).
    rms_residual : float
        rms of ``s - law(T)``, decades (unweighted).
    chi2 : float
        Whitened residual sum of squares.
    aic : float
        ``chi2 + 2 k``.
    reference_temperature_c : float
        Tref, deg C.
    offset : float
        Fitted constant of the shift factors (0 unless ``free_offset``), decades.
    offset_std : float
        Its standard error (0 unless ``free_offset``).
    n_points : int
        Shift factors used.
    """

    c1: float
    c2: float
    c1_std: float
    c2_std: float
    correlation: float
    rms_residual: float
    chi2: float
    aic: float
    reference_temperature_c: float
    offset: float = 0.0
    offset_std: float = 0.0
    n_points: int = 0

    def log10_shift(self, temperature_c):
        """``log10 aT`` at ``temperature_c`` (deg C), 0 at the reference temperature."""
        return wlf_log10_shift(temperature_c, self.c1, self.c2, self.reference_temperature_c)

    def to_dict(self) -> dict:
        """JSON form: c1, c2, their std and correlation, rms residual, chi2, aic (None where not finite)."""
        return {"c1": _f(self.c1), "c2": _f(self.c2), "c1_std": _f(self.c1_std), "c2_std": _f(self.c2_std),
                "correlation": _f(self.correlation), "rms_residual": _f(self.rms_residual),
                "chi2": _f(self.chi2), "aic": _f(self.aic)}


@dataclass(frozen=True)
class ArrheniusFit:
    """Arrhenius law fitted to shift factors.

    Parameters
    ----------
    activation_energy_j_mol, std : float
        Activation energy ``Ea`` and its standard error, J/mol.
    rms_residual, chi2, aic : float
        As in :class:`WLFFit`.
    reference_temperature_c : float
        Tref, deg C.
    offset, offset_std : float
        Fitted constant (``free_offset``), decades.
    n_points : int
        Shift factors used.
    """

    activation_energy_j_mol: float
    std: float
    rms_residual: float
    chi2: float
    aic: float
    reference_temperature_c: float
    offset: float = 0.0
    offset_std: float = 0.0
    n_points: int = 0

    def log10_shift(self, temperature_c):
        """``log10 aT`` at ``temperature_c`` (deg C), 0 at the reference temperature."""
        return arrhenius_log10_shift(temperature_c, self.activation_energy_j_mol, self.reference_temperature_c)

    def to_dict(self) -> dict:
        """JSON form: Ea and its std (J/mol), rms residual, chi2, aic (None where not finite)."""
        return {"activation_energy_j_mol": _f(self.activation_energy_j_mol), "std": _f(self.std),
                "rms_residual": _f(self.rms_residual), "chi2": _f(self.chi2), "aic": _f(self.aic)}


def _prepare(temperature_c, log10_shift, covariance, reference_temperature_c, free_offset):
    """Points to fit, the whitening matrix and the anchor temperature.

    A zero-variance point is the anchor of the shift factors (``s = 0`` by
    definition). At Tref every law passes through it and it is dropped; with
    ``free_offset`` (Tref not measured) it fixes the constant,
    ``o = -law(T_anchor)``, and the other points are fitted as
    ``s = law(T) - law(T_anchor)``.
    """
    t = np.asarray(temperature_c, dtype=float).reshape(-1)
    s = np.asarray(log10_shift, dtype=float).reshape(-1)
    if t.shape != s.shape:
        raise DataError(f"shift law: {t.size} temperatures but {s.size} shift factors")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(s))):
        raise DataError("shift law: temperatures and shift factors must be finite")
    if covariance is None:
        C = None
    else:
        C = np.asarray(covariance, dtype=float)
        if C.ndim == 1:
            C = np.diag(C**2)
        if C.shape != (t.size, t.size) or not np.all(np.isfinite(C)):
            raise DataError(f"shift law: covariance must be finite with shape ({t.size},) std or ({t.size}, {t.size})")
    keep = np.ones(t.size, dtype=bool)
    anchor = None
    if C is not None:
        zero = np.diag(C) <= 0
        if np.any(np.abs(s[zero]) > 1e-12):
            raise DataError("shift law: a zero-variance shift factor (the anchor) is not 0")
        if not free_offset:
            if np.any(zero & (np.abs(t - reference_temperature_c) > 1e-9)):
                raise DataError("shift law: a shift factor away from the reference temperature has zero variance")
        elif zero.sum() > 1:
            raise DataError("shift law: more than one shift factor has zero variance")
        elif zero.sum() == 1:
            anchor = float(t[zero][0])
        keep = ~zero
    t, s = t[keep], s[keep]
    W = None
    if C is not None:
        C = C[np.ix_(keep, keep)]
        try:
            L = np.linalg.cholesky(C)
        except np.linalg.LinAlgError:
            raise DataError("shift law: the covariance of the shift factors is not positive definite") from None
        W = np.linalg.inv(L)
    return t, s, W, anchor


def _finish(sol_fun, jac, W, n, k):
    """Parameter covariance, chi2 and AIC of a (whitened) least-squares solution."""
    r = np.asarray(sol_fun, dtype=float)
    chi2 = float(r @ r)
    dof = n - k
    if W is None:
        cov = jacobian_covariance(jac, r)
        s2 = chi2 / dof if dof > 0 else math.nan
        aic = n * math.log(max(chi2 / n, 1e-300)) + 2 * k if n > 0 else math.nan
        return cov, chi2, aic, s2
    J = np.asarray(jac, dtype=float)
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    if sv.size < k or sv[-1] <= sv[0] * max(J.shape) * np.finfo(float).eps * 10:
        cov = np.full((k, k), np.inf)
    else:
        cov = (Vt.T / sv**2) @ Vt
        if dof > 0:
            cov = cov * max(1.0, chi2 / dof)
    return cov, chi2, chi2 + 2 * k, None


def fit_wlf(temperature_c, log10_shift, reference_temperature_c: float, covariance=None, *,
            free_offset: bool = False) -> WLFFit:
    """Fit the WLF law ``log10 aT = -c1 (T - Tref) / (c2 + T - Tref)`` (+ offset) to shift factors.

    Parameters
    ----------
    temperature_c : array_like, shape (N,)
        Temperatures, deg C.
    log10_shift : array_like, shape (N,)
        Measured ``log10 aT``, decades.
    reference_temperature_c : float
        Tref, deg C.
    covariance : array_like, shape (N,) or (N, N), optional
        Standard errors or covariance of the shift factors (decades). A point
        at Tref with zero variance (the anchor) is left out: every law gives 0 there.
    free_offset : bool
        Also fit a constant of the shift factors (Tref not measured).

    Returns
    -------
    WLFFit

    Raises
    ------
    DataError
        Fewer points than parameters (2, or 3 with the offset), or bad input.
    """
    t, s, W, anchor = _prepare(temperature_c, log10_shift, covariance, reference_temperature_c, free_offset)
    fit_offset = free_offset and anchor is None
    k = 3 if fit_offset else 2
    if t.size < k:
        raise DataError(f"WLF fit: needs at least {k} shift factors away from the anchor, got {t.size}")
    x = t - reference_temperature_c
    xa = (anchor - reference_temperature_c) if anchor is not None else 0.0
    # start: x / s = -(c2 + x) / c1 is linear in x
    nz = np.abs(s) > 1e-12
    c1, c2 = 10.0, 100.0
    if nz.sum() >= 2 and not free_offset:  # (with an offset the plain start is used)
        A = np.column_stack([np.ones(nz.sum()), x[nz]])
        (a0, a1), *_ = np.linalg.lstsq(A, x[nz] / s[nz], rcond=None)
        if a1 < 0 and a0 < 0:
            c1, c2 = -1.0 / a1, a0 / a1
    Wm = np.eye(t.size) if W is None else W

    def law(p):
        return -p[0] * x / (p[1] + x) + (p[2] if fit_offset else 0.0) + p[0] * xa / (p[1] + xa)

    def resid(p):
        return Wm @ (s - law(p))

    def jac(p):
        cols = [-x / (p[1] + x) + xa / (p[1] + xa), p[0] * x / (p[1] + x) ** 2 - p[0] * xa / (p[1] + xa) ** 2]
        if fit_offset:
            cols.append(np.ones_like(x))
        return -Wm @ np.column_stack(cols)

    p0 = np.array([c1, c2] + ([0.0] if fit_offset else []))
    best = None
    for scale in (1.0, 0.5, 2.0):  # further starts only when the first does not converge to a pole-free law
        q0 = p0.copy()
        q0[1] = max(p0[1] * scale, -min(x.min(), xa) + 1.0)
        sol = least_squares(resid, q0, jac=jac, method="lm", xtol=1e-14, ftol=1e-14, max_nfev=2000)
        if best is None or sol.cost < best.cost:
            best = sol
        if best.status > 0 and best.x[1] + min(x.min(), xa) > 0:
            break
    cov, chi2, aic, _ = _finish(best.fun, best.jac, W, t.size, k)
    sd = np.sqrt(np.diag(cov))
    corr = cov[0, 1] / (sd[0] * sd[1]) if np.all(np.isfinite(sd[:2])) and sd[0] > 0 and sd[1] > 0 else math.nan
    p = best.x
    offset, offset_std = (float(p[2]), float(sd[2])) if fit_offset else (0.0, 0.0)
    if anchor is not None:  # o = -law(T_anchor) = c1 xa / (c2 + xa)
        offset = float(p[0] * xa / (p[1] + xa))
        g = np.array([xa / (p[1] + xa), -p[0] * xa / (p[1] + xa) ** 2])
        offset_std = float(math.sqrt(max(g @ cov[:2, :2] @ g, 0.0))) if np.all(np.isfinite(cov[:2, :2])) else math.inf
    return WLFFit(float(p[0]), float(p[1]), float(sd[0]), float(sd[1]), float(corr),
                  float(np.sqrt(np.mean((s - law(p)) ** 2))), chi2, aic, float(reference_temperature_c),
                  offset, offset_std, int(t.size))


def fit_arrhenius(temperature_c, log10_shift, reference_temperature_c: float, covariance=None, *,
                  free_offset: bool = False) -> ArrheniusFit:
    """Fit the Arrhenius law ``log10 aT = Ea / (R ln 10) (1/T - 1/Tref)`` (+ offset) by linear GLS.

    Parameters
    ----------
    temperature_c, log10_shift, reference_temperature_c, covariance, free_offset
        As in :func:`fit_wlf`.

    Returns
    -------
    ArrheniusFit
    """
    t, s, W, anchor = _prepare(temperature_c, log10_shift, covariance, reference_temperature_c, free_offset)
    fit_offset = free_offset and anchor is None
    k = 2 if fit_offset else 1
    if t.size < k:
        raise DataError(f"Arrhenius fit: needs at least {k} shift factors away from the anchor, got {t.size}")

    def basis(tc):
        return (1.0 / (tc + KELVIN) - 1.0 / (reference_temperature_c + KELVIN)) / (GAS_CONSTANT * math.log(10.0))

    ga = basis(anchor) if anchor is not None else 0.0
    g = basis(t) - ga
    A = np.column_stack([g] + ([np.ones_like(g)] if fit_offset else []))
    Wm = np.eye(t.size) if W is None else W
    p, *_ = np.linalg.lstsq(Wm @ A, Wm @ s, rcond=None)
    r = Wm @ (s - A @ p)
    cov, chi2, aic, _ = _finish(r, -(Wm @ A), W, t.size, k)
    sd = np.sqrt(np.diag(cov))
    offset, offset_std = (float(p[1]), float(sd[1])) if fit_offset else (0.0, 0.0)
    if anchor is not None:  # o = -law(T_anchor)
        offset, offset_std = float(-p[0] * ga), float(abs(ga) * sd[0])
    return ArrheniusFit(float(p[0]), float(sd[0]), float(np.sqrt(np.mean((s - A @ p) ** 2))), chi2, aic,
                        float(reference_temperature_c), offset, offset_std, int(t.size))


def preferred_law(wlf: WLFFit | None, arrhenius: ArrheniusFit | None) -> str | None:
    """``"wlf"`` or ``"arrhenius"``: the law with the lower AIC (None if neither was fitted; Arrhenius on ties)."""
    aw = wlf.aic if wlf is not None and math.isfinite(wlf.aic) else math.inf
    aa = arrhenius.aic if arrhenius is not None and math.isfinite(arrhenius.aic) else math.inf
    if not (math.isfinite(aw) or math.isfinite(aa)):
        return None
    return "wlf" if aw < aa else "arrhenius"


def moved_shift_covariance(fit, temperature_c, log10_shift, reference_temperature_c: float, covariance,
                           offset_variance: float, step: float = 1e-6) -> np.ndarray:
    """Covariance of the shift factors moved to an unmeasured reference, ``s - o 1``, decades^2.

    When the reference temperature was not measured, the shifts ``s`` (anchored at a measured
    temperature) are moved by the law's offset ``o(s)`` (``log10 aT`` of the anchor relative to the
    reference). With ``h = do/ds`` (central differences of ``fit``, step ``step`` decades) and
    ``M = I - 1 h^T``::

        cov(s - o 1) = M C M^T + (var_o - h^T C h) 1 1^T

    the last term (when positive) being the law's Birge inflation of ``var_o``. The common term moves
    every reduced frequency together: it is the relaxation time's share of the extrapolation's error.

    Parameters
    ----------
    fit : callable
        :func:`fit_wlf` or :func:`fit_arrhenius` (called with ``free_offset=True``).
    temperature_c, log10_shift : ndarray, shape (N,)
        The master curve's temperatures, deg C, and shifts relative to the anchor, decades.
    reference_temperature_c : float
        The (unmeasured) reference, deg C.
    covariance : ndarray, shape (N, N)
        Covariance ``C`` of ``log10_shift`` (the anchor's row and column zero), decades^2.
    offset_variance : float
        ``var_o``, the law's variance of the offset, decades^2.
    step : float
        Difference step, decades.

    Returns
    -------
    ndarray, shape (N, N)
    """
    s = np.asarray(log10_shift, dtype=float)
    C = np.asarray(covariance, dtype=float)
    h = np.zeros(s.size)
    for k in range(s.size):
        if not C[k, k] > 0:  # the anchor: fixed at 0, the law is fitted without it
            continue
        e = np.zeros(s.size)
        e[k] = step
        up = fit(temperature_c, s + e, reference_temperature_c, C, free_offset=True).offset
        down = fit(temperature_c, s - e, reference_temperature_c, C, free_offset=True).offset
        h[k] = (up - down) / (2.0 * step)
    one = np.ones(s.size)
    M = np.eye(s.size) - np.outer(one, h)
    extra = max(float(offset_variance) - float(h @ C @ h), 0.0)
    return M @ C @ M.T + extra * np.outer(one, one)


def wlf_undetermined(wlf: WLFFit, temperature_c, log10_shift, reference_temperature_c: float, covariance=None, *,
                     free_offset: bool = False) -> str:
    """Why the shift factors do not determine a fitted WLF law, with what to measure; ``""`` when they do.

    The linearized covariance of (c1, c2) is not to be trusted when the temperatures are close: c1 = s / b and
    c2 = 1 / b with ``b`` the curvature parameter (``log10 aT = -s x / (1 + b x)``, ``x = T - Tref``), so a ``b``
    near 0 within its error gives any c1, c2 with a small-looking linearized std. The test is on ``b`` instead:

    * **profile likelihood**: the straight line (``b = 0``, c2 infinite) is fitted with the same weights; the law is
      determined only when it beats the line by ``chi2_line - chi2_wlf >= WLF_CURVATURE_Z**2`` (divided by the WLF
      fit's Birge ratio ``chi2 / dof`` when above 1), i.e. the curvature is seen at :data:`WLF_CURVATURE_Z` standard
      errors;
    * **no degree of freedom** (as many constants as shift factors): at :data:`WLF_CURVATURE_Z_EXACT` standard errors
      (nothing tests the stated errors of the shift factors).

    The span to measure is the larger of ``WLF_SPAN_OF_C2 * TYPICAL_WLF_C2_K`` and the span at which the curvature
    of a law with c2 = :data:`TYPICAL_WLF_C2_K` would be seen at the needed standard errors (the curvature's std falls
    as the span squared for the same temperatures' pattern and errors).

    Parameters
    ----------
    wlf : WLFFit
        The law fitted to these shift factors (:func:`fit_wlf`, same arguments).
    temperature_c, log10_shift, reference_temperature_c, covariance, free_offset
        As for :func:`fit_wlf` (deg C, decades).

    Returns
    -------
    str
        e.g. ``"the curvature of log aT over T, which sets c2, is seen at 0.9 standard errors (3 needed): a straight
        line (c2 infinite) is not excluded; measure temperatures spread over at least 25 C (now 2 C)"``, or ``""``.
    """
    t_all = np.asarray(temperature_c, dtype=float).reshape(-1)
    t, s, W, anchor = _prepare(temperature_c, log10_shift, covariance, reference_temperature_c, free_offset)
    fit_offset = free_offset and anchor is None
    k = 3 if fit_offset else 2
    x = t - reference_temperature_c
    xa = (anchor - reference_temperature_c) if anchor is not None else 0.0
    Wm = np.eye(t.size) if W is None else W
    extra = [np.ones_like(x)] if fit_offset else []
    line = Wm @ np.column_stack([x - xa, *extra])
    coef, *_ = np.linalg.lstsq(line, Wm @ s, rcond=None)
    chi2_line = float(np.sum((Wm @ s - line @ coef) ** 2))
    dof = t.size - k
    birge = max(1.0, wlf.chi2 / dof) if dof > 0 else 1.0
    z = math.sqrt(max(chi2_line - wlf.chi2, 0.0) / birge)
    span = float(np.ptp(t_all))
    quad = Wm @ np.column_stack([x - xa, x**2 - xa**2, *extra])
    q, *_ = np.linalg.lstsq(quad, Wm @ s, rcond=None)
    try:
        sd_a2 = math.sqrt(float(np.linalg.inv(quad.T @ quad)[1, 1]) * birge)
    except np.linalg.LinAlgError:
        sd_a2 = math.inf
    # log10 aT ~ a1 x + a2 x^2 with a2 = -a1 / c2: seen at z = |a1| / (c2 sd_a2), which grows as the span squared
    z_needed = WLF_CURVATURE_Z if dof > 0 else WLF_CURVATURE_Z_EXACT
    scale = math.sqrt(z_needed * TYPICAL_WLF_C2_K * sd_a2 / abs(q[0])) if q[0] != 0 and math.isfinite(sd_a2) else math.inf
    need = max(WLF_SPAN_OF_C2 * TYPICAL_WLF_C2_K, span * scale)
    need_text = f"{5 * math.ceil(need / 5):g}" if math.isfinite(need) else "far more than"
    if z >= z_needed:
        return ""
    exact = "" if dof > 0 else f", the law passing exactly through the {t.size} shift factors"
    return (f"the curvature of log aT over T, which sets c2, is seen at {z:.2g} standard errors ({z_needed:g} needed{exact}): "
            f"a straight line (c2 infinite) is not excluded; measure temperatures spread over at least {need_text} C "
            f"(now {span:g} C)")
