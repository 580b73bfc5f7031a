"""The default estimator's expected error for a layout, before any test: smoothing and column calibration.

:class:`~jointid.methods.design.layout.LayoutPredictor` gives the per-line covariance of
the receptance-coupling estimate. The default identification
(:func:`~jointid.methods.receptance.coupling.identify_joint_coupling`) does two more things
that change the error, and change it differently for different layouts:

1. **Smoothing over frequency** (:mod:`jointid.methods.receptance.smoothing`): each term's
   real and imaginary part is fitted by a weighted P-spline (weights ``2 / v_f``,
   ``v_f`` the per-line variance ``E|dK_f|^2``), lambda by GCV. For a fixed lambda
   the smoother is linear, ``S = B (B^T W B + lam D^T D)^-1 B^T W``, and with the
   generalized eigenvectors ``T`` of ``(D^T D, B^T W B)`` (``T^T B^T W B T = I``,
   ``T^T D^T D T = diag(s)``) and ``phi = 1 / (1 + lam s)``::

       variance_f(lam) = sum_k (B T)_fk^2 phi_k^2          (frequentist: diag(S V S^T))
       bias_f(lam)     = (B T diag(phi) T^T B^T W y)_f - y_f   (y: the true real or imaginary part)
       E GCV(lam)      = n (||W^1/2 bias||^2 + n - 2 tr S + tr S^2) / (n - tr S)^2,  tr S = sum phi

   The predicted lambda minimizes the *expected* GCV score (what the estimator
   minimizes on data); the predicted error per line is
   ``E|dK_f|^2 = bias_re^2 + bias_im^2 + variance_re + variance_im`` at that
   lambda. What matters is therefore not the median of the per-line variance but
   the information ``sum 1 / v_f`` within a smoothing window together with the
   bias the window leaves: a layout whose per-line errors are small on most lines
   but huge where the rotational term changes can be worse after smoothing.
2. **Column calibration** (:mod:`jointid.methods.receptance.column_calibration`): with
   force noise the estimator estimates a smooth calibration error per excitation
   column (``n_basis`` cubic B-splines each) jointly with the joint and adds the
   estimate's uncertainty ``T N^-1 T^H`` (see that module; residual scale 1 on
   the stated noise) to every line. Frequency smoothing does not reduce it; the
   rotational term is nearly indistinguishable from a column error, so this
   common error dominates K_theta_theta whenever calibration is applied, and it
   depends on the layout (how differently the columns see the joint).
   ``common_variance`` computes it from the exact FRFs of the layout.
3. **The joint spline fit** (:mod:`jointid.methods.receptance.spline_fit`; the default for a
   symmetric joint of 4-6 DOFs, a mount): every term ``K_ab(f) = sum_k c_k B_k(log f)``
   fitted to every line's FRFs at once. Its error is bounded below by the Cramer-Rao
   bound of its richest class, ``E|dK_ab(f)|^2 >= B(f) [(J^H W J)^-1]_ab B(f)^H`` at the
   true joint (``J``: the FRF residuals' Jacobian in the coefficients, ``W`` the inverse
   FRF variance); :func:`spline_bound` computes it. The fit reaches it within 1.5x on a
   6-DOF mount (``benchmarks/mount_6dof.py``), and it is the "information" of a layout:
   a layout whose bound misses a target cannot reach it with any estimator of that class.

The relinearization of the estimator (per-line estimates linearized around the
smooth estimate, close to the truth) is what makes the truth the right point to
linearize at here. Caveats: the expected GCV is not the GCV of one realization
(on data lambda scatters, and with it the error: the K_theta_theta error of one
synthetic realization varies severalfold between seeds, ``benchmarks/design.py``
prints it per seed); the bias uses the expected joint (``[joint.model]``), so it
is as right as that model.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..receptance.column_calibration import CALIBRATION_BASIS
from ..receptance.coupling_lines import symmetric_parametrization, whitened_line_design
from ..receptance.smoothing import LOG_LAMBDA_GRID, MAX_BASIS
from ..receptance.smoothing import bspline_basis
from ..receptance.spline_fit import DEFAULT_MAX_BASIS, log_frequency_basis, spline_covariance, term_variance

__all__ = ["SmootherPrediction", "smoothed_squared_error", "common_variance", "spline_bound"]


def spline_bound(hz: np.ndarray, Ymn: np.ndarray, Ynn: np.ndarray, Yne: np.ndarray, variance: np.ndarray, Du: np.ndarray,
                 symmetric: bool = True, n_basis: int = DEFAULT_MAX_BASIS) -> np.ndarray:
    """Cramer-Rao bound ``E|dK_ab(f)|^2`` of the joint spline fit with ``n_basis`` B-splines per term, shape (F, n, n).

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Lines, Hz (> 0, increasing).
    Ymn, Ynn, Yne : ndarray, shapes (F, m, n), (F, n, n), (F, n, e), complex
        Free receptance blocks of the identification's model, m, e.
    variance : ndarray, shape (F, m, e)
        ``E|dH|^2`` of each measured receptance value (the noise the test has).
    Du : ndarray, shape (F, n, n), complex
        The true (expected) joint.
    symmetric : bool
        ``K = K^T`` (the fit's parametrization).
    n_basis : int
        B-splines per term (the fit's richest order; capped at ``F - 1``).

    Notes
    -----
    ``(J^H W J)^-1`` of :func:`~jointid.methods.receptance.spline_fit.spline_covariance` at ``Du``
    with unit noise scale, mapped to each term on each line. Linear in the FRF errors: where the
    bound is 100 % and more the fit is not linear and the actual error can be larger.
    """
    basis = log_frequency_basis(np.asarray(hz, float), max(1, min(int(n_basis), np.size(hz) - 1)))
    cov = spline_covariance((Ymn, Ynn, Yne, variance, symmetric), Du, basis)
    return term_variance(cov, basis, Du.shape[1], symmetric)


class SmootherPrediction:
    """The P-spline smoother of :mod:`jointid.methods.receptance.smoothing` on fixed lines, for many variance series.

    Parameters
    ----------
    hz : ndarray, shape (F,)
        The lines (increasing).
    n_basis : int, optional
        As :func:`~jointid.methods.receptance.smoothing.smooth_series` (default ``min(F // 2, MAX_BASIS)``).
    """

    def __init__(self, hz: np.ndarray, n_basis: int | None = None):
        self.hz = np.asarray(hz, float)
        F = self.hz.size
        K = int(n_basis or min(max(F // 2, 4), MAX_BASIS))
        self.K = max(4, min(K, F - 1))
        self.B = bspline_basis(self.hz, self.K).toarray()
        D = np.diff(np.eye(self.K), 2, axis=0)
        self.P = D.T @ D

    def squared_error(self, y: np.ndarray, variance: np.ndarray) -> np.ndarray:
        """Expected ``E|K_hat - K|^2`` per line of a complex series after smoothing, shape (F,).

        Parameters
        ----------
        y : ndarray, shape (F,), complex
            The true values of the term.
        variance : ndarray, shape (F,)
            Per-line ``E|dK|^2`` of the estimate (half in each of the real and imaginary part).
        """
        ok = np.isfinite(variance) & (variance > 0)
        if not ok.any():
            return np.full(self.hz.size, np.inf)
        v = np.where(ok, variance / 2.0, 1.0)
        w = np.where(ok, 1.0 / v, 0.0)
        B, K = self.B, self.K
        BWB = B.T @ (B * w[:, None])
        jitter = 1e-12 * np.trace(BWB) / K
        L = np.linalg.cholesky(BWB + jitter * np.eye(K))
        Li = sla.solve_triangular(L, np.eye(K), lower=True)
        s, U = np.linalg.eigh(Li @ self.P @ Li.T)
        s = np.clip(s, 0.0, None)
        T = Li.T @ U
        BT = B @ T  # (F, K)
        lams = np.trace(BWB) / max(np.trace(self.P), 1e-300) * 10.0**LOG_LAMBDA_GRID
        phi = 1.0 / (1.0 + lams[None, :] * s[:, None])  # (K, G)
        n = int(ok.sum())
        trS, trS2 = phi.sum(axis=0), (phi**2).sum(axis=0)
        out = np.zeros(self.hz.size)
        for part in (np.real(y), np.imag(y)):  # each part at its own lambda, as the estimator smooths them
            c = T.T @ (B.T @ (w * np.where(ok, part, 0.0)))
            bias = BT @ (c[:, None] * phi) - part[:, None]  # (F, G)
            egcv = n * (np.sum(w[:, None] * bias**2, axis=0) + n - 2 * trS + trS2) / np.maximum(n - trS, 1e-9) ** 2
            g = int(np.argmin(egcv))
            out += bias[:, g] ** 2 + (BT**2) @ (phi[:, g] ** 2)  # bias^2 + variance of the part
        return out


def smoothed_squared_error(hz: np.ndarray, y: np.ndarray, variance: np.ndarray, n_basis: int | None = None) -> np.ndarray:
    """Expected squared error ``E|K_hat - K|^2`` per line after the estimator's smoothing, shape (F,).

    One-shot form of :meth:`SmootherPrediction.squared_error` (see the module docstring).
    """
    return SmootherPrediction(hz, n_basis).squared_error(y, variance)


def common_variance(
    hz: np.ndarray, Ymn: np.ndarray, Yne: np.ndarray, Ynn: np.ndarray, H: np.ndarray, variance: np.ndarray,
    Du: np.ndarray, symmetric: bool = True, n_basis: int = CALIBRATION_BASIS,
) -> np.ndarray:
    """``E|dDu_ij|^2`` common to all lines that estimating the columns' calibration adds, shape (F, n, n).

    The covariance of :func:`~jointid.methods.receptance.column_calibration.estimate_column_calibration`
    with residual scale 1 (the stated noise is the true noise), mapped to Du at the
    true joint ``Du``: ``J T N^-1 T^H J^H``.

    Parameters
    ----------
    hz : ndarray, shape (F,)
    Ymn, Yne, Ynn : ndarray
        Free receptance blocks of the identification's model, shapes (F, m, n), (F, n, e), (F, n, n).
    H : ndarray, shape (F, m, e)
        Exact receptance of the test article.
    variance : ndarray, shape (F, m, e)
        ``E|dH|^2`` of each measured value.
    Du : ndarray, shape (F, n, n)
        The true joint.
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    P = symmetric_parametrization(n, symmetric)
    p = P.shape[1]
    nb = int(n_basis)
    if nb < 4 or F < 2 * nb or F * (m * e - p) - e * nb <= 0:
        return np.zeros((F, n, n))
    sw, cs, Q, R = whitened_line_design(Ymn, Yne, variance, symmetric)
    Gw = np.zeros((F, m, e, e), complex)
    idx = np.arange(e)
    Gw[:, :, idx, idx] = H
    Gw = Gw.reshape(F, m * e, e) * sw[:, :, None]
    QhG = np.conj(np.swapaxes(Q, 1, 2)) @ Gw
    Z = Gw - Q @ QhG
    Bs = bspline_basis(np.asarray(hz, float), nb).toarray()
    ZZ = np.conj(np.swapaxes(Z, 1, 2)) @ Z  # (F, e, e)
    BB = (Bs[:, :, None] * Bs[:, None, :]).reshape(F, nb * nb)
    N = (ZZ.reshape(F, e * e).T @ BB).reshape(e, e, nb, nb).transpose(0, 2, 1, 3).reshape(e * nb, e * nb)
    try:
        Ninv = np.linalg.inv(N)
    except np.linalg.LinAlgError:
        return np.full((F, n, n), np.inf)
    U = np.linalg.solve(R, QhG) / cs[:, :, None]
    Tm = np.einsum("fpj,fb->fpjb", U, Bs).reshape(F, p, e * nb)
    M = (Tm.reshape(F * p, e * nb) @ Ninv).reshape(F, p, e * nb)  # one matrix product, not F small ones
    Cx = np.einsum("fpk,fqk->fpq", M, Tm.conj())
    I = np.eye(n)
    J = np.einsum("fik,flj->fijkl", I[None] + Du @ Ynn, I[None] + Ynn @ Du).reshape(F, n * n, n * n) @ P
    return np.real(np.einsum("fab,fbc,fac->fa", J, Cx, J.conj())).reshape(F, n, n)
