"""A free model with joints attached, by receptance coupling: the test article of a general structure.

With ``Y`` the free structure's receptance and ``Du(f)`` the joints' dynamic
stiffness on their DOFs n (every joint's matrix summed onto n: grounded joints
and joints between two DOF sets alike), the receptance of the jointed
structure between any rows r and columns c is (Woodbury; the joints act as a
rank-|n| update of the dynamic stiffness)::

    H[r,c] = Y[r,c] - Y[r,n] (I + Du Y[n,n])^-1 Du Y[n,c]

which needs no inverse of ``Du`` (a joint between two parts, ``[[K, -K], [-K, K]]``,
is singular) and only the free receptance on r, n and c -- modal or sparse, from
:class:`~jointid.physics.sparse_model.SparseModel` or any
:class:`~jointid.physics.free_model.FreeModel`. Exact to the free model's own
accuracy; vectorized over frequency (one batched solve of size |n|).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from ..dofs import Dof, parse_dofs
from ..errors import ModelError
from ..frequency import Frequency
from .free_model import as_free_model
from .structure import ComplexStiffness

__all__ = ["JointedModel", "joint_dofs", "assemble_joints"]


def joint_dofs(joints: Sequence[ComplexStiffness]) -> tuple[Dof, ...]:
    """Every DOF of ``joints`` once, in order of first appearance."""
    seen: dict[Dof, None] = {}
    for j in joints:
        seen.update(dict.fromkeys(j.dofs))
    return tuple(seen)


def assemble_joints(joints: Sequence[ComplexStiffness], f_hz) -> np.ndarray:
    """``Du`` on :func:`joint_dofs`: every joint's matrix summed in, shape (F, n, n), complex.

    Joints on disjoint DOFs give a block-diagonal ``Du``; joints sharing a DOF add up there.
    """
    n = joint_dofs(joints)
    pos = {d: i for i, d in enumerate(n)}
    f_hz = np.atleast_1d(np.asarray(f_hz, float))
    Du = np.zeros((f_hz.size, len(n), len(n)), complex)
    for j in joints:
        idx = np.array([pos[d] for d in j.dofs])
        Du[:, idx[:, None], idx[None, :]] += j(f_hz)
    return Du


@dataclass(frozen=True, eq=False)
class JointedModel:
    """A free model plus frequency-dependent joints, with the :class:`FreeModel` interface.

    Parameters
    ----------
    free : FreeModel or Structure
        The free structure (anything with ``dofs`` and ``receptance(frequency, rows, cols)``).
    joints : sequence of ComplexStiffness
        Joint stiffness matrices on DOFs of ``free`` (N/m, N/rad, N*m/m, N*m/rad).
    """

    free: object
    joints: tuple[ComplexStiffness, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "free", as_free_model(self.free))
        object.__setattr__(self, "joints", tuple(self.joints))
        if not self.joints:
            raise ModelError("JointedModel needs at least one joint")
        have = set(self.free.dofs) if len(self.free.dofs) < 50_000 else None
        for j in self.joints:
            if not isinstance(j, ComplexStiffness):
                raise ModelError(f"joints must be ComplexStiffness objects, got {type(j).__name__}")
            if have is not None:
                missing = [str(d) for d in j.dofs if d not in have]
                if missing:
                    raise ModelError(f"joint {j.name!r}: DOF(s) {missing} are not DOFs of the free model")

    @property
    def dofs(self) -> tuple[Dof, ...]:
        """The free model's DOFs."""
        return self.free.dofs

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """Every joint DOF once, in order of first appearance."""
        return joint_dofs(self.joints)

    def joint_stiffness(self, f_hz: np.ndarray) -> np.ndarray:
        """``Du`` on :attr:`joint_dofs`: every joint's matrix summed in, shape (F, n, n), complex."""
        return assemble_joints(self.joints, f_hz)

    def receptance(self, frequency, rows: Iterable, cols: Iterable) -> np.ndarray:
        """Receptance of the jointed structure ``H[rows, cols]``, m/N (or rad/(N*m), ...), shape (F, r, c)."""
        freq = frequency if isinstance(frequency, Frequency) else Frequency(np.atleast_1d(np.asarray(frequency, float)))
        rows, cols = parse_dofs(rows), parse_dofs(cols)
        n = self.joint_dofs
        nr, nn = len(rows), len(n)
        Y = self.free.receptance(freq, tuple(rows) + n, n + tuple(cols))
        Yrc, Yrn, Ync, Ynn = Y[:, :nr, nn:], Y[:, :nr, :nn], Y[:, nr:, nn:], Y[:, nr:, :nn]
        Du = self.joint_stiffness(freq.hz)
        eye = np.broadcast_to(np.eye(nn), Du.shape)
        return Yrc - Yrn @ np.linalg.solve(eye + Du @ Ynn, Du @ Ync)
