"""The study-to-model translation, in one place: a validated study's free model, true joints and test article.

Every command and study that needs a model of a :class:`~jointid.study.Study` gets it
here, whatever its free structure (the free-structure protocol of
:mod:`jointid.study.structures`: the ``[beam]`` factory, matrix files, ...):

* :func:`free_model` -- ``study.structure.free_model(stop)``, with the ``[accelerometers]``
  (mass on every translation, rotary inertia on every rotation of their nodes) when asked;
* :func:`true_joints` -- every joint's ``[joint.model]`` built by the registry of
  :mod:`jointid.physics.joints` (``type`` -> builder), in study order;
* :func:`constrained_model` -- the test article: the free model with its accelerometers and
  every true joint (``free.with_joints``: a dense beam assembles them, a sparse model couples
  them by Woodbury).

Each true joint is a :class:`~jointid.physics.structure.ComplexStiffness`
(``joint(f_hz)`` -> (F, k, k) complex, on ``joint.dofs``). The paper studies' configuration
(:mod:`jointid.reproduce.config`, not a study file) has its own translation in
:func:`config_elastomer_joint` and :func:`config_beam`.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .errors import ModelError, StudyError
from .physics.structure import ComplexStiffness, Structure
from .study import Study

__all__ = [
    "free_model", "uncertain_free_model", "true_joint", "true_joints", "build_true_joint", "true_joint_matrix",
    "constrained_model", "config_elastomer_joint", "config_beam", "UNCERTAINTY_MAX_RELATIVE",
]


def free_model(study: Study, with_accelerometers: bool | None = None, refined: bool = True):
    """The free model ``Do`` of the study (with its ``[accelerometers]`` when asked).

    Parameters
    ----------
    with_accelerometers : bool, optional
        Default: ``[identification].model_accelerometers``.
    refined : bool
        Mesh for FRFs converged up to ``[frequency].stop`` where the structure is meshed by
        jointid (the beam: ``[beam].elements_per_segment`` or :mod:`jointid.physics.beam_mesh`'s
        criterion); False: the structure as given (the beam's grid, the paper's model).

    Raises
    ------
    StudyError
        A matrix file that cannot be read or does not fit the DOF list (one line naming the key and file).
    """
    try:
        model = study.structure.free_model(study.frequency.stop if refined else None)
    except StudyError as exc:
        raise StudyError(f"{study.source}: {exc}") from None
    if with_accelerometers is None:
        with_accelerometers = study.identification.model_accelerometers
    acc = study.accelerometers
    if with_accelerometers and acc is not None:
        model = model.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
    return model


class _FamilyMember:
    """One member (parameter ``values``) of an update model family as a free model (``dofs``, ``receptance``)."""

    def __init__(self, family, values: Mapping[str, float]) -> None:
        self.family, self.values = family, dict(values)

    @property
    def dofs(self):
        return tuple(self.family.dofs(self.values))

    def receptance(self, frequency, rows, cols) -> np.ndarray:
        return self.family.receptance(self.values, frequency, rows, cols)


#: An ``[uncertainty]`` standard deviation may be at most this fraction of its parameter's value (linear propagation;
#: ``jointid update`` writes none larger).
UNCERTAINTY_MAX_RELATIVE = 0.5


def uncertain_free_model(study: Study, free):
    """``free`` with what the study says of its errors: ``[uncertainty]`` and a mesh coarser than the criterion's.

    ``[uncertainty]``: models at ``p -+ v_i`` per direction of the parameters' covariance, on the
    parameterized model ``jointid update`` fits (``study.structure.update_model``); the directions ``v_i``
    are the covariance's eigenvectors times the square roots of their eigenvalues (directions of zero
    variance are left out). A free structure meshed coarser than its convergence criterion
    (``study.structure.reference_model``) adds the converged model as a reference (its discretization
    error). Returns ``free`` itself when there is neither, else a
    :class:`~jointid.physics.free_model.UncertainFreeModel`.

    Raises
    ------
    StudyError
        An ``[uncertainty]`` parameter of the accelerometers on a study that does not model them, or a standard
        deviation above :data:`UNCERTAINTY_MAX_RELATIVE` times its parameter.
    """
    from .physics.free_model import StructureModel, UncertainFreeModel, as_free_model

    acc = study.accelerometers if study.identification.model_accelerometers else None
    reference = study.structure.reference_model(study.frequency.stop)
    spec = study.uncertainty
    if spec is None and reference is None:
        return free
    directions, said = [], []
    if spec is not None:
        names, cov = spec.covariance()
        build, initial, _, _ = study.structure.update_model(acc, study.frequency.stop)
        missing = [k for k in names if k not in initial]
        if missing:
            raise StudyError(f"{study.source}: [uncertainty].{missing[0]}: this study's free model has no such parameter "
                             "(accelerometer parameters need [accelerometers] and [identification] model_accelerometers = true)")
        std = np.sqrt(np.diag(cov))
        for k, sd in zip(names, std):
            if not sd <= UNCERTAINTY_MAX_RELATIVE * abs(initial[k]):  # what `jointid update` writes at most
                raise StudyError(f"{study.source}: [uncertainty].{k} = {sd:g} is above {UNCERTAINTY_MAX_RELATIVE:g} times the "
                                 f"parameter ({initial[k]:g}): the propagation of the free model's uncertainty is linear, "
                                 "and holds for standard deviations well below the values; give a smaller one or leave it out")
        lam, vec = np.linalg.eigh(cov)
        keep = lam > lam.max() * 1e-12 if lam.max() > 0 else np.zeros(lam.size, bool)
        steps = vec[:, keep] * np.sqrt(lam[keep])  # (parameters, directions)

        def member(values):
            return StructureModel(build(values)) if callable(build) else _FamilyMember(build, values)

        for v in steps.T:
            pair = []
            for sign in (-1.0, 1.0):
                values = dict(initial)
                values.update({k: initial[k] + sign * dv for k, dv in zip(names, v)})
                pair.append(member(values))
            directions.append(tuple(pair))
        said.append(f"its parameter uncertainty ([uncertainty]: {', '.join(names)})")
    references = ()
    if reference is not None:
        finer, text = reference
        if acc is not None:
            finer = finer.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
        references = (as_free_model(finer),)
        said.append(text)
    return UncertainFreeModel(as_free_model(free), tuple(directions), "the free model's error: " + " and ".join(said), references)


def build_true_joint(joint, source: str = "<study>") -> ComplexStiffness:
    """One joint (:class:`~jointid.study.JointSpec`) as a ComplexStiffness on ``joint.joint_dofs`` (the registry's model).

    Raises
    ------
    StudyError
        No ``[joint.model]``, or a model the physics refuses (not passive, an elastomer the FE
        model cannot build): one line starting with ``source`` and naming the joint.
    """
    from .physics.joints import build_joint

    if joint.model is None:
        raise StudyError(f"{source}: [[joint]] {joint.name!r} has no [joint.model] table: add one to simulate the joint")
    try:
        return build_joint(joint.model.type, joint.dofs, joint.other, joint.model.parameters, joint.name)
    except ModelError as exc:
        raise StudyError(f"{source}: [[joint]] {joint.name!r} [joint.model]: {str(exc).removeprefix(joint.name + ': ')}") from None


def true_joints(study: Study) -> list[ComplexStiffness]:
    """Every true joint of the study as a ComplexStiffness, in study order.

    Raises
    ------
    StudyError
        A joint without ``[joint.model]`` or with a model that cannot be built.
    """
    return [build_true_joint(joint, study.source) for joint in study.joints]


def true_joint(study: Study) -> ComplexStiffness:
    """The true joint of a study of one joint (several: :func:`true_joints`).

    Raises
    ------
    StudyError
        No ``[joint.model]``, or several joints.
    """
    if len(study.joints) != 1:
        raise StudyError(f"{study.source}: the study has {len(study.joints)} joints; use true_joints")
    return true_joints(study)[0]


def true_joint_matrix(study: Study, frequency_hz) -> np.ndarray:
    """Every true joint's matrix on ``study.joint_dofs`` (summed in, block diagonal), shape (F, n, n), complex."""
    from .physics.jointed_model import assemble_joints

    return assemble_joints(true_joints(study), frequency_hz)


def constrained_model(study: Study):
    """The test article: the free model with its accelerometers (if any) and every true joint attached.

    Raises
    ------
    StudyError
        A joint without ``[joint.model]`` or with a model that cannot be built.
    """
    return free_model(study, with_accelerometers=True).with_joints(true_joints(study))


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
