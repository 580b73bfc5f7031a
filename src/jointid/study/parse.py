"""Study files: the TOML schema of a jointid study, validated before any computation.

Every section and key of a study is validated here (one schema); the
validated sections are the frozen dataclasses of :mod:`jointid.study.sections`,
re-exported here. Units are SI: m, Pa, kg/m^3, kg, kg*m^2, Hz, s, N.

.. code-block:: toml

    [beam]                    # the free beam (the FE model Do)
    length = 0.9144           # m
    width = 0.0127            # m   (rectangle; or `diameter` for a circle)
    height = 0.0127           # m   (bending direction)
    elastic_modulus = 69e9    # Pa
    density = 2700.0          # kg/m^3
    loss_factor = 0.006       # structural, K (1 + j eta)
    poisson_ratio = 0.33      # or shear_modulus (Pa)
    shear_coefficient = 0.8333333333333334
    nodes = 19                # equally spaced, numbered 1..nodes from x = 0
    theory = "timoshenko"
    elements_per_segment = 8  # mesh between grid nodes (default: automatic, 48 elements per bending
                              #   wavelength at [frequency].stop; see jointid.physics.beam_mesh)     # or "euler-bernoulli"

    [joint]
    node = 10                 # beam node where the joint connects the beam to ground
    dofs = ["w", "theta"]

    [joint.model]             # the true joint, for `simulate` / `experiment` only
    type = "parametric"       # or "elastomer"
    # parametric: K*(f) = K0 (1 + growth (f / reference_frequency)^exponent) (1 + j loss_factor)
    k_w_w = 2.0e5             # N/m
    k_w_theta = 0.0           # N/rad (= N*m/m)
    k_theta_theta = 50.0      # N*m/rad
    loss_factor = 0.1
    growth = 0.0
    reference_frequency = 100.0   # Hz
    exponent = 1.0
    # elastomer: material = "A" | "B", optional elastic_modulus (Pa), loss_factor,
    #            density (kg/m^3), length (m), diameter (m), poisson_ratio, elements;
    #            cap = true (the beam-side steel cap belongs to the joint model; false:
    #            model it on the beam instead), cap_diameter, cap_thickness (m), cap_density

    [measurement]
    observed = [1, 3, 6, 9, 12, 15, 19]   # beam nodes, transverse w
    excited = [3, 9, 15]                  # beam nodes, transverse force
    axis = "+Z"               # the FRF file's direction that is the model's w:
                              # "+X" "-X" "+Y" "-Y" "+Z" "-Z" (records along the
                              # opposite direction are sign-flipped, others skipped)

    [measurement.points]      # FRF file point id = beam node; without this table the
    1001 = 1                  # file's point ids are the node numbers; with it, points
    1003 = 3                  # not listed are skipped (every observed/excited node needs one)

    [accelerometers]          # sensors on the test article (simulate / experiment)
    mass = 0.005              # kg each
    rotary_inertia = 0.0      # kg*m^2 each
    nodes = [1, 3, 6]         # default: the observed nodes

    [identification]
    method = "receptance"     # "receptance" (weighted FRF coupling, smoothed, with uncertainty) | "hong-lee"
    smoothing = "auto"        # receptance: "structured" (the joint's physics over all lines, AIC-averaged orders) for
                              #   joints of <= 3 DOFs, "spline" for one joint of 4-6 DOFs, else "gcv" | "structured" |
                              #   "gcv" (each term alone) | "spline"
                              #   (every term a few B-splines in log f, all lines at once: 6-DOF mounts) | "none"
    weighting = "auto"        # receptance: FRF variance from coherence if the file has it, else relative
                              #   (var ~ |H|^2); "coherence" | "relative" | "none" (unweighted)
    averages = 5              # averages behind the coherence (optional; the scale is taken from the residuals)
    max_relative_std = 0.1    # a term is reliable on a line when its predicted relative std is below this
    symmetric = true          # enforce Du = Du^T (default: true for receptance, false for hong-lee)
    regularization = "none"   # "none" | "gcv" | "lcurve" (Tikhonov, lambda per line)
    model_accelerometers = false  # add the [accelerometers] to Do
    estimation = "qr"         # "qr" (fast) | "svd" (one SVD per line): same least-squares solution
    cond_rtol = 0.01          # certified relative accuracy of cond_A with "qr" (0: an SVD on every line)
    units_check = true        # receptance: FRFs scaled by a unit factor in every column (g/N read as SI) are
                              #   refused (false: used as they are, every term flagged unreliable, one finding)
    model_check = true        # receptance: bands where the free model does not explain the FRFs (residual far
                              #   above the noise) flag every term there, with a finding (false: no such check)

    [identification.targets]  # optional, receptance: median relative error each term must reach; flagged
    K_theta_theta = 0.05      #   unreliable where its predicted error is above it (jointid design reports on them)

    [frequency]
    start = 5.0               # Hz
    stop = 1000.0
    step = 1.0

    [experiment]              # virtual roving-hammer test (`jointid experiment`)
    sample_rate = 8192.0      # Hz
    duration = 2.0            # s, record length per hit
    averages = 5              # hits per excited node
    force_noise = 0.01        # force noise rms / peak force
    response_noise = 0.01     # response noise rms / response rms over the record
    pulse_duration = 0.0005   # s, half-sine hammer pulse
    pulse_amplitude = 100.0   # N
    exponential_window = 0.0  # s, time constant tau (0: none)
    seed = 0

    [truth]                   # the true beam of `simulate` / `simulate --free` (virtual tests only):
    elastic_modulus = 70.38e9 #   any of these [beam] keys replace the model's value in the simulated
    density = 2673.0          #   structure, so a model error is explicit; `identify` and `update`
    loss_factor = 0.0042      #   start from [beam]
    elements_per_segment = 32 # e.g. data from a finer mesh than the model

    [uncertainty]             # 1-sigma of the free model's parameters (`jointid update` writes it from its fit;
    elastic_modulus = 2.3e6   #   `jointid update`'s names, the parameter's unit): `identify` (receptance) adds
    density = 0.10            #   its effect on the joint to every term's band
    loss_factor = 1.7e-6
    correlation = [[1.0, 0.96, 0.0], [0.96, 1.0, 0.0], [0.0, 0.0, 1.0]]  # optional, in the order above

Only ``[beam]``, ``[joint]``, ``[measurement]`` and ``[frequency]`` are required.

A *structure study* gives ``[structure]`` (mass and stiffness matrix files and
a DOF list) instead of ``[beam]``, one or more ``[[joint]]`` tables (named,
1-6 DOFs per side, grounded or between two DOF sets, ``[joint.model] type =
"mount"`` or ``"elastomer"``) and DOF labels in ``[measurement]``; see
:mod:`jointid.study.structures` for its keys. ``Study.beam`` and ``Study.joint``
are then ``None``, ``Study.structure`` and ``Study.joints`` hold it.

Physical bounds (a value outside is refused in one line naming the key, e.g.
``[beam].elastic_modulus: 1e-300 Pa is outside 1e3-1e13 Pa``; see
:mod:`jointid.schema`): lengths 1e-6-1e4 m (``length``, ``width``, ``height``,
``diameter``, elastomer and cap sizes), moduli 1e3-1e13 Pa (``elastic_modulus``,
``shear_modulus``), densities 1-1e5 kg/m^3, ``shear_coefficient`` 0.1-1.5, loss
factors 0-2, frequencies 0-1e6 Hz, ``[structure]`` scales 1e-6-1e6, joint stiffnesses
1e-6-1e15 (N/m, N*m/rad; couplings up to +-1e15), ``growth`` 0-1e3, ``exponent``
1e-3-10; ``[experiment]``:
``sample_rate`` 1-1e7 Hz, ``duration`` 1e-3-1e4 s, at most :data:`MAX_RECORD_SAMPLES`
samples per record, ``averages`` 1-1000, noise ratios 0-10, ``pulse_duration``
1e-7-10 s and short enough to excite the band (its first spectral zero 1.5 / T above
``start`` and above ``stop`` / 10; keep it above ``stop`` for good data),
``pulse_amplitude`` 1e-6-1e7 N, ``exponential_window`` 0 or at least duration / 100; each
accelerometer lighter than the beam, its rotary inertia below the beam's about
its middle (m L^2 / 12).

Limits (so that a typo cannot exhaust the memory): ``[beam].nodes`` at most
:data:`MAX_NODES` (10 000), the ``[frequency]`` grid at most
:data:`MAX_LINES` (1 000 000) lines.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any, Mapping

from ..dofs import DIRECTIONS, Dof
from ..errors import StudyError
from ..schema import DENSITY, EXPONENT, FREQUENCY, GROWTH, LENGTH, LOSS_FACTOR, MODULUS, SCALE, SHEAR_COEFFICIENT, STIFFNESS
from ..schema import Field as _Field
from ..schema import format_number as _num
from ..schema import choices as _choices
from ..schema import nonneg as _nonneg
from ..schema import positive as _positive
from ..schema import section as _section
from .targets import parse_targets
from .structures import ELASTOMER_MATERIAL_FIELDS, matrix_joint_model, parse_dof_list_key, parse_joints, parse_structure_table
from .sections import (
    UncertaintySpec,
    TRUTH_KEYS,
    AccelerometerSpec,
    BeamSpec,
    ExperimentSpec,
    FrequencySpec,
    IdentificationSpec,
    JointModelSpec,
    JointSpec,
    MeasurementSpec,
    Study,
    TruthSpec,
)

__all__ = ["load_study", "parse_study", "MAX_NODES", "MAX_LINES", "MAX_RECORD_SAMPLES", "MAX_AVERAGES"]

#: Largest ``[beam].nodes`` accepted (the FE model is dense per frequency line).
MAX_NODES = 10_000
#: Largest number of ``[frequency]`` lines (``(stop - start) / step + 1``) accepted.
MAX_LINES = 1_000_000
#: Largest ``[experiment]`` record, samples (``sample_rate * duration``): 2^24, 128 MiB per channel.
MAX_RECORD_SAMPLES = 2**24
#: Largest ``[experiment].averages`` (hits per excited node).
MAX_AVERAGES = 1000


# --------------------------------------------------------------------------- validation helpers
def _nodes_in_range(section: str, key: str, nodes, n_nodes: int) -> None:
    for x in nodes if isinstance(nodes, tuple) else (nodes,):
        if not 1 <= x <= n_nodes:
            raise StudyError(f"[{section}].{key}: node {x} is out of range; the beam has nodes 1..{n_nodes}")


_BEAM = {
    "length": _Field("number", True, unit="m", check=_positive, bounds=LENGTH),
    "width": _Field("number", unit="m", check=_positive, bounds=LENGTH),
    "height": _Field("number", unit="m", check=_positive, bounds=LENGTH),
    "diameter": _Field("number", unit="m", check=_positive, bounds=LENGTH),
    "elastic_modulus": _Field("number", True, unit="Pa", check=_positive, bounds=MODULUS),
    "density": _Field("number", True, unit="kg/m^3", check=_positive, bounds=DENSITY),
    "loss_factor": _Field("number", False, 0.0, check=_nonneg, bounds=LOSS_FACTOR),
    "poisson_ratio": _Field("number", False, None, check=lambda v: None if -1 < v < 0.5 else "a number in (-1, 0.5)"),
    "shear_modulus": _Field("number", unit="Pa", check=_positive, bounds=MODULUS),
    "shear_coefficient": _Field("number", False, 5.0 / 6.0, check=_positive, bounds=SHEAR_COEFFICIENT),
    "nodes": _Field("int", True, check=lambda v: None if 2 <= v <= MAX_NODES else f"an integer in 2..{MAX_NODES}"),
    "theory": _Field("str", False, "timoshenko", check=_choices("timoshenko", "euler-bernoulli")),
    "elements_per_segment": _Field("int", False, None, check=lambda v: None if 1 <= v <= 64 else "an integer in 1..64"),
}
_JOINT = {
    "node": _Field("int", True),
    "dofs": _Field("str_list", False, list(DIRECTIONS)),
}
_PARAMETRIC = {
    "type": _Field("str", True),
    "k_w_w": _Field("number", True, unit="N/m", check=_positive, bounds=STIFFNESS),
    "k_w_theta": _Field("number", False, 0.0, unit="N/rad", bounds=(-STIFFNESS[1], STIFFNESS[1])),
    "k_theta_theta": _Field("number", True, unit="N*m/rad", check=_positive, bounds=STIFFNESS),
    "loss_factor": _Field("number", False, 0.1, check=_nonneg, bounds=LOSS_FACTOR),
    "growth": _Field("number", False, 0.0, check=_nonneg, bounds=GROWTH),
    "reference_frequency": _Field("number", False, 100.0, unit="Hz", check=_positive, bounds=FREQUENCY),
    "exponent": _Field("number", False, 1.0, check=_positive, bounds=EXPONENT),
}
_ELASTOMER = {"type": _Field("str", True), **ELASTOMER_MATERIAL_FIELDS}
_AXES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
_MEASUREMENT = {
    "observed": _Field("int_list", True),
    "excited": _Field("int_list", True),
    "axis": _Field("str", False, "+Z", check=_choices(*_AXES)),
}
_ACCELEROMETERS = {
    "mass": _Field("number", False, 0.005, unit="kg", check=_nonneg),
    "rotary_inertia": _Field("number", False, 0.0, unit="kg*m^2", check=_nonneg),
    "nodes": _Field("int_list", False, None),
}
_IDENTIFICATION = {
    "method": _Field("str", False, "receptance", check=_choices("receptance", "hong-lee")),
    "smoothing": _Field("str", False, "auto", check=_choices("auto", "structured", "gcv", "spline", "none")),
    "weighting": _Field("str", False, "auto", check=_choices("auto", "coherence", "relative", "none")),
    "averages": _Field("int", False, None, check=lambda v: None if v >= 1 else "an integer >= 1"),
    "max_relative_std": _Field("number", False, 0.1, check=_positive),
    "symmetric": _Field("bool", False, None),
    "calibration": _Field("str", False, "auto", check=_choices("auto", "columns", "none")),
    "regularization": _Field("str", False, "none", check=_choices("none", "gcv", "lcurve")),
    "model_accelerometers": _Field("bool", False, False),
    "estimation": _Field("str", False, "qr", check=_choices("qr", "svd")),
    "cond_rtol": _Field("number", False, 0.01, check=lambda v: None if 0 <= v < 1 else "a number in [0, 1)"),
    "units_check": _Field("bool", False, True),
    "model_check": _Field("bool", False, True),
}
_FREQUENCY = {
    "start": _Field("number", True, unit="Hz", check=_nonneg, bounds=FREQUENCY),
    "stop": _Field("number", True, unit="Hz", check=_positive, bounds=FREQUENCY),
    "step": _Field("number", True, unit="Hz", check=_positive),
}
_EXPERIMENT = {
    "sample_rate": _Field("number", False, 8192.0, unit="Hz", check=_positive, bounds=(1.0, 1e7)),
    "duration": _Field("number", False, 2.0, unit="s", check=_positive, bounds=(1e-3, 1e4)),
    "averages": _Field("int", False, 5, check=lambda v: None if 1 <= v <= MAX_AVERAGES else f"an integer in 1..{MAX_AVERAGES}"),
    "force_noise": _Field("number", False, 0.01, check=_nonneg, bounds=(0.0, 10.0)),
    "response_noise": _Field("number", False, 0.01, check=_nonneg, bounds=(0.0, 10.0)),
    "pulse_duration": _Field("number", False, 0.0005, unit="s", check=_positive, bounds=(1e-7, 10.0)),
    "pulse_amplitude": _Field("number", False, 100.0, unit="N", check=_positive, bounds=(1e-6, 1e7)),
    "exponential_window": _Field("number", False, 0.0, unit="s", check=_nonneg),
    "seed": _Field("int", False, 0, check=lambda v: None if v >= 0 else "an integer >= 0"),
}
_TRUTH = {k: replace(_BEAM[k], required=False, default=None) for k in TRUTH_KEYS}
_STRUCTURE_TRUTH = {
    "stiffness_scale": _Field("number", False, None, check=_positive, bounds=SCALE),
    "mass_scale": _Field("number", False, None, check=_positive, bounds=SCALE),
    "loss_factor": _Field("number", False, None, check=_nonneg, bounds=LOSS_FACTOR),
}
_TOP = ("beam", "structure", "joint", "measurement", "frequency", "accelerometers", "identification", "experiment", "truth",
        "uncertainty")


def parse_study(data: Mapping[str, Any], source: str = "<study>") -> Study:
    """Validate a study given as nested mappings (parsed TOML) and return a :class:`Study`.

    Raises
    ------
    StudyError
        Naming the section and key that is wrong and what was expected.
    """
    try:
        return _parse(data, source)
    except StudyError as exc:
        raise StudyError(f"{source}: {exc}") from None


def _parse(data: Mapping[str, Any], source: str) -> Study:
    unknown = [k for k in data if k not in _TOP]
    if unknown:
        raise StudyError(f"unknown section [{unknown[0]}]; expected sections: " + ", ".join(f"[{s}]" for s in _TOP))
    if "beam" in data and "structure" in data:
        raise StudyError("give either [beam] (the beam factory) or [structure] (matrix files), not both")
    if "structure" in data:
        return _parse_structure_study(data, source)
    for sec in ("beam", "joint", "measurement", "frequency"):
        if sec not in data:
            raise StudyError(f"missing section [{sec}]")
    if isinstance(data["joint"], list):
        raise StudyError("[[joint]] (several joints) needs a [structure] study; a [beam] study has one [joint] table")

    b = _section(data["beam"], "beam", _BEAM)
    if b["diameter"] is None and (b["width"] is None or b["height"] is None):
        raise StudyError("[beam]: give width and height (m) for a rectangle, or diameter (m) for a circle")
    if b["diameter"] is not None and (b["width"] is not None or b["height"] is not None):
        raise StudyError("[beam]: give either width and height or diameter, not both")
    if b["poisson_ratio"] is None and b["shear_modulus"] is None:
        raise StudyError("[beam]: missing key 'poisson_ratio' (or 'shear_modulus', Pa)")
    beam = BeamSpec(**b)
    nn = beam.nodes

    jdata = data["joint"]
    j = _section(jdata, "joint", _JOINT, sub=("model",))
    _nodes_in_range("joint", "node", j["node"], nn)
    dofs = tuple(j["dofs"])
    for d in dofs:
        if d not in DIRECTIONS:
            raise StudyError(f"[joint].dofs: {d!r} is not a joint DOF; expected 'w' and/or 'theta'")
    if not dofs:
        raise StudyError("[joint].dofs: expected at least one of 'w', 'theta'")
    dofs = tuple(d for d in DIRECTIONS if d in dofs)
    model = None
    if "model" in jdata:
        mdata = jdata["model"]
        if not isinstance(mdata, Mapping):
            raise StudyError("[joint.model] must be a table")
        mtype = mdata.get("type")
        if mtype == "parametric":
            params = _section(mdata, "joint.model", _PARAMETRIC)
        elif mtype == "elastomer":
            params = _section(mdata, "joint.model", _ELASTOMER)
        elif mtype != "matrix":
            raise StudyError(f"[joint.model].type: expected 'parametric', 'elastomer' or 'matrix', got {mtype!r}")
        if mtype == "matrix":
            base = Path(source).parent if not source.startswith("<") else Path(".")
            model = matrix_joint_model("[joint.model]", mdata, tuple(Dof(j["node"], d) for d in dofs), base)
        else:
            params.pop("type")
            model = JointModelSpec(mtype, {k: v for k, v in params.items() if v is not None})
    joint = JointSpec("joint", tuple(Dof(j["node"], d) for d in dofs), (), model)

    mdata = data["measurement"]
    m = _section(mdata, "measurement", _MEASUREMENT, sub=("points",))
    for key in ("observed", "excited"):
        if not m[key]:
            raise StudyError(f"[measurement].{key}: expected at least one node")
        _nodes_in_range("measurement", key, m[key], nn)
    points = _points(mdata.get("points"), nn, m["observed"] + m["excited"]) if "points" in mdata else ()
    measurement = MeasurementSpec(m["observed"], m["excited"], m["axis"], points)

    return _shared_sections(data, source, beam, (joint,), measurement, lambda key, nodes: _nodes_in_range("accelerometers", key, nodes, nn),
                            lambda acc: _sensors_below_beam(acc, beam), _TRUTH)


def _shared_sections(data: Mapping, source: str, structure, joints: tuple, measurement: MeasurementSpec, check_nodes,
                     check_sensors, truth_fields: Mapping) -> Study:
    """The sections every free structure shares -- ``[frequency]``, ``[accelerometers]`` (default nodes: the observed
    ones), ``[identification]``, ``[experiment]``, ``[truth]`` (the keys the structure's spec may change) -- and the Study.

    ``check_nodes(key, nodes)`` and ``check_sensors(acc)`` are the free structure's own checks (nodes it has, sensors
    lighter than it)."""
    frequency = _frequency(data)
    acc = None
    if "accelerometers" in data:
        a = _section(data["accelerometers"], "accelerometers", _ACCELEROMETERS)
        if a["nodes"] is None:
            a["nodes"] = tuple(dict.fromkeys(d.node for d in measurement.observed_dofs))
        check_nodes("nodes", a["nodes"])
        acc = AccelerometerSpec(**a)
        check_sensors(acc)
    idata = data.get("identification", {})
    ident = IdentificationSpec(**_section(idata, "identification", _IDENTIFICATION, sub=("targets",)))
    if "targets" in idata:
        ident = replace(ident, targets=parse_targets(idata["targets"], tuple(d for j in joints for d in j.joint_dofs)))
    if ident.model_accelerometers and acc is None:
        raise StudyError("[identification].model_accelerometers = true needs an [accelerometers] section")
    exp = _experiment(data, frequency)
    truth = TruthSpec(**_section(data["truth"], "truth", truth_fields)) if "truth" in data else None
    uncertainty = _uncertainty(data["uncertainty"], structure) if "uncertainty" in data else None
    return Study(structure, joints, measurement, frequency, acc, ident, exp, source, truth, uncertainty)


def _uncertainty(table: Any, structure) -> UncertaintySpec:
    """``[uncertainty]``: 1-sigma per parameter ``jointid update`` knows for this structure, and an optional correlation."""
    if not isinstance(table, Mapping):
        raise StudyError("[uncertainty] must be a table of parameter = standard deviation")
    known, _ = structure.update_parameter_names()
    std: dict[str, float] = {}
    for key, value in table.items():
        if key == "correlation":
            continue
        if key not in known:
            raise StudyError(f"[uncertainty].{key}: not a parameter of this free model; use one of {', '.join(sorted(known))}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value >= 0 or value == float("inf"):
            raise StudyError(f"[uncertainty].{key}: expected a standard deviation >= 0 in the parameter's unit, got {value!r}")
        std[key] = float(value)
    if not std:
        raise StudyError("[uncertainty] gives no parameter: add e.g. elastic_modulus = 2e8 (1-sigma, Pa), or remove the table")
    corr = table.get("correlation")
    if corr is not None:
        n = len(std)
        ok = isinstance(corr, list) and len(corr) == n and all(
            isinstance(r, list) and len(r) == n and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in r) for r in corr)
        if not ok:
            raise StudyError(f"[uncertainty].correlation: expected a {n} x {n} matrix (lists of numbers) in the order of "
                             f"the parameters given ({', '.join(std)})")
        corr = tuple(tuple(float(v) for v in r) for r in corr)
        import numpy as np

        C = np.array(corr)
        if not (np.allclose(C, C.T, rtol=0, atol=1e-9) and np.allclose(np.diag(C), 1.0, rtol=0, atol=1e-9)
                and np.linalg.eigvalsh((C + C.T) / 2).min() >= -1e-9):
            raise StudyError("[uncertainty].correlation: not a correlation matrix (symmetric, ones on the diagonal, "
                             "positive semidefinite)")
    return UncertaintySpec(std, corr)


def _sensors_below_beam(acc: AccelerometerSpec, beam: BeamSpec) -> None:
    """Each sensor lighter than the beam (mass) and than the beam's rotary inertia about its middle, m L^2 / 12."""
    area = beam.section().area
    mass = beam.density * area * beam.length
    if acc.mass >= mass:
        raise StudyError(
            f"[accelerometers].mass: {_num(acc.mass)} kg per sensor is not below the beam's mass "
            f"({_num(mass)} kg); give the mass of one sensor in kg"
        )
    inertia = mass * beam.length**2 / 12.0
    if acc.rotary_inertia >= inertia:
        raise StudyError(
            f"[accelerometers].rotary_inertia: {_num(acc.rotary_inertia)} kg*m^2 per sensor is not below the beam's "
            f"rotary inertia about its middle ({_num(inertia)} kg*m^2); give one sensor's in kg*m^2"
        )


