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
    "UncertaintySpec",
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

    #: ``[truth]`` keys of a ``[beam]`` study (each a ``[beam]`` key).
    truth_keys = ("elastic_modulus", "density", "loss_factor", "elements_per_segment")
    #: The study table of this spec, and its keys that name files (relative to the study file).
    study_table = "beam"
    file_keys = ()

    def update_parameter_names(self) -> tuple[dict, tuple[str, ...]]:
        """The parameters ``jointid update`` can fit on a beam (name -> unit, bounds, label) and those it fits by default."""
        from ..methods.updating.parameters import DEFAULT_PARAMETERS, PARAMETERS

        return PARAMETERS, DEFAULT_PARAMETERS

    def free_model(self, max_frequency_hz: float | None = None):
        """The free structure (the free-structure protocol of :mod:`jointid.study.structures`): :meth:`structure`."""
        return self.structure(max_frequency_hz)

    def dense_model(self, max_frequency_hz: float | None = None):
        """The dense free model Hong & Lee solves with: the beam on its grid nodes, or refined where
        ``elements_per_segment`` is given (its estimation step solves for every unobserved DOF, so an
        automatic refinement would multiply its cost)."""
        return self.structure(max_frequency_hz if self.elements_per_segment is not None else None)

    def frf_reading(self, measurement) -> dict:
        """The options of :func:`jointid.io.frf_files.read_frf` for this structure: node range and the file's ``w`` axis."""
        return {"n_nodes": self.nodes, "axis": measurement.axis}

    def describe(self) -> str:
        """One line: what the free structure is."""
        return f"beam {self.length:g} m, {self.nodes} nodes, E {self.elastic_modulus:.4g} Pa, density {self.density:.5g} kg/m^3"

    def reference_model(self, max_frequency_hz: float | None):
        """The beam on the mesh the convergence criterion gives at ``max_frequency_hz``, when ``elements_per_segment``
        sets a coarser one (its discretization error then goes into the joint's bands); else None.

        Returns ``(structure, text)``: the finer beam and one line naming both meshes and the fix.
        """
        if self.elements_per_segment is None or max_frequency_hz is None:
            return None
        auto = replace(self, elements_per_segment=None).mesh_refinement(max_frequency_hz)
        if self.elements_per_segment >= auto:
            return None
        return (replace(self, elements_per_segment=auto).structure(),
                f"its mesh ([beam].elements_per_segment = {self.elements_per_segment}; {auto} converge the FRFs to "
                f"{max_frequency_hz:g} Hz: remove the key or set it to {auto})")

    def update_model(self, accelerometers, max_frequency_hz: float):
        """The beam (and its sensors) as a parameterized model for :func:`jointid.methods.updating.fit.update_free_model`.

        Returns ``(build, initial, known, default)``: ``build(values) -> Structure`` meshed with the
        refinement at ``max_frequency_hz`` (fixed, so the model is smooth in the parameters), ``values``
        replacing ``elastic_modulus``, ``density``, ``loss_factor``, ``shear_coefficient`` and
        ``accelerometers.mass`` / ``accelerometers.rotary_inertia``; ``initial`` the study's values
        (the accelerometer ones only with sensors); the parameter names known and fitted by default.
        """
        from ..methods.updating.parameters import DEFAULT_PARAMETERS, PARAMETERS

        r = self.mesh_refinement(max_frequency_hz)
        beam_keys = ("elastic_modulus", "density", "loss_factor", "shear_coefficient")
        initial = {k: float(getattr(self, k)) for k in beam_keys}
        acc = accelerometers
        if acc is not None:
            initial["accelerometers.mass"] = acc.mass
            initial["accelerometers.rotary_inertia"] = acc.rotary_inertia

        def build(values):
            s = replace(self, elements_per_segment=r, **{k: values[k] for k in beam_keys if k in values}).structure()
            if acc is not None:
                s = s.with_masses(acc.nodes, values.get("accelerometers.mass", acc.mass),
                                  values.get("accelerometers.rotary_inertia", acc.rotary_inertia))
            return s

        return build, initial, PARAMETERS, DEFAULT_PARAMETERS

    def compatible(self, other, source: str = "the study") -> str | None:
        """Why ``other`` cannot be the true structure of the study ``source`` (None: it can): a beam on the same nodes."""
        if not isinstance(other, BeamSpec):
            return f"--truth needs a [beam] study (the true beam of {source}); this one is a [{other.study_table}] study"
        if other.nodes != self.nodes:
            return f"[beam].nodes = {other.nodes} differs from the {self.nodes} of {source}; the true beam needs the same grid of nodes"
        return None

    def structure(self, max_frequency_hz: float | None = None):
        """The free-free beam (:class:`~jointid.physics.structure.Structure`), grid nodes 1..N from x = 0.

        Parameters
        ----------
        max_frequency_hz : float, optional
            Refine the mesh between grid nodes for FRFs converged up to this
            frequency (:meth:`mesh_refinement`); internal nodes are numbered N+1, ...
        """
        from ..physics.structure import build_beam

        return build_beam(
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
    """One joint of a study (every study: the beam's ``[joint]`` is a shorthand for one ``[[joint]]``).

    ``dofs``: side one (grounded joint: its only side); ``other``: side two of a joint between
    two parts (empty: grounded); ``model``: the true joint for virtual tests (``type`` registered in
    :data:`jointid.physics.joints.JOINT_MODELS`), or None.
    """

    name: str
    dofs: tuple[Dof, ...]
    other: tuple[Dof, ...] = ()
    model: JointModelSpec | None = None

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """The joint matrix's DOFs: ``dofs`` (grounded) or ``dofs + other``."""
        return tuple(self.dofs) + tuple(self.other)

    @property
    def node(self) -> int | None:
        """The node of a joint whose DOFs are all on one node (the beam's joint), else None."""
        nodes = {d.node for d in self.joint_dofs}
        return nodes.pop() if len(nodes) == 1 else None


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
    (:mod:`jointid.methods.receptance.column_calibration`). ``units_check``, ``model_check``
    ("receptance" only): refuse FRFs scaled by a unit factor, flag bands the free model does not explain.
    ``targets`` (``[identification.targets]``, "receptance" only): ``(term, relative error)`` pairs; a
    term is flagged reliable only where its predicted relative std is within its target (and within
    ``max_relative_std``); ``jointid design`` reports against them.
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
    units_check: bool = True
    model_check: bool = True
    targets: tuple[tuple[str, float], ...] = ()


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
    """``[truth]``: how the true (simulated) structure differs from the study's model.

    Each value given replaces the free structure's key of the same name (a ``[beam]``:
    ``elastic_modulus``, ``density``, ``loss_factor``, ``elements_per_segment``; a
    ``[structure]``: ``stiffness_scale``, ``mass_scale``, ``loss_factor``) in the structure
    that ``simulate``/``experiment`` (and ``simulate --free``) use; ``identify`` and ``update``
    start from the study's own. ``None``: as in the study.
    """

    elastic_modulus: float | None = None
    density: float | None = None
    loss_factor: float | None = None
    elements_per_segment: int | None = None
    stiffness_scale: float | None = None
    mass_scale: float | None = None

    def apply(self, structure):
        """``structure`` (a free-structure spec) with the overrides applied."""
        return replace(structure, **{k: v for k, v in vars(self).items() if v is not None})


#: Keys of a ``[beam]`` study's ``[truth]`` (each a ``[beam]`` key).
TRUTH_KEYS = BeamSpec.truth_keys


@dataclass(frozen=True)
class UncertaintySpec:
    """``[uncertainty]``: 1-sigma of the free model's parameters (``jointid update`` writes it), for the bands.

    ``std`` maps ``jointid update``'s parameter names (``elastic_modulus``, ``density``,
    ``loss_factor``, ``accelerometers.mass``, ...; a ``[structure]``: ``stiffness_scale``,
    ``mass_scale``, ``loss_factor``) to a standard deviation in the parameter's unit;
    ``correlation`` (optional) is their correlation matrix in the order of ``std``.
    ``identify`` (receptance method) propagates it into every term's band
    (:mod:`jointid.methods.receptance.model_uncertainty`).
    """

    std: Mapping[str, float]
    correlation: tuple[tuple[float, ...], ...] | None = None

    def covariance(self) -> tuple[tuple[str, ...], "np.ndarray"]:
        """The parameter names and their covariance ``D C D`` (parameters' units squared)."""
        import numpy as np

        names = tuple(self.std)
        d = np.array([self.std[k] for k in names], float)
        C = np.eye(len(names)) if self.correlation is None else np.array(self.correlation, float)
        return names, d[:, None] * C * d[None, :]


@dataclass(frozen=True)
class Study:
    """A validated study: free structure, joints, measurement, frequency grid and optional sections.

    ``structure`` is the free structure's spec -- a :class:`BeamSpec` (``[beam]``) or a
    :class:`~jointid.study.structures.MatrixStructureSpec` (``[structure]``): each gives the
    free model, its dense form for Hong & Lee, how FRF files name its DOFs and what
    ``[truth]`` may change (the free-structure protocol, :mod:`jointid.study.structures`).
    ``joints`` are the study's joints (:class:`JointSpec`, identified together).
    """

    structure: Any
    joints: tuple[JointSpec, ...]
    measurement: MeasurementSpec
    frequency: FrequencySpec
    accelerometers: AccelerometerSpec | None = None
    identification: IdentificationSpec = IdentificationSpec()
    experiment: ExperimentSpec = ExperimentSpec()
    source: str = "<study>"
    truth: TruthSpec | None = None
    uncertainty: UncertaintySpec | None = None

    @property
    def beam(self) -> BeamSpec | None:
        """The ``[beam]`` spec when the free structure is the beam factory's (the shorthand), else None."""
        return self.structure if isinstance(self.structure, BeamSpec) else None

    @property
    def joint(self) -> JointSpec:
        """The study's one joint (a study of several joints: the first; see :attr:`joints`)."""
        return self.joints[0]

    @property
    def joint_dofs(self) -> tuple[Dof, ...]:
        """Every joint DOF, joint after joint in study order (identified together)."""
        return tuple(d for j in self.joints for d in j.joint_dofs)

    @property
    def grid(self) -> Frequency:
        """The study's frequency grid."""
        return self.frequency.frequency()

    def true_study(self) -> "Study":
        """The study of the true structure: the ``[truth]`` overrides applied (itself without ``[truth]``)."""
        if self.truth is None:
            return self
        return replace(self, structure=self.truth.apply(self.structure), truth=None)
