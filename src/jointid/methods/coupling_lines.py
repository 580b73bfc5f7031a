"""Per-line weighted least squares of the receptance-coupling equation, with covariance.

With ``Y`` the free structure's receptance and ``H`` the measured constrained
one, the joint ``Du`` on the joint DOFs n acts as a rank-|n| update
(Sherman-Morrison-Woodbury; LM-FBS decoupling, de Klerk, Rixen & Voormeeren 2008)::

    Y[m,e] - H[m,e] = Y[m,n] X Y[n,e],     X = (Y[n,n] + Du^-1)^-1

The equation is *linear in X* and the measured FRFs appear only on the left:
there is no error in the variables, so weighted least squares with weights
``1 / var(H[m,e])`` is the best linear unbiased (and, for Gaussian errors, the
maximum-likelihood) estimate of X, and by invariance ``Du = (X^-1 - Y[n,n])^-1
= (I - X Y[n,n])^-1 X`` is the maximum-likelihood estimate of Du. ``Du = Du^T``
holds exactly when ``X = X^T`` (Y[n,n] is symmetric), so symmetry is a linear
constraint: X is parametrized by its upper triangle.

Per line, with ``A = Y[n,e]^T (x) Y[m,n]`` (Kronecker, |m||e| x |n|^2) and the
duplication matrix P (symmetric case)::

    min_x || W^(1/2) (vec(Y[m,e] - H) - A P x) ||^2

solved by Householder QR of the column-equilibrated weighted design (no normal
equations), batched over lines. Covariance: ``cov(x) = s^2 (A_w^H A_w)^-1``
with the scale ``s^2`` estimated from the residuals (chi^2 per degree of
freedom, pooled over neighbouring lines), so only the *shape* of the weights
must be right. First-order propagation to Du: ``dDu = (I + Du Y[n,n]) dX
(I + Y[n,n] Du)``.

Caveats: the linearization holds while the predicted relative error of a term
is small (say < 30 %); ``Du`` is an inverse of ``X^-1 - Y[n,n]``, so a term far
beyond the structure's own stiffness at n (identifiability ratio >> 1) is
poorly determined, and so is one far below it (the rotational term of a soft
joint: ratio ~1e-3). The FE model's error is not in the covariance.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

__all__ = ["LineEstimates", "coupling_per_line", "symmetric_parametrization", "relinearize"]


@dataclass(frozen=True, eq=False)
class LineEstimates:
    """Per-line estimates of ``Du`` and their second moments.

    Attributes
    ----------
    stiffness : ndarray, shape (F, n, n), complex
    variance : ndarray, shape (F, n, n)
        ``E|dDu_ij|^2`` (real and imaginary parts each carry half for circular errors).
    scale : ndarray, shape (F,)
        Residual variance factor ``s^2`` (pooled chi^2 per degree of freedom; NaN without redundancy).
    condition : ndarray, shape (F,)
        Condition number of the column-equilibrated weighted design.
    dof : int
        Residual degrees of freedom per line (complex).
    common_variance : ndarray, shape (F, n, n)
        ``E|dDu_ij|^2`` of an error common to all lines (a column calibration
        estimated over the band); zero when there is none. Frequency smoothing
        does not reduce it.
    x, x_covariance, common_x_covariance, Ynn, symmetric
        The per-line coupling parameters (upper triangle of X if ``symmetric``), their
        covariance (scaled), the common part, and ``Y[n,n]``: what
        :func:`relinearize` needs.
    """

    stiffness: np.ndarray
    variance: np.ndarray
    scale: np.ndarray
    condition: np.ndarray
    dof: int
    common_variance: np.ndarray | None = None
    x: np.ndarray | None = None
    x_covariance: np.ndarray | None = None
    common_x_covariance: np.ndarray | None = None
    Ynn: np.ndarray | None = None
    symmetric: bool = True


def symmetric_parametrization(n: int, symmetric: bool) -> np.ndarray:
    """Matrix P (n^2 x p) with ``vec(X) = P x``: the upper triangle if ``symmetric``, else the identity."""
    if not symmetric:
        return np.eye(n * n)
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    P = np.zeros((n * n, len(pairs)))
    for p, (i, j) in enumerate(pairs):
        P[i * n + j, p] = 1.0
        P[j * n + i, p] = 1.0
    return P


def coupling_per_line(
    Ymn: np.ndarray,
    Yne: np.ndarray,
    Ynn: np.ndarray,
    change: np.ndarray,
    variance: np.ndarray,
    symmetric: bool = True,
    pool_lines: int | None = None,
    common_x_covariance: np.ndarray | None = None,
) -> LineEstimates:
    """Weighted least-squares ``Du`` per line from the measured change of receptance.

    Parameters
    ----------
    Ymn, Yne, Ynn : ndarray, shapes (F, m, n), (F, n, e), (F, n, n), complex
        Free receptance blocks.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]`` (free minus measured constrained receptance), m/N.
    variance : ndarray, shape (F, m, e)
        Variance (shape) of each measured receptance value, (m/N)^2.
    symmetric : bool
        Enforce ``Du = Du^T``.
    pool_lines : int, optional
        Lines pooled (running mean) for the residual scale ``s^2`` (default ``max(1, F // 40) | 1``).
    common_x_covariance : ndarray, shape (F, p, p), optional
        Covariance of x (upper triangle of X if ``symmetric``) from an error common to all
        lines (:class:`~jointid.methods.column_calibration.ColumnCalibration`), propagated
        to ``common_variance``.
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    P = symmetric_parametrization(n, symmetric)
    p = P.shape[1]
    # vec over (row r, column c) of Y[m,n] X Y[n,e]: sum_ik Ymn[r,i] X[i,k] Yne[k,c]
    A = np.einsum("fkc,fri->frcik", Yne, Ymn).reshape(F, m * e, n * n) @ P
    sw = 1.0 / np.sqrt(variance.reshape(F, m * e))
    Aw = A * sw[:, :, None]
    dw = change.reshape(F, m * e) * sw
    cs = np.linalg.norm(Aw, axis=1)  # column equilibration
    cs = np.where(cs > 0, cs, 1.0)
    Aw = Aw / cs[:, None, :]
    Q, R = np.linalg.qr(Aw)
    qd = np.einsum("fji,fj->fi", Q.conj(), dw)
    eye = np.broadcast_to(np.eye(p), (F, p, p))
    Ri = np.linalg.solve(R, eye)  # R^-1: p x p per line
    xs = np.einsum("fij,fj->fi", Ri, qd)
    resid = dw - np.einsum("fij,fj->fi", Aw, xs)
    dof = m * e - p
    sv = np.linalg.svd(R, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = sv[:, 0] / sv[:, -1]
    if dof > 0:
        chi2 = np.sum(np.abs(resid) ** 2, axis=1) / dof
        w = pool_lines or (max(1, F // 40) | 1)
        scale = uniform_filter1d(chi2, size=min(w, F), mode="nearest")
    else:
        scale = np.full(F, np.nan)
    x = xs / cs
    C = (Ri @ np.conj(np.swapaxes(Ri, 1, 2))) / (cs[:, :, None] * cs[:, None, :])  # cov(x) / s^2
    X = (x @ P.T).reshape(F, n, n)
    I = np.eye(n)
    Du = np.linalg.solve(I[None] - X @ Ynn, X)  # (X^-1 - Ynn)^-1
    L = I[None] + Du @ Ynn
    Rr = I[None] + Ynn @ Du
    J = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ P  # d vec(Du) / d x
    V = np.real(np.einsum("fab,fbc,fac->fa", J, C, J.conj())).reshape(F, n, n) * scale[:, None, None]
    common = np.zeros_like(V)
    if common_x_covariance is not None:
        common = np.real(np.einsum("fab,fbc,fac->fa", J, common_x_covariance, J.conj())).reshape(F, n, n)
    return LineEstimates(Du, V, scale, cond, dof, common, x, C * scale[:, None, None], common_x_covariance, Ynn, symmetric)


def relinearize(lines: LineEstimates, around: np.ndarray) -> LineEstimates:
    """Per-line estimates of Du linearized around a smooth estimate instead of at each noisy line.

    ``Du = (X^-1 - Y[n,n])^-1`` is nonlinear in the estimated X: where a line's
    relative error is large (the rotational term of a soft joint: 100 % and
    more per line) the per-line ``Du`` is biased and heavy-tailed, and its
    variance, linearized at the noisy estimate itself, is wrong. Around a
    smooth estimate ``D0`` (close to the truth after smoothing), one
    Gauss-Newton step gives pseudo-observations that are linear in the FRF
    errors::

        Du_f = D0 + (I + D0 Y[n,n]) (X^_f - X(D0)) (I + Y[n,n] D0),   X(D0) = (I + D0 Y[n,n])^-1 D0

    with their variance propagated through the same Jacobian evaluated at ``D0``.
    Smoothing these again is a Gauss-Newton iteration of the penalized fit of all
    lines at once (each term smoothed on its own).

    Parameters
    ----------
    lines : LineEstimates
        From :func:`coupling_per_line`.
    around : ndarray, shape (F, n, n), complex
        The smooth estimate ``D0``.
    """
    F, n, _ = around.shape
    P = symmetric_parametrization(n, lines.symmetric)
    I = np.eye(n)
    L = I[None] + around @ lines.Ynn
    Rr = I[None] + lines.Ynn @ around
    X0 = np.linalg.solve(L, around)
    Xh = (lines.x @ P.T).reshape(F, n, n)
    Du = around + L @ (Xh - X0) @ Rr
    J = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ P
    V = np.real(np.einsum("fab,fbc,fac->fa", J, lines.x_covariance, J.conj())).reshape(F, n, n)
    common = np.zeros_like(V)
    if lines.common_x_covariance is not None:
        common = np.real(np.einsum("fab,fbc,fac->fa", J, lines.common_x_covariance, J.conj())).reshape(F, n, n)
    return dataclasses.replace(lines, stiffness=Du, variance=V, common_variance=common)
