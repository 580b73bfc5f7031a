"""Real normal modes of a structure: ``Re(K) phi = w^2 M phi``, mass-normalized."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..dofs import Dof
from ..errors import ModelError
from .structure import Structure

__all__ = ["Modes", "natural_modes", "DENSE_EIGEN_LIMIT"]

#: Above this many DOFs, modes come from a sparse shift-invert Lanczos solver (a subset).
DENSE_EIGEN_LIMIT = 1500
#: Eigenvalues below this fraction of the largest are rigid-body modes (set to exactly 0):
#: round-off puts them near 1e-17 lam_max, the lowest elastic mode of any sensible mesh above 1e-11.
_RIGID_TOL = 1e-14


@dataclass(frozen=True, eq=False)
class Modes:
    """Real modes of a structure.

    Parameters
    ----------
    eigenvalues : ndarray, shape (r,)
        ``w_r^2`` in (rad/s)^2 (rigid-body modes ~0, clipped at 0).
    shapes : ndarray, shape (n, r)
        Mass-normalized mode shapes (``Phi^T M Phi = I``) on ``dofs``.
    dofs : tuple of Dof
        Active DOFs of the structure (rows of ``shapes``).
    loss_factor : float or None
        Proportional structural loss factor (``Im K = eta Re K``) or None.
    complete : bool
        True if every mode of the model is present (modal synthesis is then exact).
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray
    dofs: tuple[Dof, ...]
    loss_factor: float | None
    complete: bool

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies, Hz, shape (r,)."""
        return np.sqrt(np.clip(self.eigenvalues, 0.0, None)) / (2.0 * np.pi)

    def rigid_body_count(self, tol_hz: float = 1e-3) -> int:
        """Number of modes below ``tol_hz`` (rigid-body modes)."""
        return int(np.sum(self.frequencies_hz < tol_hz))


#: Dense eigensolutions kept for structures solved again (the same matrices: a model rebuilt, a study run twice);
#: at most this many, each of at most :data:`_CACHED_DOFS` DOFs (a few MB in all).
_CACHE_SIZE = 16
_CACHED_DOFS = 400
_cache: OrderedDict = OrderedDict()
_cache_lock = threading.Lock()


def _dense_modes(K: np.ndarray, M: np.ndarray, dofs: tuple, eta) -> Modes:
    """Every mode by LAPACK's ``eigh(K, M)``; the same matrices (bit for bit) get the same, read-only arrays again."""
    key = None
    if isinstance(K, np.ndarray) and isinstance(M, np.ndarray) and K.shape[0] <= _CACHED_DOFS:
        digest = hashlib.blake2b(np.ascontiguousarray(K).tobytes(), digest_size=16)
        digest.update(np.ascontiguousarray(M).tobytes())
        key = (K.shape, K.dtype.str, M.dtype.str, digest.digest())
        with _cache_lock:
            hit = _cache.get(key)
            if hit is not None:
                _cache.move_to_end(key)
                return Modes(hit[0], hit[1], dofs, eta, True)
    lam, phi = sla.eigh(K, M)
    lam = np.clip(np.where(np.abs(lam) < _RIGID_TOL * max(abs(lam[-1]), 1.0), 0.0, lam), 0.0, None)
    if key is not None:
        lam.flags.writeable = phi.flags.writeable = False
        with _cache_lock:
            _cache[key] = (lam, phi)
            while len(_cache) > _CACHE_SIZE:
                _cache.popitem(last=False)
    return Modes(lam, phi, dofs, eta, True)


def natural_modes(
    structure: Structure,
    max_frequency_hz: float | None = None,
    min_count: int = 12,
) -> Modes:
    """Solve ``Re(K) phi = w^2 M phi`` for the structure's real modes.

    Parameters
    ----------
    structure : Structure
        Must have no frequency-dependent joints (their stiffness has no single value).
    max_frequency_hz : float, optional
        For models above :data:`DENSE_EIGEN_LIMIT` DOFs only: compute the modes up
        to this frequency (at least ``min_count``) by shift-invert Lanczos.
        Smaller models always get every mode (dense LAPACK ``eigh``).
    min_count : int
        Minimum number of modes returned by the sparse path.

    Returns
    -------
    Modes
        Sorted by frequency; rigid-body modes (free-free) appear at ~0 Hz.

    Notes
    -----
    A free-free structure has singular ``K``; the dense solver handles it, the
    sparse one shifts to a negative ``sigma`` so the factorized matrix
    ``K + |sigma| M`` is positive definite. The dense path keeps its last
    solutions of up to 400 DOFs (keyed by the matrices' bytes): a structure
    built again gets the same, read-only arrays without a new ``eigh``.
    """
    if structure.joints:
        raise ModelError(
            "natural_modes needs a structure without frequency-dependent joints; "
            "use the free beam, or replace the joint by a constant spring"
        )
    K = structure.K.real
    M = structure.M
    n = K.shape[0]
    eta = structure.proportional_loss_factor
    if n <= DENSE_EIGEN_LIMIT:
        return _dense_modes(K, M, structure.dofs, eta)
    if max_frequency_hz is None:
        raise ModelError(
            f"the model has {n} DOFs (> {DENSE_EIGEN_LIMIT}): give max_frequency_hz to compute the modes below it"
        )
    Ks, Ms = sp.csc_matrix(K), sp.csc_matrix(M)
    lam_max = (2 * np.pi * max_frequency_hz) ** 2
    # shift below zero: K + s M is positive definite even with rigid-body modes
    sigma = -0.01 * lam_max
    k = min(max(min_count, 8), n - 2)
    while True:
        lam, phi = spla.eigsh(Ks, k=k, M=Ms, sigma=sigma, which="LM")
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
        if lam[-1] >= lam_max or k >= n - 2:
            break
        k = min(2 * k, n - 2)
    keep = (lam <= lam_max) | (np.arange(lam.size) < min_count)
    lam, phi = lam[keep], phi[:, keep]
    # the largest eigenvalue is not computed here: estimate it from the diagonals
    lam_top = float(np.max(np.abs(np.diag(K)) / np.maximum(np.diag(M), 1e-300)))
    lam = np.where(np.abs(lam) < _RIGID_TOL * max(lam_top, 1.0), 0.0, lam)
    # eigsh returns M-orthonormal vectors already; renormalize for safety
    phi = phi / np.sqrt(np.sum(phi * (Ms @ phi), axis=0))[None, :]
    return Modes(np.clip(lam, 0.0, None), phi, structure.dofs, eta, False)
