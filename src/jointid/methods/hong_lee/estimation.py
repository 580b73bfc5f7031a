"""Estimation step of the inverse method: the unobserved FRFs from the observed ones.

Rows ``nbar`` (not touching the joint) of ``(Do + Du) H* = I`` give, for the
excited columns ``e``, the least-squares problem

    A x = b,   A = Do[nbar, mbar],   x = H*[mbar, e],   b = I[nbar, e] - Do[nbar, m] H*[m, e]

whose solution ``x = A^+ b`` (generalized left inverse) is the estimate. All
quantities here are in the scaled coordinates of :mod:`jointid.methods.hong_lee.inverse`
(rotations times a length), and ``Do(w) = K - w^2 M`` with ``K`` complex.
Two solvers return the same ``x`` when ``A`` has full column rank:

``qr`` (:func:`estimate_qr`)
    Householder QR of the augmented matrix ``[A | b] = Q [R c; 0 d]`` per line
    (batched LAPACK ``geqrf``), then ``x = R^-1 c`` by back-substitution: the
    least-squares algorithm of LAPACK ``gels``, never the normal equations.
    About a tenth of the time of an SVD with vectors (17 vs 169 us per line for
    the benchmark's 36 x 31 block); it gives no singular values,
    so ``cond(A)`` comes from :func:`~jointid.methods.hong_lee.condition.pencil_condition`.

``svd`` (:func:`estimate_svd`)
    One SVD of ``A`` per line (batched LAPACK ``gesdd``): ``x = V S^-1 U^H b``
    with singular values below ``max(shape) eps s_max`` dropped (the
    pseudo-inverse, minimum-norm on rank-deficient lines); ``cond(A)`` exactly.

Both are O(N^3) per line and are run on chunks of lines. Neither forms all of
``Do``: only ``Do[nbar, mbar]`` per line, and the products of ``Do`` with known
receptances are single matrix products with ``K`` and ``M`` over a whole chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["EstimationLayout", "WeightedEstimate", "estimate_qr", "estimate_svd", "estimate_weighted", "svd_solve_left"]


@dataclass(frozen=True, eq=False)
class EstimationLayout:
    """Index sets of one identification and the scaled free-beam matrices.

    Attributes
    ----------
    n, m, e : ndarray of int
        Joint, observed and excited coordinates (indices into the free model's DOFs).
    nbar, mbar : ndarray of int
        Rows not touching the joint; unobserved coordinates.
    loads : ndarray, shape (N, |e|)
        Scaled unit loads ``S I[:, e]`` (``S`` the coordinate scaling).
    stiffness : ndarray, shape (N, N), complex
        Scaled ``K`` (``S K S``), N/m-equivalent.
    mass : ndarray, shape (N, N)
        Scaled ``M`` (``S M S``), kg-equivalent.
    """

    n: np.ndarray
    m: np.ndarray
    e: np.ndarray
    nbar: np.ndarray
    mbar: np.ndarray
    loads: np.ndarray
    stiffness: np.ndarray
    mass: np.ndarray

    def dynamic_stiffness_times(self, rows: np.ndarray, cols: np.ndarray, w2: np.ndarray, X: np.ndarray) -> np.ndarray:
        """``Do[rows, cols] X`` per line: ``X`` shape (F, |cols|, k) -> (F, |rows|, k); ``w2`` (F,) (rad/s)^2.

        Two matrix products over all lines at once (``K`` and ``M`` are constant).
        """
        F, c, k = X.shape
        flat = X.transpose(1, 0, 2).reshape(c, F * k)
        KX = (self.stiffness[np.ix_(rows, cols)] @ flat).reshape(rows.size, F, k)
        MX = (self.mass[np.ix_(rows, cols)] @ flat).reshape(rows.size, F, k)
        return (KX - w2[None, :, None] * MX).transpose(1, 0, 2)

    def estimation_blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """``K[nbar, mbar]`` and ``M[nbar, mbar]``: ``A(w) = Do[nbar, mbar] = K - w^2 M``."""
        block = np.ix_(self.nbar, self.mbar)
        return self.stiffness[block], self.mass[block]

    def estimation_matrix(self, w2: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``A = Do[nbar, mbar]`` per line, shape (F, |nbar|, |mbar|), complex; written into ``out`` if given."""
        K, M = self.estimation_blocks()
        if out is None:
            out = np.empty((w2.size,) + K.shape, complex)
        np.multiply.outer(-w2, M, out=out.real)  # real and imaginary parts in place: no complex temporaries
        out.real += K.real
        out.imag[...] = K.imag
        return out

    def _finish(self, x: np.ndarray, Ys_m: np.ndarray, w2: np.ndarray):
        F = Ys_m.shape[0]
        Ys = np.empty((F, self.stiffness.shape[0], self.e.size), complex)
        Ys[:, self.m] = Ys_m
        Ys[:, self.mbar] = x
        all_dofs = np.arange(self.stiffness.shape[0])
        Cs = self.loads[self.n][None] - self.dynamic_stiffness_times(self.n, all_dofs, w2, Ys)
        return Ys, Cs

    def _rhs(self, w2: np.ndarray, Ys_m: np.ndarray) -> np.ndarray:
        return self.loads[self.nbar][None] - self.dynamic_stiffness_times(self.nbar, self.m, w2, Ys_m)


def svd_solve_left(A: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares ``A X = rhs`` per line by SVD (pseudo-inverse); returns ``(X, cond(A))``.

    ``A`` shape (F, r, c), ``rhs`` (F, r, k); ``X`` (F, c, k), ``cond`` (F,) (inf if singular).
    """
    if A.shape[-1] == 0:  # nothing to estimate
        return np.zeros(A.shape[:1] + (0, rhs.shape[-1]), complex), np.ones(A.shape[0])
    U, s, Vh = np.linalg.svd(A, full_matrices=False)
    tol = s[:, :1] * max(A.shape[-2:]) * np.finfo(float).eps
    sinv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0), 0.0)
    X = np.conj(np.swapaxes(Vh, -1, -2)) @ (sinv[..., None] * (np.conj(np.swapaxes(U, -1, -2)) @ rhs))
    with np.errstate(divide="ignore"):  # an exactly singular line has cond = inf
        return X, s[:, 0] / s[:, -1]


def estimate_svd(layout: EstimationLayout, w2: np.ndarray, Ys_m: np.ndarray):
    """Estimation by one SVD of ``Do[nbar, mbar]`` per line (pseudo-inverse).

    Parameters
    ----------
    layout : EstimationLayout
    w2 : ndarray, shape (F,)
        Squared circular frequency, (rad/s)^2.
    Ys_m : ndarray, shape (F, |m|, |e|), complex
        Scaled measured receptance ``H*[m, e]``.

    Returns
    -------
    Ys : ndarray, shape (F, N, |e|)
        Scaled receptance on every DOF (measured rows as given).
    Cs : ndarray, shape (F, |n|, |e|)
        Identification right-hand side ``S I[n, e] - Do_s[n, :] Ys``.
    cond_A : ndarray, shape (F,)
        ``sigma_max / sigma_min`` of ``Do[nbar, mbar]`` (scaled), inf where singular.
    """
    x, cond = svd_solve_left(layout.estimation_matrix(w2), layout._rhs(w2, Ys_m))
    return (*layout._finish(x, Ys_m, w2), cond)


def estimate_qr(layout: EstimationLayout, w2: np.ndarray, Ys_m: np.ndarray):
    """Estimation by a Householder QR of ``[Do[nbar, mbar] | b]`` per line.

    Same parameters and first two returns as :func:`estimate_svd` (no condition
    number). ``Do[nbar, mbar]`` must have full column rank on every line: the
    caller sends rank-deficient lines to :func:`estimate_svd`.
    """
    L = layout
    F, r, c, k = w2.size, L.nbar.size, L.mbar.size, Ys_m.shape[2]
    aug = np.empty((F, r, c + k), complex)
    L.estimation_matrix(w2, out=aug[:, :, :c])
    aug[:, :, c:] = L._rhs(w2, Ys_m)
    h, _ = np.linalg.qr(aug, mode="raw")  # LAPACK layout: [R y; 0 d] is the upper triangle of h^T
    Ra = np.swapaxes(h, 1, 2)
    x = np.empty((F, c, k), complex)
    for i in range(c - 1, -1, -1):  # back-substitution x = R^-1 y, vectorized over lines
        x[:, i] = (Ra[:, i, c:] - (Ra[:, i : i + 1, i + 1 : c] @ x[:, i + 1 :])[:, 0]) / Ra[:, i, i, None]
    return L._finish(x, Ys_m, w2)


@dataclass(frozen=True, eq=False)
class WeightedEstimate:
    """The noise-weighted estimation step on a chunk of lines (scaled coordinates).

    Attributes
    ----------
    Ys : ndarray, shape (F, N, |e|)
        Estimated receptance ``H*[:, e]`` on every DOF, the observed rows included (fitted).
    Cs : ndarray, shape (F, |n|, |e|)
        Identification right-hand side ``S I[n, e] - Do_s[n, :] Ys``.
    null : ndarray, shape (F, N, |n|)
        Orthonormal basis ``Z`` of the null space of ``Do_s[nbar, :]``: ``Ys = Ys0 + Z g``.
    cov : ndarray, shape (F, |e|, |n|, |n|)
        Covariance of each column's ``g`` per unit relative FRF variance: ``(A_w^H A_w)^+``.
    rss : ndarray, shape (F,)
        Weighted residual sum of squares over the excited columns (dimensionless).
    cond_w : ndarray, shape (F,)
        Largest condition number over the columns of the weighted ``W Z[m]`` (inf if rank deficient).
    """

    Ys: np.ndarray
    Cs: np.ndarray
    null: np.ndarray
    cov: np.ndarray
    rss: np.ndarray
    cond_w: np.ndarray


def estimate_weighted(layout: EstimationLayout, w2: np.ndarray, Ys_m: np.ndarray, weights: np.ndarray,
                      method: str = "qr") -> WeightedEstimate:
    """Estimation step as the generalized least squares of the measured FRFs' noise.

    The rows ``nbar`` of ``(Do + Du) H* = I`` hold exactly; only the measured ``H*[m, e]`` carry
    noise, of standard deviation ``sigma / w_k`` per value (``weights`` ``w``, relative
    noise ``sigma`` unknown). The right-hand side ``b = I[nbar, e] - Do[nbar, m] H*[m, e]`` of
    the paper's left inverse therefore has the singular covariance
    ``Do[nbar, m] diag(sigma^2 / w^2) Do[nbar, m]^H``; its best linear unbiased estimate solves

        min_H  sum_k w_k^2 |H[m_k] - H*[m_k]|^2   subject to   Do[nbar, :] H = I[nbar, e]

    per excited column. Every ``H`` satisfying the rows ``nbar`` is ``H0 + Z g`` with ``Z`` an
    orthonormal basis of the null space of ``Do[nbar, :]`` (``|n|`` columns: ``g`` are the
    joint's forces in the basis ``Z``) and ``H0`` the minimum-norm solution, so ``g`` is a
    weighted least-squares fit of ``|m|`` values with ``|n|`` unknowns::

        g = (W Z[m])^+ W (H*[m] - H0[m])

    On exact data consistent with ``Do`` this is the paper's estimate (any weighting is);
    on noisy data it weights each measured value by its noise rather than the rows by their
    units, so it does not depend on the scaling of rotations. The measured rows of ``Ys`` are the
    fitted ones.

    Parameters
    ----------
    layout : EstimationLayout
    w2 : ndarray, shape (F,)
        Squared circular frequency, (rad/s)^2.
    Ys_m : ndarray, shape (F, |m|, |e|), complex
        Scaled measured receptance ``H*[m, e]``.
    weights : ndarray, shape (F, |m|, |e|)
        ``w_k``: inverse relative standard deviation of each measured value, 1/(m/N).
    method : {"qr", "svd"}
        Null space and ``H0`` from a complete Householder QR of ``Do[nbar, :]^H`` per line, or
        from its SVD (the same subspace and ``H0``). ``g`` always comes from the SVD of the small
        ``W Z[m]`` (|m| x |n|), so a layout whose observed points cannot tell the joint forces
        apart gets the pseudo-inverse (minimum-norm ``g``) and an infinite ``cond_w``.

    Returns
    -------
    WeightedEstimate
    """
    L = layout
    N = L.stiffness.shape[0]
    F, r, n = w2.size, L.nbar.size, L.n.size
    allk = np.arange(N)
    Z = L.stiffness[L.nbar][None] - w2[:, None, None] * L.mass[L.nbar][None]  # (F, r, N)
    rhs = np.broadcast_to(L.loads[L.nbar], (F, r, L.e.size))
    if method == "qr":
        Q, R = np.linalg.qr(np.conj(np.swapaxes(Z, 1, 2)), mode="complete")  # Z^H = Q [R1; 0]
        d = np.abs(np.diagonal(R, axis1=1, axis2=2))
        deficient = ~(d.min(axis=1) > N * np.finfo(float).eps * d.max(axis=1))
        if deficient.any():  # Do[nbar, :] (numerically) rank deficient: those lines by the SVD
            ok = np.flatnonzero(~deficient)
            out = [estimate_weighted(L, w2[i], Ys_m[i], weights[i], m) for i, m in ((ok, "qr"), (np.flatnonzero(deficient), "svd"))]
            return WeightedEstimate(*(_merge(a, b, deficient) for a, b in zip(vars(out[0]).values(), vars(out[1]).values())))
        R1h = np.conj(np.swapaxes(R[:, :r, :], 1, 2))  # lower triangular, (F, r, r)
        null = Q[:, :, r:]
        H0 = Q[:, :, :r] @ np.linalg.solve(R1h, rhs)
    else:
        U, s, Vh = np.linalg.svd(Z, full_matrices=True)  # Z = U S Vh[:r]
        V = np.conj(np.swapaxes(Vh, 1, 2))
        null = V[:, :, r:]
        tol = s[:, :1] * N * np.finfo(float).eps
        sinv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0), 0.0)
        H0 = V[:, :, :r] @ ((np.conj(np.swapaxes(U, 1, 2)) @ rhs) * sinv[..., None])
    # per column j: weighted fit of g_j on the |m| measured values
    Am = weights.transpose(0, 2, 1)[..., None] * null[:, None, L.m, :]  # (F, e, m, n)
    bm = (weights * (Ys_m - H0[:, L.m])).transpose(0, 2, 1)  # (F, e, m)
    Ua, sa, Vah = np.linalg.svd(Am, full_matrices=False)
    tol = sa[..., :1] * max(Am.shape[-2:]) * np.finfo(float).eps
    sinv = np.where(sa > tol, 1.0 / np.where(sa > tol, sa, 1.0), 0.0)  # (F, e, k)
    Va = np.conj(np.swapaxes(Vah, -1, -2))
    g = (Va @ (sinv[..., None] * (np.conj(np.swapaxes(Ua, -1, -2)) @ bm[..., None])))[..., 0]  # (F, e, n)
    res = bm - (Am @ g[..., None])[..., 0]
    cov = (Va * (sinv**2)[..., None, :]) @ Vah
    with np.errstate(divide="ignore"):
        cond_w = np.max(np.where(sa[..., -1] > tol[..., 0], sa[..., 0] / sa[..., -1], np.inf), axis=1)
    Ys = H0 + null @ np.swapaxes(g, 1, 2)
    Cs = L.loads[L.n][None] - L.dynamic_stiffness_times(L.n, allk, w2, Ys)
    return WeightedEstimate(Ys, Cs, null, cov, np.sum(np.abs(res) ** 2, axis=(1, 2)), cond_w)


def _merge(a: np.ndarray, b: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Lines of ``a`` where ``second`` is False and of ``b`` where it is True, in line order."""
    out = np.empty((second.size,) + a.shape[1:], np.result_type(a, b))
    out[~second], out[second] = a, b
    return out