def _experiment(data: Mapping, frequency: FrequencySpec) -> ExperimentSpec:
    """``[experiment]``: each key in its bounds, a record of at most :data:`MAX_RECORD_SAMPLES`, a pulse that excites
    the band (a half-sine of duration T has its first spectral zero at 1.5 / T: refused below ``start`` or ``stop / 10``)
    and a window that keeps the record; the cross-checks apply to a study that has an ``[experiment]`` table."""
    x = ExperimentSpec(**_section(data.get("experiment", {}), "experiment", _EXPERIMENT))
    if "experiment" not in data:  # the defaults: checked against the band when a virtual test runs (pipeline)
        return x
    samples = x.sample_rate * x.duration
    if samples > MAX_RECORD_SAMPLES:
        raise StudyError(
            f"[experiment]: sample_rate x duration = {_num(x.sample_rate)} Hz x {_num(x.duration)} s = {_num(samples)} samples per record; "
            f"at most {MAX_RECORD_SAMPLES} are allowed: lower sample_rate or duration"
        )
    if 1.5 / x.pulse_duration <= max(frequency.start, frequency.stop / 10.0):
        raise StudyError(
            f"[experiment].pulse_duration: a {_num(x.pulse_duration)} s hammer pulse has its first spectral zero at "
            f"{_num(1.5 / x.pulse_duration)} Hz, far below [frequency].stop ({_num(frequency.stop)} Hz): it does not excite "
            f"the band; give a pulse shorter than {_num(1.5 / frequency.stop)} s"
        )
    if x.exponential_window and x.exponential_window < x.duration / 100.0:
        raise StudyError(
            f"[experiment].exponential_window: tau = {_num(x.exponential_window)} s is below duration / 100 "
            f"({_num(x.duration / 100.0)} s): the window would remove nearly all of the record; give tau in s (0: none)"
        )
    return x


