"""Labelled degrees of freedom: a DOF is a (node, direction) pair.

Directions of the planar bending model are ``"w"`` (transverse displacement,
+Z, m) and ``"theta"`` (rotation about the beam's normal axis, rad,
``theta = dw/dx``: positive when the beam tip rises for increasing x).
Labels print as ``"10w"`` / ``"10theta"`` and parse back with :func:`parse_dof`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Iterable, Sequence

from .errors import DofError

__all__ = ["Dof", "DIRECTIONS", "parse_dof", "parse_dofs", "dof_indices"]

DIRECTIONS: tuple[str, ...] = ("w", "theta")
_UNITS = {"w": "m", "theta": "rad"}
_FORCE_UNITS = {"w": "N", "theta": "N*m"}
_LABEL = re.compile(r"^\s*(\d+)\s*[:_ ]?\s*(w|theta)\s*$")


@dataclass(frozen=True, order=True)
class Dof:
    """A degree of freedom: beam/structure node number and direction.

    Parameters
    ----------
    node : int
        Node number (>= 1).
    direction : {"w", "theta"}
        ``"w"`` transverse displacement (m), ``"theta"`` rotation (rad).
    """

    node: int
    direction: str = "w"

    def __post_init__(self) -> None:
        if not isinstance(self.node, int) or isinstance(self.node, bool) or self.node < 1:
            raise DofError(f"DOF node must be an integer >= 1, got {self.node!r}")
        if self.direction not in DIRECTIONS:
            raise DofError(
                f"DOF direction must be one of {DIRECTIONS}, got {self.direction!r}"
            )

    @property
    def unit(self) -> str:
        """SI unit of the displacement at this DOF (``"m"`` or ``"rad"``)."""
        return _UNITS[self.direction]

    @property
    def force_unit(self) -> str:
        """SI unit of the generalized force at this DOF (``"N"`` or ``"N*m"``)."""
        return _FORCE_UNITS[self.direction]

    def __str__(self) -> str:
        return f"{self.node}{self.direction}"


def parse_dof(label: "Dof | str | tuple[int, str] | int") -> Dof:
    """Return a :class:`Dof` from a DOF, a label ``"10w"``/``"10:theta"``, a tuple or a node number (w).

    Raises
    ------
    DofError
        If the label cannot be read.
    """
    if isinstance(label, Dof):
        return label
    if isinstance(label, bool):
        raise DofError(f"cannot read a DOF from {label!r}")
    if isinstance(label, int):
        return Dof(label, "w")
    if isinstance(label, tuple) and len(label) == 2:
        return Dof(int(label[0]), str(label[1]))
    if isinstance(label, str):
        m = _LABEL.match(label)
        if m:
            return Dof(int(m.group(1)), m.group(2))
    raise DofError(
        f"cannot read a DOF from {label!r}; write it as '<node><direction>', e.g. '10w' or '10theta'"
    )


def parse_dofs(labels: Iterable) -> tuple[Dof, ...]:
    """Parse an iterable of DOF labels (see :func:`parse_dof`) into a tuple of :class:`Dof`."""
    if isinstance(labels, (str, Dof, int)):
        labels = [labels]
    return tuple(parse_dof(x) for x in labels)


def dof_indices(dofs: Sequence[Dof], wanted: Iterable, what: str = "model") -> list[int]:
    """Positions of the ``wanted`` DOFs in ``dofs``.

    Raises
    ------
    DofError
        Naming the first DOF that is not in ``dofs``.
    """
    pos = {d: i for i, d in enumerate(dofs)}
    out = []
    for d in parse_dofs(wanted):
        if d not in pos:
            raise DofError(
                f"DOF {d} is not in the {what} (it has {len(dofs)} DOFs, "
                f"nodes {min(x.node for x in dofs) if dofs else '-'}..{max(x.node for x in dofs) if dofs else '-'})"
            )
        out.append(pos[d])
    return out
