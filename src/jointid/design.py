"""From a study to a test design: where to measure and hit (the API behind ``jointid design``).

Like :mod:`jointid.pipeline`, it only translates study settings into a call of
:func:`jointid.methods.design.layout.design_layout`: the free beam meshed for
convergence (:func:`jointid.pipeline.free_model`, without the sensors, which
the design adds per layout), the study's ``[joint.model]`` as the expected joint,
the ``[accelerometers]`` (on the observed nodes when the study has them exactly
there, so they move with a new layout; otherwise fixed where the study puts them),
``[identification].model_accelerometers`` and ``symmetric``, and the band
``[frequency] start..stop`` on the study's grid.

A ``[structure]`` study (:func:`_design_on_dofs`): the candidates are DOFs
(default every translational DOF of the nodes the study observes or excites), the
free model its :class:`~jointid.physics.sparse_model.SparseModel`, the expected joint
the block-diagonal assembly of every ``[[joint]]``'s ``[joint.model]`` and the
criterion over each joint's own terms (``"front:K_x_x"`` with several joints).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Sequence

import numpy as np

from .dofs import Dof, DofArray, pack_dof_keys, parse_dof
from .errors import DofError, StudyError
from .frequency import Frequency
from .methods.design.layout import LayoutDesign, Scenario, Sensors, design_layout
from .models import true_joints
from .pipeline import coupling_options, free_model, true_joint
from .study import Study

__all__ = [
    "design_study", "dof_candidates", "study_sensors", "with_layout", "design_band",
    "hammer_noise", "MAX_CANDIDATES",
]

#: Most candidate DOFs a ``[structure]`` design searches (the search costs about K x candidates layouts per pass).
MAX_CANDIDATES = 300


def study_sensors(study: Study) -> Sensors | None:
    """The study's accelerometers as :class:`Sensors` (``nodes=None``: they ride on the observed nodes)."""
    acc = study.accelerometers
    if acc is None:
        return None
    follow = set(acc.nodes) == set(study.measurement.observed)
    return Sensors(acc.mass, acc.rotary_inertia, None if follow else tuple(acc.nodes), study.identification.model_accelerometers)


def with_layout(study: Study, observed: Sequence, excited: Sequence) -> Study:
    """The study with ``[measurement]`` observed/excited replaced (accelerometers follow as in :func:`study_sensors`).

    Beam nodes for a ``[beam]`` study, DOF labels or :class:`~jointid.dofs.Dof` for a
    ``[structure]`` study. A ``[measurement.points]`` map is kept only if it still names every node.
    """
    m = study.measurement
    if study.beam is None:  # layouts of DOF labels (the beam's shorthand: nodes, transverse w)
        try:
            observed, excited = tuple(parse_dof(d) for d in observed), tuple(parse_dof(d) for d in excited)
        except DofError as exc:
            raise StudyError(f"layout: {exc}") from None
        nodes = {d.node for d in observed + excited}
        points = m.points if nodes <= {node for _, node in m.points} else ()
        return dataclasses.replace(study, measurement=dataclasses.replace(m, observed=observed, excited=excited, points=points))
    nodes = set(observed) | set(excited)
    points = m.points if nodes <= {node for _, node in m.points} else ()
    measurement = dataclasses.replace(m, observed=tuple(observed), excited=tuple(excited), points=points)
    acc = study.accelerometers
    if acc is not None and set(acc.nodes) == set(m.observed):
        acc = dataclasses.replace(acc, nodes=tuple(observed))
    return dataclasses.replace(study, measurement=measurement, accelerometers=acc)


def design_band(study: Study, band_hz: tuple[float, float] | None = None) -> Frequency:
    """The lines of the study's grid inside ``band_hz`` (default ``[frequency] start..stop``), above 0 Hz."""
    f = study.grid.hz
    lo, hi = band_hz if band_hz is not None else (study.frequency.start, study.frequency.stop)
    if not (0 <= lo < hi):
        raise StudyError(f"band: expected 0 <= low < high (Hz), got {lo:g}-{hi:g}")
    keep = f[(f >= lo) & (f <= hi) & (f > 0)]
    if keep.size < 8:
        raise StudyError(
            f"band {lo:g}-{hi:g} Hz holds {keep.size} lines of the study's [frequency] grid; a design needs at least 8"
        )
    return Frequency(keep)


