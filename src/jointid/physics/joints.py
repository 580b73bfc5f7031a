"""Joint models, registered by type: every study's true joints are built here, for any structure.

A joint is a :class:`~jointid.physics.structure.ComplexStiffness` on its DOFs (one side,
grounded) or on ``dofs + other`` (between two parts). :data:`JOINT_MODELS` maps a study's
``[joint.model] type`` to its builder ``build(dofs, other, parameters, name)``:

``"mount"``
    :class:`~jointid.physics.mount.MountModel`, the parametric joint:
    ``K*(f) = K0 (1 + growth (f / reference_frequency)^exponent) (1 + j loss_factor)`` with
    ``stiffness`` (one per DOF) on the diagonal of ``K0`` and ``couplings`` (``(dof_i, dof_j, value)``) off it.
``"parametric"``
    The beam study's shorthand for a mount on ``(node w, node theta)``: ``k_w_w`` (N/m),
    ``k_theta_theta`` (N*m/rad), ``k_w_theta`` (N/rad) and the same frequency law (the formula
    lives once, in :class:`~jointid.physics.mount.MountModel`).
``"matrix"``
    A joint given as a table (a measured or computed one, e.g. a previous identification):
    ``frequency_hz`` (F0,) and ``stiffness`` (F0, k, k) complex, interpolated linearly in
    frequency (real and imaginary parts) on the lines asked for, which must lie in the table's band.
``"elastomer"``
    The elastomer cylinder's FE model (:mod:`jointid.physics.elastomer_joint`) on one
    (translation, rotation) pair of the joint's DOFs (``pair``, ``sigma``;
    :func:`~jointid.physics.elastomer_mount.elastomer_mount`), or, without ``pair``, on a beam
    node's ``(w, theta)`` (or one of them).

A new joint model is one builder added to :data:`JOINT_MODELS` (and its keys to the study schema).
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..dofs import DIRECTIONS, Dof, parse_dof
from ..errors import ModelError
from .mount import MountModel
from .structure import ComplexStiffness

__all__ = ["parametric_joint", "build_joint", "JOINT_MODELS"]


def parametric_joint(
    node: int,
    k_w_w: float,
    k_theta_theta: float,
    k_w_theta: float = 0.0,
    loss_factor: float = 0.1,
    growth: float = 0.0,
    reference_frequency: float = 100.0,
    exponent: float = 1.0,
    dofs: Sequence[str] = DIRECTIONS,
) -> ComplexStiffness:
    """A grounded beam joint with a frequency-dependent complex 2x2 stiffness (a :class:`MountModel`).

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

    Raises
    ------
    ModelError
        ``K0`` not positive definite, or a law that is not passive.
    """
    return build_joint("parametric", tuple(Dof(node, d) for d in dofs), (), {
        "k_w_w": k_w_w, "k_theta_theta": k_theta_theta, "k_w_theta": k_w_theta, "loss_factor": loss_factor,
        "growth": growth, "reference_frequency": reference_frequency, "exponent": exponent,
    }, "parametric joint")


def _law(p: Mapping[str, Any]) -> dict:
    return {k: float(p.get(k, d)) for k, d in (("loss_factor", 0.1), ("growth", 0.0), ("reference_frequency", 100.0), ("exponent", 1.0))}


def _mount(dofs, other, p, name) -> ComplexStiffness:
    k = len(dofs)
    stiffness = p["stiffness"]
    if len(stiffness) != k:
        raise ModelError(f"{name}: {len(stiffness)} stiffnesses for {k} DOFs; give one per DOF")
    K0 = np.diag(np.asarray(stiffness, dtype=float))
    pos = {d: i for i, d in enumerate(dofs)}
    for a, b, v in p.get("couplings", ()):
        i, j = pos[parse_dof(a)], pos[parse_dof(b)]
        K0[i, j] = K0[j, i] = v
    mount = MountModel(tuple(dofs), K0, other=tuple(other), **_law(p))
    return ComplexStiffness(mount.joint_dofs, mount, name)


def _parametric(dofs, other, p, name) -> ComplexStiffness:
    if other:
        raise ModelError(f"{name}: the parametric beam joint is grounded; use type = \"mount\" between two parts")
    K0 = {("w", "w"): p["k_w_w"], ("theta", "theta"): p["k_theta_theta"], ("w", "theta"): p.get("k_w_theta", 0.0)}
    directions = [d.direction for d in dofs]
    stiffness = [K0[(d, d)] for d in directions]
    couplings = [(str(dofs[0]), str(dofs[1]), K0[("w", "theta")])] if directions == ["w", "theta"] and K0[("w", "theta")] else []
    return _mount(dofs, (), {**_law(p), "stiffness": stiffness, "couplings": couplings}, name)


def _elastomer(dofs, other, p, name) -> ComplexStiffness:
    from .elastomer_joint import elastomer_joint_model
    from .elastomer_mount import elastomer_mount

    material = {k: v for k, v in p.items() if k not in ("pair", "sigma", "axes", "cylinder_axis")}
    fe = elastomer_joint_model(material)
    if "pair" in p:
        return elastomer_mount(fe, tuple(dofs), tuple(p["pair"]), int(p["sigma"]), tuple(other), name)
    if other or len({d.node for d in dofs}) != 1 or not all(d.direction in DIRECTIONS for d in dofs):
        raise ModelError(f"{name}: an elastomer joint without axes acts on one beam node's (w, theta); give axes for other DOFs")
    return fe.complex_stiffness(dofs[0].node, tuple(d.direction for d in dofs), name=name)


def _matrix(dofs, other, p, name) -> ComplexStiffness:
    f0 = np.asarray(p["frequency_hz"], float)
    K0 = np.asarray(p["stiffness"], complex)
    k = len(dofs) + len(other)
    if K0.shape != (f0.size, k, k) or f0.size < 2 or not np.all(np.diff(f0) > 0):
        raise ModelError(f"{name}: a joint table needs increasing frequencies and a {k} x {k} matrix on each, got {K0.shape}")
    if not np.all(np.isfinite(K0)):
        raise ModelError(f"{name}: the joint table has values that are not finite")

    def stiffness(f_hz: np.ndarray) -> np.ndarray:
        f = np.atleast_1d(np.asarray(f_hz, float))
        if f.size and (f.min() < f0[0] or f.max() > f0[-1]):
            raise ModelError(f"{name}: lines at {f.min():g}-{f.max():g} Hz reach outside the joint table's {f0[0]:g}-{f0[-1]:g} Hz")
        flat = K0.reshape(f0.size, -1)
        re = np.stack([np.interp(f, f0, c) for c in flat.real.T], axis=1)
        im = np.stack([np.interp(f, f0, c) for c in flat.imag.T], axis=1)
        return (re + 1j * im).reshape(f.size, k, k)

    return ComplexStiffness(tuple(dofs) + tuple(other), stiffness, name)


#: ``[joint.model] type`` -> ``build(dofs, other, parameters, name) -> ComplexStiffness``.
JOINT_MODELS: dict[str, Callable[..., ComplexStiffness]] = {
    "mount": _mount,
    "parametric": _parametric,
    "elastomer": _elastomer,
    "matrix": _matrix,
}


def build_joint(type: str, dofs: Sequence[Dof], other: Sequence[Dof], parameters: Mapping[str, Any], name: str = "joint") -> ComplexStiffness:
    """The joint model registered as ``type`` on ``dofs`` (grounded) or ``dofs + other``, as a ComplexStiffness.

    Raises
    ------
    ModelError
        An unknown type, or parameters the model refuses (one line naming the joint).
    """
    if type not in JOINT_MODELS:
        raise ModelError(f"{name}: unknown joint model type {type!r}; known: {', '.join(JOINT_MODELS)}")
    try:
        return JOINT_MODELS[type](tuple(dofs), tuple(other), parameters, name)
    except ModelError as exc:
        text = str(exc)
        raise ModelError(text if text.startswith(name) else f"{name}: {text}") from None
