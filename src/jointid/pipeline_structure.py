"""From a ``[structure]`` study to virtual tests and identifications of several joints at once.

The general path behind ``jointid simulate`` / ``jointid identify`` for studies
whose free structure comes from matrix files (:mod:`jointid.study.structures`);
:mod:`jointid.pipeline` dispatches here. The free model is a
:class:`~jointid.physics.sparse_model.SparseModel`; only its receptance on the
observed, joint and excited DOFs (m, n, e) is ever computed.

The models (free structure, true joints, test article) come from
:mod:`jointid.models`; ``structure_model``, ``true_joints``,
``true_joint_matrix`` and ``constrained_structure`` are re-exported here.

**Simulation** (the constrained structure's FRFs, exactly): every joint's true
matrix (a mount between two sets contributes ``[[K, -K], [-K, K]]``, an
elastomer joint its two-end condensation) is attached
to the free model by :class:`~jointid.physics.jointed_model.JointedModel`
(Woodbury: ``H[m,e] = Y[m,e] - Y[m,n] (I + Du Y[n,n])^-1 Du Y[n,e]``, vectorized
over lines; ``Du`` may be singular). The same test article serves the virtual
roving-hammer experiment (:func:`jointid.pipeline.experiment`).

**Identification**: all joints at once,
:func:`~jointid.methods.receptance.coupling.identify_joint_coupling` with the joint DOFs of
every joint concatenated (a full symmetric ``Du``: the terms between joints are
estimated too, and should vanish); the result is split into one
:class:`~jointid.methods.receptance.coupling.CouplingResult` per joint
(:func:`split_joints`), and :func:`cross_joint_ratio` reports how large the
terms between joints came out relative to the joints' own terms (a diagnostic
of model error or of a joint the study does not list).

**Model updating** (:func:`update_structure`, behind ``jointid update``): the
free structure's ``stiffness_scale``, ``mass_scale`` and ``loss_factor`` fitted
to free-free FRFs (no joints) on the observed x excited DOFs, by
:func:`jointid.methods.updating.fit.update_free_model` on
:class:`jointid.methods.updating.scaled_matrices.ScaledMatrixFamily` (one modal
basis for the whole fit: exact scaling law).
"""

from __future__ import annotations

import os

import numpy as np

from .errors import StudyError
from .frequency import Frequency
from .frf import FRF
from .methods.receptance.coupling import identify_joint_coupling
from .models import constrained_model, structure_model, true_joint_matrix, true_joints  # re-exported
from .study.parse import Study

__all__ = [
    "structure_model", "true_joints", "true_joint_matrix", "constrained_structure", "simulate_structure",
    "read_measured_structure", "identify_structure", "split_joints", "cross_joint_ratio",
    "structure_parameters", "simulate_free_structure", "read_free_measured_structure", "update_structure",
]


def constrained_structure(study: Study):
    """The test article of a ``[structure]`` study (:func:`jointid.models.constrained_model`): a
    :class:`~jointid.physics.jointed_model.JointedModel`.

    Raises
    ------
    StudyError
        A ``[beam]`` study, or a joint without ``[joint.model]`` or whose model cannot be built.
    """
    if not study.is_structure:
        raise StudyError(f"{study.source}: a [structure] study is needed here; this one has [beam]")
    return constrained_model(study)


def simulate_structure(study: Study, frequency: Frequency | None = None):
    """Exact accelerances of the structure on all its true joints at the study's observed x excited DOFs.

    Parameters
    ----------
    frequency : Frequency, optional
        Default: the study's grid (a 0 Hz line is dropped: the free receptance is singular there).

    Returns
    -------
    VirtualTest
        ``frf`` accelerance ``(m/s^2)/N`` (rotations: rad/s^2, per N*m), ``truth`` (F, n, n) on ``joint_dofs``
        = every joint's DOFs in study order.
    """
    from .pipeline import VirtualTest

    frequency = frequency or study.grid
    if frequency.hz[0] <= 0:
        frequency = frequency[frequency.hz > 0]
    article = constrained_structure(study)  # matrices read and joint models built once
    m = study.measurement
    H = article.receptance(frequency, m.observed_dofs, m.excited_dofs)
    Du = article.joint_stiffness(frequency.hz)
    frf = FRF(frequency, H, m.observed_dofs, m.excited_dofs, "receptance").to("accelerance")
    return VirtualTest(frf, Du, study.joint_dofs)


