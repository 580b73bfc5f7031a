"""Per-term predicted error of the inverse method: the FRF noise propagated through both steps.

The noise-weighted estimation step (:func:`~jointid.methods.hong_lee.estimation.estimate_weighted`)
writes the constrained receptance as ``H = H0 + Z g`` and fits the joint-force coordinates ``g``
(one ``|n|``-vector per excited column ``j``) to the ``|m|`` measured values of that column.
With relative FRF noise of variance ``sigma^2`` (``E|dH|^2 = sigma^2 |H|^2``, circular, independent
per value), to first order

    cov(g_j) = sigma^2 (A_j^H A_j)^+,   A_j = W_j Z[m],  W_j = diag(1 / |H*[m, j]|)

and ``sigma^2`` is estimated from the weighted residuals: ``E[rss] = sigma^2 (|m| - |n|) |e|``
per line (complex degrees of freedom), pooled over a window of neighbouring lines. The
identification step ``Du = f(g)`` is linearized by central differences in the real and imaginary
part of every ``g_jk`` (``2 |n| |e|`` evaluations of the small right inverse per line, all lines at
once), and the covariance of ``(Re g_j, Im g_j)`` of a circular ``g_j`` with ``E[g g^H] = S`` is
``[[Re S, -Im S], [Im S, Re S]] / 2``. The result is the 1-sigma of ``Re Du_ik`` and ``Im Du_ik``.

What it does not contain: bias (model error in ``Do``, the nonlinearity of the right inverse where
``H*[n, e]`` is ill-conditioned); model error shows in the pooled ``sigma`` instead (larger
residuals), so it widens the predicted error but does not remove the bias.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .identification import identify_step

__all__ = ["Reliability", "pooled_noise", "propagate_std"]


@dataclass(frozen=True)
class Reliability:
    """The per-term ``reliable`` flag of the inverse method.

    A term is reliable on a line when its predicted relative standard deviation
    ``sqrt(std_real^2 + std_imag^2) / scale`` (scale: :func:`jointid.methods.estimate.term_scale`)
    is at most ``max_relative_std`` and ``cond_A <= max_cond_A`` (a layout whose observed
    points barely tell the joint forces apart). Without a predicted error (no redundant
    observed point, ``|m| = |n|``, or ``weighting = "none"``) no term is reliable.

    Attributes
    ----------
    max_relative_std : float
        Largest predicted relative standard deviation of a reliable term.
    max_cond_A : float
        Largest condition number of ``Do[nbar, mbar]`` (scaled) on a reliable line.
    window : int
        Lines (odd) over which the relative FRF noise is pooled from the residuals.
    """

    max_relative_std: float = 0.1
    max_cond_A: float = 1e5
    window: int = 21


def pooled_noise(rss: np.ndarray, dof: int, window: int) -> np.ndarray:
    """Relative FRF noise variance per line, ``sigma^2 = sum rss / sum dof`` over a window of lines.

    Parameters
    ----------
    rss : ndarray, shape (F,)
        Weighted residual sum of squares of the estimation step per line (dimensionless).
    dof : int
        Complex degrees of freedom per line, ``(|m| - |n|) |e|``; 0 gives NaN.
    window : int
        Lines pooled (centred; shorter at the band's ends).

    Returns
    -------
    ndarray, shape (F,)
        ``sigma^2`` (dimensionless, ``E|dH|^2 / |H|^2``).
    """
    if dof <= 0:
        return np.full(rss.shape, np.nan)
    h = max(int(window), 1) // 2
    c = np.concatenate([[0.0], np.cumsum(rss)])
    i = np.arange(rss.size)
    lo, hi = np.maximum(i - h, 0), np.minimum(i + h + 1, rss.size)
    return (c[hi] - c[lo]) / ((hi - lo) * dof)


def propagate_std(B: np.ndarray, C: np.ndarray, Nn: np.ndarray, P: np.ndarray, cov: np.ndarray,
                  sigma2: np.ndarray, lam: np.ndarray, symmetric: bool) -> tuple[np.ndarray, np.ndarray]:
    """1-sigma of ``Re Du`` and ``Im Du`` per line (scaled units), first order in the FRF noise.

    Parameters
    ----------
    B, C : ndarray, shape (F, |n|, |e|)
        ``H*[n, e]`` and ``I[n, e] - Do[n, :] H*[:, e]`` of the identification step.
    Nn, P : ndarray, shape (F, |n|, |n|)
        ``Z[n]`` and ``Do[n, :] Z``: ``dB_j = Nn dg_j``, ``dC_j = -P dg_j``.
    cov : ndarray, shape (F, |e|, |n|, |n|)
        ``cov(g_j)`` per unit relative noise variance.
    sigma2 : ndarray, shape (F,)
        Relative noise variance.
    lam : ndarray, shape (F,)
        Tikhonov lambda of each line (held fixed).
    symmetric : bool
        The identification step's ``Du = Du^T`` option.

    Returns
    -------
    std_real, std_imag : ndarray, shape (F, |n|, |n|)
    """
    F, n, e = B.shape
    S = cov * sigma2[:, None, None, None]
    var_re = np.zeros((F, n, n))
    var_im = np.zeros((F, n, n))
    for j, J in enumerate(_jacobians(B, C, Nn, P, lam, symmetric)):
        Cr = 0.5 * np.block([[S[:, j].real, -S[:, j].imag], [S[:, j].imag, S[:, j].real]])  # (F, 2n, 2n)
        var_re += np.einsum("faxy,fab,fbxy->fxy", J.real, Cr, J.real)
        var_im += np.einsum("faxy,fab,fbxy->fxy", J.imag, Cr, J.imag)
    return np.sqrt(np.maximum(var_re, 0.0)), np.sqrt(np.maximum(var_im, 0.0))


def _jacobians(B, C, Nn, P, lam, symmetric):
    """Per excited column j: ``dDu / d(Re g_j)`` then ``/ d(Im g_j)``, shape (F, 2 |n|, |n|, |n|).

    The plain right inverse ``Du = C B^+`` (``B`` of full row rank, ``G = (B B^H)^-1``) has
    ``dDu = (dC - Du dB) B^+ + R dB^H G`` with the residual ``R = C - Du B``; with ``dB_j = Nn dg_j``
    and ``dC_j = -P dg_j``, ``dDu = -T dg_j B^+[j, :] + R[:, j] (conj(dg_j)^T Nn^H G)``,
    ``T = P + Du Nn``; the symmetric solve likewise (:func:`_symmetric_jacobians`). The
    regularized solves are differentiated by central differences (``2 |n| |e|`` pairs of solves).
    """
    F, n, e = B.shape
    if symmetric and n > 1 and not np.any(lam > 0):
        yield from _symmetric_jacobians(B, C, Nn, P)
        return
    if symmetric or np.any(lam > 0):
        h = 1e-5 * np.abs(B).max(axis=(1, 2))[:, None, None]  # step in g, the units of B
        for j in range(e):
            J = np.empty((F, 2 * n, n, n), complex)
            for k in range(n):
                for p, unit in enumerate((1.0, 1j)):
                    dB = np.zeros((F, n, e), complex)
                    dC = np.zeros((F, n, e), complex)
                    dB[:, :, j] = Nn[:, :, k] * unit
                    dC[:, :, j] = -P[:, :, k] * unit
                    plus = identify_step(B + h * dB, C + h * dC, symmetric, lam=lam)[0]
                    minus = identify_step(B - h * dB, C - h * dC, symmetric, lam=lam)[0]
                    J[:, p * n + k] = (plus - minus) / (2 * h)
            yield J
        return
    Bh = np.conj(np.swapaxes(B, 1, 2))
    G = np.linalg.pinv(B @ Bh, hermitian=True)
    Bplus = Bh @ G  # (F, e, n)
    Du = C @ Bplus
    R = C - Du @ B
    T = P + Du @ Nn
    M = np.conj(np.swapaxes(Nn, 1, 2)) @ G  # (F, n, n): [l, k]
    for j in range(e):
        lin = -T[:, :, None, :] * Bplus[:, j, None, :, None]  # (F, i, k, l)
        conj_ = R[:, :, j, None, None] * np.swapaxes(M, 1, 2)[:, None, :, :]  # (F, i, k, l)
        J = np.concatenate([lin + conj_, 1j * (lin - conj_)], axis=-1)  # (F, i, k, 2n)
        yield np.moveaxis(J, -1, 1)


def _symmetric_jacobians(B, C, Nn, P):
    """:func:`_jacobians` of the symmetric solve ``min ||G(B) x - vec C||``, ``x`` the upper triangle of ``Du``.

    ``G`` is linear in ``B``, so ``dx = G^+ (dc - dG x) + (G^H G)^-1 dG^H r`` with ``r = vec C - G x``;
    ``dc - dG x = vec(dC - Du dB) = -vec(T dg_j e_j^T)`` and, for ``dB = u e_j^T``, entry ``(a, b)``
    of ``dG^H r`` is ``conj(u_b) r[a, j] + conj(u_a) r[b, j]`` (``a != b``).
    """
    from .identification import symmetric_design

    F, n, e = B.shape
    G, pairs = symmetric_design(B)
    Gp = np.linalg.pinv(G)  # (F, p, n e)
    Du = identify_step(B, C, True)[0]
    T = P + Du @ Nn
    r = (C - Du @ B)  # (F, n, e): vec C - G x, row-major like G's rows
    Hinv = np.linalg.pinv(np.conj(np.swapaxes(G, 1, 2)) @ G, hermitian=True)  # (F, p, p)
    a_idx = np.array([a for a, _ in pairs])
    b_idx = np.array([b for _, b in pairs])
    off = (a_idx != b_idx)[None, :, None]
    Gp4 = Gp.reshape(F, len(pairs), n, e)
    for j in range(e):
        lin = -np.einsum("fpi,fil->fpl", Gp4[:, :, :, j], T)  # (F, p, l)
        # dG^H r for u = Nn[:, :, l]: (F, p, l)
        q = np.conj(Nn[:, b_idx, :]) * r[:, a_idx, j, None] + off * np.conj(Nn[:, a_idx, :]) * r[:, b_idx, j, None]
        conj_ = Hinv @ q
        dx = np.concatenate([lin + conj_, 1j * (lin - conj_)], axis=-1)  # (F, p, 2n)
        J = np.empty((F, 2 * n, n, n), complex)
        J[:, :, a_idx, b_idx] = np.swapaxes(dx, 1, 2)
        J[:, :, b_idx, a_idx] = np.swapaxes(dx, 1, 2)
        yield J
