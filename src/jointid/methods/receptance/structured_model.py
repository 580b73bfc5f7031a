"""The structured joint model: the Craig-Bampton form of a joint made of one viscoelastic material.

A joint of one viscoelastic material (constant Poisson ratio, modulus ``E g(w)``),
condensed exactly to its boundary DOFs with its fixed-interface internal modes,
has the dynamic stiffness::

    Du(w) = g(w) [ A - s B - s^2 sum_r c_r c_r^T / (mu_r - s) ],      s = w^2 / g(w)
          = g A - w^2 B - w^4 sum_r c_r c_r^T / (g mu_r - w^2)   [ - w^4 E / g ]

with ``g(w)`` the material's normalized complex modulus (smooth in frequency),
``A`` the static (Guyan) stiffness, ``B`` the Guyan mass (rigid caps included),
``c_r`` the boundary-mass coupling of internal mode ``r`` and ``mu_r`` its
eigenvalue at the reference modulus (all real; ``A``, ``B`` symmetric). The
optional ``-w^4 E / g`` (``E`` real symmetric) is the first term of the truncated
modes' expansion. Every term of ``Du`` shares ``g`` and the internal poles, which
is what lets a poorly determined rotational term borrow the precision of the
translational one (:mod:`jointid.methods.receptance.structured_fit`).

Scaling: ``Du = S Du' S`` with ``S = diag(d)`` (:func:`default_scale`) and
``w' = f / f_ref``; the parameters are those of ``Du'`` with ``A'_00 = 1`` (the
scale is in ``g``). ``g`` is a complex constant (``g_basis = 1``) or a cubic
B-spline with ``g_basis >= 4`` complex coefficients over the band; ``mu_r = exp(nu_r)``.

Caveats: a joint of several materials, or whose modulus varies faster than the
knots of ``g``, is outside the class; :mod:`jointid.methods.receptance.structured_select`
tests the fit and falls back to per-term smoothing when it fails.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..bspline_basis import bspline_design, clamped_uniform_knots

__all__ = ["StructuredModel", "structured_stiffness", "structured_terms", "default_scale", "sym_basis", "unpack", "pack", "extend", "drop_last_mode"]


@dataclass(frozen=True)
class StructuredModel:
    """Order and scaling of the structured joint model.

    Parameters
    ----------
    n : int
        Joint DOFs.
    n_modes : int
        Internal (fixed-interface) modes kept.
    g_basis : int
        1: constant complex ``g``; >= 4: cubic B-spline coefficients of ``g`` over the band.
    residual : bool
        Add ``-w^4 E / g`` (truncated modes, first order).
    scale : tuple of float, length n
        ``d``: ``Du = diag(d) Du' diag(d)`` (square roots of the diagonal terms' units).
    f_ref : float
        Hz; ``w' = f / f_ref``.
    band : tuple of float
        Hz, the interval of the spline of ``g``.
    """

    n: int
    n_modes: int
    g_basis: int
    residual: bool
    scale: tuple
    f_ref: float
    band: tuple

    @property
    def p(self) -> int:
        """Independent entries of a symmetric n x n matrix."""
        return self.n * (self.n + 1) // 2

    @property
    def sizes(self) -> dict:
        """Number of real parameters per block, in the order of the parameter vector."""
        return {"A": self.p - 1, "B": self.p, "E": self.p if self.residual else 0, "modes": self.n_modes * (self.n + 1), "g": 2 * self.g_basis}

    @property
    def n_params(self) -> int:
        """Real parameters ``P``."""
        return sum(self.sizes.values())

    @property
    def order(self) -> tuple:
        """``(n_modes, g_basis, residual)``."""
        return (self.n_modes, self.g_basis, self.residual)

    @property
    def label(self) -> str:
        """E.g. ``"2 internal modes, constant modulus, +residual"``."""
        g = "constant modulus" if self.g_basis == 1 else f"modulus spline of {self.g_basis}"
        return f"{self.n_modes} internal mode{'s' if self.n_modes != 1 else ''}, {g}{', +residual' if self.residual else ''}"

    def with_order(self, n_modes: int, g_basis: int, residual: bool) -> "StructuredModel":
        """The same scaling and band with another order."""
        return StructuredModel(self.n, n_modes, g_basis, residual, self.scale, self.f_ref, self.band)

    def g_design(self, hz: np.ndarray) -> np.ndarray:
        """Basis of ``g``, shape (F, g_basis)."""
        if self.g_basis == 1:
            return np.ones((hz.size, 1))
        lo, hi = self.band
        u = np.clip((hz - lo) / (hi - lo), 0.0, 1.0)
        return bspline_design(u, clamped_uniform_knots(self.g_basis, 3), 3)


@lru_cache(maxsize=16)
def sym_basis(n: int) -> np.ndarray:
    """Symmetric unit matrices ``E_k`` (p, n, n) of the upper triangle (i <= j, row-major); read-only."""
    iu = np.triu_indices(n)
    E = np.zeros((iu[0].size, n, n))
    for k, (i, j) in enumerate(zip(*iu)):
        E[k, i, j] = E[k, j, i] = 1.0
    E.flags.writeable = False
    return E


def unpack(theta: np.ndarray, model: StructuredModel):
    """``(A, B, E, modes, gamma)``: A and B and E as upper-triangle vectors, modes (r, n + 1) = (c_r, nu_r), gamma complex."""
    n, s = model.n, model.sizes
    i = 0
    A = np.empty(s["A"] + 1)
    A[0] = 1.0
    A[1:] = theta[i:i + s["A"]]
    i += s["A"]
    B = theta[i:i + s["B"]]
    i += s["B"]
    E = theta[i:i + s["E"]]
    i += s["E"]
    modes = theta[i:i + s["modes"]].reshape(model.n_modes, n + 1)
    i += s["modes"]
    gam = theta[i:i + s["g"]].reshape(model.g_basis, 2)
    return A, B, E, modes, gam[:, 0] + 1j * gam[:, 1]


def pack(A, B, E, modes, gam) -> np.ndarray:
    """Inverse of :func:`unpack` (``A[0]`` is the fixed 1)."""
    gam = np.asarray(gam, complex)
    return np.r_[np.asarray(A, float)[1:], B, E, np.asarray(modes, float).ravel(), np.stack([gam.real, gam.imag], axis=-1).ravel()]


def structured_terms(theta: np.ndarray, hz: np.ndarray, model: StructuredModel, jacobian: bool = False, Gd: np.ndarray | None = None):
    """``Du'`` and its parameter derivatives in factored form: frequency functions times fixed real symmetric matrices.

    ``Du'(f) = sum_t coefs[t](f) mats[t]``. With ``jacobian``: ``dDu'/dtheta_k = jc[k](f) jm[k]`` for
    every parameter but the spline of ``g`` (the first ``P - 2 K`` columns, in parameter order) and
    ``dDu'/dg = dg(f)``, so ``dDu'/dgamma_j = b_j(f) dg`` (and ``i b_j(f) dg`` for its imaginary part).
    The fit (:mod:`jointid.methods.receptance.structured_fit`) maps each fixed matrix once per line instead of
    forming the dense ``(F, n, n, P)`` Jacobian of :func:`structured_stiffness`.

    Parameters
    ----------
    theta : ndarray, shape (P,)
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    model : StructuredModel
    jacobian : bool
    Gd : ndarray, shape (F, K), optional
        ``model.g_design(hz)``, when the caller holds it already.

    Returns
    -------
    coefs : ndarray, shape (T, F), complex
    mats : ndarray, shape (T, n, n)
    jac : tuple ``(jc (P - 2K, F) complex, jm (P - 2K, n, n), dg (F, n, n) complex, Gd (F, K))`` or None
    """
    n = model.n
    Eb = sym_basis(n)
    idx = _sym_index(n)
    A, B, E, modes, gam = unpack(theta, model)
    Gd = model.g_design(hz) if Gd is None else Gd
    g = Gd @ gam
    w2 = (hz / model.f_ref) ** 2
    w4 = w2 ** 2
    r = model.n_modes
    t = 2 + model.residual  # first mode's term
    T = t + r
    coefs = np.empty((T, hz.size), complex)  # Du' = sum coefs[t] mats[t]
    mats = np.empty((T, n, n))
    coefs[0], coefs[1] = g, -w2
    mats[0], mats[1] = A[idx], B[idx]
    if model.residual:
        coefs[2] = -w4 / g
        mats[2] = E[idx]
    c = modes[:, :n]  # (r, n)
    mu = np.exp(np.clip(modes[:, n], -50.0, 50.0))  # (r,)
    q = 1.0 / (g[None] * mu[:, None] - w2[None])  # (r, F)
    np.multiply(-w4[None], q, out=coefs[t:])
    np.multiply(c[:, :, None], c[:, None, :], out=mats[t:])
    if not jacobian:
        return coefs, mats, None
    # dDu'/dg = A + w'^4 E / g^2 + sum_r w'^4 mu_r q_r^2 C_r: terms (A, [E], C_r) = the terms but B
    keep = _DG_TERMS[T, model.residual]
    dgc = np.empty((T - 1, hz.size), complex)
    dgc[0] = 1.0
    if model.residual:
        dgc[1] = w4 / g ** 2
    dgc[t - 1:] = w4[None] * q ** 2 * mu[:, None]
    dg = (dgc.T @ mats[keep].reshape(T - 1, n * n)).reshape(hz.size, n, n)
    p = Eb.shape[0]
    J = model.n_params - 2 * model.g_basis
    jc = np.empty((J, hz.size), complex)
    jm = np.empty((J, n, n))
    jc[:p - 1], jm[:p - 1] = g, Eb[1:]
    jc[p - 1:2 * p - 1], jm[p - 1:2 * p - 1] = -w2, Eb
    k = 2 * p - 1
    if model.residual:
        jc[k:k + p], jm[k:k + p] = coefs[2], Eb
        k += p
    if r:  # per mode: c_r (n columns), then nu_r
        blocks = jc[k:].reshape(r, n + 1, hz.size)
        blocks[:, :n] = coefs[t:, None, :]
        blocks[:, n] = w4[None] * q ** 2 * g[None] * mu[:, None]
        mblocks = jm[k:].reshape(r, n + 1, n, n)
        ec = _eye(n)[None, :, :, None] * c[:, None, None, :]  # e_k c_r^T, (r, n, n, n)
        np.add(ec, ec.transpose(0, 1, 3, 2), out=mblocks[:, :n])
        mblocks[:, n] = mats[t:]
    return coefs, mats, (jc, jm, dg, Gd)


class _DGTerms(dict):
    """``(T, residual)`` -> indices of the terms but B (``mats[1]``), cached."""

    def __missing__(self, key):
        T, _ = key
        value = np.r_[0, np.arange(2, T)]
        value.flags.writeable = False
        self[key] = value
        return value


_DG_TERMS = _DGTerms()


@lru_cache(maxsize=16)
def _eye(n: int) -> np.ndarray:
    """The n x n identity; read-only."""
    e = np.eye(n)
    e.flags.writeable = False
    return e


@lru_cache(maxsize=16)
def _sym_index(n: int) -> np.ndarray:
    """``k`` of entry (i, j) in the upper-triangle vector of a symmetric n x n matrix (:func:`sym_basis` order); read-only."""
    idx = np.zeros((n, n), int)
    for k, (i, j) in enumerate(zip(*np.triu_indices(n))):
        idx[i, j] = idx[j, i] = k
    idx.flags.writeable = False
    return idx


def structured_stiffness(theta: np.ndarray, hz: np.ndarray, model: StructuredModel, jacobian: bool = False):
    """Scaled model stiffness ``Du'`` (F, n, n) and optionally ``dDu'/dtheta`` (F, n, n, P), complex.

    Every derivative is a frequency function times a fixed symmetric matrix
    (``dDu'/dA_k = g E_k``, ``dDu'/dB_k = -w'^2 E_k``, ``dDu'/dc_rk = h_r (e_k c_r^T + c_r e_k^T)``
    with ``h_r = -w'^4 / (g mu_r - w'^2)``, ``dDu'/dnu_r = w'^4 g mu_r c_r c_r^T / (g mu_r - w'^2)^2``),
    except the spline of ``g``: ``dDu'/dgamma_j = b_j(f) dDu'/dg`` (and ``i b_j`` for its imaginary part);
    :func:`structured_terms` gives these factors.

    Parameters
    ----------
    theta : ndarray, shape (P,)
        Real parameters (layout: :attr:`StructuredModel.sizes`).
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    model : StructuredModel
    jacobian : bool
    """
    n = model.n
    coefs, mats, jac = structured_terms(theta, hz, model, jacobian)
    D = (coefs.T @ mats.reshape(len(mats), n * n)).reshape(hz.size, n, n)
    if not jacobian:
        return D
    jc, jm, dg, Gd = jac
    nl = jc.shape[0]
    J = np.empty((hz.size, n, n, nl + 2 * model.g_basis), complex)  # written in place: no (F, n, n, P) temporaries
    np.multiply(jc.T[:, None, None, :], np.moveaxis(jm, 0, -1)[None], out=J[..., :nl])  # (F, n, n, P - 2K)
    np.multiply(dg[..., None], Gd[:, None, None, :], out=J[..., nl::2])  # dDu'/dRe gamma_j = b_j dg: (re_0, im_0, re_1, ...)
    np.multiply(J[..., nl::2], 1j, out=J[..., nl + 1::2])
    return D, J


def default_scale(Du: np.ndarray) -> tuple:
    """``d_i = sqrt(median |Du_ii|)`` of per-line estimates (robust to their heavy tails), shape (n,)."""
    with warnings.catch_warnings():  # an all-NaN term: scale 1
        warnings.simplefilter("ignore", RuntimeWarning)
        d = np.sqrt(np.nanmedian(np.abs(np.diagonal(Du, axis1=1, axis2=2)), axis=0))
    return tuple(float(v) if np.isfinite(v) and v > 0 else 1.0 for v in d)


def extend(theta: np.ndarray, old: StructuredModel, new: StructuredModel, mode=None) -> np.ndarray:
    """Parameters of ``old`` embedded in the larger ``new`` (more modes, residual, spline g); ``mode`` = (c, nu) of an added mode."""
    A, B, E, modes, gam = unpack(theta, old)
    E = (E if old.residual else np.zeros(new.p)) if new.residual else np.zeros(0)
    modes = list(modes)
    while len(modes) < new.n_modes:
        modes.append(mode if mode is not None else np.r_[np.zeros(new.n), 0.0])
    modes = modes[: new.n_modes]
    if new.g_basis != old.g_basis:
        x = np.linspace(*new.band, 200)
        gam = np.linalg.lstsq(new.g_design(x), old.g_design(x) @ gam, rcond=None)[0]
    return pack(A, B, E, modes, gam)


def drop_last_mode(theta: np.ndarray, model: StructuredModel) -> np.ndarray:
    """Parameters of ``model`` without its last internal mode."""
    A, B, E, modes, gam = unpack(theta, model)
    return pack(A, B, E, modes[:-1], gam)
