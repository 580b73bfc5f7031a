"""FRF synthesis from an FE model: batched direct solve or modal superposition.

Receptance ``H(w) = D(w)^-1`` with ``D(w) = K* + sum_j K_j(f) - w^2 M``
(see :mod:`jointid.physics.structure`), restricted to the requested response
rows and reference columns.

Two paths, chosen by ``method="auto"`` and overridable:

``"direct"``
    Solves ``D(w) X = E`` for the reference columns E only. Models up to
    :data:`DENSE_DIRECT_LIMIT` DOFs: one batched LAPACK ``gesv`` over frequency
    (in chunks that bound memory). Larger models: a sparse LU per line
    (``scipy.sparse.linalg.splu``) -- the one place a loop over lines remains,
    because a batched dense factorization of a 4000-DOF model per line would
    need 256 MB a line.
    Exact for any damping and any frequency-dependent joint.
``"modal"``
    ``H = Phi diag(1 / (w_r^2 (1 + j eta) - w^2)) Phi^T`` with real
    mass-normalized modes. Exact (to rounding) when damping is proportional
    (``Im K = eta Re K``) and there are no frequency-dependent joints. With
    every mode present (models up to
    :data:`~jointid.physics.modes.DENSE_EIGEN_LIMIT` DOFs) it equals the direct
    result to ~1e-10. Larger models keep the modes below
    ``cutoff_factor * f_max`` and add the truncated modes' residual flexibility
    evaluated at a negative shift ``s0 = -sigma``:
    ``R = [(K* + sigma M)^-1]_rc - sum_kept phi phi^T / (w_r^2 (1 + j eta) + sigma)``;
    its relative error is of order ``(f_max / f_cut)^2`` of the truncated part.

``"auto"`` picks ``"modal"`` whenever it is exact (or, for large models,
residual-compensated) and ``"direct"`` otherwise.

At 0 Hz a structure with rigid-body modes (free-free) has a singular ``D``:
its receptance is undefined there and :class:`~jointid.errors.FrequencyError`
is raised.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import FrequencyError, ModelError
from ..frequency import Frequency
from ..frf import FRF, kind_factor
from ..dofs import parse_dofs
from .modes import Modes, natural_modes
from .structure import Structure

__all__ = ["synthesize_frf", "receptance_direct", "receptance_modal", "DENSE_DIRECT_LIMIT", "choose_method"]

#: Largest model (DOFs) solved by dense batched LAPACK; larger ones use sparse LU per line.
DENSE_DIRECT_LIMIT = 600
_CHUNK_BYTES = 64 * 2**20


def _as_frequency(frequency) -> Frequency:
    return frequency if isinstance(frequency, Frequency) else Frequency(frequency)


def _check_zero_frequency(structure: Structure, frequency: Frequency) -> None:
    if frequency.hz[0] > 0.0:
        return
    D0 = structure.dynamic_stiffness(frequency.hz[:1])[0]
    n = D0.shape[0]
    if n <= 2000:
        s = np.linalg.svd(D0, compute_uv=False)
        singular = s[-1] <= 1e-12 * s[0]
    else:
        Ks = sp.csc_matrix(D0.real)
        Ms = sp.csc_matrix(structure.M)
        lam = spla.eigsh(Ks, k=1, M=Ms, sigma=-1.0, which="LM", return_eigenvectors=False)
        singular = abs(lam[0]) < 1e-6
    if singular:
        raise FrequencyError(
            "the receptance is undefined at 0 Hz: the structure has rigid-body modes "
            "(free-free or under-constrained), so its stiffness matrix is singular; "
            "start the frequency grid above 0 Hz"
        )


def choose_method(structure: Structure) -> str:
    """The synthesis path ``"auto"`` takes for ``structure``: ``"modal"`` or ``"direct"``."""
    if structure.joints or structure.proportional_loss_factor is None:
        return "direct"
    return "modal"


def receptance_direct(structure: Structure, frequency: Frequency, responses, references) -> np.ndarray:
    """Receptance by direct solution of ``D(w) X = E``, shape (F, r, c), complex (m/N, rad/N, ...).

    Parameters
    ----------
    structure : Structure
    frequency : Frequency
    responses, references : sequence of Dof
        Active DOFs of the structure.
    """
    frequency = _as_frequency(frequency)
    ri = structure.index(responses)
    ci = structure.index(references)
    n = len(structure.dofs)
    F = frequency.size
    out = np.empty((F, len(ri), len(ci)), dtype=complex)
    E = np.zeros((n, len(ci)))
    E[ci, np.arange(len(ci))] = 1.0
    # symmetric diagonal scaling (translations vs rotations differ by ~L^2) keeps the
    # solve accurate on fine meshes: D_s = S D S, X = S D_s^-1 S E
    scale = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(structure.K)), 1e-300))
    Es = E * scale[:, None]
    if n <= DENSE_DIRECT_LIMIT:
        chunk = max(1, _CHUNK_BYTES // (16 * n * n))
        S2 = scale[:, None] * scale[None, :]
        for a in range(0, F, chunk):  # chunks bound memory; each chunk is one batched LAPACK call
            D = structure.dynamic_stiffness(frequency.hz[a : a + chunk]) * S2[None]
            X = np.linalg.solve(D, np.broadcast_to(Es, (D.shape[0], n, len(ci))))
            out[a : a + chunk] = X[:, ri, :] * scale[ri][None, :, None]
        return out
    Sd = sp.diags(scale)
    K = sp.csc_matrix(structure.K)
    M = sp.csc_matrix(structure.M)
    joint_terms = structure.joint_terms(frequency.hz)
    w2 = frequency.omega**2
    for i in range(F):  # large sparse models: one sparse LU per line
        D = K - w2[i] * M
        for kj, idx in joint_terms:
            r, c = np.meshgrid(idx, idx, indexing="ij")
            D = D + sp.csc_matrix((kj[i].ravel(), (r.ravel(), c.ravel())), shape=(n, n))
        X = spla.splu(sp.csc_matrix(Sd @ D @ Sd)).solve(Es.astype(complex))
        out[i] = X[ri, :] * scale[ri][:, None]
    return out


def receptance_modal(
    structure: Structure,
    frequency: Frequency,
    responses,
    references,
    modes: Modes | None = None,
    cutoff_factor: float = 4.0,
) -> np.ndarray:
    """Receptance by modal superposition (proportional structural damping), shape (F, r, c).

    Parameters
    ----------
    structure : Structure
        No frequency-dependent joints; ``Im K = eta Re K``.
    frequency : Frequency
    responses, references : sequence of Dof
    modes : Modes, optional
        Precomputed modes of ``structure`` (reused across calls).
    cutoff_factor : float
        Large models: keep modes below ``cutoff_factor * f_max`` plus residual flexibility.
    """
    frequency = _as_frequency(frequency)
    eta = structure.proportional_loss_factor
    if structure.joints or eta is None:
        raise ModelError(
            "modal superposition needs proportional structural damping and no frequency-dependent joints; "
            "use method='direct'"
        )
    fmax = float(frequency.hz[-1])
    if modes is None:
        modes = natural_modes(structure, max_frequency_hz=cutoff_factor * max(fmax, 1.0))
    ri = structure.index(responses)
    ci = structure.index(references)
    lam = modes.eigenvalues * (1.0 + 1j * eta)
    w2 = frequency.omega**2
    pr = modes.shapes[ri, :]
    pc = modes.shapes[ci, :]
    g = 1.0 / (lam[None, :] - w2[:, None])  # (F, modes)
    H = np.einsum("rk,fk,ck->frc", pr, g, pc, optimize=True)
    if not modes.complete:
        # shift to the first elastic eigenvalue: far enough from the rigid-body modes that
        # G - kept does not cancel catastrophically, low enough that the truncated modes'
        # flexibility 1 / (w_r^2 + sigma) is close to their 1 / (w_r^2 - w^2) in the band
        elastic = modes.eigenvalues[modes.eigenvalues > 0]
        sigma = float(elastic[0]) if elastic.size else (2.0 * np.pi * max(fmax, 1.0)) ** 2
        n = len(structure.dofs)
        scale = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(structure.K)), 1e-300))
        Sd = sp.diags(scale)
        E = np.zeros((n, len(ci)), dtype=complex)
        E[ci, np.arange(len(ci))] = scale[ci]
        Ks = sp.csc_matrix(Sd @ sp.csc_matrix(structure.K + sigma * structure.M) @ Sd)
        G = spla.splu(Ks).solve(E)[ri, :] * scale[ri][:, None]
        kept = np.einsum("rk,k,ck->rc", pr, 1.0 / (lam + sigma), pc)
        H = H + (G - kept)[None, :, :]
    return H


def synthesize_frf(
    structure: Structure,
    frequency,
    responses: Iterable,
    references: Iterable,
    kind: str = "receptance",
    method: str = "auto",
    modes: Modes | None = None,
) -> FRF:
    """FRFs of ``structure`` between labelled DOFs over a frequency grid.

    Parameters
    ----------
    structure : Structure
    frequency : Frequency or array_like (Hz), shape (F,)
    responses, references : iterable of Dof or labels (``"3w"``)
        Active DOFs; references are unit forces (N) or moments (N*m).
    kind : {"receptance", "mobility", "accelerance"}
    method : {"auto", "direct", "modal"}
        See the module docstring.
    modes : Modes, optional
        Precomputed modes for the modal path.

    Returns
    -------
    FRF
        Data shaped (F, r, c).

    Raises
    ------
    FrequencyError
        At 0 Hz for a structure with rigid-body modes.
    """
    frequency = _as_frequency(frequency)
    responses = parse_dofs(responses)
    references = parse_dofs(references)
    if method not in ("auto", "direct", "modal"):
        raise ModelError(f"unknown synthesis method {method!r}; expected 'auto', 'direct' or 'modal'")
    kind_factor(frequency.omega[-1:], "receptance", kind)  # validates the kind
    _check_zero_frequency(structure, frequency)
    if method == "auto":
        method = choose_method(structure)
    if method == "modal":
        H = receptance_modal(structure, frequency, responses, references, modes)
    else:
        H = receptance_direct(structure, frequency, responses, references)
    frf = FRF(frequency, H, responses, references, "receptance")
    return frf.to(kind)
