"""A parametric elastic mount: a 6x6 (or smaller) complex stiffness per side, frequency-dependent and passive.

The true joint of a structure study's ``[joint.model] type = "mount"``, for
virtual tests. On its ``k`` DOFs (1-6 components of one side)::

    K*(f) = K0 (1 + growth (f / reference_frequency)^exponent) (1 + j loss_factor)

``K0`` (k x k, real symmetric) holds the ``stiffness`` of each DOF on its
diagonal (N/m for translations, N*m/rad for rotations) and the ``couplings``
off it (``K0[i, j] = K0[j, i]``: N/rad = N*m/m between a translation and a
rotation). It must be positive definite; with ``growth >= 0`` and
``loss_factor >= 0`` the mount is then passive on every line (``Im K*`` is
positive semidefinite) and its storage stiffness grows with frequency
(elastomer-like stiffening; ``growth = 0``: frequency-independent).

A grounded mount acts on its ``dofs`` alone (``Du = K*``); a mount between two
sets of DOFs (``dofs`` on one part, ``other`` on the other) has the ``2k x 2k``
matrix ``[[K*, -K*], [-K*, K*]]`` on ``dofs + other`` (the force depends only
on the relative displacement ``u_dofs - u_other``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..dofs import Dof
from ..errors import ModelError

__all__ = ["MountModel"]


@dataclass(frozen=True, eq=False)
class MountModel:
    """A parametric mount between ``dofs`` and ground, or between ``dofs`` and ``other``.

    Parameters
    ----------
    dofs : tuple of Dof, length k (1-6)
        The mount's DOFs on its first side.
    stiffness0 : ndarray, shape (k, k), real symmetric positive definite
        ``K0``: N/m, N/rad, N*m/m, N*m/rad.
    loss_factor : float
        ``eta >= 0`` of ``(1 + j eta)``.
    growth : float
        Stiffening factor ``>= 0`` at ``reference_frequency`` (0: none).
    reference_frequency : float
        Hz.
    exponent : float
        Power of the stiffening (> 0).
    other : tuple of Dof, length k, or empty
        The second side's DOFs (empty: grounded).
    """

    dofs: tuple[Dof, ...]
    stiffness0: np.ndarray
    loss_factor: float = 0.1
    growth: float = 0.0
    reference_frequency: float = 100.0
    exponent: float = 1.0
    other: tuple[Dof, ...] = ()

    def __post_init__(self) -> None:
        k = len(self.dofs)
        K0 = np.asarray(self.stiffness0, dtype=float)
        if K0.shape != (k, k):
            raise ModelError(f"mount stiffness must be {k} x {k} for {k} DOFs, got shape {K0.shape}")
        if not np.all(np.isfinite(K0)) or np.abs(K0 - K0.T).max() > 1e-12 * np.abs(K0).max():
            raise ModelError("mount stiffness must be finite and symmetric")
        if self.other and len(self.other) != k:
            raise ModelError(f"a mount between two sets needs as many DOFs on each side, got {k} and {len(self.other)}")
        lam = np.linalg.eigvalsh(K0)
        if lam[0] <= 0:
            raise ModelError(
                f"the mount stiffness (diagonal and couplings) is not positive definite (smallest eigenvalue {lam[0]:.3g}); "
                "lower the couplings or raise the diagonal stiffnesses"
            )
        if not (self.loss_factor >= 0 and self.growth >= 0 and self.reference_frequency > 0 and self.exponent > 0):
            raise ModelError("mount loss_factor and growth must be >= 0, reference_frequency and exponent > 0")
        object.__setattr__(self, "stiffness0", K0)

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """The DOFs of the joint matrix: ``dofs`` (grounded) or ``dofs + other``."""
        return tuple(self.dofs) + tuple(self.other)

    def side(self, frequency_hz: Sequence[float]) -> np.ndarray:
        """``K*(f)`` of one side, shape (F, k, k), complex."""
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        scale = (1.0 + self.growth * (f / self.reference_frequency) ** self.exponent) * (1.0 + 1j * self.loss_factor)
        return scale[:, None, None] * self.stiffness0[None, :, :]

    def __call__(self, frequency_hz: Sequence[float]) -> np.ndarray:
        """The joint matrix on :attr:`joint_dofs`, shape (F, k, k) grounded or (F, 2k, 2k) between two sets."""
        Ks = self.side(frequency_hz)
        if not self.other:
            return Ks
        return np.concatenate([np.concatenate([Ks, -Ks], axis=2), np.concatenate([-Ks, Ks], axis=2)], axis=1)
