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

**Many joint DOFs: the Kronecker path.** The design above is ``|m||e| x p`` per
line (``p = n(n+1)/2``): for four 6-DOF mounts (n = 24, p = 300) and 48 x 36
FRFs that is 8 MB per line, 17 GB for 2000 lines, and its covariance ``p x p``
per line another 2.9 GB. When the exact path's arrays would exceed
:data:`DENSE_PATH_BYTES` (see :func:`uses_kronecker`), :func:`coupling_per_line`
takes a two-sided least-squares path that never forms them. The weights are
approximated as *separable* per line, ``1 / var(H[r,c]) ~ wr[r] wc[c]``, from the
two-way means of ``log var`` (``log wr[r] = -mean_c log var[r,c]``,
``log wc[c] = -mean_r log var[r,c] + mean_rc log var``; exact when the variance
is a row profile times a column profile, e.g. a noise level per sensor and a force
spectrum per hit). With ``A = Wr^(1/2) Y[m,n]`` (m x n), ``B = Y[n,e] Wc^(1/2)``
(n x e) and ``C_w = Wr^(1/2) (Y[m,e] - H) Wc^(1/2)`` the weighted problem
``min || C_w - A X B ||_F`` is solved by two small pseudo-inverses::

    X_u = A^+ C_w B^+                      (SVD of A and B: n x n work per line)

Its covariance is a Kronecker product, ``E[dX_ab conj(dX_cd)] = s^2 Gr[a,c] Gc[b,d]``
with ``Gr = (A^H A)^-1`` and ``Gc = conj((B B^H)^-1)``. The symmetric constraint is
imposed *optimally* (the constrained weighted fit, not the plain projection
``(X_u + X_u^T)/2``, which ignores that the two entries of a pair have different
variances and is markedly less accurate) in the
basis that decorrelates it: with ``Gc = Lc Lc^H`` (Cholesky, after a symmetric
diagonal equilibration) and ``Lc^-1 Gr Lc^-H = W diag(mu) W^H``, ``U = Lc W`` gives
``Gr = U diag(mu) U^H`` and ``Gc = U U^H``, so ``Z = U^-1 X_u U^-T`` has independent
entries, ``var Z_kl = s^2 mu_k``, and ``X = X^T`` iff ``Z = Z^T``. The
minimum-variance symmetric ``Z`` combines each pair by inverse variance::

    Z_kl = (mu_l Z_u,kl + mu_k Z_u,lk) / (mu_k + mu_l),   var = s^2 v_kl,  v_kl = mu_k mu_l / (mu_k + mu_l)
    X = U Z U^T = X_p + U (Z_a,kl (mu_l - mu_k) / (mu_k + mu_l)) U^T

with ``X_p = (X_u + X_u^T) / 2`` and ``Z_a = U^-1 X_a U^-T`` of the antisymmetric part
``X_a = (X_u - X_u^T) / 2``: computed so, the round-off of the basis change touches
only ``X_a`` (zero for exact data), not all of X. The diagonal keeps ``Z_kk``, var
``mu_k = 2 v_kk``. The variance of each ``Du`` term follows without any p x p array: with ``L = I + Du Y[n,n]``, ``R = I + Y[n,n] Du``
(``dDu = L dX R``), ``Lt = L U`` and ``Rt = U^T R``::

    E|dDu_ij|^2 = s^2 [ sum_kl v_kl |Lt_ik|^2 |Rt_lj|^2 + Re sum_kl v_kl a_ikj conj(a_ilj) ],   a_ikj = Lt_ik conj(Rt_kj)

(n^4 per line, chunked over lines; without symmetry
``s^2 (sum_k mu_k |Lt_ik|^2) (sum_l |Rt_lj|^2)``). Only ``U`` and ``mu`` (n x n and n per
line) are kept for :func:`relinearize`. Exact data stay exact on this path (a
symmetric ``X_u`` has a symmetric ``Z``). The price of the approximation is
only in the weights, the separable part of ``1 / var``: the estimate is
unbiased; with separable variances it *is* the exact path's constrained
weighted fit, estimate and variance (to 1e-11, tests/test_coupling_kronecker.py);
otherwise its variance is computed as if the separable weights were the true
ones, which misstates it somewhat, and the estimate is a little less accurate than
the exact path's with the true weights. ``benchmarks/large_model.py`` prints both paths'
rms error (of ``sqrt|Du_ii Du_jj|``) and rms of error / predicted std (~1 when the
variance is right) on noisy lines where both run.
The column force-calibration estimate needs the full design and is not
available on this path. ``condition`` is that of the unconstrained
column-equilibrated design, ``cond(A Da) cond(Db B)``. Memory: n x n arrays per
line instead of the exact path's ``|m||e| x p`` design; ``benchmarks/large_model.py``
prints the time and peak memory of both paths.