def design_study(
    study: Study, observed: int | None = None, excited: int | None = None, *, candidates: Sequence | None = None,
    noise: float = 0.01, weights: Mapping[str, float] | None = None, band_hz: tuple[float, float] | None = None,
    search_lines: int = 300, monte_carlo: int = 0, progress=None, targets: Mapping[str, float] | None = None,
) -> LayoutDesign:
    """Choose ``observed`` and ``excited`` nodes of the study's beam for the best-determined joint.

    Parameters
    ----------
    study : Study
        Needs ``[joint.model]`` (the expected joint).
    observed, excited : int, optional
        K and L (default: as many as the study's ``[measurement]``).
    candidates : sequence of int, optional
        Beam nodes that may be observed or excited (default: every node 1..N); for a
        ``[structure]`` study DOF labels (see :func:`dof_candidates`).
    noise : float
        Relative 1-sigma FRF noise (0.01 = 1 %).
    weights : mapping, optional
        Term -> weight, e.g. ``{"K_theta_theta": 4}``.
    band_hz : (low, high), optional
        Default: ``[frequency] start..stop``.
    search_lines : int
        Lines of the search grid.
    monte_carlo : int
        Seeds of the final Monte Carlo check of the best layouts with the study's identification
        options (0: none; see :mod:`jointid.methods.design.check`).
    progress : callable, optional
        Called with one line after each step of the search (see :func:`~jointid.methods.design.layout.design_layout`).
    targets : mapping, optional
        Term -> target median relative error (0.05 = 5 %): which layout reaches it,
        predicted and (with ``monte_carlo``) confirmed (:mod:`jointid.methods.design.term_goals`);
        default: the study's ``[identification.targets]`` (a study of one joint; with several the
        design names terms ``"joint:K_x_x"``).

    Returns
    -------
    LayoutDesign
        With the study's current layout for comparison.

    Raises
    ------
    StudyError
        No ``[joint.model]``, a candidate that is not a beam node, an empty band.
    IdentificationError
        K or L out of range, an unknown term weight.
    """
    if targets is None and study.identification.targets and len(study.joints) == 1:  # the study's own (one joint: same names)
        targets = dict(study.identification.targets)
    if study.beam is None:  # candidates are DOFs (the beam's shorthand: nodes, with its sensor model)
        return _design_on_dofs(
            study, observed, excited, candidates=candidates, noise=noise, weights=weights, band_hz=band_hz,
            search_lines=search_lines, monte_carlo=monte_carlo, progress=progress, targets=targets,
        )
    if study.joint.model is None:
        raise StudyError(f"{study.source}: [joint.model] is missing; a design needs the expected joint stiffness")
    n_nodes = study.beam.nodes
    if candidates is None:
        candidates = range(1, n_nodes + 1)
    candidates = list(candidates)
    if not candidates:
        raise StudyError("candidates: expected at least one beam node")
    for c in candidates:
        if not 1 <= c <= n_nodes:
            raise StudyError(f"candidates: node {c} is not a node of the beam (nodes 1..{n_nodes})")
    m = study.measurement
    spec = study.identification
    scenarios = _beam_scenarios(study, noise)
    return design_layout(
        free_model(study, with_accelerometers=False),
        true_joint(study),
        study.joint.joint_dofs,
        design_band(study, band_hz),
        candidates,
        len(m.observed) if observed is None else observed,
        len(m.excited) if excited is None else excited,
        noise=noise, weights=weights, sensors=study_sensors(study),
        symmetric=True if spec.symmetric is None else bool(spec.symmetric),
        current=(m.observed, m.excited), search_lines=search_lines,
        monte_carlo=monte_carlo, coupling_options=coupling_options(study), scenarios=scenarios, progress=progress,
        targets=targets,
    )


def _beam_scenarios(study: Study, noise: float) -> list[Scenario]:
    """Relative and hammer-like additive noise, smoothed, each without and with column calibration."""
    scenarios = [Scenario("relative", "smoothed", c) for c in (False, True)]
    scenarios += [Scenario("additive", "smoothed", c, hammer_noise(study, noise)) for c in (False, True)]
    return [scenarios[0], scenarios[2], scenarios[1], scenarios[3]]


def hammer_noise(study: Study, noise: float) -> float:
    """The additive scenario's noise level: a roving-hammer test's response noise per line of the study's grid.

    ``[experiment].response_noise / sqrt(averages * step * duration)``: the response
    noise (relative to the response's rms) averaged over the hits and over the
    ``step * duration`` lines of the test's resolution in one line of the grid (a
    nominal level: the noise floor of a virtual test's FRFs, relative to each FRF's
    rms over the band, scatters around it from FRF to FRF). Without ``[experiment]``: ``noise``.
    """
    x = getattr(study, "experiment", None)
    if x is None:
        return noise
    lines = max(1.0, study.frequency.step * x.duration)
    return float(x.response_noise / math.sqrt(max(1, x.averages) * lines))


