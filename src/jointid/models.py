"""The study-to-model translation, in one place: a validated study's free model, true joints and test article.

Every command and study that needs a model of a :class:`~jointid.study.parse.Study`
gets it here (:mod:`jointid.pipeline` and :mod:`jointid.pipeline_structure`
re-export these functions under their old names):

=====================  ==============================================  ==============================================
function               ``[beam]`` study                                ``[structure]`` study
=====================  ==============================================  ==============================================
:func:`free_model`     :class:`~jointid.physics.structure.Structure`   :class:`~jointid.physics.sparse_model.SparseModel`
                       (meshed for ``[frequency].stop``, with the      from the matrix files
                       ``[accelerometers]`` when asked)
:func:`true_joints`    ``[joint.model]`` (parametric or elastomer)     every ``[[joint]]``'s ``[joint.model]`` (mount or
                       on ``(node w, node theta)``: one joint          elastomer) on its DOFs, in study order
:func:`constrained_    the beam with its accelerometers on the true    :class:`~jointid.physics.jointed_model.JointedModel`:
model`                 joint (``Structure.with_joint``)                the free model with every true joint (Woodbury)
=====================  ==============================================  ==============================================

Each true joint is a :class:`~jointid.physics.structure.ComplexStiffness`
(``joint(f_hz)`` -> (F, k, k) complex, on ``joint.dofs``); a structure study's
elastomer joint (``type = "elastomer"``) is
:func:`jointid.physics.elastomer_mount.elastomer_mount` on its ``axes``.
The paper studies' configuration (:mod:`jointid.reproduce.config`, not a study
file) has its own translation in :func:`config_elastomer_joint` and
:func:`config_beam`.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .errors import ModelError, StudyError
from .physics.structure import ComplexStiffness, Structure
from .study.parse import Study

__all__ = [
    "free_model", "structure_model", "true_joint", "true_joints", "structure_joint", "true_joint_matrix",
    "constrained_model", "config_elastomer_joint", "config_beam",
]


def free_model(study: Study, with_accelerometers: bool | None = None, refined: bool = True):
    """The free model ``Do`` of the study: the beam (with ``[accelerometers]`` when asked) or the ``[structure]``.

    A ``[structure]`` study: its :class:`~jointid.physics.sparse_model.SparseModel`
    (:func:`structure_model`; the options do not apply).

    Parameters
    ----------
    with_accelerometers : bool, optional
        Default: ``[identification].model_accelerometers``.
    refined : bool
        Mesh the beam between its grid nodes for FRFs converged up to ``[frequency].stop``
        (``[beam].elements_per_segment``, or :mod:`jointid.physics.beam_mesh`'s criterion);
        False: one element per segment (the paper's model on the measurement grid).
    """
    if study.is_structure:  # matrices from files: a SparseModel (no accelerometers, no mesh refinement)
        return structure_model(study)
    beam = study.beam.structure(study.frequency.stop if refined else None)
    if with_accelerometers is None:
        with_accelerometers = study.identification.model_accelerometers
    acc = study.accelerometers
    if with_accelerometers and acc is not None:
        beam = beam.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
    return beam


def structure_model(study: Study):
    """The study's free structure (``[structure]``) as a :class:`~jointid.physics.sparse_model.SparseModel`.

    Raises
    ------
    StudyError
        A ``[beam]`` study, or a matrix file that cannot be read or does not fit the DOF list
        (one line naming the key and file).
    """
    if not study.is_structure:
        raise StudyError(f"{study.source}: a [structure] study is needed here; this one has [beam]")
    try:
        return study.structure.model()
    except StudyError as exc:
        raise StudyError(f"{study.source}: {exc}") from None


def true_joint(study: Study) -> ComplexStiffness:
    """A ``[beam]`` study's true joint (``[joint.model]``) as a complex stiffness on the joint DOFs.

    Raises
    ------
    StudyError
        No ``[joint.model]``, or a ``[structure]`` study (several joints: :func:`true_joints`).
    """
    if study.is_structure:
        raise StudyError(f"{study.source}: a [structure] study has [[joint]] tables; use true_joints")
    from .physics.joints import joint_from_spec

    return joint_from_spec(study.joint)


def structure_joint(joint, source: str = "<study>") -> ComplexStiffness:
    """One ``[[joint]]`` (:class:`~jointid.study.structures.NamedJoint`) as a ComplexStiffness on ``joint.joint_dofs``.

    ``type = "mount"``: :class:`~jointid.physics.mount.MountModel`; ``type = "elastomer"``:
    :func:`~jointid.physics.elastomer_mount.elastomer_mount` (grounded: k x k, zero off its
    ``axes``; between two parts: 2k x 2k, the two-end condensation with both caps).

    Raises
    ------
    StudyError
        No ``[joint.model]``, a mount that is not passive, or an elastomer the FE model refuses
        (one line starting with ``source``).
    """
    from .study.structures import ElastomerSpec

    spec = joint.model
    try:
        if not isinstance(spec, ElastomerSpec):
            return ComplexStiffness(joint.joint_dofs, joint.mount(), joint.name)
        from .physics.elastomer_joint import elastomer_joint_model
        from .physics.elastomer_mount import elastomer_mount

        try:
            fe = elastomer_joint_model(spec.parameters)
        except ModelError as exc:
            raise StudyError(f"[[joint]] {joint.name!r} [joint.model]: {exc}") from None
        return elastomer_mount(fe, joint.dofs, spec.pair, spec.sigma, joint.other, joint.name)
    except StudyError as exc:
        raise StudyError(f"{source}: {exc}") from None


def true_joints(study: Study) -> list[ComplexStiffness]:
    """Every true joint of the study as a ComplexStiffness, in study order (a ``[beam]`` study: one).

    Raises
    ------
    StudyError
        A joint without ``[joint.model]`` or with a model that cannot be built.
    """
    if not study.is_structure:
        return [true_joint(study)]
    return [structure_joint(joint, study.source) for joint in study.joints]


def true_joint_matrix(study: Study, frequency_hz) -> np.ndarray:
    """Every true joint's matrix on ``study.joint_dofs`` (summed in, block diagonal), shape (F, n, n), complex."""
    from .physics.jointed_model import assemble_joints

    return assemble_joints(true_joints(study), frequency_hz)


def constrained_model(study: Study):
    """The test article: the free model with the true joint(s) attached.

    A ``[beam]`` study: the beam with its accelerometers (if any) on the true joint to ground
    (a :class:`Structure`); a ``[structure]`` study: a
    :class:`~jointid.physics.jointed_model.JointedModel` (receptance by Woodbury coupling).

    Raises
    ------
    StudyError
        A joint without ``[joint.model]`` or with a model that cannot be built.
    """
    if study.is_structure:
        from .physics.jointed_model import JointedModel

        return JointedModel(structure_model(study), true_joints(study))
    return free_model(study, with_accelerometers=True).with_joint(true_joint(study))


# --------------------------------------------------------------------------- the paper studies' configuration
def config_elastomer_joint(config, material: str):
    """The :class:`~jointid.physics.elastomer_joint.ElastomerJoint` of ``config.materials[material]`` without end caps.

    The caps are rigid steel masses; "every mass on one side": in the studies the
    beam-side cap belongs to the beam (see :func:`config_beam`), not to the joint.
    """
    from .physics.elastomer_joint import ElastomerJoint

    return ElastomerJoint.from_material(config.materials[material], cap=None)


def config_beam(config, scale: Mapping[str, float] | None = None) -> Structure:
    """The free beam of the studies with the joint's beam-side steel cap as a rigid mass at the joint node.

    Parameters
    ----------
    scale : mapping, optional
        Beam parameter -> factor (``{"elastic_modulus": 1.01}``) for model-error variants.
    """
    from dataclasses import replace

    from .physics.elastomer_joint import EndCap

    spec = config.beam
    if scale:
        spec = replace(spec, **{k: getattr(spec, k) * v for k, v in scale.items()})
    cap = EndCap()
    inertia = cap.rotary_inertia_kg_m2 + cap.mass_kg * cap.offset_m**2
    return spec.structure().with_mass(config.joint_node, cap.mass_kg, inertia)
