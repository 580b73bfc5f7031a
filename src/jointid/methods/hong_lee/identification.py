"""Identification step of the inverse method: ``Du`` from ``Du H*[n, e] = C`` per line (right inverse).

``C = I[n, e] - Do[n, :] H*[:, e]``. Per line the rows of ``Du`` are |n| least-squares
problems sharing the matrix ``H*[n, e]^T`` (``|e| >= |n|`` equations each), solved by one small
SVD per line: ``Du = C B^+`` with ``B = H*[n, e]``. Options: ``Du = Du^T`` enforced by least
squares on the independent entries; Tikhonov regularization ``min ||Du B - C||^2 + lambda^2 ||Du||^2``
with ``lambda`` per line by generalized cross-validation or the L-curve corner (biased: it shrinks
``Du`` where ``B`` is ill-conditioned).
"""

from __future__ import annotations

import numpy as np

__all__ = ["identify_step", "symmetric_design"]


def _tikhonov_lambda(s: np.ndarray, beta: np.ndarray, out_norm2: np.ndarray, m_eq: int, method: str) -> np.ndarray:
    """Lambda per line for ``min ||A x - c||^2 + lambda^2 ||x||^2`` from the SVD of A.

    Parameters
    ----------
    s : (F, k) singular values of A; beta : (F, k) |U^H c|^2 summed over right-hand sides;
    out_norm2 : (F,) squared norm of c outside range(A); m_eq : number of equations.
    """
    grid = s[:, :1] * np.logspace(-4, 0, 41)[None, :]  # (F, G)
    lam2 = grid[:, :, None] ** 2
    s2 = s[:, None, :] ** 2
    f = s2 / (s2 + lam2)  # filter factors (F, G, k)
    res = np.sum(((1 - f) ** 2) * beta[:, None, :], axis=-1) + out_norm2[:, None]
    if method == "gcv":
        dof = m_eq - np.sum(f, axis=-1)
        score = res / np.maximum(dof, 1e-12) ** 2
        return grid[np.arange(s.shape[0]), np.argmin(score, axis=1)]
    # L-curve: corner of maximum curvature of (log ||r||, log ||x||)
    xn = np.sum((f**2) * beta[:, None, :] / s2, axis=-1)
    x = 0.5 * np.log(np.maximum(res, 1e-300))
    y = 0.5 * np.log(np.maximum(xn, 1e-300))
    t = np.log(grid)
    dx, dy = np.gradient(x, axis=1) / np.gradient(t, axis=1), np.gradient(y, axis=1) / np.gradient(t, axis=1)
    ddx, ddy = np.gradient(dx, axis=1) / np.gradient(t, axis=1), np.gradient(dy, axis=1) / np.gradient(t, axis=1)
    kappa = (dx * ddy - ddx * dy) / np.maximum((dx**2 + dy**2) ** 1.5, 1e-300)
    kappa[:, [0, -1]] = -np.inf
    return grid[np.arange(s.shape[0]), np.argmax(kappa, axis=1)]


def identify_step(B: np.ndarray, C: np.ndarray, symmetric: bool = False, regularization: str = "none",
                  lam: np.ndarray | None = None):
    """Solve ``Du B = C`` per line (right inverse); returns ``(Du, cond_B, lambda)``.

    ``B`` (F, |n|, |e|), ``C`` (F, |n|, |e|) complex (scaled units); ``lam`` (F,): use these lambdas
    instead of choosing them (the same filter on a perturbed ``B``, for error propagation).
    """
    F, n, e = B.shape
    # Du B = C  <=>  B^T Du^T = C^T : a least-squares problem with n unknowns per row of Du
    At = np.swapaxes(B, -1, -2)  # (F, e, n)
    Ct = np.swapaxes(C, -1, -2)  # (F, e, n): columns are right-hand sides
    U, s, Vh = np.linalg.svd(At, full_matrices=False)  # U (F,e,k), s (F,k), Vh (F,k,n)
    with np.errstate(divide="ignore"):
        cond = s[:, 0] / s[:, -1]
    Uh = np.conj(np.swapaxes(U, -1, -2))
    proj = Uh @ Ct  # (F, k, n)
    if lam is not None:
        pass
    elif regularization == "none":
        lam = np.zeros(F)
    else:
        beta = np.sum(np.abs(proj) ** 2, axis=-1)  # (F, k)
        out2 = np.sum(np.abs(Ct) ** 2, axis=(-2, -1)) - np.sum(beta, axis=-1)
        lam = _tikhonov_lambda(s, beta, np.maximum(out2, 0.0), e, regularization)
    if symmetric and n > 1:
        return _symmetric(B, C, lam), cond, lam  # lambda chosen on B's singular values, as for the plain solve
    filt = s / (s**2 + lam[:, None] ** 2)
    DuT = np.conj(np.swapaxes(Vh, -1, -2)) @ (filt[..., None] * proj)
    return np.swapaxes(DuT, -1, -2), cond, lam


def _symmetric(B: np.ndarray, C: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Least-squares ``Du = Du^T`` with ``Du B = C``: unknowns are the upper triangle of Du."""
    F, n, e = B.shape
    G, pairs = symmetric_design(B)
    rhs = C.reshape(F, n * e, 1)
    U, s, Vh = np.linalg.svd(G, full_matrices=False)
    filt = s / (s**2 + lam[:, None] ** 2)
    x = (np.conj(np.swapaxes(Vh, -1, -2)) @ (filt[..., None] * (np.conj(np.swapaxes(U, -1, -2)) @ rhs)))[..., 0]
    Du = np.empty((F, n, n), complex)
    for p, (i, j) in enumerate(pairs):
        Du[:, i, j] = x[:, p]
        Du[:, j, i] = x[:, p]
    return Du


def symmetric_design(B: np.ndarray):
    """``G`` (F, |n| |e|, p) with ``vec(Du B) = G x``, ``x`` the upper triangle of ``Du`` (row-major ``vec``); and the pairs."""
    F, n, e = B.shape
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    # vec(Du B)[i, c] = sum_k Du[i, k] B[k, c]; Du[i, k] = x[p(i, k)]
    G = np.zeros((F, n * e, len(pairs)), complex)
    for p, (i, j) in enumerate(pairs):
        G[:, i * e : (i + 1) * e, p] += B[:, j, :]
        if i != j:
            G[:, j * e : (j + 1) * e, p] += B[:, i, :]
    return G, pairs
