"""Bands of a structured joint fit: the parameters' covariance from the Jacobian, and each term's 1-sigma from it.

:func:`covariance_factor` factors ``(J^T J)^-1 = W W^T`` through the singular values of ``J`` (accurate to
``cond(J) eps``, not ``cond(J)^2 eps``) and names the directions the FRFs do not determine;
:func:`terms_moving_along` says which terms change along them (those have no band);
:func:`structured_bands` maps the factor to each term's real and imaginary 1-sigma per line
(linearized, from the factored derivatives of :func:`~.structured_model.structured_terms`) as the
norm of ``W^T g`` for each gradient ``g``: a sum of squares, never negative, and free of the
cancellation of ``g^T C g`` with ``C`` formed (which, for a gradient nearly orthogonal to a weak
direction, loses ``cond(J)^2 eps`` relative and can go below 0).
"""

from __future__ import annotations

import numpy as np

from .structured_model import StructuredModel, structured_stiffness, structured_terms

__all__ = ["covariance_factor", "parameter_covariance", "terms_moving_along", "structured_bands", "distinct_rows"]


def covariance_factor(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``W`` (P, r) with ``W W^T = (J^T J)^-1`` from the singular values of ``J`` (N, P), not from ``J^T J``; and the
    directions it leaves out.

    ``J = Q R``, ``R = U diag(s) V^T``: ``W = V diag(1 / s)``, accurate to about ``cond(J) eps`` per
    direction where inverting ``J^T J`` loses ``cond(J)^2 eps``. Directions below the numerical
    rank (``s <= s_max max(N, P) eps``) are left out (the pseudo-inverse): the FRFs determine nothing
    along them. On the benchmark beam the order with one internal mode, 4 modulus coefficients and
    no residual term has such a direction (``s_min / s_max`` 6e-17: the modulus spline trades against
    the mode, ``K`` constant along it to first order); through ``J^T J`` its bands, and the Akaike
    average's (weight 0.41 there), moved by up to 9 % when the FRFs changed by one rounding (1 + 2.2e-16).

    Returns
    -------
    factor : ndarray, shape (P, r)
        ``r`` kept directions scaled by ``1 / s``; all NaN (P, P) for a non-finite ``J`` (no band, as the fit's values).
    unseen : ndarray, shape (P, k)
        The left-out directions (orthonormal columns; k = 0 when ``J`` has full numerical rank).
    """
    P = J.shape[1]
    if P == 0:
        return np.zeros((0, 0)), np.zeros((0, 0))
    if not np.all(np.isfinite(J)):
        return np.full((P, P), np.nan), np.zeros((P, 0))
    R = np.linalg.qr(J, mode="r")  # (min(N, P), P)
    _, sv, Vt = np.linalg.svd(R)  # Vt (P, P); fewer rows than P: the missing singular values are 0
    s = np.zeros(P)
    s[:sv.size] = sv
    keep = s > s[0] * max(J.shape) * np.finfo(float).eps
    return Vt[keep].T / s[keep], Vt[~keep].T


def parameter_covariance(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(J^T J)^-1`` (P, P) as ``W W^T`` of :func:`covariance_factor`, and the directions it leaves out."""
    W, unseen = covariance_factor(J)
    return W @ W.T, unseen


def terms_moving_along(theta: np.ndarray, hz: np.ndarray, model: StructuredModel, directions: np.ndarray) -> np.ndarray:
    """Terms (n, n) of ``K`` that change to first order along ``directions`` (P, k) of the scaled parameters.

    Such a direction is one the FRFs do not see although the joint changes along it: the term is not
    determined, and its band is infinite (then :func:`~.structured_select.model_average` leaves the fit out).
    A change below 1e-6 of the term's largest value per unit step (the scaled parameters are O(1)) is none:
    the left-out directions of a mode traded against the modulus change ``K`` at second order only.
    """
    K, dK = structured_stiffness(theta, hz, model, jacobian=True)  # (F, n, n), (F, n, n, P)
    change = np.max(np.abs(dK @ directions), axis=(0, 3))
    size = np.max(np.abs(K), axis=0)
    return change > 1e-6 * np.where(size > 0, size, 1.0)


def structured_bands(theta, factor, hz, model: StructuredModel, undetermined: np.ndarray | None = None):
    """Stiffness (F, n, n) and the 1-sigma of its real and imaginary parts from the parameters' covariance factor
    ``factor`` (P, r), ``cov = factor factor^T`` (:func:`covariance_factor`; linearized).

    ``undetermined`` (bool, (n, n)), optional: terms that move along a direction the FRFs do not
    determine (:func:`terms_moving_along`); their bands are infinite.

    From the factored derivatives of :func:`structured_terms`: the gradient of term ``t`` (real or
    imaginary part) at line ``f`` is ``E_t z(f)``, with ``z(f)`` the few distinct frequency functions
    (the distinct rows of ``jc``, and ``b_l(f) dg_t(f)`` of the modulus) and ``E_t`` a fixed
    (P, d) map; so its variance is ``|(E_t^T W)^T z|^2``: a (d, r) product per line instead of a
    (P, P) form, no dense ``(F, n, n, P)`` Jacobian, and a sum of squares. Only the ``p`` independent terms.
    """
    n = model.n
    S = np.asarray(model.scale, float)
    SS = S[:, None] * S[None, :]
    coefs, mats, (jc, jm, dg, Gd) = structured_terms(theta, hz, model, jacobian=True)
    W = np.asarray(factor, float)
    F, P, nl, K = hz.size, W.shape[0], jc.shape[0], Gd.shape[1]
    D = (coefs.T @ (mats * SS).reshape(len(mats), n * n)).reshape(F, n, n)
    iu = np.triu_indices(n)
    p = iu[0].size
    funcs, which = distinct_rows(jc)  # the distinct frequency functions of the parameters
    d = funcs.shape[0]
    mj = (jm[:, iu[0], iu[1]] * SS[iu]).T  # (p, nl)
    b = (dg[:, iu[0], iu[1]] * SS[iu]).T[:, :, None] * Gd[None]  # (p, F, K): dDu/dRe gamma_l; i b for Im gamma_l
    var = np.empty((2, p, F))
    for part in (0, 1):
        z = np.empty((F, d + 2 * K))
        z[:, :d] = (funcs.real if part == 0 else funcs.imag).T
        for t in range(p):
            z[:, d:d + K], z[:, d + K:] = b[t].real, b[t].imag
            E, ks = np.zeros((P, d + 2 * K)), nl + 2 * np.arange(K)
            E[np.arange(nl), which] = mj[t]
            if part == 0:  # Re(b g_l): +Re b on Re gamma_l, -Im b on Im gamma_l
                E[ks, d + np.arange(K)], E[ks + 1, d + K + np.arange(K)] = 1.0, -1.0
            else:  # Im(b g_l): +Im b on Re gamma_l, +Re b on Im gamma_l
                E[ks, d + K + np.arange(K)], E[ks + 1, d + np.arange(K)] = 1.0, 1.0
            g = z @ (E.T @ W)  # (F, r): the gradient in the kept directions, scaled
            var[part, t] = np.einsum("fr,fr->f", g, g)
    std = np.sqrt(var)
    sr, si = np.empty((F, n, n)), np.empty((F, n, n))
    sr[:, iu[0], iu[1]] = sr[:, iu[1], iu[0]] = std[0].T
    si[:, iu[0], iu[1]] = si[:, iu[1], iu[0]] = std[1].T
    if undetermined is not None:
        sr, si = np.where(undetermined, np.inf, sr), np.where(undetermined, np.inf, si)
    return D, sr, si


def distinct_rows(a: np.ndarray) -> tuple:
    """``(rows, which)``: the distinct rows of ``a`` (bitwise equal ones merged; a loop over rows, not lines) and
    the index of each row of ``a`` among them, so ``rows[which] == a``."""
    reps, which, seen = [], np.empty(a.shape[0], int), {}
    for k, row in enumerate(a):
        for j in seen.get(key := row[:4].tobytes(), ()):
            if np.array_equal(a[reps[j]], row):
                which[k] = j
                break
        else:
            seen.setdefault(key, []).append(len(reps))
            which[k] = len(reps)
            reps.append(k)
    return a[reps], which
