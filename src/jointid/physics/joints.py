"""Joint models that connect a beam node to ground: parametric and (via the direct method) elastomeric.

A joint is a :class:`~jointid.physics.structure.ComplexStiffness` on the joint
coordinates ``(node w, node theta)`` (or a subset).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..dofs import Dof
from ..errors import StudyError
from .structure import ComplexStiffness

__all__ = ["parametric_joint", "joint_from_spec"]


def parametric_joint(
    node: int,
    k_w_w: float,
    k_theta_theta: float,
    k_w_theta: float = 0.0,
    loss_factor: float = 0.1,
    growth: float = 0.0,
    reference_frequency: float = 100.0,
    exponent: float = 1.0,
    dofs: Sequence[str] = ("w", "theta"),
) -> ComplexStiffness:
    """A grounded joint with a frequency-dependent complex 2x2 stiffness.

    ``K*(f) = K0 (1 + growth (f / reference_frequency)^exponent) (1 + j loss_factor)``
    with ``K0 = [[k_w_w, k_w_theta], [k_w_theta, k_theta_theta]]``.

    Parameters
    ----------
    node : int
        Beam node the joint connects to ground.
    k_w_w : float
        Static translational stiffness, N/m.
    k_theta_theta : float
        Static rotational stiffness, N*m/rad.
    k_w_theta : float
        Coupling stiffness, N/rad (= N*m/m).
    loss_factor : float
        Loss factor eta of every term.
    growth, reference_frequency, exponent : float
        Storage-stiffness rise with frequency (dimensionless, Hz, dimensionless).
    dofs : sequence of {"w", "theta"}
        Joint DOFs kept (the matrix is restricted to them).
    """
    K0 = np.array([[k_w_w, k_w_theta], [k_w_theta, k_theta_theta]], dtype=float)
    keep = [("w", "theta").index(d) for d in dofs]
    K0 = K0[np.ix_(keep, keep)]

    def stiffness(f_hz: np.ndarray) -> np.ndarray:
        s = 1.0 + growth * (np.asarray(f_hz) / reference_frequency) ** exponent
        return s[:, None, None] * K0[None] * (1.0 + 1j * loss_factor)

    return ComplexStiffness(tuple(Dof(node, d) for d in dofs), stiffness, "parametric joint")


def joint_from_spec(joint) -> ComplexStiffness:
    """The true joint of a study's ``[joint]`` / ``[joint.model]`` section (:class:`~jointid.study.parse.JointSpec`)."""
    model = joint.model
    if model is None:
        raise StudyError("the study has no [joint.model] section: add one to simulate the joint")
    if model.type == "parametric":
        return parametric_joint(joint.node, dofs=joint.dofs, **dict(model.parameters))
    if model.type == "elastomer":
        from .elastomer_joint import elastomer_joint_from_parameters

        return elastomer_joint_from_parameters(joint.node, joint.dofs, dict(model.parameters))
    raise StudyError(f"[joint.model].type: unknown joint model {model.type!r}")
