"""Joint stiffness terms: their labels and SI units, for every layer (methods, plots, report, CLI).

A joint of ``n`` DOFs has ``n x n`` terms ``K_ij``: the force (or moment) at DOF ``i`` per
unit displacement (or rotation) at DOF ``j``. A term is named ``K_{li}_{lj}`` with the
labels of :func:`dof_term_labels`: the direction when every joint DOF is on one node
(``K_w_theta`` for the beam's joint, ``K_x_ry`` for a 3-D mount), else the full DOF label
(``K_101x_201x``), so that names never collide. Units: ``N/m`` (translation/translation),
``N/rad``, ``N*m/m``, ``N*m/rad`` (:func:`term_unit`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .dofs import Dof
from .errors import IdentificationError
from .frequency import Frequency

__all__ = ["dof_term_labels", "term_names", "term_unit", "term_units", "joint_term", "stiffness_columns", "Z90"]

#: Two-sided 90 % normal quantile: a term's 90 % band is +-Z90 sigma of its real and imaginary parts.
Z90 = 1.6448536269514722


def dof_term_labels(joint_dofs: Sequence[Dof]) -> list[str]:
    """The label of each joint DOF in term names: its direction when all are on one node, else its full label.

    ``["w", "theta"]`` for the beam's joint, ``["x", ..., "rz"]`` for a 3-D joint on
    one node (``K_x_ry``), ``["101x", ..., "201x"]`` for a joint on several nodes
    (``K_101x_201x``).
    """
    if len({d.node for d in joint_dofs}) <= 1:
        return [d.direction for d in joint_dofs]
    return [str(d) for d in joint_dofs]


def term_names(joint_dofs: Sequence[Dof]) -> list[tuple[int, int, str]]:
    """``(i, j, "K_{li}_{lj}")`` for every ordered pair of joint DOFs, row-major."""
    labels = dof_term_labels(joint_dofs)
    return [(a, b, f"K_{la}_{lb}") for a, la in enumerate(labels) for b, lb in enumerate(labels)]


def term_unit(di: Dof, dj: Dof) -> str:
    """SI unit of the stiffness term ``K_ij`` (force at ``di`` per displacement at ``dj``), e.g. ``"N/rad"``."""
    return f"{di.force_unit}/{dj.unit}"


def term_units(joint_dofs: Sequence[Dof]) -> dict[str, str]:
    """Term name -> SI unit for every ordered pair of joint DOFs."""
    return {name: term_unit(joint_dofs[a], joint_dofs[b]) for a, b, name in term_names(joint_dofs)}


def joint_term(stiffness: np.ndarray, joint_dofs: Sequence[Dof], i: str, j: str) -> np.ndarray:
    """Term ``K_ij`` of ``stiffness`` (F, n, n) by term label (``"w"``, ``"theta"``, ``"x"`` or ``"101x"``), shape (F,).

    Raises
    ------
    IdentificationError
        A label that is not one of the joint's.
    """
    labels = dof_term_labels(joint_dofs)
    try:
        return stiffness[:, labels.index(i), labels.index(j)]
    except ValueError:
        raise IdentificationError(f"joint term K_{i}_{j} was not identified (joint DOFs: {labels})") from None


def stiffness_columns(frequency: Frequency, joint_dofs: Sequence[Dof], stiffness: np.ndarray) -> dict[str, np.ndarray]:
    """``frequency_hz`` then ``K_{i}_{j}_real``, ``K_{i}_{j}_imag`` for every ordered pair of joint DOFs (N/m, N/rad, ...)."""
    cols: dict[str, np.ndarray] = {"frequency_hz": frequency.hz}
    for a, b, name in term_names(joint_dofs):
        cols[f"{name}_real"] = stiffness[:, a, b].real
        cols[f"{name}_imag"] = stiffness[:, a, b].imag
    return cols
