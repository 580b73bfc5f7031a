"""Labelled degrees of freedom: a DOF is a (node, direction) pair.

Two families of directions share one :class:`Dof` type:

* the planar bending beam's ``"w"`` (transverse displacement, +Z, m) and
  ``"theta"`` (rotation about the beam's normal axis, rad, ``theta = dw/dx``:
  positive when the beam tip rises for increasing x), labelled ``"10w"`` /
  ``"10theta"``; ``Dof(10)`` is ``Dof(10, "w")``;
* a general 3-D model's components ``"x", "y", "z"`` (translations, m) and
  ``"rx", "ry", "rz"`` (rotations, rad) -- UFF direction codes and Nastran
  components 1-6 -- plus scalar points ``"s"`` (component 0: a Nastran SPOINT,
  a Craig-Bampton modal coordinate; unit ``"1"``), labelled ``"101z"``,
  ``"101rx"``, ``"1995001s"``.

Labels parse back with :func:`parse_dof`. Large models hold their DOFs as two
integer arrays (node, component code) in a :class:`DofArray`, whose
:meth:`DofArray.indices` finds requested DOFs by a binary search on packed
int64 keys ``node * 16 + code`` (no Python loop over the model). Component
codes: ``s`` 0, ``x..rz`` 1-6 (as UFF and Nastran), and, for the beam only,
``w`` 7, ``theta`` 8 (jointid's own codes, not UFF's).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from .errors import DofError

__all__ = [
    "Dof",
    "DIRECTIONS",
    "COMPONENTS",
    "ALL_DIRECTIONS",
    "COMPONENT_CODES",
    "DofArray",
    "parse_dof",
    "parse_dofs",
    "parse_component",
    "dof_indices",
    "partition_indices",
    "pack_dof_keys",
]

#: Directions of the planar bending beam.
DIRECTIONS: tuple[str, ...] = ("w", "theta")
#: Components of a general 3-D model (UFF direction codes / Nastran components 1-6).
COMPONENTS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")
#: Every direction a :class:`Dof` may have (``"s"``: scalar point, component 0).
ALL_DIRECTIONS: tuple[str, ...] = DIRECTIONS + COMPONENTS + ("s",)
#: Integer code of each direction (``s`` 0, ``x..rz`` 1-6 as UFF/Nastran, ``w`` 7, ``theta`` 8).
COMPONENT_CODES: dict[str, int] = {"s": 0, "x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6, "w": 7, "theta": 8}
_CODE_NAMES: tuple[str, ...] = ("s", "x", "y", "z", "rx", "ry", "rz", "w", "theta")
_KEY_BITS = 4  # packed key = node << 4 | code (codes 0..8)
_UNITS = {"w": "m", "theta": "rad", "x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad", "rz": "rad", "s": "1"}
_FORCE_UNITS = {"w": "N", "theta": "N*m", "x": "N", "y": "N", "z": "N", "rx": "N*m", "ry": "N*m", "rz": "N*m", "s": "1"}
_LABEL = re.compile(r"^\s*(\d+)\s*[:_ ]?\s*(w|theta|x|y|z|rx|ry|rz|s)\s*$")


@dataclass(frozen=True, order=True)
class Dof:
    """A degree of freedom: node (or scalar point) number and direction.

    Parameters
    ----------
    node : int
        Node (grid or scalar point) number (>= 1).
    direction : str
        Beam: ``"w"`` transverse displacement (m), ``"theta"`` rotation (rad).
        3-D: ``"x"``, ``"y"``, ``"z"`` (m), ``"rx"``, ``"ry"``, ``"rz"`` (rad);
        ``"s"`` a scalar point (unit ``"1"``). Default ``"w"``.
    """

    node: int
    direction: str = "w"

    def __post_init__(self) -> None:
        if not isinstance(self.node, int) or isinstance(self.node, bool) or self.node < 1:
            raise DofError(f"DOF node must be an integer >= 1, got {self.node!r}")
        if self.direction not in ALL_DIRECTIONS:
            raise DofError(
                f"DOF direction must be one of {DIRECTIONS} (beam) or {COMPONENTS + ('s',)} (3-D, scalar point), got {self.direction!r}"
            )

    @property
    def unit(self) -> str:
        """SI unit of the displacement at this DOF (``"m"``, ``"rad"``, or ``"1"`` for a scalar point)."""
        return _UNITS[self.direction]

    @property
    def force_unit(self) -> str:
        """SI unit of the generalized force at this DOF (``"N"``, ``"N*m"``, or ``"1"`` for a scalar point)."""
        return _FORCE_UNITS[self.direction]

    @property
    def code(self) -> int:
        """Integer component code: ``s`` 0, ``x..rz`` 1-6 (UFF/Nastran), beam ``w`` 7, ``theta`` 8."""
        return COMPONENT_CODES[self.direction]

    def __str__(self) -> str:
        return f"{self.node}{self.direction}"


def parse_component(value: "str | int") -> str:
    """Direction name of a component given as a name or a code.

    Accepts ``x|y|z|rx|ry|rz`` (any case), ``w``/``theta``, ``s``, or the
    codes ``1..6`` (UFF direction / Nastran component) and ``0`` (scalar point),
    as int or string.

    Raises
    ------
    DofError
        If the component cannot be read.
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if 0 <= int(value) <= 6:
            return _CODE_NAMES[int(value)]
    elif isinstance(value, str):
        v = value.strip().lower()
        if v in ALL_DIRECTIONS:
            return v
        if v.isdigit() and 0 <= int(v) <= 6:
            return _CODE_NAMES[int(v)]
    raise DofError(f"cannot read a DOF component from {value!r}; use x, y, z, rx, ry, rz, 1-6, or 0 for a scalar point")