Caveats: the linearization holds while the predicted relative error of a term
is small (say < 30 %); ``Du`` is an inverse of ``X^-1 - Y[n,n]``, so a term far
beyond the structure's own stiffness at n (identifiability ratio >> 1) is
poorly determined, and so is one far below it (the rotational term of a soft
joint: ratio ~1e-3). The FE model's error is not in the covariance.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass

import numpy as np

from ...parallel import map_lines
from ..moving_average import moving_average

__all__ = [
    "LineEstimates", "coupling_per_line", "symmetric_parametrization", "relinearize", "uses_kronecker", "DENSE_PATH_BYTES",
    "separable_weights", "kronecker_basis", "kronecker_variance", "whitened_line_design", "inverse_perturbation",
    "MAX_INVERSE_PERTURBATION", "DESIGN_VARIANCE_RTOL", "same_inputs",
]

#: The exact per-line path is taken while its arrays (the design, its weighted and Q copies, the p x p
#: covariance and Jacobian per line) fit in this many bytes; above it, the Kronecker path.
DENSE_PATH_BYTES = 1_000_000_000


def uses_kronecker(lines: int, m: int, e: int, n: int, symmetric: bool = True) -> bool:
    """True when :func:`coupling_per_line` takes the Kronecker path for this size.

    The exact path needs about ``16 F (|m||e| (n^2 + 3 p) + 3 p^2 + n^2 p)`` bytes
    (``p = n(n+1)/2`` if symmetric, else ``n^2``); above :data:`DENSE_PATH_BYTES`
    the two-sided least-squares path is used (see the module docstring).
    """
    p = n * (n + 1) // 2 if symmetric else n * n
    need = 16.0 * lines * (m * e * (n * n + 3 * p) + 3 * p * p + n * n * p)
    return need > DENSE_PATH_BYTES


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
        :func:`relinearize` needs. ``x_covariance`` is None on the Kronecker path.
    x_basis, x_basis_variance : ndarray, shapes (F, n, n) complex and (F, n), optional
        Kronecker path only: ``U`` and ``scale * mu`` (module docstring), the
        decorrelating basis of X and the variances of its coordinates.
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
    x_basis: np.ndarray | None = None
    x_basis_variance: np.ndarray | None = None

    @property
    def kronecker(self) -> bool:
        """The estimates come from the Kronecker (two-sided least-squares) path."""
        return self.x_basis is not None


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
    path: str = "auto",
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
        lines (:class:`~jointid.methods.receptance.column_calibration.ColumnCalibration`), propagated
        to ``common_variance`` (exact path only).
    path : {"auto", "exact", "kronecker"}
        The exact per-line weighted fit, or the two-sided least squares with separable
        weights (module docstring); "auto": :func:`uses_kronecker`.
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    if path not in ("auto", "exact", "kronecker"):
        raise ValueError(f"path must be 'auto', 'exact' or 'kronecker', got {path!r}")
    if path == "kronecker" or (path == "auto" and uses_kronecker(F, m, e, n, symmetric)):
        if common_x_covariance is not None:
            raise ValueError("the Kronecker path takes no common_x_covariance (column calibration needs the exact path)")
        return _kronecker_per_line(Ymn, Yne, Ynn, change, variance, symmetric, pool_lines)
    P = symmetric_parametrization(n, symmetric)
    p = P.shape[1]
    sw, cs, Q, R = whitened_line_design(Ymn, Yne, variance, symmetric)
    # independent lines: on the cores (jointid.parallel.map_lines); the residual scale pools lines, so it comes between
    xs, rss, cond, Ri = map_lines(_solve_lines, change.reshape(F, m * e) * sw, Q, R)
    dof = m * e - p
    scale = _pooled_scale(rss, dof, pool_lines)
    x = xs / cs
    C = (Ri @ np.conj(np.swapaxes(Ri, 1, 2))) / (cs[:, :, None] * cs[:, None, :])  # cov(x) / s^2
    if common_x_covariance is None:
        Du, V = map_lines(lambda x_, C_, Y_: _stiffness_lines(x_, C_, Y_, P, n), x, C, Ynn)
        common = np.zeros_like(V)
    else:
        Du, V, common = map_lines(lambda x_, C_, Y_, G_: _stiffness_lines(x_, C_, Y_, P, n, G_), x, C, Ynn, common_x_covariance)
    V = V * scale[:, None, None]
    return LineEstimates(Du, V, scale, cond, dof, common, x, C * scale[:, None, None], common_x_covariance, Ynn, symmetric)


