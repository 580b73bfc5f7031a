"""The sections of a validated study: one frozen dataclass per TOML table.

:mod:`jointid.study.parse` validates a study file and builds these (it re-exports
every class here, so ``from jointid.study.parse import BeamSpec`` keeps working);
the key-by-key schema, units and defaults are documented there.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from ..dofs import DIRECTIONS, Dof
from ..frequency import Frequency

__all__ = [
    "Study",
    "BeamSpec",
    "JointSpec",
    "JointModelSpec",
    "MeasurementSpec",
    "AccelerometerSpec",
    "IdentificationSpec",
    "FrequencySpec",
    "ExperimentSpec",
    "TruthSpec",
    "TRUTH_KEYS",
]


@dataclass(frozen=True)
class BeamSpec:
    """The free beam: geometry (m), material (Pa, kg/m^3), loss factor, mesh."""

    length: float
    elastic_modulus: float
    density: float
    nodes: int
    width: float | None = None
    height: float | None = None
    diameter: float | None = None
    loss_factor: float = 0.0
    poisson_ratio: float | None = 0.33
    shear_modulus: float | None = None
    shear_coefficient: float = 5.0 / 6.0
    theory: str = "timoshenko"
    elements_per_segment: int | None = None

    def section(self):
        """The cross-section (:class:`~jointid.physics.elements.Section`)."""
        from ..physics.elements import Section

        if self.diameter is not None:
            return Section.circle(self.diameter)
        return Section.rectangle(self.width, self.height)

    def material(self):
        """The beam material (:class:`~jointid.physics.elements.Material`)."""
        from ..physics.elements import Material

        return Material(self.elastic_modulus, self.density, self.loss_factor, self.poisson_ratio, self.shear_modulus)

    def mesh_refinement(self, max_frequency_hz: float | None = None) -> int:
        """Elements per segment between grid nodes: ``elements_per_segment``, or automatic.

        Automatic (key absent) with ``max_frequency_hz``: the convergence criterion of
        :func:`jointid.physics.beam_mesh.elements_per_segment` at that frequency;
        without it: 1 (the grid itself).
        """
        if self.elements_per_segment is not None:
            return self.elements_per_segment
        if max_frequency_hz is None:
            return 1
        from ..physics.beam_mesh import elements_per_segment

        return elements_per_segment(self.length, self.nodes, self.section(), self.material(), max_frequency_hz)

    def structure(self, max_frequency_hz: float | None = None):
        """The free-free beam (:class:`~jointid.physics.structure.Structure`), grid nodes 1..N from x = 0.

        Parameters
        ----------
        max_frequency_hz : float, optional
            Refine the mesh between grid nodes for FRFs converged up to this
            frequency (:meth:`mesh_refinement`); internal nodes are numbered N+1, ...
        """
        from ..physics.structure import beam_structure

        return beam_structure(
            self.length,
            self.section(),
            self.material(),
            self.nodes,
            self.shear_coefficient,
            euler_bernoulli=self.theory == "euler-bernoulli",
            elements_per_segment=self.mesh_refinement(max_frequency_hz),
        )


@dataclass(frozen=True)
class JointModelSpec:
    """The true joint for virtual experiments: ``type`` and its parameters (SI units)."""

    type: str
    parameters: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class JointSpec:
    """Where the joint connects the beam to ground, on which DOFs."""

    node: int
    dofs: tuple[str, ...] = DIRECTIONS
    model: JointModelSpec | None = None

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """The joint coordinates n as labelled DOFs."""
        return tuple(Dof(self.node, d) for d in self.dofs)


@dataclass(frozen=True)
class MeasurementSpec:
    """Observed (response) and excited (force) coordinates; how the FRF file names them.

    Beam studies: ``observed``/``excited`` are beam node numbers (transverse ``w``);
    structure studies: :class:`~jointid.dofs.Dof` (any component).

    ``axis`` is the FRF file's direction that is the model's ``w``;
    ``points`` pairs (file point id, beam node), empty: the file's point ids
    are node numbers.
    """

    observed: tuple
    excited: tuple
    axis: str = "+Z"
    points: tuple[tuple[int, int], ...] = ()

    @property
    def point_map(self) -> dict[int, int] | None:
        """File point id -> beam node, or None (point ids are node numbers)."""
        return dict(self.points) if self.points else None

    @property
    def observed_dofs(self) -> tuple[Dof, ...]:
        """Observed coordinates m (beam: transverse w)."""
        return tuple(n if isinstance(n, Dof) else Dof(n, "w") for n in self.observed)

    @property
    def excited_dofs(self) -> tuple[Dof, ...]:
        """Excited coordinates e (beam: transverse force)."""
        return tuple(n if isinstance(n, Dof) else Dof(n, "w") for n in self.excited)


@dataclass(frozen=True)
class AccelerometerSpec:
    """Accelerometers on the test article: mass (kg), rotary inertia (kg*m^2) each, nodes."""

    mass: float = 0.005
    rotary_inertia: float = 0.0
    nodes: tuple[int, ...] = ()


@dataclass(frozen=True)
class IdentificationSpec:
    """Options of the inverse identification: the method and its options.

    ``method = "receptance"`` (default): weighted receptance-coupling estimator with
    smoothing over frequency and per-term uncertainty (:mod:`jointid.methods.receptance.coupling`);
    ``"hong-lee"``: the paper's per-line method (:mod:`jointid.methods.hong_lee.inverse`).
    ``symmetric`` defaults to true for "receptance" and false for "hong-lee".
    ``calibration`` ("receptance" only): force-calibration error per excitation column,
    corrected when significant ("auto"), always ("columns") or never ("none")
    (:mod:`jointid.methods.receptance.column_calibration`).
    """

    method: str = "receptance"
    smoothing: str = "auto"
    weighting: str = "auto"
    averages: int | None = None
    max_relative_std: float = 0.1
    symmetric: bool | None = None
    calibration: str = "auto"
    regularization: str = "none"
    model_accelerometers: bool = False
    estimation: str = "qr"
    cond_rtol: float = 0.01


@dataclass(frozen=True)
class FrequencySpec:
    """Frequency grid, Hz."""

    start: float
    stop: float
    step: float

    def frequency(self) -> Frequency:
        """The grid as a :class:`~jointid.frequency.Frequency`."""
        return Frequency.from_range(self.start, self.stop, self.step)


@dataclass(frozen=True)
class ExperimentSpec:
    """Virtual roving-hammer experiment settings (Hz, s, N, relative noise rms)."""

    sample_rate: float = 8192.0
    duration: float = 2.0
    averages: int = 5
    force_noise: float = 0.01
    response_noise: float = 0.01
    pulse_duration: float = 0.0005
    pulse_amplitude: float = 100.0
    exponential_window: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class TruthSpec:
    """``[truth]``: how the true (simulated) beam differs from the study's model.

    Each value given replaces the ``[beam]`` key of the same name in the
    structure that ``jointid simulate`` (and ``simulate --free``) synthesizes;
    the study's ``[beam]`` stays the model that ``identify`` and ``update``
    start from. ``None``: as in ``[beam]``.
    """

    elastic_modulus: float | None = None
    density: float | None = None
    loss_factor: float | None = None
    elements_per_segment: int | None = None

    def apply(self, beam: BeamSpec) -> BeamSpec:
        """``beam`` with the overrides applied."""
        return replace(beam, **{k: getattr(self, k) for k in TRUTH_KEYS if getattr(self, k) is not None})


#: Keys of ``[truth]`` (each a ``[beam]`` key).
TRUTH_KEYS = ("elastic_modulus", "density", "loss_factor", "elements_per_segment")


@dataclass(frozen=True)
class Study:
    """A validated study: beam, joint, measurement, frequency grid and optional sections.

    A structure study (``[structure]`` instead of ``[beam]``) has ``beam = None``,
    ``joint = None``, its free structure in ``structure``
    (:class:`~jointid.study.structures.StructureSpec`) and its joints in ``joints``
    (:class:`~jointid.study.structures.NamedJoint`, one or more).
    """

    beam: BeamSpec | None
    joint: JointSpec | None
    measurement: MeasurementSpec
    frequency: FrequencySpec
    accelerometers: AccelerometerSpec | None = None
    identification: IdentificationSpec = IdentificationSpec()
    experiment: ExperimentSpec = ExperimentSpec()
    source: str = "<study>"
    truth: TruthSpec | None = None
    structure: Any = None
    joints: tuple = ()

    @property
    def is_structure(self) -> bool:
        """True for a ``[structure]`` study (matrices from files, ``[[joint]]``), False for a ``[beam]`` study."""
        return self.structure is not None

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """Every joint DOF: the beam joint's, or every ``[[joint]]``'s in order (identified together)."""
        if self.structure is None:
            return self.joint.joint_dofs
        return tuple(d for j in self.joints for d in j.joint_dofs)

    @property
    def grid(self) -> Frequency:
        """The study's frequency grid."""
        return self.frequency.frequency()

    def true_study(self) -> "Study":
        """The study of the true structure: ``[beam]`` with the ``[truth]`` overrides (itself without ``[truth]``)."""
        if self.truth is None:
            return self
        return replace(self, beam=self.truth.apply(self.beam), truth=None)