def parse_dof(label: "Dof | str | tuple[int, str] | int") -> Dof:
    """Return a :class:`Dof` from a DOF, a label, a ``(node, component)`` tuple or a node number (w).

    Labels: ``"10w"``, ``"10:theta"``, ``"101z"``, ``"101_rx"``, ``"1995001s"``.
    A tuple's component is a direction name or a code 0-6 (see :func:`parse_component`).

    Raises
    ------
    DofError
        If the label cannot be read.
    """
    if isinstance(label, Dof):
        return label
    if isinstance(label, bool):
        raise DofError(f"cannot read a DOF from {label!r}")
    if isinstance(label, (int, np.integer)):
        return Dof(int(label), "w")
    if isinstance(label, tuple) and len(label) == 2:
        comp = label[1]
        if isinstance(comp, (int, np.integer)) and not isinstance(comp, bool):
            comp = parse_component(comp)
        return Dof(int(label[0]), str(comp))
    if isinstance(label, str):
        m = _LABEL.match(label)
        if m:
            return Dof(int(m.group(1)), m.group(2))
    raise DofError(
        f"cannot read a DOF from {label!r}; write it as '<node><direction>', e.g. '10w', '10theta', '101z', '101rx' or '1995001s'"
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


def pack_dof_keys(node, code) -> np.ndarray:
    """Packed int64 keys ``node * 16 + code`` of DOF arrays (node >= 1, code 0..8), shape of the inputs."""
    return (np.asarray(node, dtype=np.int64) << _KEY_BITS) | np.asarray(code, dtype=np.int64)


def _wanted_arrays(wanted) -> tuple[np.ndarray, np.ndarray]:
    """(node, code) arrays of requested DOFs: a :class:`DofArray`, a pair of arrays, or DOF labels."""
    if isinstance(wanted, DofArray):
        return wanted.node, wanted.code
    if isinstance(wanted, tuple) and len(wanted) == 2 and all(isinstance(a, np.ndarray) for a in wanted):
        return np.asarray(wanted[0], dtype=np.int64), np.asarray(wanted[1], dtype=np.int64)
    dofs = parse_dofs(wanted)
    return (np.fromiter((d.node for d in dofs), dtype=np.int64, count=len(dofs)),
            np.fromiter((d.code for d in dofs), dtype=np.int64, count=len(dofs)))


def partition_indices(node, code, wanted, what: str = "model") -> np.ndarray:
    """Positions of the ``wanted`` DOFs in a model whose DOFs are the arrays ``(node, code)``.

    Vectorized: the model's packed keys are sorted once and the requested keys
    found by ``searchsorted`` (O((N + k) log N), no Python loop over the model).
    For repeated look-ups build a :class:`DofArray` once and use its
    :meth:`DofArray.indices` (the sort is cached).

    Parameters
    ----------
    node, code : array_like of int, shape (N,)
        The model's DOFs: node numbers and component codes (see :data:`COMPONENT_CODES`).
    wanted : DofArray, (node, code) pair of arrays, or iterable of DOF labels
        The DOFs to find (labels as in :func:`parse_dof`).
    what : str
        Name of the model in the error message.

    Returns
    -------
    ndarray of int64, shape (k,)

    Raises
    ------
    DofError
        One line naming the missing DOF(s) (the first few) and how many.
    """
    return DofArray(node, code).indices(wanted, what)


class DofArray:
    """The DOFs of a (large) model as two integer arrays: node number and component code.

    Parameters
    ----------
    node : array_like of int, shape (N,)
        Node (grid or scalar point) numbers, >= 1.
    code : array_like of int, shape (N,)
        Component codes (:data:`COMPONENT_CODES`: ``s`` 0, ``x..rz`` 1-6, ``w`` 7, ``theta`` 8).

    Raises
    ------
    DofError
        Arrays of different lengths, a node < 1 or a code outside 0..8.
    """

    __slots__ = ("node", "code", "_keys", "_order", "_sorted", "_dofs")

    def __init__(self, node, code) -> None:
        node = np.array(node, dtype=np.int64).ravel()
        code = np.array(code, dtype=np.int64).ravel()
        if node.shape != code.shape:
            raise DofError(f"DOF arrays differ in length: {node.size} nodes, {code.size} component codes")
        if node.size and node.min() < 1:
            raise DofError(f"DOF node must be an integer >= 1, got {int(node.min())}")
        if code.size and (code.min() < 0 or code.max() > 8):
            bad = int(code[(code < 0) | (code > 8)][0])
            raise DofError(f"DOF component code must be 0..8 (s, x, y, z, rx, ry, rz, w, theta), got {bad}")
        node.flags.writeable = False
        code.flags.writeable = False
        self.node, self.code = node, code
        self._keys = pack_dof_keys(node, code)
        self._order = np.argsort(self._keys, kind="stable")
        self._sorted = self._keys[self._order]
        self._dofs = None

    @classmethod
    def from_dofs(cls, dofs: Iterable) -> "DofArray":
        """A :class:`DofArray` of DOFs or labels (see :func:`parse_dof`)."""
        return cls(*_wanted_arrays(list(dofs) if not isinstance(dofs, (str, Dof, int)) else [dofs]))

    def __len__(self) -> int:
        return int(self.node.size)

    def __repr__(self) -> str:
        return f"DofArray({len(self)} DOFs)"

    @property
    def keys(self) -> np.ndarray:
        """Packed int64 keys ``node * 16 + code``, shape (N,)."""
        return self._keys

    def duplicates(self) -> tuple[Dof, ...]:
        """DOFs that occur more than once (each once, in key order)."""
        rep = self._sorted[1:][self._sorted[1:] == self._sorted[:-1]]
        rep = np.unique(rep)
        return tuple(Dof(int(k >> _KEY_BITS), _CODE_NAMES[int(k & 15)]) for k in rep)

    def to_dofs(self) -> tuple[Dof, ...]:
        """Every DOF as a :class:`Dof`, in order (built once, then cached)."""
        if self._dofs is None:
            names = np.array(_CODE_NAMES, dtype=object)[self.code]
            self._dofs = tuple(Dof(n, d) for n, d in zip(self.node.tolist(), names.tolist()))
        return self._dofs

    def indices(self, wanted, what: str = "model") -> np.ndarray:
        """Positions of the ``wanted`` DOFs, shape (k,) int64 (see :func:`partition_indices`).

        Raises
        ------
        DofError
            One line naming the missing DOF(s).
        """
        wn, wc = _wanted_arrays(wanted)
        keys = pack_dof_keys(wn, wc)
        if self._sorted.size == 0:
            pos = np.zeros(keys.shape, dtype=np.int64)
            found = np.zeros(keys.shape, dtype=bool)
        else:
            pos = np.searchsorted(self._sorted, keys)
            pos = np.minimum(pos, self._sorted.size - 1)
            found = self._sorted[pos] == keys
        if not found.all():
            miss = np.flatnonzero(~found)
            names = [f"{int(wn[i])}{_CODE_NAMES[int(wc[i])] if 0 <= wc[i] <= 8 else '?'}" for i in miss[:5]]
            more = f" and {miss.size - 5} more" if miss.size > 5 else ""
            span = f"nodes {int(self.node.min())}..{int(self.node.max())}" if len(self) else "no nodes"
            which = f"DOF {names[0]} is" if miss.size == 1 else f"DOFs {', '.join(names)}{more} are"
            raise DofError(f"{which} not in the {what} (it has {len(self)} DOFs, {span})")
        return self._order[pos]
