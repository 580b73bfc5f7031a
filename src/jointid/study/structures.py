"""The ``[structure]`` and ``[[joint]]`` sections of a study: any free structure, several joints.

A study describes its free structure either by ``[beam]`` (the planar beam
factory) or by ``[structure]`` (mass and stiffness matrices and a DOF list read
from files; exactly one of the two). With ``[structure]`` the joints are an
array of tables ``[[joint]]`` (a single ``[joint]`` table is one joint), and
``[measurement] observed/excited`` are DOF labels:

.. code-block:: toml

    [structure]
    mass = "frame.npz"            # .mtx, .npz (arrays M and K) or .op4 (MXX / KXX), or "file:NAME"
    stiffness = "frame.npz"       # paths relative to the study file
    dofs = "frame_dofs.csv"       # node,component per matrix row
    loss_factor = 0.002           # structural damping K (1 + j eta)
    stiffness_scale = 1.0         # alpha, mass_scale = beta: the free model is alpha K (1 + j eta) - w^2 beta M
    mass_scale = 1.0              #   (fitted by `jointid update`; default 1)
    method = "auto"               # free receptance: "auto" | "modal" | "direct" (jointid.physics.sparse_model)

    [[joint]]
    name = "front"                # letters, digits, '-', '_' (names the output file)
    dofs = ["101x", "101y", "101z", "101rx", "101ry", "101rz"]   # 1-6 DOFs (grounded)
    [joint.model]                 # the true mount, for `simulate` only
    type = "mount"
    stiffness = [2e6, 2e6, 4e6, 800.0, 800.0, 400.0]   # per DOF of `dofs`: N/m, N*m/rad
    couplings = [["101x", "101ry", 5e3]]                # K0[i,j] = K0[j,i] (N/rad)
    loss_factor = 0.1
    growth = 0.2                  # K*(f) = K0 (1 + growth (f/reference_frequency)^exponent) (1 + j loss_factor)
    reference_frequency = 100.0   # Hz
    exponent = 1.0

    [[joint]]
    name = "link"
    dofs = ["205x", "205y", "205z"]
    other = ["305x", "305y", "305z"]   # a mount between two parts: 2k x 2k, [[K, -K], [-K, K]]

    [[joint]]
    name = "bush"
    dofs = ["40z", "40ry"]
    [joint.model]                 # the elastomer joint FE model (jointid.physics.elastomer_mount)
    type = "elastomer"
    axes = ["z", "ry"]            # (translation, rotation) of dofs playing (w, theta / sigma)
    cylinder_axis = "+x"          # optional; default rotation x translation (here +x): theta = -ry
    material = "A"                # and the beam study's keys: elastic_modulus, loss_factor, density,
                                  # length, diameter, poisson_ratio, elements, cap, cap_diameter, ...

``type = "elastomer"``: the elastomer cylinder of
:mod:`jointid.physics.elastomer_joint` (``material`` "A" or "B" and the same
overrides as a ``[beam]`` study's elastomer joint) on one (translation, rotation)
pair of the joint's ``dofs`` (components named by ``axes``, each once in ``dofs``,
both on one node); every other DOF of the joint gets zero stiffness. The cylinder
lies along ``cylinder_axis`` (from ground, or from the ``other`` side, to ``dofs``);
``theta = dw/ds = sigma phi_r`` with ``sigma = (r x a) . t``: for a cylinder along +x,
``w`` along z, ``theta = -ry``. Between two parts the matrix is the cylinder's
two-end dynamic condensation with both caps (see :mod:`jointid.physics.elastomer_mount`);
``other`` must then have the same components as ``dofs``.

    [measurement]
    observed = ["12x", "12y", "12z", "40y"]
    excited = ["12x", "40y", "40z"]

Every joint DOF, observed and excited DOF must be a DOF of the structure; a
DOF belongs to at most one joint; all joints are identified at once, so at
least as many observed and excited DOFs as joint DOFs (of all joints
together) are needed. Both methods apply: the receptance method (default, any
model size) and the plain Hong & Lee method (``[identification] method =
"hong-lee"``) on models of at most 500 DOFs, which it needs dense.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping


import numpy as np

from ..dofs import Dof, DofArray, parse_dof
from .sections import JointModelSpec, JointSpec
from ..errors import DataError, DofError, ModelError, StudyError
from ..schema import (
    DENSITY, EXPONENT, FREQUENCY, GROWTH, LENGTH, LOSS_FACTOR, MODULUS, SCALE, STIFFNESS, Field, choices, nonneg, positive, section, typed,
)

__all__ = [
    "MatrixStructureSpec", "parse_structure_table", "parse_joints", "parse_dof_list_key", "matrix_joint_model",
    "MOUNT_KEYS", "ELASTOMER_KEYS", "ELASTOMER_MATERIAL_FIELDS",
]

_JOINT_KEYS = ("name", "dofs", "other", "model")
_NAME = re.compile(r"^[A-Za-z0-9_-]{1,40}$")


def _all_positive(v) -> str | None:
    return None if all(x > 0 for x in v) else "a list of positive numbers"


def _list_of_lists(v) -> str | None:
    return None if isinstance(v, list) else "a list of [dof_i, dof_j, value]"


def _file_name(v) -> str | None:
    return None if v.strip() else "a file name (a string)"


#: Schema of ``[structure]``.
_STRUCTURE_FIELDS = {
    "mass": Field("str", True, check=_file_name, expected="a file name (a string)"),
    "stiffness": Field("str", True, check=_file_name, expected="a file name (a string)"),
    "dofs": Field("str", True, check=_file_name, expected="a file name (a string)"),
    "loss_factor": Field("number", default=0.0, check=nonneg, bounds=LOSS_FACTOR),
    "method": Field("str", default="auto", check=choices("auto", "modal", "direct")),
    "stiffness_scale": Field("number", default=1.0, check=positive, bounds=SCALE),
    "mass_scale": Field("number", default=1.0, check=positive, bounds=SCALE),
}
#: Schema of ``[joint.model] type = "mount"`` (the stiffness list's length is checked against the joint's DOFs).
_MOUNT_FIELDS = {
    "type": Field("str", check=choices("mount")),
    "stiffness": Field("number_list", True, unit="N/m, N*m/rad", check=_all_positive,
                       expected="a list of positive stiffnesses, one per DOF of dofs", unique=False, bounds=STIFFNESS),
    "couplings": Field("any", default=[], check=_list_of_lists),
    "loss_factor": Field("number", default=0.1, check=nonneg, bounds=LOSS_FACTOR),
    "growth": Field("number", default=0.0, check=nonneg, bounds=GROWTH),
    "reference_frequency": Field("number", default=100.0, unit="Hz", check=positive, bounds=FREQUENCY),
    "exponent": Field("number", default=1.0, check=positive, bounds=EXPONENT),
}
#: Schema of the elastomer joint's material and geometry keys (as
#: :func:`~jointid.physics.elastomer_joint.elastomer_joint_model` takes them), shared by the
#: ``[joint.model]`` of a ``[beam]`` study and ``type = "elastomer"`` of a ``[[joint]]``.
ELASTOMER_MATERIAL_FIELDS = {
    "material": Field("str", default="A", check=choices("A", "B")),
    "elastic_modulus": Field("number", unit="Pa", check=positive, bounds=MODULUS),
    "loss_factor": Field("number", check=nonneg, bounds=LOSS_FACTOR),
    "density": Field("number", unit="kg/m^3", check=positive, bounds=DENSITY),
    "length": Field("number", unit="m", check=positive, bounds=LENGTH),
    "diameter": Field("number", unit="m", check=positive, bounds=LENGTH),
    "poisson_ratio": Field("number", check=lambda v: None if -1 < v < 0.5 else "a number in (-1, 0.5)"),
    "elements": Field("int", check=lambda v: None if 2 <= v <= 200 else "an integer in 2..200"),
    "cap": Field("bool"),
    "cap_diameter": Field("number", unit="m", check=positive, bounds=LENGTH),
    "cap_thickness": Field("number", unit="m", check=positive, bounds=LENGTH),
    "cap_density": Field("number", unit="kg/m^3", check=positive, bounds=DENSITY),
}
#: Schema of ``[joint.model] type = "elastomer"`` of a ``[[joint]]``.
_ELASTOMER_FIELDS = {
    "type": Field("str", check=choices("elastomer")),
    "axes": Field("any"),
    "cylinder_axis": Field("any"),
    **ELASTOMER_MATERIAL_FIELDS,
}
#: Keys of ``[joint.model] type = "mount"``.
MOUNT_KEYS = tuple(_MOUNT_FIELDS)
#: Keys of ``[joint.model] type = "elastomer"`` (material and overrides as for a ``[beam]`` study's elastomer joint).
ELASTOMER_KEYS = tuple(_ELASTOMER_FIELDS)


@dataclass(frozen=True)
class MatrixStructureSpec:
    """``[structure]``: the free structure's matrix files and DOF list (as given), damping, receptance method.

    The free model is ``stiffness_scale K (1 + j loss_factor) - w^2 mass_scale M``.
    Relative paths are relative to ``base`` (the study file's directory).
    ``dof_array`` is read at validation (to check the study's DOFs); the
    matrices are read by :meth:`model`.
    """

    mass: str
    stiffness: str
    dofs: str
    loss_factor: float = 0.0
    method: str = "auto"
    base: str = "."
    dof_array: DofArray | None = None
    stiffness_scale: float = 1.0
    mass_scale: float = 1.0

    #: ``[truth]`` keys of a ``[structure]`` study.
    truth_keys = ("stiffness_scale", "mass_scale", "loss_factor")
    #: The study table of this spec, and its keys that name files (relative to the study file).
    study_table = "structure"
    file_keys = ("mass", "stiffness", "dofs")

    def update_parameter_names(self) -> tuple[dict, tuple[str, ...]]:
        """The parameters ``jointid update`` can fit on matrices (name -> unit, bounds, label) and those it fits by default."""
        from ..methods.updating.parameters import DEFAULT_STRUCTURE_PARAMETERS, STRUCTURE_PARAMETERS

        return STRUCTURE_PARAMETERS, DEFAULT_STRUCTURE_PARAMETERS

    def free_model(self, max_frequency_hz: float | None = None):
        """The free structure (the free-structure protocol): :meth:`model` (matrices from files need no meshing)."""
        return self.model()

    def dense_model(self, max_frequency_hz: float | None = None):
        """The dense free model Hong & Lee solves with (:meth:`SparseModel.to_dense`; at most 500 DOFs).

        Raises
        ------
        StudyError
            A model too large to be dense (one line).
        """
        try:
            return self.model().to_dense()
        except ModelError as exc:
            raise StudyError(f"[identification].method = 'hong-lee': {exc}") from None

    def frf_reading(self, measurement) -> dict:
        """The options of :func:`jointid.io.frf_files.read_frf`: UFF direction codes 1-6 are x..rz (no ``w`` axis)."""
        return {"axis": None}

    def describe(self) -> str:
        """One line: what the free structure is."""
        return f"structure ({self.dofs})"

    def update_model(self, accelerometers, max_frequency_hz: float):
        """The matrices as a parameterized model for :func:`jointid.methods.updating.fit.update_free_model`.

        Returns ``(family, initial, known, default)``: a
        :class:`~jointid.methods.updating.scaled_matrices.ScaledMatrixFamily` of
        ``alpha K (1 + j eta) - w^2 beta M`` (the sensors' masses, if any, are in ``M`` and scale
        with ``beta``), the study's ``stiffness_scale``, ``mass_scale``, ``loss_factor``, the
        parameter names known and fitted by default.
        """
        from ..methods.updating.parameters import DEFAULT_STRUCTURE_PARAMETERS, STRUCTURE_PARAMETERS
        from ..methods.updating.scaled_matrices import ScaledMatrixFamily

        initial = {"stiffness_scale": self.stiffness_scale, "mass_scale": self.mass_scale, "loss_factor": self.loss_factor}
        model = self.model()
        if accelerometers is not None:
            model = model.with_masses(accelerometers.nodes, accelerometers.mass, accelerometers.rotary_inertia)
        return ScaledMatrixFamily(model, initial, self.method), initial, STRUCTURE_PARAMETERS, DEFAULT_STRUCTURE_PARAMETERS

    def reference_model(self, max_frequency_hz: float | None):
        """A finer discretization of the same structure: None (matrices from files are the model as given)."""
        return None

    def compatible(self, other, source: str = "the study") -> str | None:
        """Why ``other`` cannot be the true structure of the study ``source`` (None: it can): matrices on the same DOFs."""
        if not isinstance(other, MatrixStructureSpec):
            return f"--truth needs a [structure] study (the true structure of {source}); this one is a [{other.study_table}] study"
        if len(other.dof_array) != len(self.dof_array) or not (
            (other.dof_array.node == self.dof_array.node).all() and (other.dof_array.code == self.dof_array.code).all()
        ):
            return f"[structure].dofs {other.dofs} differs from the DOF list of {source}; the true structure needs the same DOFs"
        return None

    def model(self):
        """The free structure as a :class:`~jointid.physics.sparse_model.SparseModel` (the matrices times their scales).

        Raises
        ------
        StudyError
            One line naming the ``[structure]`` key and the file that cannot be read.
        """
        from ..io.matrix_files import check_semidefinite, check_symmetric, read_matrix
        from ..physics.sparse_model import SparseModel

        mats = []
        for key in ("mass", "stiffness"):
            spec = getattr(self, key)
            try:
                A = read_matrix(spec, key, Path(self.base))
                label = spec if Path(spec).is_absolute() else str(Path(self.base) / spec)
                check_symmetric(A, label)
                check_semidefinite(A, label, key)
            except DataError as exc:
                raise StudyError(f"[structure].{key}: {exc}") from None
            if A.shape[0] != len(self.dof_array):
                raise StudyError(
                    f"[structure].{key}: the {key} matrix in {spec} is {A.shape[0]} x {A.shape[1]} "
                    f"but the DOF list {self.dofs} has {len(self.dof_array)} DOFs"
                )
            mats.append(A)
        try:
            M, K = mats
            M = M if self.mass_scale == 1.0 else M * self.mass_scale
            K = K if self.stiffness_scale == 1.0 else K * self.stiffness_scale
            return SparseModel(M, K, self.dof_array, self.loss_factor, method=self.method)
        except ModelError as exc:
            raise StudyError(f"[structure]: {exc}") from None


def parse_structure_table(data: Any, base: Path) -> MatrixStructureSpec:
    """Validate ``[structure]`` (paths relative to ``base``) and read its DOF list.

    Raises
    ------
    StudyError
        A missing or unknown key, a bad value, or an unreadable DOF list (one line naming the key and file).
    """
    if isinstance(data, Mapping):
        for key in ("mass", "stiffness", "dofs"):
            if key not in data and not [k for k in data if k not in _STRUCTURE_FIELDS]:
                raise StudyError(f"[structure]: missing key {key!r} (a file name relative to the study file)")
    v = section(data, "structure", _STRUCTURE_FIELDS)
    from ..io.matrix_files import read_dof_list

    try:
        dof_array = read_dof_list(v["dofs"], base)
    except DataError as exc:
        raise StudyError(f"[structure].dofs: {exc}") from None
    return MatrixStructureSpec(
        v["mass"], v["stiffness"], v["dofs"], v["loss_factor"], v["method"], str(base), dof_array,
        stiffness_scale=v["stiffness_scale"], mass_scale=v["mass_scale"],
    )


def parse_dof_list_key(where: str, value: Any, model: DofArray, model_name: str, allow_empty: bool = False) -> tuple[Dof, ...]:
    """A list of DOF labels (``["101x", "12rz"]``), each once and each a DOF of ``model``.

    Raises
    ------
    StudyError
        ``{where}: ...`` naming the label that is not a DOF, repeated or missing from the model.
    """
    if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
        raise StudyError(f"{where}: expected a list of DOF labels such as [\"101x\", \"101rz\"], got {value!r}")
    if not value and not allow_empty:
        raise StudyError(f"{where}: expected at least one DOF label")
    out = []
    for label in value:
        try:
            d = parse_dof(label)
        except DofError as exc:
            raise StudyError(f"{where}: {exc}") from None
        if d in out:
            raise StudyError(f"{where}: DOF {d} is listed twice; list each once")
        out.append(d)
    if out:
        try:
            model.indices(out, model_name)
        except DofError as exc:
            raise StudyError(f"{where}: {exc}") from None
    return tuple(out)


def parse_joints(data: Any, model: DofArray, model_name: str, base: Path = Path(".")) -> tuple[JointSpec, ...]:
    """Validate ``[[joint]]`` (or one ``[joint]`` table) of a structure study.

    Raises
    ------
    StudyError
        One line naming the joint and key: unknown key, bad name, a DOF not in the
        model, 0 or more than 6 DOFs per side, sides of different sizes, a DOF in two
        joints, a bad ``[joint.model]``.
    """
    tables = data if isinstance(data, list) else [data]
    if not tables:
        raise StudyError("[[joint]]: expected at least one joint")
    joints: list[JointSpec] = []
    owner: dict[Dof, str] = {}
    for i, t in enumerate(tables, 1):
        if not isinstance(t, Mapping):
            raise StudyError(f"[[joint]] number {i} must be a table, got {t!r}")
        name = t.get("name", f"joint{i}" if len(tables) > 1 else "joint")
        if not isinstance(name, str) or not _NAME.match(name):
            raise StudyError(f"[[joint]] number {i}: name must be 1-40 letters, digits, '-' or '_' (it names the output file), got {name!r}")
        if any(j.name == name for j in joints):
            raise StudyError(f"[[joint]] {name!r}: two joints have this name; give each joint its own name")
        where = f"[[joint]] {name!r}"
        unknown = [k for k in t if k not in _JOINT_KEYS]
        if unknown:
            raise StudyError(f"{where}: unknown key {unknown[0]!r}; expected one of: " + ", ".join(_JOINT_KEYS))
        if "dofs" not in t:
            raise StudyError(f"{where}: missing key 'dofs' (DOF labels such as [\"101x\", \"101rz\"])")
        dofs = parse_dof_list_key(f"{where}.dofs", t["dofs"], model, model_name)
        other = parse_dof_list_key(f"{where}.other", t["other"], model, model_name) if "other" in t else ()
        if len(dofs) > 6:
            raise StudyError(f"{where}.dofs: {len(dofs)} DOFs; a joint has 1-6 DOFs per side")
        if other and len(other) != len(dofs):
            raise StudyError(f"{where}.other: {len(other)} DOFs for {len(dofs)} in dofs; a joint between two sets has as many DOFs on each side")
        for a, b in zip(dofs, other):  # the joint acts on dofs[i] - other[i]: a translation minus a rotation has no unit
            if a.unit != b.unit:
                raise StudyError(f"{where}.other: {b} ({b.unit}) is opposite {a} ({a.unit}) of dofs; pair translations "
                                 "with translations and rotations with rotations, in the order of dofs")
        for d in dofs + other:
            if d in owner:
                same = owner[d] == name
                raise StudyError(
                    f"{where}: DOF {d} is " + ("on both sides of this joint" if same else f"already in joint {owner[d]!r}")
                    + "; a DOF belongs to one joint only"
                )
            owner[d] = name
        model_spec = _joint_model(f"{where} [joint.model]", t["model"], dofs, other, base) if "model" in t else None
        joints.append(JointSpec(name, dofs, other, model_spec))
    return tuple(joints)


def _joint_model(where: str, data: Any, dofs: tuple[Dof, ...], other: tuple[Dof, ...], base: Path) -> JointModelSpec:
    if not isinstance(data, Mapping):
        raise StudyError(f"{where} must be a table")
    if data.get("type") == "elastomer":
        return _elastomer(where, data, dofs, other)
    if data.get("type") == "matrix":
        return matrix_joint_model(where, data, dofs + other, base)
    if data.get("type") != "mount":
        raise StudyError(f"{where}.type: expected 'mount', 'elastomer' or 'matrix' for a joint of a [structure] study, got {data.get('type')!r}")
    return _mount(where, data, dofs)


def matrix_joint_model(where: str, data: Mapping, joint_dofs: tuple[Dof, ...], base: Path) -> JointModelSpec:
    """``[joint.model] type = "matrix"``: the joint as a table, ``file`` (relative to the study file) in the layout
    ``jointid identify`` writes (``frequency_hz``, ``K_{i}_{j}_real``/``_imag`` in N/m, N/rad, N*m/m, N*m/rad;
    term labels of :func:`jointid.terms.dof_term_labels` on the joint's DOFs).

    Raises
    ------
    StudyError
        An unknown key, a file that cannot be read, a missing term column, non-finite values (one line).
    """
    from ..io.tables import read_csv_columns
    from ..terms import term_names

    unknown = [k for k in data if k not in ("type", "file")]
    if unknown or not isinstance(data.get("file"), str) or not data["file"].strip():
        raise StudyError(f"{where}: a joint table is type = \"matrix\" and file = \"NAME.csv\" (a joint_stiffness.csv of "
                         f"jointid identify)" + (f"; unknown key {unknown[0]!r}" if unknown else ""))
    path = Path(data["file"]) if Path(data["file"]).is_absolute() else base / data["file"]
    try:
        cols = read_csv_columns(path, "joint table")
    except DataError as exc:
        raise StudyError(f"{where}.file: {exc}") from None
    k = len(joint_dofs)
    names = term_names(joint_dofs)
    missing = [f"{name}_{part}" for _, _, name in names for part in ("real", "imag") if f"{name}_{part}" not in cols]
    if "frequency_hz" not in cols or missing:
        raise StudyError(f"{where}.file: {path} has no column {('frequency_hz' if 'frequency_hz' not in cols else missing[0])!r}; "
                         f"it needs frequency_hz and K_i_j_real/_imag for the joint's DOFs ({', '.join(map(str, joint_dofs))})")
    f = cols["frequency_hz"]
    K = np.empty((f.size, k, k), complex)
    for a, b, name in names:
        K[:, a, b] = cols[f"{name}_real"] + 1j * cols[f"{name}_imag"]
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(f)) and f.size >= 2 and np.all(np.diff(f) > 0)):
        raise StudyError(f"{where}.file: {path}: the table needs increasing frequencies and finite values on at least two lines")
    return JointModelSpec("matrix", {"file": str(path), "frequency_hz": f, "stiffness": K})


def _elastomer(where: str, data: Mapping, dofs: tuple[Dof, ...], other: tuple[Dof, ...]) -> JointModelSpec:
    from ..physics.elastomer_mount import AXIS_DIRECTIONS, ROTATIONS, TRANSLATIONS, axis_sign

    unknown = [k for k in data if k not in ELASTOMER_KEYS]
    if unknown:
        raise StudyError(f"{where}: unknown key {unknown[0]!r}; expected one of: " + ", ".join(ELASTOMER_KEYS))
    axes = data.get("axes")
    planar = axes == ["w", "theta"]  # a planar model's own (w, theta = dw/ds): no 3-D orientation to resolve
    if not (isinstance(axes, list) and len(axes) == 2 and (planar or (axes[0] in TRANSLATIONS and axes[1] in ROTATIONS))):
        raise StudyError(f"{where}.axes: expected [translation, rotation] playing (w, theta), such as [\"z\", \"ry\"] or "
                         f"[\"w\", \"theta\"], got {axes!r}")
    t, r = axes
    if not planar and r[1] == t:
        raise StudyError(f"{where}.axes: the rotation {r} is about the translation {t}; theta turns about an axis across w: use e.g. [\"{t}\", \"r{'y' if t != 'y' else 'x'}\"]")
    pair = []
    for c in axes:
        at = [i for i, d in enumerate(dofs) if d.direction == c]
        if len(at) != 1:
            raise StudyError(
                f"{where}.axes: {c} is " + ("not a component of" if not at else "the component of several DOFs in")
                + f" the joint's dofs ({', '.join(map(str, dofs))}); the elastomer joint needs exactly one {c} DOF there"
            )
        pair.append(at[0])
    if dofs[pair[0]].node != dofs[pair[1]].node:
        raise StudyError(f"{where}.axes: {dofs[pair[0]]} and {dofs[pair[1]]} are on different nodes; the elastomer joint's (w, theta) are on one node")
    if other:
        for i in pair:
            if other[i].direction != dofs[i].direction:
                raise StudyError(f"{where}.axes: other has {other[i]} opposite {dofs[i]}; an elastomer joint between two parts needs the same components on both sides")
        if other[pair[0]].node != other[pair[1]].node:
            raise StudyError(f"{where}.axes: {other[pair[0]]} and {other[pair[1]]} (other) are on different nodes; the elastomer joint's (w, theta) are on one node")
    cyl = data.get("cylinder_axis")
    if cyl is not None and (planar or cyl not in AXIS_DIRECTIONS):
        raise StudyError(f"{where}.cylinder_axis: " + ("a planar joint on (w, theta) has no cylinder_axis: leave it out" if planar
                         else f"expected one of {', '.join(AXIS_DIRECTIONS)}, got {cyl!r}"))
    from ..physics.elastomer_mount import default_cylinder_axis

    try:
        sigma = 1 if planar else axis_sign(t, r, cyl)
        cyl = None if planar else cyl or default_cylinder_axis(t, r)
    except ModelError as exc:
        raise StudyError(f"{where}: {exc}") from None
    section(data, "joint.model", _ELASTOMER_FIELDS, label=where)  # types and ranges, one line each
    params = {k: v for k, v in data.items() if k not in ("type", "axes", "cylinder_axis")}
    return JointModelSpec("elastomer", {**params, "axes": (t, r), "cylinder_axis": cyl, "pair": (pair[0], pair[1]), "sigma": sigma})


def _mount(where: str, data: Mapping, dofs: tuple[Dof, ...]) -> JointModelSpec:
    v = section(data, "joint.model", _MOUNT_FIELDS, label=where)
    if len(v["stiffness"]) != len(dofs):
        raise StudyError(f"{where}.stiffness: expected a list of {len(dofs)} stiffnesses (N/m, N*m/rad), one per DOF of dofs, got {data['stiffness']!r}")
    couplings = []
    seen = set()
    for c in data.get("couplings", []):
        if not (isinstance(c, list) and len(c) == 3 and isinstance(c[0], str) and isinstance(c[1], str)):
            raise StudyError(f"{where}.couplings: expected entries [dof_i, dof_j, value] such as [\"101x\", \"101ry\", 5e3], got {c!r}")
        try:
            a, b = parse_dof(c[0]), parse_dof(c[1])
        except DofError as exc:
            raise StudyError(f"{where}.couplings: {exc}") from None
        for d in (a, b):
            if d not in dofs:
                raise StudyError(f"{where}.couplings: DOF {d} is not one of the joint's dofs ({', '.join(map(str, dofs))})")
        if a == b or frozenset((a, b)) in seen:
            raise StudyError(f"{where}.couplings: [{a}, {b}] is " + ("a diagonal term (give it in stiffness)" if a == b else "given twice"))
        seen.add(frozenset((a, b)))
        couplings.append((str(a), str(b), typed(None, "couplings", Field("number", bounds=(-STIFFNESS[1], STIFFNESS[1])), c[2], where)))
    return JointModelSpec("mount", {
        "stiffness": tuple(v["stiffness"]), "couplings": tuple(couplings), "loss_factor": v["loss_factor"],
        "growth": v["growth"], "reference_frequency": v["reference_frequency"], "exponent": v["exponent"],
    })
