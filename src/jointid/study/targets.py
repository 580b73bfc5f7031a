"""``[identification.targets]``: the accuracy each joint term must reach, as the study states it.

::

    [identification.targets]   # median relative error per term (0.002 = 0.2 %)
    K_x_x = 0.002
    K_rx_rx = 0.05

Terms are named as in ``joint_stiffness.csv`` (``K_w_w``, ``K_x_ry``; a joint on several
nodes ``K_101x_201x``); ``K_a_b`` and ``K_b_a`` are the same term of a symmetric joint.
The identification flags a term reliable only where its predicted relative standard
deviation is within its target; ``jointid design`` says which layout reaches them.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

from ..dofs import Dof
from ..errors import StudyError
from ..terms import term_names

__all__ = ["parse_targets"]


def parse_targets(table: Any, joint_dofs: Sequence[Dof]) -> tuple[tuple[str, float], ...]:
    """``[identification.targets]`` as sorted ``(term, relative error)`` pairs (module docstring).

    Raises
    ------
    StudyError
        Not a table, a name that is not a term of the study's joints (the terms listed), a value
        that is not a number in (0, 10].
    """
    if not isinstance(table, Mapping):
        raise StudyError("[identification.targets] must be a table of term = relative error, e.g. K_x_x = 0.002")
    names = [name for a, b, name in term_names(joint_dofs) if a <= b]
    mirror = {f"K_{name.split('_', 2)[2]}_{name.split('_', 2)[1]}": name for name in names if name.count("_") == 2}
    out = {}
    for key, value in table.items():
        name = key if key in names else mirror.get(key)
        if name is None:
            raise StudyError(f"[identification.targets]: {key!r} is not a term of the joint; expected one of: {', '.join(names)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and 0 < value <= 10):
            raise StudyError(f"[identification.targets].{key}: expected a relative error > 0 (0.002 = 0.2 %), got {value!r}")
        out[name] = float(value)
    return tuple(sorted(out.items()))