def read_measured_structure(study: Study, path: str | os.PathLike) -> FRF:
    """Read the study's observed x excited FRFs from a file: UFF direction codes 1-6 are x..rz (negative: flipped).

    ``[measurement.points]`` (if given) maps file point ids to model nodes.
    """
    from .io.frf_files import read_frf

    m = study.measurement
    return read_frf(
        path, points=m.point_map, axis=None, responses=m.observed_dofs, references=m.excited_dofs, coherence=True
    )


def identify_structure(study: Study, measured: FRF, options=None):
    """Identify every joint of a structure study at once (one ``Du`` on all joint DOFs).

    Uses the lines of ``measured`` inside ``[frequency] start..stop`` (above 0 Hz);
    responses and references are reordered to the study's observed/excited DOFs.
    Split the result per joint with :func:`split_joints`.

    The method is ``[identification].method`` unless ``options`` says otherwise: the
    receptance method (:class:`~jointid.methods.receptance.coupling.CouplingOptions`, any model size) or the plain Hong &
    Lee method (:class:`~jointid.methods.hong_lee.inverse.InverseOptions`) on the dense model,
    for models of at most :data:`~jointid.physics.sparse_model.DENSE_STRUCTURE_MAX_DOFS`
    DOFs (it solves with ``Do[nbar, mbar]`` on every line).

    Raises
    ------
    DataError
        The file lacks one of the study's DOFs.
    StudyError
        Hong & Lee on a model too large for it (one line).
    """
    from .errors import ModelError
    from .methods.hong_lee.inverse import InverseOptions, identify_joint
    from .pipeline import coupling_options, inverse_options, study_frfs

    data = study_frfs(study, measured)
    if isinstance(options, InverseOptions) or (options is None and study.identification.method == "hong-lee"):
        try:
            dense = structure_model(study).dense_structure()
        except ModelError as exc:
            raise StudyError(f"{study.source}: [identification].method = 'hong-lee': {exc}") from None
        return identify_joint(dense, data, study.joint_dofs, options or inverse_options(study))
    return identify_joint_coupling(structure_model(study), data, study.joint_dofs, options or coupling_options(study))


def split_joints(study: Study, result):
    """One result per ``[[joint]]`` (name -> its block of ``result``, a CouplingResult or InverseResult), in study order."""
    out, i = {}, 0
    for joint in study.joints:
        k = len(joint.joint_dofs)
        out[joint.name] = result.subset(range(i, i + k))
        i += k
    return out


def cross_joint_ratio(study: Study, stiffness: np.ndarray) -> float:
    """Largest ``|K_ij|`` between DOFs of different joints over the largest within-joint ``|K_ij|`` (all lines).

    0 for a single joint. The true ``Du`` is block diagonal, so on exact data
    this is round-off; a large value points to model error or a joint missing
    from the study.
    """
    owner = np.concatenate([np.full(len(j.joint_dofs), a) for a, j in enumerate(study.joints)])
    cross = owner[:, None] != owner[None, :]
    if not cross.any():
        return 0.0
    mag = np.abs(stiffness)
    return float(mag[:, cross].max() / mag[:, ~cross].max())


# --------------------------------------------------------------------------- free-free test and model updating
def structure_parameters(study: Study) -> dict:
    """The ``[structure]`` values :func:`update_structure` can fit: ``stiffness_scale``, ``mass_scale``, ``loss_factor``."""
    spec = study.structure
    return {"stiffness_scale": spec.stiffness_scale, "mass_scale": spec.mass_scale, "loss_factor": spec.loss_factor}