def _solve_lines(dw: np.ndarray, Q: np.ndarray, R: np.ndarray):
    """:func:`coupling_per_line`'s least squares on some lines: ``(R^-1 Q^H dw, |(I - Q Q^H) dw|^2, cond R, R^-1)``."""
    F, p = R.shape[0], R.shape[2]
    qd = np.conj(np.einsum("fji,fj->fi", Q, np.conj(dw)))  # Q^H dw without a conjugated copy of Q
    Ri = np.linalg.solve(R, np.broadcast_to(np.eye(p), (F, p, p)))  # R^-1: p x p per line
    xs = np.einsum("fij,fj->fi", Ri, qd)
    resid = dw - np.einsum("fij,fj->fi", Q, qd)  # (I - Q Q^H) dw
    sv = np.linalg.svd(R, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = sv[:, 0] / sv[:, -1]
    return xs, np.sum(np.abs(resid) ** 2, axis=1), cond, Ri


def _stiffness_lines(x: np.ndarray, C: np.ndarray, Ynn: np.ndarray, P: np.ndarray, n: int, common_x_covariance=None):
    """``Du = (X^-1 - Ynn)^-1`` on some lines and the variance of each term (unit scale; with the common error's)."""
    F = x.shape[0]
    X = (x @ P.T).reshape(F, n, n)
    I = np.eye(n)
    Du = np.linalg.solve(I[None] - X @ Ynn, X)  # (X^-1 - Ynn)^-1
    L = I[None] + Du @ Ynn
    Rr = I[None] + Ynn @ Du
    J = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ P  # d vec(Du) / d x
    V = np.real(np.einsum("fab,fbc,fac->fa", J, C, J.conj())).reshape(F, n, n)
    if common_x_covariance is None:
        return Du, V
    return Du, V, np.real(np.einsum("fab,fbc,fac->fa", J, common_x_covariance, J.conj())).reshape(F, n, n)


def whitened_line_design(Ymn: np.ndarray, Yne: np.ndarray, variance: np.ndarray, symmetric: bool = True, keep: bool = True):
    """The weighted, column-equilibrated per-line design of the coupling parameters, factored.

    Row ``(r, c)`` of ``A`` is ``vec`` of ``Y[m,n] X Y[n,e]`` at ``(r, c)`` in the parameters ``x``
    (upper triangle of X if ``symmetric``); rows are weighted by ``sw = 1 / sqrt(variance)`` and
    columns scaled to unit norm by ``cs``.

    One identification asks for the same design several times (the junk-line test, the column
    calibration, the per-line fit and the model check weight the lines alike): the last one
    computed in this thread is kept with a copy of its inputs and returned again (read-only
    arrays) for the same ``Ymn``, ``Yne`` and ``symmetric`` and a variance within
    :data:`DESIGN_VARIANCE_RTOL` (relative) of its own: weights ``sw`` within ``2 eps`` of the
    ones asked for, about the rounding of ``1 / sqrt(variance)`` itself (the variances of one
    identification are the same numbers computed in different orders, 1 ulp apart). ``keep=False``
    (the noise-model choice's designs of a subset of the lines, asked for between the junk-line
    test and the calibration, and never again) computes a design without replacing the kept one.

    Returns
    -------
    sw : ndarray, shape (F, m e)
    cs : ndarray, shape (F, p)
    Q, R : ndarray, shapes (F, m e, p), (F, p, p), complex
        ``Q R = diag(sw) A diag(1 / cs)`` per line.
    """
    inputs = (np.asarray(Ymn), np.asarray(Yne), np.asarray(variance))
    last = getattr(_LAST_DESIGN, "entry", None)
    if last is not None and last[1] == bool(symmetric) and same_inputs(inputs, last[0], DESIGN_VARIANCE_RTOL):
        return last[2]
    out = _line_design(*inputs, bool(symmetric))
    for a in out:
        a.flags.writeable = False
    if keep:
        _LAST_DESIGN.entry = (tuple(a.copy() for a in inputs), bool(symmetric), out)
    return out


#: The last design of :func:`whitened_line_design` in each thread: (inputs, symmetric, outputs).
_LAST_DESIGN = threading.local()


#: A design is reused for a variance within this relative distance of its own (:func:`whitened_line_design`).
DESIGN_VARIANCE_RTOL = 4.0 * np.finfo(float).eps


def same_inputs(inputs: tuple, kept: tuple, rtol: float) -> bool:
    """Whether arrays ``inputs`` are those of a kept result: every one but the last of the same shape, dtype and
    values, the last (a variance) within ``rtol`` of its own (``|a - b| <= rtol |b|``); a NaN never matches.
    The rule of the per-thread caches of :func:`whitened_line_design` and
    :func:`~.model_check.residual_statistics`."""
    if len(inputs) != len(kept) or any(a.shape != b.shape or a.dtype != b.dtype for a, b in zip(inputs, kept)):
        return False
    if not all(np.array_equal(a, b) for a, b in zip(inputs[:-1], kept[:-1])):
        return False
    with np.errstate(invalid="ignore"):
        return bool(np.all(np.abs(inputs[-1] - kept[-1]) <= rtol * np.abs(kept[-1])))


def _line_design(Ymn: np.ndarray, Yne: np.ndarray, variance: np.ndarray, symmetric: bool):
    """:func:`whitened_line_design`'s computation (independent lines: on the cores, :func:`~jointid.parallel.map_lines`)."""
    return map_lines(lambda a, b, v: _design_of_lines(a, b, v, symmetric), Ymn, Yne, variance)


def _design_of_lines(Ymn: np.ndarray, Yne: np.ndarray, variance: np.ndarray, symmetric: bool):
    """:func:`_line_design` on some lines."""
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    i, k = _parameter_pairs(n, symmetric)
    # vec over (row r, column c) of Y[m,n] X Y[n,e]: sum_ik Ymn[r,i] X[i,k] Yne[k,c]; parameter (i, k) of the
    # upper triangle stands for X[i,k] and X[k,i]: column Ymn[r,i] Yne[k,c] + Ymn[r,k] Yne[i,c] (i < k)
    Aw = np.empty((F, m, e, i.size), complex)
    np.multiply(Ymn[:, :, None, i], np.swapaxes(Yne[:, k, :], 1, 2)[:, None, :, :], out=Aw)  # (F, m, e, p)
    off = np.flatnonzero(i != k) if symmetric else np.zeros(0, int)
    if off.size:
        Aw[..., off] += Ymn[:, :, None, k[off]] * np.swapaxes(Yne[:, i[off], :], 1, 2)[:, None, :, :]
    Aw = Aw.reshape(F, m * e, i.size)
    sw = 1.0 / np.sqrt(variance.reshape(F, m * e))
    Aw *= sw[:, :, None]
    parts = Aw.view(float).reshape(F, m * e, i.size, 2)  # real and imaginary parts
    cs = np.sqrt(np.einsum("frqt,frqt->fq", parts, parts))  # column equilibration: the 2-norm of each column
    cs = np.where(cs > 0, cs, 1.0)
    Aw /= cs[:, None, :]
    Q, R = np.linalg.qr(Aw)
    return sw, cs, Q, R


def _parameter_pairs(n: int, symmetric: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(i, k)`` of each coupling parameter, the columns of :func:`symmetric_parametrization`:
    the upper triangle (row-major) if ``symmetric``, else every ``(i, k)`` row-major."""
    if symmetric:
        return np.triu_indices(n)
    return np.repeat(np.arange(n), n), np.tile(np.arange(n), n)


def _pooled_scale(chi2: np.ndarray, dof: int, pool_lines: int | None) -> np.ndarray:
    """Residual variance factor per line: chi^2 per degree of freedom, running mean over ``pool_lines``."""
    F = chi2.size
    if dof <= 0:
        return np.full(F, np.nan)
    w = pool_lines or (max(1, F // 40) | 1)
    return moving_average(chi2 / dof, min(w, F))


def separable_weights(variance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column weights ``(wr (F, m), wc (F, e))`` with ``1 / var[f,r,c] ~ wr[f,r] wc[f,c]``.

    Two-way additive fit of ``-log var`` per line (row means + column means - grand mean):
    exact for a separable variance, otherwise its least-squares separable part in log.
    """
    lv = np.log(np.maximum(variance, np.finfo(float).tiny))
    rows = lv.mean(axis=2)
    cols = lv.mean(axis=1) - lv.mean(axis=(1, 2))[:, None]
    return np.exp(-rows), np.exp(-cols)


def _pinv_factors(A: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched pseudo-inverse of A (full column rank for side "left", full row rank for "right").

    Returns ``(A^+, G, cond)`` with ``G = (A^H A)^-1`` (left) or ``(A A^H)^-1`` (right),
    both from the SVD of the equilibrated A (columns, resp. rows, scaled to unit norm),
    and the equilibrated condition number.
    """
    axis = 1 if side == "left" else 2
    d = np.linalg.norm(A, axis=axis)  # (F, n)
    d = np.where(d > 0, d, 1.0)
    As = A / (d[:, None, :] if side == "left" else d[:, :, None])
    U, sv, Vh = np.linalg.svd(As, full_matrices=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = sv[:, 0] / sv[:, -1]
        inv = 1.0 / sv
    if side == "left":  # As = U S Vh, A = As D: A^+ = D^-1 Vh^H S^-1 U^H, (A^H A)^-1 = D^-1 Vh^H S^-2 Vh D^-1
        V = np.conj(np.swapaxes(Vh, 1, 2)) / d[:, :, None]
        pinv = (V * inv[:, None, :]) @ np.conj(np.swapaxes(U, 1, 2))
        G = (V * inv[:, None, :] ** 2) @ np.conj(np.swapaxes(V, 1, 2))
    else:  # As = D^-1 A = U S Vh: A^+ = Vh^H S^-1 U^H D^-1, (A A^H)^-1 = D^-1 U S^-2 U^H D^-1
        Ud = U / d[:, :, None]
        pinv = (np.conj(np.swapaxes(Vh, 1, 2)) * inv[:, None, :]) @ np.conj(np.swapaxes(Ud, 1, 2))
        G = (Ud * inv[:, None, :] ** 2) @ np.conj(np.swapaxes(Ud, 1, 2))
    return pinv, G, cond


def kronecker_basis(Gr: np.ndarray, Gc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(U, mu)`` with ``Gr = U diag(mu) U^H`` and ``Gc = U U^H``; shapes (F, n, n), (F, n).

    Both are Hermitian positive definite; a symmetric diagonal equilibration
    ``D = (diag Gr diag Gc)^(1/4)`` (units of rotations vs translations) comes first.
    """
    d = (np.real(np.diagonal(Gr, axis1=1, axis2=2)) * np.real(np.diagonal(Gc, axis1=1, axis2=2))) ** 0.25
    d = np.where(d > 0, d, 1.0)
    outer = d[:, :, None] * d[:, None, :]
    Lc = np.linalg.cholesky(Gc / outer)
    Li = np.linalg.inv(Lc)
    C = Li @ (Gr / outer) @ np.conj(np.swapaxes(Li, 1, 2))
    mu, W = np.linalg.eigh(0.5 * (C + np.conj(np.swapaxes(C, 1, 2))))
    return d[:, :, None] * (Lc @ W), mu


def kronecker_variance(L: np.ndarray, Rr: np.ndarray, U: np.ndarray, mu: np.ndarray, symmetric: bool, chunk: int = 128) -> np.ndarray:
    """``E|dDu_ij|^2`` for ``dDu = L dX R`` with X in the basis ``(U, mu)``; shape (F, n, n).

    The equation is in the module docstring: n^4 work per line, in chunks of ``chunk`` lines
    (memory ``48 chunk n^3`` bytes), no p x p array.
    """
    F, n, _ = L.shape
    out = np.empty((F, n, n))
    for s in range(0, F, chunk):
        Lt = L[s:s + chunk] @ U[s:s + chunk]
        Rt = np.swapaxes(U[s:s + chunk], 1, 2) @ Rr[s:s + chunk]
        m = mu[s:s + chunk]
        L2, R2 = np.abs(Lt) ** 2, np.abs(Rt) ** 2
        if not symmetric:
            out[s:s + chunk] = np.einsum("fik,fk->fi", L2, m)[:, :, None] * R2.sum(axis=1)[:, None, :]
            continue
        v = m[:, :, None] * m[:, None, :] / (m[:, :, None] + m[:, None, :])  # (f, k, l)
        a = Lt[:, :, :, None] * np.conj(Rt)[:, None, :, :]  # a[f, i, k, j]
        va = v[:, None, :, :] @ a  # sum_l v_kl a_ilj
        out[s:s + chunk] = (L2 @ v @ R2) + np.real(np.sum(a * np.conj(va), axis=2))
    return out


def _kronecker_per_line(Ymn, Yne, Ynn, change, variance, symmetric, pool_lines) -> LineEstimates:
    """The Kronecker path of :func:`coupling_per_line` (module docstring): n x n work per line."""
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    wr, wc = separable_weights(variance)
    sr, sc = np.sqrt(wr), np.sqrt(wc)
    A = Ymn * sr[:, :, None]
    B = Yne * sc[:, None, :]
    Cw = change * sr[:, :, None] * sc[:, None, :]
    Ap, Gr, cond_a = _pinv_factors(A, "left")
    Bp, Gb, cond_b = _pinv_factors(B, "right")
    X = Ap @ Cw @ Bp
    U, mu = kronecker_basis(Gr, np.conj(Gb))
    if symmetric:  # X_p + U (Z_a (mu_l - mu_k) / (mu_k + mu_l)) U^T: only the antisymmetric part X_a goes through U
        Xa = 0.5 * (X - np.swapaxes(X, 1, 2))
        Za = np.swapaxes(np.linalg.solve(U, np.swapaxes(np.linalg.solve(U, Xa), 1, 2)), 1, 2)  # U^-1 X_a U^-T
        Za = Za * (mu[:, None, :] - mu[:, :, None]) / (mu[:, :, None] + mu[:, None, :])
        X = (X - Xa) + U @ Za @ np.swapaxes(U, 1, 2)
    resid = Cw - A @ X @ B
    p = n * (n + 1) // 2 if symmetric else n * n
    dof = m * e - p
    scale = _pooled_scale(np.sum(np.abs(resid) ** 2, axis=(1, 2)), dof, pool_lines)
    I = np.eye(n)
    Du = np.linalg.solve(I[None] - X @ Ynn, X)
    mu_s = mu * scale[:, None]
    V = kronecker_variance(I[None] + Du @ Ynn, I[None] + Ynn @ Du, U, mu_s, symmetric)
    iu = np.triu_indices(n) if symmetric else (np.repeat(np.arange(n), n), np.tile(np.arange(n), n))
    return LineEstimates(Du, V, scale, cond_a * cond_b, dof, np.zeros_like(V), X[:, iu[0], iu[1]], None, None, Ynn, symmetric, U, mu_s)


#: Largest :func:`inverse_perturbation` of a line whose linearized per-line variance is trusted: one standard deviation
#: of X then moves the inverted matrix by less than half of itself (rms over its entries, relative). Beyond it the
#: per-line Du is biased and heavy-tailed (on a 6-DOF mount, lines above 1 had errors of 5-20 linearized standard
#: deviations). Measured at the noisy estimate, it also dips below 1 by chance where it is not well below: a 3-D
#: frame's 6-DOF mount (9 x 9 FRFs, 1 % noise, 8 seeds) kept 185 diagonal term-lines at 0.69-0.96, 39 of them beyond
#: 3 sigma (K_rx_rx 526 % off, predicted 9 %); at 0.5 none. The benchmark beam (0.5 % and 2 % noise, its eta's median
#: 0.01-0.05): K_theta_theta reliable on 12.3 % of lines instead of 13.2 %, K_w_w unchanged.
MAX_INVERSE_PERTURBATION = 0.5


def inverse_perturbation(lines: LineEstimates, chunk: int = 1024) -> np.ndarray | None:
    """How far one standard deviation of X moves the inverse that gives Du, per line: ``sqrt(E||L dX Y[n,n]||_F^2)``.

    ``Du = (I - X Y[n,n])^-1 X`` and ``(I - X Y[n,n])^-1 = L = I + Du Y[n,n]``: a change ``dX`` perturbs the
    inverted matrix by ``L dX Y[n,n]`` relative to it. With ``M = A dx``, ``A = (L (x) Y[n,n]^T) P`` (row-major
    vec, ``P`` the parametrization), ``E||M||_F^2 = tr(A^H A C)`` and ``A^H A = P^T ((L^H L) (x) (conj(Y) Y^T)) P``,
    ``C`` the covariance of x. The first-order (linearized) variance of Du holds while this is well below 1 and
    fails beyond it (a layout that does not see some of the joint's directions makes it >> 1 while the linearized
    std of those terms, evaluated at the noisy estimate, can be small). Returns shape (F,), inf where the estimate
    is not finite; None on the Kronecker path (no per-line covariance of x).
    """
    if lines.x_covariance is None or lines.Ynn is None:
        return None
    F, n, _ = lines.stiffness.shape
    P = symmetric_parametrization(n, lines.symmetric)
    out = np.full(F, np.inf)
    for a in range(0, F, chunk):
        b = min(a + chunk, F)
        with np.errstate(invalid="ignore", over="ignore"):
            L = np.eye(n)[None] + lines.stiffness[a:b] @ lines.Ynn[a:b]
            LL = np.conj(np.swapaxes(L, 1, 2)) @ L
            YY = np.conj(lines.Ynn[a:b]) @ np.swapaxes(lines.Ynn[a:b], 1, 2)
            W = np.einsum("fij,fkl->fikjl", LL, YY).reshape(b - a, n * n, n * n)  # (L^H L) kron (conj(Y) Y^T)
            G = P.T @ W @ P
            e2 = np.real(np.einsum("fab,fba->f", G, lines.x_covariance[a:b]))
        ok = np.isfinite(e2)
        out[a:b][ok] = np.sqrt(np.maximum(e2[ok], 0.0))
    return out


def relinearize(lines: LineEstimates, around: np.ndarray) -> LineEstimates:
    """Per-line estimates of Du linearized around a smooth estimate instead of at each noisy line.

    ``Du = (X^-1 - Y[n,n])^-1`` is nonlinear in the estimated X: where a line's
    relative error is large (the rotational term of a soft joint, whose per-line
    error can exceed the term itself) the per-line ``Du`` is biased and heavy-tailed, and its
    variance, linearized at the noisy estimate itself, is wrong. Around a
    smooth estimate ``D0`` (close to the truth after smoothing), one
    Gauss-Newton step gives pseudo-observations that are linear in the FRF
    errors::

        Du_f = D0 + (I + D0 Y[n,n]) (X^_f - X(D0)) (I + Y[n,n] D0),   X(D0) = (I + D0 Y[n,n])^-1 D0

    with their variance propagated through the same Jacobian evaluated at ``D0``
    (on the Kronecker path by :func:`kronecker_variance` with ``L`` and ``R`` at ``D0``:
    n^4 work per line in chunks of lines, no ``(F, p, p)`` or ``(F, n^2, p)`` array).
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
    if lines.kronecker:  # no p x p arrays: the Kronecker factors (row factor scaled)
        V = kronecker_variance(L, Rr, lines.x_basis, lines.x_basis_variance, lines.symmetric)
        return dataclasses.replace(lines, stiffness=Du, variance=V, common_variance=np.zeros_like(V))
    J = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ P
    V = np.real(np.einsum("fab,fbc,fac->fa", J, lines.x_covariance, J.conj())).reshape(F, n, n)
    common = np.zeros_like(V)
    if lines.common_x_covariance is not None:
        common = np.real(np.einsum("fab,fbc,fac->fa", J, lines.common_x_covariance, J.conj())).reshape(F, n, n)
    return dataclasses.replace(lines, stiffness=Du, variance=V, common_variance=common)