def _frequency(data: Mapping) -> FrequencySpec:
    fr = _section(data["frequency"], "frequency", _FREQUENCY)
    if fr["start"] >= fr["stop"]:
        raise StudyError(f"[frequency]: start ({fr['start']:g} Hz) must be below stop ({fr['stop']:g} Hz)")
    lines = (fr["stop"] - fr["start"]) / fr["step"] + 1.0  # may be inf for a tiny step
    if not lines < MAX_LINES + 1:
        raise StudyError(
            f"[frequency].step: {fr['step']:g} Hz gives {lines:.3g} lines from {fr['start']:g} to {fr['stop']:g} Hz; "
            f"at most {MAX_LINES} lines are allowed: raise step"
        )
    return FrequencySpec(**fr)


def _parse_structure_study(data: Mapping[str, Any], source: str) -> Study:
    """A ``[structure]`` study: matrices from files, ``[[joint]]``, DOF-label measurements (see :mod:`jointid.study.structures`)."""
    for sec in ("joint", "measurement", "frequency"):
        if sec not in data:
            raise StudyError(f"missing section [{sec}]" if sec != "joint" else "missing section [[joint]]")
    base = Path(source).parent if not source.startswith("<") else Path(".")
    structure = parse_structure_table(data["structure"], base)
    model_name = f"structure ({structure.dofs})"
    joints = parse_joints(data["joint"], structure.dof_array, model_name, base)
    mdata = data["measurement"]
    if not isinstance(mdata, Mapping):
        raise StudyError(f"[measurement] must be a table, got {mdata!r}")
    unknown = [k for k in mdata if k not in ("observed", "excited", "points", "axis")]
    if unknown:
        raise StudyError(f"[measurement]: unknown key {unknown[0]!r}; expected one of: observed, excited, points")
    if "axis" in mdata:
        raise StudyError("[measurement].axis applies to [beam] studies only; in a [structure] study each DOF label names its direction (\"12x\", \"40rz\")")
    dofs = {}
    for key in ("observed", "excited"):
        if key not in mdata:
            raise StudyError(f"[measurement]: missing key {key!r}")
        dofs[key] = parse_dof_list_key(f"[measurement].{key}", mdata[key], structure.dof_array, model_name)
    n_joint = sum(len(j.joint_dofs) for j in joints)
    for key, what in (("observed", "observed"), ("excited", "excited")):
        if len(dofs[key]) < n_joint:
            raise StudyError(
                f"[measurement].{key}: {len(dofs[key])} {what} DOFs for {n_joint} joint DOFs (all joints together); "
                f"{'observe' if key == 'observed' else 'excite'} at least as many DOFs as there are joint DOFs"
            )
    points = ()
    if "points" in mdata:
        nodes = tuple(d.node for d in dofs["observed"] + dofs["excited"])
        points = _points(mdata["points"], int(structure.dof_array.node.max()), nodes)
    measurement = MeasurementSpec(dofs["observed"], dofs["excited"], "+Z", points)
    known = set(structure.dof_array.node.tolist())

    def check_nodes(key, nodes):
        for n in nodes:
            if n not in known:
                raise StudyError(f"[accelerometers].{key}: node {n} has no DOF in the structure ({structure.dofs})")

    return _shared_sections(data, source, structure, joints, measurement, check_nodes, lambda acc: None, _STRUCTURE_TRUTH)