def simulate_free_structure(study: Study, frequency: Frequency | None = None, noise: float = 0.0, seed: int = 0) -> FRF:
    """A virtual free-free test: accelerances of the study's free structure (no joints) at its observed x excited DOFs.

    The structure is ``[structure]`` as given (matrices times ``stiffness_scale``,
    ``mass_scale``; ``loss_factor``): to test a model against a different true
    structure, simulate a study of that structure.

    Parameters
    ----------
    frequency : Frequency, optional
        Default: the study's grid (a 0 Hz line is dropped: a free structure has no receptance there).
    noise : float
        Relative rms of complex Gaussian noise on every value, ``H (1 + noise n)``,
        ``n`` circular with ``E|n|^2 = 1`` (0: exact).
    seed : int
        Seed of the noise.

    Returns
    -------
    FRF
        Accelerance, (m/s^2)/N (rotations rad/s^2, per N*m), shape (F, |m|, |e|).
    """
    from .errors import DataError

    if not (np.isfinite(noise) and noise >= 0):
        raise DataError(f"noise must be a relative rms >= 0, got {noise!r}")
    frequency = frequency or study.grid
    if frequency.hz[0] <= 0:
        frequency = frequency[frequency.hz > 0]
    m = study.measurement
    Y = structure_model(study).receptance(frequency, m.observed_dofs, m.excited_dofs)
    frf = FRF(frequency, Y, m.observed_dofs, m.excited_dofs, "receptance").to("accelerance")
    if noise > 0:
        rng = np.random.default_rng(seed)
        n = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2.0)
        frf = FRF(frf.frequency, frf.data * (1.0 + noise * n), frf.responses, frf.references, frf.kind)
    return frf


def read_free_measured_structure(study: Study, path: str | os.PathLike) -> FRF:
    """Read a free-free FRF file (the structure without joints) on the study's observed x excited DOFs, with coherence.

    Read like :func:`read_measured_structure` (UFF direction codes 1-6 are x..rz,
    ``[measurement.points]`` applies).
    """
    return read_measured_structure(study, path)


def update_structure(study: Study, measured: FRF, options=None):
    """Update the free structure of a ``[structure]`` study from free-free FRFs over the study's band.

    Fits ``stiffness_scale`` (alpha), ``mass_scale`` (beta) and ``loss_factor`` (eta)
    of ``alpha K (1 + j eta) - w^2 beta M`` (any subset, ``options.parameters``;
    default all three) to the observed x excited FRFs of ``measured`` in
    ``[frequency] start..stop`` (above 0 Hz, on the data's own lines): see
    :func:`jointid.methods.updating.fit.update_free_model` and
    :mod:`jointid.methods.updating.scaled_matrices`.

    Returns
    -------
    UpdateResult

    Raises
    ------
    ModelError
        A parameter that is not one of the structure's (one line naming the allowed ones).
    DataError
        The file lacks one of the study's DOFs; the fit did not converge.
    """
    from .methods.updating.fit import (
        DEFAULT_STRUCTURE_PARAMETERS, STRUCTURE_PARAMETERS, UpdateOptions, check_parameter_names, update_free_model,
    )
    from .methods.updating.scaled_matrices import ScaledMatrixFamily
    from .pipeline import study_frfs

    options = options or UpdateOptions(parameters=DEFAULT_STRUCTURE_PARAMETERS)
    check_parameter_names(options.parameters, known=STRUCTURE_PARAMETERS, prefix=f"{study.source}: a [structure] study: ")
    initial = structure_parameters(study)
    family = ScaledMatrixFamily(structure_model(study), initial, study.structure.method)
    return update_free_model(family, initial, study_frfs(study, measured), options)
