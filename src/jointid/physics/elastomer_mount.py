"""The elastomer joint FE model on a (translation, rotation) pair of 3-D DOFs: a structure study's true joint.

:class:`~jointid.physics.elastomer_joint.ElastomerJoint` is planar: its
cylinder lies along its own ``s`` axis (from the cap at ``s = 0`` to the cap
at ``s = L``), is loaded laterally in ``w`` and its end sections rotate by
``theta = dw/ds``. On a 3-D structure (DOFs ``x, y, z, rx, ry, rz``, right-handed
rotations about the global axes) the joint acts on one translation ``t`` (the
lateral ``w = u_t``) and one rotation ``r`` about an axis across the cylinder,
with the cylinder along a global axis ``a`` perpendicular to both.

Sign convention
---------------
A rotation ``phi`` about ``r`` moves the section at ``s`` by ``phi r x (s a)``, so
``theta = dw/ds = sigma phi`` with ``sigma = (r x a) . t`` = +1 or -1. The
joint's matrix on the structure's ``(u_t, phi_r)`` is ``S K S`` with
``S = diag(1, sigma)``: the coupling terms change sign when ``sigma = -1``.
Example: a cylinder along +x, ``w`` along z, ``theta = dw/dx`` is ``-ry``
(a positive ``ry`` moves +x toward -z): ``axes = ["z", "ry"]`` with
``cylinder_axis = "+x"`` gives ``sigma = -1``; ``["y", "rz"]`` along +x gives
``sigma = +1``. The default axis is ``a = r x t`` (for ``["z", "ry"]``: +x; for
``["y", "rz"]``: -x), for which ``sigma = -1`` always. The direction of ``a``
matters only through the sign of the couplings (the cylinder reversed is the
mirror image).

Grounded and two-part joints
----------------------------
Grounded (``other`` empty): the cap at ``s = 0`` is on the ground and the
structure DOFs carry the cap at ``s = L`` (its rigid-body inertia belongs to
the joint): :meth:`ElastomerJoint.driving_point_matrix` mapped onto (t, r).
Between two parts: ``a`` points from the ``other`` side (the cap at
``s = 0``) to the ``dofs`` side (the cap at ``s = L``); the matrix is the
dynamic two-end condensation :meth:`ElastomerJoint.blocked_condensed_matrix`
on ``(w0, theta0, wL, thetaL)`` plus both caps' rigid-body inertia (each cap's
centroid outboard of its face), not ``[[K, -K], [-K, K]]``: the cylinder's mass
makes the two ends' forces differ. With the ``other`` side held, it reduces to
the grounded joint exactly. Every other DOF of the joint gets zero stiffness.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..dofs import Dof
from ..errors import ModelError
from .elastomer_joint import ElastomerJoint
from .structure import ComplexStiffness

__all__ = ["TRANSLATIONS", "ROTATIONS", "AXIS_DIRECTIONS", "default_cylinder_axis", "axis_sign", "elastomer_mount"]

TRANSLATIONS = ("x", "y", "z")
ROTATIONS = ("rx", "ry", "rz")
#: Values of ``cylinder_axis``.
AXIS_DIRECTIONS = ("+x", "-x", "+y", "-y", "+z", "-z")
_UNIT = np.eye(3)


def _vector(direction: str) -> np.ndarray:
    return (1.0 if direction[0] == "+" else -1.0) * _UNIT["xyz".index(direction[1])]


def default_cylinder_axis(translation: str, rotation: str) -> str:
    """``a = r x t`` as ``"+x"`` ... ``"-z"`` (the default ``cylinder_axis``, for which ``theta = -phi_r``).

    Raises
    ------
    ModelError
        ``translation`` not one of x, y, z; ``rotation`` not one of rx, ry, rz; or the rotation about ``translation``.
    """
    if translation not in TRANSLATIONS or rotation not in ROTATIONS:
        raise ModelError(f"expected a translation (x, y, z) and a rotation (rx, ry, rz), got {translation!r} and {rotation!r}")
    a = np.cross(_UNIT[ROTATIONS.index(rotation)], _UNIT[TRANSLATIONS.index(translation)])
    if not a.any():
        raise ModelError(f"the rotation {rotation} is about the translation {translation}; theta = dw/ds turns about an axis across w")
    i = int(np.argmax(np.abs(a)))
    return ("+" if a[i] > 0 else "-") + "xyz"[i]


def axis_sign(translation: str, rotation: str, cylinder_axis: str | None = None) -> int:
    """``sigma = (r x a) . t``: ``theta = dw/ds = sigma phi_r`` for the cylinder along ``cylinder_axis``.

    Raises
    ------
    ModelError
        A bad pair (see :func:`default_cylinder_axis`), or an axis not across both ``t`` and ``r``.
    """
    default = default_cylinder_axis(translation, rotation)
    a = default if cylinder_axis is None else cylinder_axis
    if a not in AXIS_DIRECTIONS:
        raise ModelError(f"cylinder_axis must be one of {', '.join(AXIS_DIRECTIONS)}, got {a!r}")
    if a[1] != default[1]:
        raise ModelError(
            f"cylinder_axis {a} is not across both {translation} and {rotation}; the cylinder of axes "
            f"[{translation}, {rotation}] lies along {default[1]}: use +{default[1]} or -{default[1]}"
        )
    sigma = np.cross(_UNIT[ROTATIONS.index(rotation)], _vector(a)) @ _UNIT[TRANSLATIONS.index(translation)]
    return int(round(sigma))


def elastomer_mount(
    joint: ElastomerJoint,
    dofs: Sequence[Dof],
    pair: tuple[int, int],
    sigma: int,
    other: Sequence[Dof] = (),
    name: str = "elastomer joint",
) -> ComplexStiffness:
    """The elastomer joint on positions ``pair = (i_t, i_r)`` of ``dofs`` (and of ``other``) as a ComplexStiffness.

    Parameters
    ----------
    joint : ElastomerJoint
        The FE model (its ``cap``: the structure-side cap, and for a two-part joint both caps).
    dofs : sequence of Dof, length k
        The joint's DOFs (side one: the cap at ``s = L``).
    pair : (int, int)
        Positions in ``dofs`` of the translation ``t`` (plays ``w``) and the rotation ``r`` (plays ``theta / sigma``).
    sigma : {+1, -1}
        :func:`axis_sign`.
    other : sequence of Dof, length k, or empty
        Side two (the cap at ``s = 0``), same positions; empty: grounded.

    Returns
    -------
    ComplexStiffness
        On ``dofs`` (k x k) or ``dofs + other`` (2k x 2k); N/m, N/rad, N*m/m, N*m/rad; zero off the pair.
    """
    k = len(dofs)
    if sigma not in (1, -1):
        raise ModelError(f"sigma must be +1 or -1, got {sigma!r}")
    if other and len(other) != k:
        raise ModelError(f"an elastomer joint between two sets needs as many DOFs on each side, got {k} and {len(other)}")
    it, ir = pair
    S = np.array([1.0, float(sigma)])
    if other:
        idx = np.array([it, ir, k + it, k + ir])  # (wL, thetaL) on dofs, (w0, theta0) on other
        S4 = np.concatenate([S, S])
        caps = None
        if joint.cap is not None:
            caps = np.zeros((4, 4))
            caps[:2, :2] = joint.cap.mass_matrix(+1.0)
            caps[2:, 2:] = joint.cap.mass_matrix(-1.0)

        def stiffness(f_hz: np.ndarray) -> np.ndarray:
            C = joint.blocked_condensed_matrix(f_hz)[:, [2, 3, 0, 1]][:, :, [2, 3, 0, 1]]
            if caps is not None:
                C = C - ((2.0 * np.pi * np.asarray(f_hz)) ** 2)[:, None, None] * caps[None]
            out = np.zeros((C.shape[0], 2 * k, 2 * k), complex)
            out[:, idx[:, None], idx[None, :]] = S4[:, None] * C * S4[None, :]
            return out

        return ComplexStiffness(tuple(dofs) + tuple(other), stiffness, name)

    idx = np.array([it, ir])

    def stiffness(f_hz: np.ndarray) -> np.ndarray:
        C = joint.driving_point_matrix(f_hz)
        out = np.zeros((C.shape[0], k, k), complex)
        out[:, idx[:, None], idx[None, :]] = S[:, None] * C * S[None, :]
        return out

    return ComplexStiffness(tuple(dofs), stiffness, name)