def _points(table: Any, n_nodes: int, used: tuple[int, ...]) -> tuple[tuple[int, int], ...]:
    """``[measurement.points]`` as sorted (file point id, beam node) pairs."""
    if not isinstance(table, Mapping) or not table:
        raise StudyError("[measurement.points] must be a table of file point id = beam node, e.g. 1001 = 1")
    pairs: dict[int, int] = {}
    for key, node in table.items():
        k = str(key).strip()
        if not k.isdigit() or int(k) < 1:
            raise StudyError(f"[measurement.points]: key {key!r} is not a point id (an integer >= 1)")
        if isinstance(node, bool) or not isinstance(node, int) or not 1 <= node <= n_nodes:
            raise StudyError(
                f"[measurement.points].{k}: expected a beam node in 1..{n_nodes}, got {node!r}"
            )
        pairs[int(k)] = node
    by_node: dict[int, int] = {}
    for point, node in pairs.items():
        if node in by_node:
            raise StudyError(
                f"[measurement.points]: points {by_node[node]} and {point} both map to node {node}; map each node once"
            )
        by_node[node] = point
    missing = [n for n in dict.fromkeys(used) if n not in by_node]
    if missing:
        raise StudyError(
            f"[measurement.points]: node {missing[0]} is observed or excited but no file point maps to it; "
            f"add '<point id> = {missing[0]}'"
        )
    return tuple(sorted(pairs.items()))


def load_study(path: str | os.PathLike) -> Study:
    """Read and validate a TOML study file.

    Raises
    ------
    StudyError
        If the file is missing, is not valid TOML, or breaks the schema.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise StudyError(f"{p}: cannot read the study file ({exc.strerror or exc})") from None
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise StudyError(f"{p} line 1: UTF-16 text; save the study file as UTF-8")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise StudyError(f"{p} line {line}: not UTF-8 text (byte {raw[exc.start]:#04x}); save the study file as UTF-8") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{p}: not valid TOML ({exc})") from None
    return parse_study(data, str(p))
