"""MINPACK's Levenberg-Marquardt (``lmder``) on the normal equations: for residuals of many rows and few parameters.

The algorithm is Moré's (1978) as MINPACK's ``lmder`` implements it (``scipy.optimize.leastsq`` with a
Jacobian), step for step: scaling by the Jacobian's column norms (``diag`` = the largest norm seen), the trust
region of radius ``delta`` (``factor`` times the scaled start's norm), the Levenberg-Marquardt parameter of
``lmpar`` (Newton's iteration on ``||D p|| = delta``, at most 10 steps, accepted within 10 %), the ratio of the
actual to the predicted reduction and MINPACK's updates of ``delta`` and of the parameter, and its tests
``ftol`` (relative reduction of the sum of squares), ``xtol`` (trust radius relative to ``||D x||``), ``gtol``
(cosine of the residual with every column) and ``max_nfev`` (residual evaluations).

What differs is the linear algebra. MINPACK factors the ``m x P`` Jacobian by a column-pivoted Householder QR
at every iteration (``qrfac``: unblocked, level-1 loops): for the structured joint fit (``m`` = 2 x lines x
terms, up to 240 000 rows, ``P`` = 10-40 parameters) that was a third of the fit's time. Here the caller gives
the normal equations ``N = J^T J`` and ``g = J^T r`` (``P x P``: one matrix product, BLAS level 3), and every
step solves ``(D^-1 N D^-1 + par I) z = D^-1 g`` from one symmetric eigendecomposition of the scaled ``N`` per
Jacobian (``lmpar``'s ten trial parameters then cost nothing).

Caveats: the normal equations square the condition number of the scaled Jacobian. The steps need it only
to a few digits (a step computed to relative accuracy ``cond^2 eps`` still lowers the cost, and convergence is
judged on the cost itself); the converged point is where ``g`` (formed directly, not squared) vanishes, so it
is as accurate as ``J`` and ``r``. Directions whose scaled eigenvalue is below ``P eps`` times the largest are
treated as MINPACK treats an exactly singular ``R`` (the Gauss-Newton step has no part along them and the
lower bound of the parameter is 0). Uncertainties are not computed here: the caller takes them from ``J``
itself (an SVD or QR, never ``N``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["LeastSquaresSolution", "levenberg_marquardt"]

_EPS = np.finfo(float).eps
_DWARF = np.finfo(float).tiny


@dataclass(frozen=True, eq=False)
class LeastSquaresSolution:
    """The result of :func:`levenberg_marquardt`.

    Attributes
    ----------
    x : ndarray, shape (P,)
        The parameters at the end.
    fun : ndarray, shape (m,)
        The residual there.
    cost : float
        ``0.5 ||fun||^2``.
    nfev, njev : int
        Residual and normal-equation evaluations.
    status : int
        MINPACK's ``info``: 1 ``ftol``, 2 ``xtol``, 3 both, 4 ``gtol``, 5 ``max_nfev`` reached, 6-8 the
        tolerances below round-off; 9: the normal equations at ``x`` are not finite (stopped there); 10: ``stall``.
    """

    x: np.ndarray
    fun: np.ndarray
    cost: float
    nfev: int
    njev: int
    status: int


class _Scaled:
    """The scaled normal equations ``Ns = D^-1 N D^-1``, ``gs = D^-1 g`` of one Jacobian, by their eigenvectors."""

    def __init__(self, N: np.ndarray, g: np.ndarray, diag: np.ndarray):
        Ns = N / diag[:, None] / diag[None, :]
        lam, self.V = np.linalg.eigh(0.5 * (Ns + Ns.T))
        self.singular = lam <= Ns.shape[0] * _EPS * max(float(lam[-1]), _DWARF)
        self.lam = np.where(self.singular, 0.0, lam)
        self.c = self.V.T @ (g / diag)  # gs in the eigenbasis

    def step(self, par: float) -> tuple[np.ndarray, np.ndarray]:
        """``z = (Ns + par I)^-1 gs`` (pseudo-inverse along singular directions at ``par = 0``) and ``V^T z``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(self.singular & (par == 0.0), 0.0, self.c / (self.lam + par))
        return self.V @ w, w

    def inverse_norm2(self, wz: np.ndarray, par: float) -> float:
        """``z^T (Ns + par I)^-1 z`` for ``z`` given in the eigenbasis (``wz = V^T z``)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return float(np.sum(np.where(self.singular & (par == 0.0), 0.0, wz ** 2 / (self.lam + par))))


def _lmpar(S: _Scaled, delta: float, par: float) -> tuple[np.ndarray, float]:
    """MINPACK's ``lmpar`` on the scaled normal equations: ``(z, par)``, ``z = D x`` with ``x`` the step's negative.

    ``par = 0`` if the Gauss-Newton step lies within 1.1 ``delta``; else ``| ||z|| - delta | <= 0.1 delta``
    (or 10 Newton steps taken).
    """
    z, wz = S.step(0.0)
    dxnorm = float(np.linalg.norm(z))
    fp = dxnorm - delta
    if fp <= 0.1 * delta:
        return z, 0.0
    parl = 0.0
    if not S.singular.any():  # the Newton step gives a lower bound
        parl = fp / delta / (S.inverse_norm2(wz, 0.0) / dxnorm ** 2)
    gnorm = float(np.linalg.norm(S.c))
    paru = gnorm / delta
    if paru == 0.0:
        paru = _DWARF / min(delta, 0.1)
    par = min(max(par, parl), paru)
    if par == 0.0:
        par = gnorm / dxnorm
    for it in range(1, 11):
        if par == 0.0:
            par = max(_DWARF, 0.001 * paru)
        z, wz = S.step(par)
        dxnorm = float(np.linalg.norm(z))
        temp, fp = fp, dxnorm - delta
        if abs(fp) <= 0.1 * delta or (parl == 0.0 and fp <= temp < 0.0) or it == 10:
            break
        parc = fp / delta / (S.inverse_norm2(wz, par) / dxnorm ** 2)
        if fp > 0.0:
            parl = max(parl, par)
        elif fp < 0.0:
            paru = min(paru, par)
        par = max(parl, par + parc)
    return z, par


def levenberg_marquardt(residual: Callable[[np.ndarray], np.ndarray],
                        normal: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], x0: np.ndarray, *,
                        ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 0.0, max_nfev: int = 200,
                        factor: float = 100.0, stall: tuple[int, float] | None = None) -> LeastSquaresSolution:
    """Minimize ``||r(x)||^2`` by MINPACK's Levenberg-Marquardt with the normal equations (module docstring).

    Parameters
    ----------
    residual : callable
        ``r(x)``, shape (m,), real.
    normal : callable
        ``(J^T J, J^T r)`` at ``x``, shapes (P, P) and (P,), ``J = dr/dx``: always asked at the ``x`` of the
        latest ``residual`` call (a caller may keep that evaluation's intermediate arrays).
    x0 : ndarray, shape (P,)
        Start.
    ftol, xtol, gtol : float
        MINPACK's tolerances: the relative reduction of the sum of squares (actual and predicted), the trust
        radius relative to the scaled parameters' norm, the cosine of the residual with each column of ``J``.
    max_nfev : int
        Largest number of ``residual`` calls.
    factor : float
        The initial trust radius in units of the scaled start's norm (MINPACK's ``factor``).
    stall : (int, float), optional
        ``(k, fall)``: stop (status 10) when the last ``k`` successful steps lowered ``||r||^2`` by less than
        ``fall`` in all (not MINPACK's: a test in the units of the sum of squares, e.g. chi^2, for a search that
        creeps along a flat valley, where ``ftol``'s relative test per step never ends it).

    Returns
    -------
    LeastSquaresSolution
    """
    x = np.array(x0, dtype=float)
    fvec = np.asarray(residual(x), float)
    nfev, njev = 1, 0
    fnorm = float(np.linalg.norm(fvec))
    par, it, status = 0.0, 1, 0
    diag = delta = xnorm = None
    history = [fnorm ** 2]  # ||r||^2 after each successful step (for ``stall``)
    while status == 0:
        N, g = normal(x)
        njev += 1
        if not (np.all(np.isfinite(N)) and np.all(np.isfinite(g))):
            status = 9
            break
        acnorm = np.sqrt(np.maximum(np.diagonal(N), 0.0))
        if it == 1:
            diag = np.where(acnorm == 0.0, 1.0, acnorm)
            xnorm = float(np.linalg.norm(diag * x))
            delta = factor * xnorm if xnorm != 0.0 else factor
        with np.errstate(divide="ignore", invalid="ignore"):  # the largest cosine of r with a column of J
            gnorm = float(np.max(np.where(acnorm > 0.0, np.abs(g) / (acnorm * fnorm), 0.0))) if fnorm != 0.0 else 0.0
        if gnorm <= gtol:
            status = 4
            break
        diag = np.maximum(diag, acnorm)
        S = _Scaled(N, g, diag)
        while True:
            z, par = _lmpar(S, delta, par)
            step = -z / diag
            pnorm = float(np.linalg.norm(z))
            if it == 1:
                delta = min(delta, pnorm)
            x_new = x + step
            f_new = np.asarray(residual(x_new), float)
            nfev += 1
            fnorm1 = float(np.linalg.norm(f_new))
            actred = 1.0 - (fnorm1 / fnorm) ** 2 if 0.1 * fnorm1 < fnorm else -1.0
            # ||J p||^2 = z^T Ns z (p = -z / diag)
            wz = S.V.T @ z
            temp1 = np.sqrt(max(float(np.sum(S.lam * wz ** 2)), 0.0)) / fnorm
            temp2 = np.sqrt(par) * pnorm / fnorm
            prered = temp1 ** 2 + temp2 ** 2 / 0.5
            dirder = -(temp1 ** 2 + temp2 ** 2)
            ratio = actred / prered if prered != 0.0 else 0.0
            if ratio <= 0.25:
                temp = 0.5 if actred >= 0.0 else 0.5 * dirder / (dirder + 0.5 * actred)
                if 0.1 * fnorm1 >= fnorm or temp < 0.1:
                    temp = 0.1
                delta = temp * min(delta, pnorm / 0.1)
                par = par / temp
            elif par == 0.0 or ratio >= 0.75:
                delta = pnorm / 0.5
                par = 0.5 * par
            if ratio >= 1e-4:  # a successful step
                x, fvec, fnorm = x_new, f_new, fnorm1
                xnorm = float(np.linalg.norm(diag * x))
                it += 1
                history.append(fnorm ** 2)
                if stall is not None and len(history) > stall[0] and history[-1 - stall[0]] - history[-1] < stall[1]:
                    status = 10
                    break
            reduced = abs(actred) <= ftol and prered <= ftol and 0.5 * ratio <= 1.0
            if reduced:
                status = 1
            if delta <= xtol * xnorm:
                status = 3 if reduced else 2
            if status:
                break
            if nfev >= max_nfev:
                status = 5
            elif abs(actred) <= _EPS and prered <= _EPS and 0.5 * ratio <= 1.0:
                status = 6
            elif delta <= _EPS * xnorm:
                status = 7
            elif gnorm <= _EPS:
                status = 8
            if status or ratio >= 1e-4:
                break
    return LeastSquaresSolution(x, fvec, 0.5 * fnorm ** 2, nfev, njev, status)
