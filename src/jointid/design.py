"""From a study to a test design: where to measure and hit (the API behind ``jointid design``).

Like :mod:`jointid.pipeline`, it only translates study settings into a call of
:func:`jointid.methods.design.design_layout`: the free beam meshed for
convergence (:func:`jointid.pipeline.free_model`, without the sensors, which
the design adds per layout), the study's ``[joint.model]`` as the expected joint,
the ``[accelerometers]`` (on the observed nodes when the study has them exactly
there, so they move with a new layout; otherwise fixed where the study puts them),
``[identification].model_accelerometers`` and ``symmetric``, and the band
``[frequency] start..stop`` on the study's grid.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Sequence

from .errors import StudyError
from .frequency import Frequency
from .methods.design import LayoutDesign, Scenario, Sensors, design_layout
from .pipeline import coupling_options, free_model, true_joint
from .study import Study

__all__ = ["design_study", "study_sensors", "with_layout", "design_band", "hammer_noise"]


def study_sensors(study: Study) -> Sensors | None:
    """The study's accelerometers as :class:`Sensors` (``nodes=None``: they ride on the observed nodes)."""
    acc = study.accelerometers
    if acc is None:
        return None
    follow = set(acc.nodes) == set(study.measurement.observed)
    return Sensors(acc.mass, acc.rotary_inertia, None if follow else tuple(acc.nodes), study.identification.model_accelerometers)


def with_layout(study: Study, observed: Sequence[int], excited: Sequence[int]) -> Study:
    """The study with ``[measurement]`` observed/excited replaced (accelerometers follow as in :func:`study_sensors`).

    A ``[measurement.points]`` map is kept only if it still names every node.
    """
    m = study.measurement
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
    study: Study, observed: int | None = None, excited: int | None = None, *, candidates: Sequence[int] | None = None,
    noise: float = 0.01, weights: Mapping[str, float] | None = None, band_hz: tuple[float, float] | None = None,
    search_lines: int = 300, monte_carlo: int = 0,
) -> LayoutDesign:
    """Choose ``observed`` and ``excited`` nodes of the study's beam for the best-determined joint.

    Parameters
    ----------
    study : Study
        Needs ``[joint.model]`` (the expected joint).
    observed, excited : int, optional
        K and L (default: as many as the study's ``[measurement]``).
    candidates : sequence of int, optional
        Beam nodes that may be observed or excited (default: every node 1..N).
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
        options (0: none; see :mod:`jointid.methods.design_check`).

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
    scenarios = [Scenario("relative", "smoothed", c) for c in (False, True)]
    scenarios += [Scenario("additive", "smoothed", c, hammer_noise(study, noise)) for c in (False, True)]
    scenarios = [scenarios[0], scenarios[2], scenarios[1], scenarios[3]]
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
        monte_carlo=monte_carlo, coupling_options=coupling_options(study), scenarios=scenarios,
    )


def hammer_noise(study: Study, noise: float) -> float:
    """The additive scenario's noise level: a roving-hammer test's response noise per line of the study's grid.

    ``[experiment].response_noise / sqrt(averages * step * duration)``: the response
    noise (relative to the response's rms) averaged over the hits and over the
    ``step * duration`` lines of the test's resolution in one line of the grid
    (benchmark: 0.01 / sqrt(5 * 1 * 2) = 0.32 %; the virtual test's FRFs have a noise
    floor of 0.27-0.42 % of each FRF's rms over the band). Without ``[experiment]``: ``noise``.
    """
    x = getattr(study, "experiment", None)
    if x is None:
        return noise
    lines = max(1.0, study.frequency.step * x.duration)
    return float(x.response_noise / math.sqrt(max(1, x.averages) * lines))
