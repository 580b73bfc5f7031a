"""Maximum-likelihood fit of the structured joint model over all frequency lines at once.

The model (:mod:`jointid.methods.receptance.structured_model`) is fitted by weighted least
squares *in the coupling parameters* ``x`` (upper triangle of
``X = (I + Du Y[n,n])^-1 Du``) of :func:`jointid.methods.receptance.coupling_lines.coupling_per_line`:
the per-line estimate ``x_f`` is linear in the FRF errors, with covariance ``C_f``,
and (for Gaussian errors) a sufficient statistic of the line's FRFs for ``X_f``, so::

    min_theta, u  sum_f || C_f^(-1/2) (x_f + G_f u - x_f(theta)) ||^2 + ||u||^2

is the maximum-likelihood fit of the model to the FRFs themselves (given the
per-line covariance, whose scale comes from each line's residuals). No noisy
per-line ``Du`` is ever inverted and no relinearization is needed. ``G_f u`` is
an error common to all lines (the column force calibration,
:attr:`~jointid.methods.receptance.column_calibration.ColumnCalibration.x_factor`,
``u ~ CN(0, I)``), profiled out in closed form: minimizing over ``u`` equals
whitening the stacked residual by ``(I + G_w G_w^H)^(-1/2)`` (thin SVD). It is
thereby estimated jointly with the joint instead of being added to the bands as
an error smoothing cannot reduce.

Jacobian analytic: ``dX = (I + Du Ynn)^-1 dDu (I + Ynn Du)^-1``; solver
:func:`~jointid.methods.levenberg_marquardt.levenberg_marquardt` (MINPACK ``lmder``'s algorithm on the normal
equations: its QR of the tall Jacobian was a third of the fit's time), ended also when it stalls: when
:data:`_STALL_STEPS` successful steps lower chi^2 by less than :data:`_STALL_CHI2` in all. A fit that creeps
along a flat valley (e.g. two internal modes above the band standing in for the residual term: on the
benchmark's 19 901 lines one used all its 200 evaluations, 0.4 s, lowering chi^2 by ~0.05 per step) ends there
with the chi^2 it reached; its Akaike weight is then that of a fit which did not show a better one, not that of
wherever the evaluations ran out. Starts: a linear fit without
modes; for the first internal mode a grid over (loss angle, pole) that is linear in
``A``, ``B``, ``C`` on the smoothed per-term curves; for further modes a grid of
poles ranked by the linearized cost.

Uncertainty: the parameter covariance ``(J^T J)^-1`` of the whitened problem
(nuisance profiled out), scaled by ``max(1, chi^2/dof)``, mapped to the real and
imaginary part of each term per line (full covariance, not a circular approximation). ``chi^2/dof`` tests the
model against the per-line covariance (~1 when both hold).

Caveats: the bands hold *within* the model class at a fixed order; the order's
own uncertainty is added by model averaging
(:func:`jointid.methods.receptance.structured_select.model_average`); a joint outside the
class leaves a systematic residual that ``chi^2/dof`` shows only when it exceeds
the noise. The per-line covariance must be on an absolute scale.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np

from ...parallel import map_lines
from ..levenberg_marquardt import levenberg_marquardt
from .structured_bands import covariance_factor, structured_bands, terms_moving_along
from .structured_model import (
    StructuredModel, default_scale, drop_last_mode, extend, pack, structured_stiffness, structured_terms, sym_basis, unpack,
)

__all__ = ["StructuredFit", "fit_structured", "refit", "base_model", "whitened_residual"]

_SQRT2 = np.sqrt(2.0)
#: Pole grid (log of ``(f / f_ref)^2``) for an added internal mode: 40 frequencies over 0.2-4 x the band's top.
_NU_GRID = np.log(np.geomspace(0.2, 4.0, 40) ** 2)
#: Relative tolerance on the parameters of each fit.
_TOL = 1e-8
#: Relative tolerance on the cost of each fit: an iteration lowering chi^2 by less (about 0.004 on 600 lines
#: of 3 terms: no Akaike weight and no estimate moves) ends it.
_FTOL = 1e-6
#: Loss angles of the first mode's grid start.
_PHASES = np.arctan(np.array([0.02, 0.05, 0.1, 0.15, 0.2, 0.3]))
#: Function evaluations each start of an added mode gets before the best one is fitted to convergence.
_SCREEN_NFEV = 20
#: A fit whose last ``_STALL_STEPS`` successful steps lowered chi^2 by less than ``_STALL_CHI2`` in all is ended there
#: (module docstring): less than a tenth of a unit per step, where an Akaike weight moves by a factor e^(chi^2 / 2).
_STALL_STEPS = 10
_STALL_CHI2 = 1.0


@dataclass(frozen=True, eq=False)
class StructuredFit:
    """A fitted structured joint model.

    Attributes
    ----------
    model : StructuredModel
    theta : ndarray, shape (P,)
    theta_covariance_factor : ndarray, shape (P, r)
        ``W`` with ``W W^T`` the covariance of the scaled parameters (nuisance profiled out, scaled by
        ``max(1, chi^2/dof)``; :func:`~.structured_bands.covariance_factor`); :attr:`theta_covariance` is ``W W^T``.
    stiffness : ndarray, shape (F, n, n), complex
        The fitted Du (physical units: N/m, N/rad, N*m/rad).
    std_real, std_imag : ndarray, shape (F, n, n)
        1-sigma of the real and imaginary part of each term.
    chi2 : float
        Real chi^2 (sum of squared whitened real residuals; expectation ~ ``dof``).
    dof : int
        ``2 F p - P``.
    aic, bic : float
        Corrected Akaike ``chi2 + 2 P + 2 P (P + 1) / (N - P - 1)`` (AICc, ``N = 2 F p`` real observations)
        and Schwarz ``chi2 + P log N``.
    seconds : float
    undetermined : ndarray of bool, shape (n, n), or None
        Terms that change along a parameter direction the FRFs do not determine (their bands are infinite,
        here and in :meth:`at`); None: every direction determined.
    """

    model: StructuredModel
    theta: np.ndarray
    theta_covariance_factor: np.ndarray
    stiffness: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    chi2: float
    dof: int
    aic: float
    bic: float
    seconds: float
    undetermined: np.ndarray | None = None

    @property
    def theta_covariance(self) -> np.ndarray:
        """Covariance of the scaled parameters, shape (P, P): ``W W^T`` of :attr:`theta_covariance_factor`."""
        return self.theta_covariance_factor @ self.theta_covariance_factor.T

    @property
    def chi2_per_dof(self) -> float:
        """chi^2 per degree of freedom (~1 when model and covariance hold)."""
        return self.chi2 / max(self.dof, 1)

    def at(self, hz) -> "StructuredFit":
        """The same fit evaluated on other frequencies (Hz, shape (F',)): stiffness and bands there (each line on its
        own: on the cores, :func:`~jointid.parallel.map_lines`)."""
        hz = np.asarray(hz, float)
        K, sr, si = map_lines(lambda h: structured_bands(self.theta, self.theta_covariance_factor, h, self.model, self.undetermined), hz)
        return replace(self, stiffness=K, std_real=sr, std_imag=si)

    def poles_hz(self) -> np.ndarray:
        """Internal-mode frequencies ``f_ref sqrt(mu_r Re g)`` at the band's start, Hz, ascending."""
        _, _, _, modes, gam = unpack(self.theta, self.model)
        g0 = (self.model.g_design(np.array([self.model.band[0]])) @ gam)[0]
        return np.sort(self.model.f_ref * np.sqrt(np.exp(np.clip(modes[:, -1], -50.0, 50.0)) * max(g0.real, 0.0)))


def _inv_small(L: np.ndarray) -> np.ndarray:
    """Inverses of a stack of small matrices (F, n, n): the adjugate formula for n <= 2 (forward stable,
    Higham 2002, sec. 1.10), LAPACK above; per line a batched LAPACK call costs more than the arithmetic."""
    n = L.shape[-1]
    if n == 1:
        return 1.0 / L
    if n == 2:
        a, b, c, d = L[:, 0, 0], L[:, 0, 1], L[:, 1, 0], L[:, 1, 1]
        out = np.empty_like(L)
        det = a * d - b * c
        out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = d / det, -b / det, -c / det, a / det
        return out
    return np.linalg.inv(L)


def _bmm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A @ B`` for stacks of small matrices ``(F, a, k) @ (F, k, c)``: for ``k <= 4`` the sum over the inner index of
    broadcast products (numpy's batched matmul of thousands of 2 x 2 to 4 x 4 complex matrices costs 2-5 times more),
    else numpy's matmul. Each entry is the same sum of ``k`` products (rounding ``k eps |A| |B|`` either way)."""
    k = A.shape[-1]
    if k > 4:
        return A @ B
    out = A[..., :, :1] * B[..., :1, :]
    for m in range(1, k):
        out += A[..., :, m:m + 1] * B[..., m:m + 1, :]
    return out


class _Problem:
    """Whitened residual and Jacobian of the fit (arrays precomputed once).

    The Jacobian is formed from the factored derivatives of :func:`structured_terms`:
    ``dx/dtheta_k = jc_k(f) (Li jm_k Ri)[upper]``, i.e. one map ``K_f`` (p x n^2) per line
    applied to a few fixed matrices, never the dense ``(F, n, n, P)`` array.
    """

    def __init__(self, hz, x, x_cov, Ynn, model: StructuredModel, common=None):
        F, p = x.shape
        self.hz, self.model, self.Ynn = hz, model, Ynn
        self.W = np.linalg.inv(np.linalg.cholesky(x_cov))  # (F, p, p): whitening
        self.xw = np.einsum("fij,fj->fi", self.W, x)
        self.iu = np.triu_indices(model.n)
        S = np.asarray(model.scale, float)
        self.SS = S[:, None] * S[None, :]
        self.Gd = model.g_design(hz)
        self.eye = np.eye(model.n)
        self.U = self.Gw = None
        if common is not None:
            self.Gw = (self.W @ common).reshape(F * p, -1)
            self.U, sv, _ = np.linalg.svd(self.Gw, full_matrices=False)
            self.UH = np.ascontiguousarray(np.conj(self.U.T))  # formed once: _project runs at every residual and Jacobian
            self.shrink = 1.0 - 1.0 / np.sqrt(1.0 + sv ** 2)
        self.P, self.F, self.p = model.n_params, F, p
        self._last = (None, None)  # (theta bytes, (x, Li, terms)): lmder asks for the Jacobian where it evaluated the residual
        self._res = (None, None)  # (theta bytes, residual)

    def _project(self, v):
        """``(I + G_w G_w^H)^(-1/2) v`` for v of shape (F p, ...)."""
        if self.U is None:
            return v
        c = self.UH @ v
        return v - self.U @ (self.shrink.reshape(-1, *([1] * (v.ndim - 1))) * c)

    def coupling(self, D, inverses: bool):
        """``x`` (upper triangle of ``X = (I + D Ynn)^-1 D``) and, if ``inverses``, ``(I + D Ynn)^-1``, ``(I + Ynn D)^-1``
        (``dX = Li dD Ri``)."""
        Li = _inv_small(self.eye[None] + _bmm(D, self.Ynn))
        x = self._upper(Li, D)
        if not inverses:
            return x, None, None
        return x, Li, _inv_small(self.eye[None] + _bmm(self.Ynn, D))

    def _upper(self, Li, D):
        """The upper triangle of ``Li @ D``, shape (F, p): only those entries formed."""
        i, j = self.iu
        x = Li[:, i, 0] * D[:, 0, j]
        for m in range(1, self.model.n):
            x += Li[:, i, m] * D[:, m, j]
        return x

    def _state(self, theta):
        """``(D, x, Li, factors)`` at ``theta`` (the last one asked for is kept: lmder asks for the Jacobian
        where it last evaluated the residual); ``factors``: the derivatives of :func:`structured_terms`."""
        key = theta.tobytes()
        if self._last[0] != key:
            n = self.model.n
            coefs, mats, factors = structured_terms(theta, self.hz, self.model, jacobian=True, Gd=self.Gd)
            D = (coefs.T @ (mats * self.SS).reshape(len(mats), n * n)).reshape(self.F, n, n)
            Li = _inv_small(self.eye[None] + _bmm(D, self.Ynn))
            x = self._upper(Li, D)
            self._last = (key, (D, x, Li, factors))
        return self._last[1]

    def x_model(self, theta):
        """``x(theta)``, shape (F, p), complex."""
        return self._state(theta)[1]

    def whitened_jacobian(self, theta):
        """``W_f dx_f/dtheta``, shape (F, p, P), complex: ``W_f K_f`` (p x n^2) formed once per line, applied to the fixed matrices."""
        D, _, Li, (jc, jm, dg, Gd) = self._state(theta)
        n, F, p = self.model.n, self.F, self.p
        Ri = _inv_small(self.eye[None] + _bmm(self.Ynn, D))
        Kx = (Li[:, self.iu[0], :, None] * Ri[:, None, :, self.iu[1]].transpose(0, 3, 1, 2)).reshape(F, p, n * n)  # Li_ik Ri_lj
        WK = _bmm(self.W, Kx)
        out = np.empty((F, p, self.P), complex)
        nl = jc.shape[0]
        np.multiply((WK.reshape(F * p, n * n) @ (jm * self.SS).reshape(nl, n * n).T).reshape(F, p, nl), jc.T[:, None, :], out=out[:, :, :nl])
        Kg = _bmm(WK, (dg * self.SS).reshape(F, n * n, 1)) * Gd[:, None, :]  # (F, p, K)
        out[:, :, nl::2] = Kg  # (re_0, im_0, re_1, ...)
        out[:, :, nl + 1::2] = 1j * Kg
        return out

    def complex_residual(self, theta):
        return (self.xw - np.einsum("fij,fj->fi", self.W, self.x_model(theta))).ravel()

    def residual(self, theta):
        key = theta.tobytes()
        if self._res[0] != key:  # the solver asks for it again with the normal equations
            r = self._project(self.complex_residual(theta))
            self._res = (key, _SQRT2 * np.concatenate([r.real, r.imag]))
        return self._res[1]

    def jacobian(self, theta):
        """``d residual / d theta``, shape (2 F p, P): ``-sqrt(2) [Re; Im]`` of the projected whitened Jacobian."""
        Jw = self._project(self.whitened_jacobian(theta).reshape(self.F * self.p, self.P))
        m = self.F * self.p
        out = np.empty((2 * m, self.P))
        np.multiply(Jw.real, -_SQRT2, out=out[:m])
        np.multiply(Jw.imag, -_SQRT2, out=out[m:])
        return out


def _solve(prob: _Problem, theta0: np.ndarray, max_nfev: int = 200):
    """MINPACK's Levenberg-Marquardt (:func:`~jointid.methods.levenberg_marquardt.levenberg_marquardt`: ``lmder``'s
    steps on the normal equations) with ``scipy.optimize.leastsq``'s settings here, and ended when it stalls
    (:data:`_STALL_STEPS`, :data:`_STALL_CHI2`): ``x``, ``fun``, ``jac`` (at ``x``), ``cost``."""
    last = [None, None]  # (parameters' bytes, Jacobian) of the latest one: the solution's when no step followed it

    def normal(theta):
        J = prob.jacobian(theta)
        last[:] = theta.tobytes(), J
        return J.T @ J, J.T @ prob.residual(theta)

    with np.errstate(all="ignore"):
        sol = levenberg_marquardt(prob.residual, normal, theta0, ftol=_FTOL, xtol=_TOL, gtol=1e-8, max_nfev=max_nfev, factor=100.0,
                                  stall=(_STALL_STEPS, _STALL_CHI2))
        J = last[1] if last[0] == sol.x.tobytes() else prob.jacobian(sol.x)
        return SimpleNamespace(x=sol.x, fun=sol.fun, jac=J, cost=sol.cost)


def _finish(prob: _Problem, sol, t0: float) -> StructuredFit:
    model, theta, J = prob.model, sol.x, sol.jac
    W, unseen = covariance_factor(J)
    real_chi2 = float(np.sum(sol.fun ** 2))  # unit-variance real residuals (sqrt(2) [Re, Im] of the complex ones)
    nobs = 2 * prob.F * prob.p
    dof = nobs - prob.P
    W = W * np.sqrt(max(1.0, real_chi2 / max(dof, 1)))  # a misfit above the noise widens the bands
    blind = terms_moving_along(theta, prob.hz, model, unseen) if unseen.shape[1] else None
    K, std_re, std_im = structured_bands(theta, W, prob.hz, model, blind)
    return StructuredFit(
        model, theta, W, K, std_re, std_im, real_chi2, dof, real_chi2 + 2.0 * prob.P + 2.0 * prob.P * (prob.P + 1) / max(dof - 1, 1),
        real_chi2 + prob.P * np.log(nobs), time.perf_counter() - t0, blind,
    )


def _smoothed_curves(hz, lines):
    """Each term's per-line estimate smoothed over frequency (P-spline, GCV) and its variance: the starts' data."""
    from .smoothing import smooth_series

    K, V = lines.stiffness.copy(), lines.variance.copy()
    for a, b in zip(*np.triu_indices(K.shape[1])):
        y, v = lines.stiffness[:, a, b], lines.variance[:, a, b]
        re, im = smooth_series(hz, y.real, v / 2.0), smooth_series(hz, y.imag, v / 2.0)
        K[:, a, b] = K[:, b, a] = re.value + 1j * im.value
        V[:, a, b] = V[:, b, a] = re.variance + im.variance
    return K, V


def _scaled_curves(hz, Ks, Vs, model):
    iu = np.triu_indices(model.n)
    S = np.asarray(model.scale)
    SS = S[:, None] * S[None, :]
    y = (Ks / SS)[:, iu[0], iu[1]]
    w = 1.0 / np.sqrt(np.maximum((Vs / SS ** 2)[:, iu[0], iu[1]], 1e-300))
    return y, w, (hz / model.f_ref) ** 2


def _initial(hz, Ks, Vs, model: StructuredModel) -> np.ndarray:
    """Linear start for 0 modes and constant g: ``Du' = a - w'^2 b`` per term (a complex, b real), weighted LS."""
    y, w, w2 = _scaled_curves(hz, Ks, Vs, model)
    F = hz.size
    M = np.zeros((2 * F, 3))
    M[:F, 0], M[:F, 2], M[F:, 1] = 1.0, -w2, 1.0
    Ac, Bv = np.empty(model.p, complex), np.empty(model.p)
    for k in range(model.p):
        ww = np.r_[w[:, k], w[:, k]]
        sol = np.linalg.lstsq(M * ww[:, None], np.r_[y[:, k].real, y[:, k].imag] * ww, rcond=None)[0]
        Ac[k], Bv[k] = sol[0] + 1j * sol[1], sol[2]
    g0 = Ac[0] if abs(Ac[0]) > 0 else 1.0
    return pack((Ac / g0).real, Bv, np.zeros(model.sizes["E"]), np.zeros((model.n_modes, model.n + 1)), np.full(model.g_basis, g0))


def _grid_start(hz, Ks, Vs, model: StructuredModel, theta_base: np.ndarray, cache: dict | None = None) -> np.ndarray:
    """Start for the first internal mode from the smooth per-term curves, in Du space (no noisy line inverted).

    With ``g = e^(i phi)`` and ``mu`` fixed, ``Du' = g A - w'^2 B - w'^4 C / (g mu - w'^2)``
    is linear in the real symmetric ``A, B, C``: weighted linear least squares over a
    ``(phi, mu)`` grid; the best is normalized to ``A_00 = 1`` and ``C`` cut to rank 1.
    The grid's best depends on the curves and the model's scaling only: ``cache`` keeps it
    for the other orders of one selection.
    """
    key = ("grid", model.scale, model.f_ref)
    if cache is None or key not in cache:
        found = _grid_search(hz, Ks, Vs, model)
        if cache is not None:
            cache[key] = found
    else:
        found = cache[key]
    g, mu, sol = found
    p = model.p
    Av, Bv, Cv = sol[:p], sol[p:2 * p], sol[2 * p:]
    a0 = Av[0] if abs(Av[0]) > 0 else 1.0
    lam, V = np.linalg.eigh(np.einsum("k,kij->ij", Cv, sym_basis(model.n)))
    c = np.sqrt(max(lam[-1], 1e-8)) * V[:, -1]
    _, _, E, modes, _ = unpack(theta_base, model)
    modes = np.array(modes, float)
    modes[0] = np.r_[c, np.log(abs(mu / a0))]  # g' = g a0, mu' = mu / a0 keep g mu
    x = np.linspace(*model.band, 50)
    gam = np.linalg.lstsq(model.g_design(x), np.full(50, g * a0), rcond=None)[0]
    return pack(Av / a0, Bv, E, modes, gam)


def _grid_costs(y, w, w2) -> np.ndarray:
    """Weighted least-squares cost of every ``(phi, mu)`` grid point of :func:`_grid_start`, shape (phases, poles).

    The least squares decouples by term (each term's rows see only its own ``A_k, B_k, C_k``): a point's
    cost is the sum over terms of ``r_44^2``, the last diagonal entry of the R factor of the term's
    ``[design | data]`` (2 F x 4, real), from one batched QR per loss angle for all poles and terms.
    ``y, w, w2``: :func:`_scaled_curves`.
    """
    F = w2.size
    p = y.shape[1]
    mus = np.exp(_NU_GRID)
    aug = np.empty((mus.size, p, 2 * F, 4))  # (pole, term, [Re; Im] rows, [g, -w'^2, C coefficient, data] columns)
    aug[:, :, :F, 1], aug[:, :, F:, 1] = (-w2[:, None] * w).T[None], 0.0
    aug[:, :, :F, 3], aug[:, :, F:, 3] = (y * w).real.T[None], (y * w).imag.T[None]
    costs = np.empty((_PHASES.size, mus.size))
    for a, phi in enumerate(_PHASES):
        g = np.exp(1j * phi)
        aug[:, :, :F, 0], aug[:, :, F:, 0] = (g.real * w).T[None], (g.imag * w).T[None]
        c = (-(w2 ** 2)[None, :] / (g * mus[:, None] - w2[None, :]))[:, None, :] * w.T[None]  # (pole, term, F)
        aug[:, :, :F, 2], aug[:, :, F:, 2] = c.real, c.imag
        r = np.linalg.qr(aug, mode="r")[..., 3, 3]
        costs[a] = np.sum(r * r, axis=1)
    costs[~np.isfinite(costs)] = np.inf
    return costs


def _grid_design(w, w2, g, mu) -> np.ndarray:
    """The whole real design (2 F p, 3 p) of one grid point: columns ``[A_k, B_k, C_k]`` of every term."""
    F, p = w.shape
    sel = np.eye(p)
    cols = []
    for coef in (np.full(F, g), -w2 + 0j, -(w2 ** 2) / (g * mu - w2)):
        m = (coef[:, None, None] * sel[None]) * w[:, :, None]  # (F, p, p): column k is term k
        cols.append(np.concatenate([m.real.reshape(F * p, p), m.imag.reshape(F * p, p)]))
    return np.concatenate(cols, axis=1)


def _grid_search(hz, Ks, Vs, model: StructuredModel) -> tuple:
    """``(g, mu, [A, B, C])`` of the best ``(phi, mu)`` grid point of :func:`_grid_start` (costs: :func:`_grid_costs`;
    the first of equal ones in phase-major order); its solution is the least-squares solution of its whole design."""
    y, w, w2 = _scaled_curves(hz, Ks, Vs, model)
    costs = _grid_costs(y, w, w2)
    a, b = np.unravel_index(int(np.argmin(costs)), costs.shape)
    g, mu = np.exp(1j * _PHASES[a]), float(np.exp(_NU_GRID[b]))
    rhs = np.concatenate([(y * w).real.ravel(), (y * w).imag.ravel()])
    sol, *_ = np.linalg.lstsq(_grid_design(w, w2, g, mu), rhs, rcond=None)
    return g, mu, sol


def _mode_starts(prob: _Problem, theta: np.ndarray) -> list:
    """Starts for the last mode of ``prob.model`` at every pole ``mu = exp(nu)`` of the grid, with their linearized costs.

    Around the fit without that mode, ``x(D + h C) ~ x(D) + Li (h C) Ri`` with
    ``h = -w'^4 / (g mu - w'^2)``: linear least squares for the real symmetric ``C``,
    cut to its rank-1 part. The linearization does not depend on ``mu`` and is formed once.
    """
    model = prob.model
    n, Eb = model.n, sym_basis(model.n)
    base = model.with_order(model.n_modes - 1, model.g_basis, model.residual)
    th_base = drop_last_mode(theta, model)
    x, Li, Ri = prob.coupling(structured_stiffness(th_base, prob.hz, base) * prob.SS, True)
    r = (prob.xw - np.einsum("fij,fj->fi", prob.W, x)).ravel()
    rr = np.r_[r.real, r.imag]
    dX = Li[:, None] @ (prob.SS * Eb)[None] @ Ri[:, None]  # (F, p, n, n): dX / dC_k per unit h
    M0 = np.einsum("fij,fkj->fik", prob.W, dX[:, :, prob.iu[0], prob.iu[1]])  # (F, p, p)
    g = base.g_design(prob.hz) @ unpack(th_base, base)[4]
    w2 = (prob.hz / model.f_ref) ** 2
    s = model.sizes
    i0 = s["A"] + s["B"] + s["E"] + (model.n_modes - 1) * (n + 1)
    starts = []
    for nu in _NU_GRID:  # 40 poles, each one small least-squares problem over all lines
        M = (-(w2 ** 2) / (g * np.exp(nu) - w2))[:, None, None] * M0
        M = M.reshape(-1, model.p)
        Mr = np.vstack([M.real, M.imag])
        coef = np.linalg.lstsq(Mr, rr, rcond=None)[0]
        lam, V = np.linalg.eigh(np.einsum("k,kij->ij", coef, Eb))
        out = theta.copy()
        out[i0:i0 + n] = np.sqrt(max(lam[-1], 1e-8)) * V[:, -1]
        out[i0 + n] = nu
        starts.append((out, float(np.sum((rr - Mr @ coef) ** 2))))
    return starts


def base_model(hz, lines) -> StructuredModel:
    """The 0-mode, constant-g model of these per-line estimates (scale and band set)."""
    hz = np.asarray(hz, float)
    return StructuredModel(lines.stiffness.shape[1], 0, 1, False, default_scale(lines.stiffness), float(hz[-1]), (float(hz[0]), float(hz[-1])))


def fit_structured(hz, lines, order=(0, 1, False), common=None, start: StructuredFit | None = None, n_starts: int = 2,
                   cache: dict | None = None) -> StructuredFit:
    """Fit the structured model of the given order to per-line coupling estimates.

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    lines : LineEstimates
        From :func:`~jointid.methods.receptance.coupling_lines.coupling_per_line` on its exact path
        (``x``, ``x_covariance``, ``Ynn``; symmetric).
    order : tuple
        ``(n_modes, g_basis, residual)`` (:class:`~jointid.methods.receptance.structured_model.StructuredModel`).
    common : ndarray, shape (F, p, k), complex, optional
        Factor of an error common to all lines, ``x_f += common_f u``, ``u ~ CN(0, I_k)``; profiled out.
    start : StructuredFit, optional
        A fit of a nested (smaller) model to grow from; else grown from the linear start.
    n_starts : int
        Pole starts tried for each added mode (the local minima of the linearized cost); each
        gets ``_SCREEN_NFEV`` evaluations and only the best is fitted to convergence.
    cache : dict, optional
        Shared by the fits of one selection (same ``hz``, ``lines``, ``common``): keeps the
        smoothed per-term curves and the first mode's grid start, which every order computes alike.

    Returns
    -------
    StructuredFit

    Raises
    ------
    numpy.linalg.LinAlgError, ValueError
        A singular per-line covariance or a degenerate start.
    """
    t0 = time.perf_counter()
    hz = np.asarray(hz, float)
    base = base_model(hz, lines) if start is None else start.model.with_order(0, 1, False)
    target = base.with_order(*order)

    def problem(model):
        return _Problem(hz, lines.x, lines.x_covariance, lines.Ynn, model, common)

    cache = {} if cache is None else cache
    last = None  # (problem, solution) of the latest step

    def curves():
        if "curves" not in cache:
            cache["curves"] = _smoothed_curves(hz, lines)
        return cache["curves"]

    def step(model, theta0):
        prob = problem(model)
        return model, (prob, _solve(prob, theta0))

    if start is None:
        cur_model, last = step(base, _initial(hz, *curves(), base))
        cur = last[1].x
    else:
        cur, cur_model = start.theta, start.model
    if target.residual and not cur_model.residual:
        m2 = cur_model.with_order(cur_model.n_modes, cur_model.g_basis, True)
        cur_model, last = step(m2, extend(cur, cur_model, m2))
        cur = last[1].x
    while cur_model.n_modes < target.n_modes:
        m2 = cur_model.with_order(cur_model.n_modes + 1, cur_model.g_basis, cur_model.residual)
        p2 = problem(m2)
        grown = extend(cur, cur_model, m2)
        starts = _mode_starts(p2, grown)
        cost = np.array([c for _, c in starts])
        interior = (cost[1:-1] <= cost[:-2]) & (cost[1:-1] <= cost[2:])
        minima = np.r_[cost[0] < cost[1], interior, cost[-1] < cost[-2]]
        picks = [int(i) for i in np.argsort(np.where(minima, cost, np.inf))[:n_starts] if minima[i]]
        trials = [starts[i][0] for i in picks]
        if m2.n_modes == 1:  # the first mode also from the Du-space grid (robust to a poor 0-mode fit)
            trials.append(_grid_start(hz, *curves(), m2, grown, cache))
        if not trials:
            raise ValueError("no start for the added internal mode")
        if len(trials) > 1:  # screen every start briefly, polish the best one
            trials = [min((_solve(p2, th, max_nfev=_SCREEN_NFEV) for th in trials), key=lambda s: s.cost).x]
        cur_model, last = m2, (p2, _solve(p2, trials[0]))
        cur = last[1].x
    if target.g_basis != cur_model.g_basis:
        m2 = cur_model.with_order(cur_model.n_modes, target.g_basis, cur_model.residual)
        cur_model, last = step(m2, extend(cur, cur_model, m2))
        cur = last[1].x
    if last is None or cur_model.order != target.order:  # grown from a fit of this very order: refit it here
        cur_model, last = step(target, cur)
    return _finish(*last, t0)


def refit(fit: StructuredFit, hz, lines, common=None, max_nfev: int = 100) -> StructuredFit:
    """The same model refitted on other lines (e.g. all lines after selecting on a subset), started from ``fit``."""
    t0 = time.perf_counter()
    prob = _Problem(np.asarray(hz, float), lines.x, lines.x_covariance, lines.Ynn, fit.model, common)
    return _finish(prob, _solve(prob, fit.theta, max_nfev=max_nfev), t0)


def whitened_residual(fit: StructuredFit, hz, lines, common=None) -> tuple:
    """The real residual the fit minimizes at its parameters and its Jacobian: ``(r (2 F p,), J (2 F p, P))``.

    ``r`` is ``sqrt(2) [Re; Im]`` of the whitened, common-error-projected complex residual
    (line-major within each part): unit variance per entry when the model and the covariance hold.
    """
    prob = _Problem(np.asarray(hz, float), lines.x, lines.x_covariance, lines.Ynn, fit.model, common)
    return prob.residual(fit.theta), prob.jacobian(fit.theta)