def dof_candidates(study: Study, candidates: Sequence | None = None, free=None) -> tuple[Dof, ...]:
    """The candidate DOFs of a design on DOF labels (any free structure but the beam shorthand), checked against the model.

    Default: every translational DOF (x, y, z) the model has at the nodes that
    ``[measurement]`` observes or excites. Given: DOF labels (``"12x"``) or
    :class:`~jointid.dofs.Dof`, each a DOF of the structure. ``free``: the study's free model when the
    caller has built it (default: built here).

    Raises
    ------
    StudyError
        A label that is not a DOF, a DOF not in the structure, none, or more than
        :data:`MAX_CANDIDATES` (one line each).
    """
    free = free if free is not None else free_model(study, with_accelerometers=False)
    dof_array = getattr(free, "dof_array", None) or DofArray.from_dofs(free.dofs)
    if candidates is None:
        m = study.measurement
        nodes = sorted({d.node for d in m.observed_dofs + m.excited_dofs})
        wanted = [Dof(k, c) for k in nodes for c in ("x", "y", "z")]
        keys = pack_dof_keys([d.node for d in wanted], [d.code for d in wanted])
        cands = tuple(d for d, ok in zip(wanted, np.isin(keys, dof_array.keys)) if ok)
    else:
        try:
            cands = tuple(dict.fromkeys(parse_dof(c) for c in candidates))
            dof_array.indices(cands, study.structure.describe())
        except DofError as exc:
            raise StudyError(f"candidates: {exc}") from None
    if not cands:
        raise StudyError("candidates: expected at least one DOF of the structure, e.g. 12x")
    if len(cands) > MAX_CANDIDATES:
        raise StudyError(
            f"candidates: {len(cands)} DOFs, a design searches at most {MAX_CANDIDATES}; "
            "name the DOFs a test can reach with --candidates (e.g. 12x,12z,40y)"
        )
    return cands


def _design_on_dofs(
    study: Study, observed: int | None = None, excited: int | None = None, *, candidates: Sequence | None = None,
    noise: float = 0.01, weights: Mapping[str, float] | None = None, band_hz: tuple[float, float] | None = None,
    search_lines: int = 300, monte_carlo: int = 0, progress=None, targets: Mapping[str, float] | None = None,
) -> LayoutDesign:
    """Choose observed and excited DOFs (of any free structure) for the best-determined joints.

    As :func:`design_study` (which dispatches here), with: candidates from
    :func:`dof_candidates`; the free model the study's
    :class:`~jointid.physics.sparse_model.SparseModel`; the expected joint the
    block-diagonal assembly of every ``[[joint]]``'s ``[joint.model]``
    (:func:`~jointid.models.true_joint_matrix`, joint DOFs
    ``study.joint_dofs``); the criterion over each joint's own terms (with several
    joints named ``"<joint>:K_x_ry"``; a weight without the prefix sets that term of
    every joint); no accelerometers (a structure's sensors are in its matrices). The
    scenarios are the beam's, per line instead of smoothed when
    ``[identification].smoothing = "none"``, the joint spline fit's bound (relative and
    additive noise) where the identification fits one (a mount of 4-6 DOFs).

    Returns
    -------
    LayoutDesign
        Layouts as :class:`~jointid.dofs.Dof`.

    Raises
    ------
    StudyError
        A joint without ``[joint.model]``, a bad candidate (see :func:`dof_candidates`), an empty band.
    """
    from .physics.jointed_model import assemble_joints

    for j in study.joints:
        if j.model is None:
            raise StudyError(
                f"{study.source}: [[joint]] {j.name!r} has no [joint.model] table; a design needs the expected stiffness of every joint"
            )
    free = free_model(study, with_accelerometers=False)  # built once: its DOFs for the candidates, then the design
    cands = dof_candidates(study, candidates, free)
    joints = true_joints(study)
    m = study.measurement
    spec = study.identification
    resolved = coupling_options(study).over_frequency(len(study.joint_dofs))
    if resolved in ("none", "spline"):  # per line, or the joint spline fit's bound (no column calibration)
        estimator = "per-line" if resolved == "none" else "spline"
        scenarios = [Scenario("relative", estimator), Scenario("additive", estimator, False, hammer_noise(study, noise))]
    else:
        scenarios = _beam_scenarios(study, noise)
    return design_layout(
        free,
        lambda f_hz: assemble_joints(joints, f_hz),
        study.joint_dofs,
        design_band(study, band_hz),
        cands,
        len(m.observed) if observed is None else observed,
        len(m.excited) if excited is None else excited,
        noise=noise, weights=weights, sensors=None,
        symmetric=True if spec.symmetric is None else bool(spec.symmetric),
        current=(m.observed_dofs, m.excited_dofs), search_lines=search_lines,
        monte_carlo=monte_carlo, coupling_options=coupling_options(study), scenarios=scenarios, progress=progress,
        blocks=[(j.name, len(j.joint_dofs)) for j in study.joints], targets=targets,
    )
