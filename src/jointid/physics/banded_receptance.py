"""Receptance of a banded free structure by banded LU per line, with its rigid-body modes split off exactly.

Model updating evaluates the free model many times; a beam's ``K`` and ``M``
(DOFs in x order) have half-bandwidth 3, so one LAPACK ``gbsv`` per line
(``O(N b^2)`` work for N DOFs and half-bandwidth b) is far cheaper than an
eigen-solution per evaluation.

A free structure's ``D(w) = K* - w^2 M`` is nearly singular at low frequency
(condition ~ ``w_max^2 / w^2`` through its rigid-body modes): a plain solve
loses about ``eps w_max^2 / w^2`` of relative accuracy there, enough to drown
the small, smooth effect of the parameters (e.g. of the loss factor off resonance) in a
finite-difference Jacobian. The rigid-body modes ``Phi_0`` (null space of
``K``, mass-normalized) are therefore split off exactly:

    H = -Phi_0 Phi_0^T / w^2 + P_M^T D^-1 P e,   P e = e - M Phi_0 Phi_0^T e,  P_M x = x - Phi_0 Phi_0^T M x,

(the load ``P e`` excites no rigid-body mode, and the rigid-body component
of the solution, which carries the solve's error, is projected out). Beam
rigid-body modes are ``w = 1`` and ``w = x, theta = 1``; a structure where
they are not in the null space of ``K`` (e.g. with suspension springs) is
solved without the split.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .structure import Structure

__all__ = ["receptance_banded", "MAX_HALF_BANDWIDTH"]

#: Largest half-bandwidth of ``K`` and ``M`` solved here (a beam's is 3).
MAX_HALF_BANDWIDTH = 16


def _bandwidth(A: np.ndarray) -> int:
    i, j = np.nonzero(A)
    return int(np.max(np.abs(i - j))) if i.size else 0


def _rigid_modes(structure: Structure) -> np.ndarray | None:
    """Mass-normalized rigid-body modes (n, 2) of a free beam, or None if they are not K's null space."""
    dofs = structure.dofs
    x = np.array([structure.coordinates.get(d.node, np.nan) for d in dofs], dtype=float)
    if not np.all(np.isfinite(x)):
        return None
    is_w = np.array([d.direction == "w" for d in dofs])
    R = np.column_stack([is_w.astype(float), np.where(is_w, x - np.mean(x), 1.0)])
    K = structure.K
    if np.max(np.abs(K @ R)) > 1e-9 * np.max(np.abs(K)) * np.max(np.abs(R)):
        return None
    G = R.T @ structure.M @ R
    L = np.linalg.cholesky(G)
    return np.linalg.solve(L, R.T).T  # R L^-T: Phi^T M Phi = I


def receptance_banded(structure: Structure, frequency, rows, cols) -> np.ndarray | None:
    """Receptance ``D(w)^-1[rows, cols]``, shape (F, r, c), or None when ``K``, ``M`` are not banded.

    Parameters
    ----------
    structure : Structure
        No frequency-dependent joints; DOFs numbered so that ``K`` and ``M`` are banded.
    frequency : Frequency
        Lines above 0 Hz (a free structure has no receptance at 0 Hz).
    rows, cols : DOF labels
    """
    from scipy.linalg.lapack import zgbsv

    K, M = structure.K, structure.M
    if structure.joints or K.shape[0] != len(structure.dofs):
        return None
    bw = max(_bandwidth(K), _bandwidth(M))
    if bw > MAX_HALF_BANDWIDTH:
        return None
    n = K.shape[0]
    ri, ci = structure.index(rows), structure.index(cols)
    # LAPACK band storage with bw extra rows for the LU's fill-in: ab[2 bw + i - j, j] = A[i, j]
    Kb = np.zeros((3 * bw + 1, n), dtype=complex)
    Mb = np.zeros((3 * bw + 1, n))
    for d in range(-bw, bw + 1):
        Kb[2 * bw - d, max(d, 0): n + min(d, 0)] = np.diagonal(K, d)
        Mb[2 * bw - d, max(d, 0): n + min(d, 0)] = np.diagonal(M, d)
    E = np.zeros((n, len(ci)), dtype=complex)
    E[ci, np.arange(len(ci))] = 1.0
    Phi = _rigid_modes(structure)
    if Phi is not None:
        MPhi = M @ Phi
        E = E - MPhi @ (Phi[ci].T.astype(complex))  # P e
        rigid = Phi[ri] @ Phi[ci].T  # (r, c)
    w2 = frequency.omega**2
    if np.any(w2 <= 0):
        raise ModelError("the receptance of a free structure is undefined at 0 Hz; start the frequency grid above 0 Hz")
    out = np.empty((w2.size, len(ri), len(ci)), dtype=complex)
    for k, x in enumerate(w2):
        _, _, X, info = zgbsv(bw, bw, Kb - x * Mb, E)
        if info != 0:
            raise ModelError(f"the structure's dynamic stiffness is singular at {frequency.hz[k]:g} Hz")
        if Phi is not None:
            X = X - Phi @ (MPhi.T @ X)
            out[k] = X[ri] - rigid / x
        else:
            out[k] = X[ri]
    return out
