"""FRF files in Universal File Format dataset 58 (ASCII and binary), via pyuff.

Conventions
-----------
* **Nodes** are beam node numbers (1..n_nodes).
* **Direction**: the transverse beam displacement ``w`` is +Z, direction code
  ``3``. A record measured in -Z (code ``-3``) is sign-flipped, on the
  response and on the reference side independently (two flips cancel). Any
  other direction (X, Y, rotations, scalar) is rejected: rotational DOFs are
  not measured, and this module never guesses how they map onto ``theta``.
* **Kind** comes from record 9 (ordinate numerator) and record 10 (ordinate
  denominator) *specific data type*: numerator 8 = displacement
  (receptance), 11 = velocity (mobility), 12 = acceleration (accelerance);
  denominator 13 = excitation force. Anything else is an error naming the
  record. Records of different kinds in one file are converted exactly to
  the kind of the first FRF record.
* **Units** are SI (m, N, s, Hz). A units dataset 164 that is not SI
  (units code 1) is rejected; files without one are read as SI.
* **Abscissa** is frequency in Hz (record 8 specific data type 18, or units
  label ``Hz``), evenly or unevenly spaced.
* **Records** are numbered 1, 2, ... in the order of the datasets in the file
  (every dataset counts, whatever its type); error messages name them so.
* Only FRF records (function type 4) build the FRF matrix; coherence records
  (function type 6, "Coherence" in the UFF58 specification) are read on
  request; every other record (time histories, type 1; spectra; ...) and
  every other dataset (geometry, units, ...) is skipped.

Precision and pyuff 2.5.8
-------------------------
* ASCII values are written ``%20.11e`` (12 significant digits, relative
  error <= 5e-12); binary values are IEEE doubles (exact).
* The abscissa minimum and increment of an evenly spaced record live in the
  ASCII header as ``%13.5e`` (6 significant digits) even in binary files. A
  frequency axis that these 6 digits do not reproduce (to 1e-10 of its
  largest line) is therefore written unevenly spaced in binary files (the
  abscissa values are then stored as doubles) and refused in ASCII files
  (:class:`~jointid.errors.DataError`: use ``binary=True``, the CSV layout,
  or a grid such as 0.5 Hz steps).
* pyuff replaces NaN/inf by numbers on writing (``numpy.nan_to_num``), so the
  writer refuses non-finite data itself.
* pyuff's ``mode="overwrite"`` truncates binary 58 files; the writer always
  uses ``mode="add"`` on a fresh, empty temporary file that is renamed onto
  the destination when complete (:func:`jointid.io.atomic.atomic_path`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dofs import Dof
from ..errors import DataError, FrequencyError, JointIdError
from ..frequency import Frequency
from ..frf import FRF, KINDS, kind_factor
from .atomic import atomic_path

__all__ = ["read_uff_frf", "write_uff_frf", "UFF_KIND_CODES", "FUNC_FRF", "FUNC_COHERENCE"]

#: UFF58 function types used here.
FUNC_TIME = 1
FUNC_FRF = 4
FUNC_COHERENCE = 6
#: Record 9 (ordinate numerator) specific data type of each FRF kind; denominator is 13.
UFF_KIND_CODES: dict[str, int] = {"receptance": 8, "mobility": 11, "accelerance": 12}
_CODE_KIND = {v: k for k, v in UFF_KIND_CODES.items()}
_FORCE = 13
_FREQUENCY = 18
_Z = 3
_NUM_LABELS = {"receptance": ("Displacement", "m"), "mobility": ("Velocity", "m/s"), "accelerance": ("Acceleration", "m/s^2")}
_DATA_TYPES = {8: "displacement", 9: "reaction force", 11: "velocity", 12: "acceleration", 13: "excitation force", 0: "unknown", 1: "general"}
_DIRS = {0: "scalar", 1: "+X", -1: "-X", 2: "+Y", -2: "-Y", 3: "+Z", -3: "-Z", 4: "+RX", -4: "-RX", 5: "+RY", -5: "-RY", 6: "+RZ", -6: "-RZ"}


@dataclass
class _Record:
    index: int  # 1-based position of the dataset in the file
    func_type: int
    response: Dof
    reference: Dof
    sign: float
    kind: str | None
    x: np.ndarray
    data: np.ndarray

    def name(self) -> str:
        return f"record {self.index} (response {self.response}, reference {self.reference})"


def _describe(index: int, d: dict) -> str:
    return (
        f"record {index} (function type {d.get('func_type')}, response node {d.get('rsp_node')} "
        f"dir {d.get('rsp_dir')}, reference node {d.get('ref_node')} dir {d.get('ref_dir')})"
    )


def _dof(d: dict, side: str, index: int, n_nodes: int | None) -> tuple[Dof, float]:
    node, direction = d.get(f"{side}_node"), d.get(f"{side}_dir")
    what = "response" if side == "rsp" else "reference"
    if direction not in (_Z, -_Z):
        raise DataError(
            f"{_describe(index, d)}: {what} direction {direction} ({_DIRS.get(direction, 'unknown')}) is not supported; "
            "only transverse translation +Z (3) or -Z (-3) can be read"
        )
    if not isinstance(node, (int, np.integer)) or node < 1 or (n_nodes is not None and node > n_nodes):
        rng = f"1..{n_nodes}" if n_nodes is not None else ">= 1"
        raise DataError(f"{_describe(index, d)}: {what} node {node} is outside the beam (nodes {rng})")
    return Dof(int(node), "w"), (1.0 if direction > 0 else -1.0)


def _kind(d: dict, index: int) -> str:
    num, den = d.get("ordinate_spec_data_type"), d.get("orddenom_spec_data_type")
    if num not in _CODE_KIND or den != _FORCE:
        raise DataError(
            f"{_describe(index, d)}: cannot tell the FRF kind from the ordinate data characteristics "
            f"(numerator {num} = {_DATA_TYPES.get(num, 'unsupported')}, denominator {den} = "
            f"{_DATA_TYPES.get(den, 'unsupported')}); expected numerator 8 (displacement), 11 (velocity) "
            "or 12 (acceleration) over denominator 13 (excitation force)"
        )
    return _CODE_KIND[num]


def _check_abscissa(d: dict, index: int) -> np.ndarray:
    spec = d.get("abscissa_spec_data_type")
    label = str(d.get("abscissa_axis_units_lab", "")).strip().lower()
    if spec != _FREQUENCY and label != "hz":
        raise DataError(
            f"{_describe(index, d)}: abscissa specific data type is {spec}, expected 18 (frequency, Hz)"
        )
    x = np.asarray(d.get("x"), dtype=float).reshape(-1)
    data = np.asarray(d.get("data")).reshape(-1)
    n = d.get("num_pts")
    if n is not None and (x.size != n or data.size != n):
        raise DataError(f"{_describe(index, d)}: header announces {n} points but the record holds {data.size}")
    if x.size == 0:
        raise DataError(f"{_describe(index, d)}: the record holds no data")
    return x


def _read_records(path: Path, n_nodes: int | None, coherence: bool) -> list[_Record]:
    import pyuff

    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception
        raise DataError(f"cannot read UFF file {path}: {exc}") from exc
    wanted = (FUNC_FRF, FUNC_COHERENCE) if coherence else (FUNC_FRF,)
    records: list[_Record] = []
    for i, t in enumerate(types):
        index = i + 1
        if t not in (58, 164):
            continue
        try:
            d = uff.read_sets(i)
        except Exception as exc:
            raise DataError(f"record {index} of {path}: pyuff cannot read dataset {t}: {exc}") from exc
        if t == 164:
            if d.get("units_code") != 1:
                raise DataError(
                    f"record {index} of {path}: units dataset 164 declares units code {d.get('units_code')} "
                    f"({str(d.get('units_description', '')).strip()!r}); only SI (code 1: meter, newton) is supported"
                )
            continue
        ft = d.get("func_type")
        if ft not in wanted:
            continue
        response, s_r = _dof(d, "rsp", index, n_nodes)
        reference, s_c = _dof(d, "ref", index, n_nodes)
        kind = _kind(d, index) if ft == FUNC_FRF else None
        x = _check_abscissa(d, index)
        data = np.asarray(d["data"]).reshape(-1)
        if ft == FUNC_COHERENCE:
            data = np.real(data).astype(float)
        if not np.all(np.isfinite(data)) or not np.all(np.isfinite(x)):
            bad = int(np.flatnonzero(~np.isfinite(data) | ~np.isfinite(x))[0])
            raise DataError(f"{_describe(index, d)}: non-finite value at line {bad + 1} ({x[bad]:g} Hz)")
        sign = s_r * s_c if ft == FUNC_FRF else 1.0
        records.append(_Record(index, int(ft), response, reference, sign, kind, x, data))
    return records


def _assemble(records: list[_Record], path: Path, what: str) -> tuple[Frequency, np.ndarray, tuple[Dof, ...], tuple[Dof, ...], list[_Record]]:
    responses: list[Dof] = []
    references: list[Dof] = []
    for r in records:
        if r.response not in responses:
            responses.append(r.response)
        if r.reference not in references:
            references.append(r.reference)
    first = records[0]
    x0 = first.x
    tol = 1e-12 * max(1.0, float(np.max(np.abs(x0))))
    for r in records[1:]:
        if r.x.size != x0.size or not np.all(np.abs(r.x - x0) <= tol):
            raise DataError(
                f"{r.name()} in {path} is on a different frequency axis ({_axis(r.x)}) than "
                f"{first.name()} ({_axis(x0)}); all {what} records must share one axis"
            )
    try:
        frequency = Frequency(x0)
    except FrequencyError as exc:
        raise DataError(f"{first.name()} in {path}: invalid frequency axis: {exc}") from exc
    seen: dict[tuple[Dof, Dof], _Record] = {}
    for r in records:
        key = (r.response, r.reference)
        if key in seen:
            raise DataError(
                f"{r.name()} in {path} duplicates the {what} pair ({r.response}, {r.reference}) "
                f"already given by record {seen[key].index}"
            )
        seen[key] = r
    for a in responses:
        for b in references:
            if (a, b) not in seen:
                raise DataError(
                    f"{path}: the {what} pair (response {a}, reference {b}) is missing; the file has responses "
                    f"{[str(d) for d in responses]} and references {[str(d) for d in references]}, and needs "
                    "every (response, reference) pair exactly once"
                )
    ri = {d: i for i, d in enumerate(responses)}
    ci = {d: i for i, d in enumerate(references)}
    dtype = complex if what == "FRF" else float
    data = np.empty((frequency.size, len(responses), len(references)), dtype=dtype)
    for r in records:
        data[:, ri[r.response], ci[r.reference]] = r.data
    return frequency, data, tuple(responses), tuple(references), list(seen.values())


def _axis(x: np.ndarray) -> str:
    if x.size == 1:
        return f"1 line at {x[0]:.10g} Hz"
    return f"{x.size} lines, {x[0]:.10g}..{x[-1]:.10g} Hz, first step {x[1] - x[0]:.10g} Hz"


def read_uff_frf(
    path: str | os.PathLike,
    n_nodes: int | None = None,
    coherence: bool = False,
    kind: str | None = None,
) -> "FRF | tuple[FRF, np.ndarray | None]":
    """Read FRFs from a UFF dataset 58 file (ASCII or binary).

    Parameters
    ----------
    path : path-like
        ``.uff`` / ``.unv`` / ``.58`` file.
    n_nodes : int, optional
        Number of beam nodes; nodes outside ``1..n_nodes`` are an error.
    coherence : bool
        Also read coherence records (function type 6) and return them.
    kind : {"receptance", "mobility", "accelerance"}, optional
        Convert the result exactly to this kind (default: the kind of the file).

    Returns
    -------
    FRF
        Responses and references in order of first appearance; ``kind`` from
        the records' ordinate characteristics (or ``kind`` if given).
    (FRF, ndarray or None)
        If ``coherence``: also the coherence, real, shape (F, r, c) aligned
        with the FRF, or ``None`` when the file has no coherence records.

    Raises
    ------
    DataError
        Naming the record: unsupported direction, node outside the beam,
        unknown ordinate characteristics, non-finite value, different
        frequency axis, duplicated pair; or naming the missing pair.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"FRF file {path} does not exist")
    if kind is not None and kind not in KINDS:
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {KINDS}")
    records = _read_records(path, n_nodes, coherence)
    frf_records = [r for r in records if r.func_type == FUNC_FRF]
    if not frf_records:
        raise DataError(f"{path} holds no FRF record (UFF dataset 58 with function type 4)")
    base = frf_records[0].kind
    assert base is not None
    omega = 2.0 * np.pi * frf_records[0].x
    for r in frf_records:
        factor = r.sign
        if r.kind != base:
            try:
                factor = factor * kind_factor(omega, r.kind, base)  # type: ignore[arg-type]
            except JointIdError as exc:
                raise DataError(f"{r.name()} in {path}: cannot convert {r.kind} to {base}: {exc}") from exc
        r.data = np.asarray(r.data, dtype=complex) * factor
    frequency, data, responses, references, _ = _assemble(frf_records, path, "FRF")
    frf = FRF(frequency, data, responses, references, base)
    if kind is not None:
        frf = frf.to(kind)
    if not coherence:
        return frf
    coh_records = [r for r in records if r.func_type == FUNC_COHERENCE]
    if not coh_records:
        return frf, None
    cf, coh, c_resp, c_ref, _ = _assemble(coh_records, path, "coherence")
    if cf != frequency or set(c_resp) != set(responses) or set(c_ref) != set(references):
        raise DataError(
            f"{path}: coherence records (first: record {coh_records[0].index}) do not match the FRF records "
            f"(responses {[str(d) for d in c_resp]} vs {[str(d) for d in responses]}, references "
            f"{[str(d) for d in c_ref]} vs {[str(d) for d in references]}, axis {cf!r} vs {frequency!r})"
        )
    coh = coh[:, [c_resp.index(d) for d in responses]][:, :, [c_ref.index(d) for d in references]]
    return frf, coh


def _even_axis(hz: np.ndarray) -> tuple[bool, float, float]:
    """Whether ``hz`` is reproduced by pyuff's ``%13.5e`` min/increment header; and those two values."""
    if hz.size < 2:
        return False, 0.0, 0.0
    f0 = float("%13.5e" % hz[0])
    df = float("%13.5e" % (hz[1] - hz[0]))
    rebuilt = f0 + np.arange(hz.size) * df
    return bool(np.all(np.abs(rebuilt - hz) <= 1e-10 * max(1.0, float(hz[-1])))), f0, df


def write_uff_frf(
    path: str | os.PathLike,
    frf: FRF,
    kind: str = "accelerance",
    coherence: np.ndarray | None = None,
    binary: bool | None = None,
    description: str = "jointid FRF",
) -> Path:
    """Write FRFs as UFF dataset 58, one record per (response, reference) pair, atomically.

    The file starts with a units dataset 164 (SI), then the FRF records
    (function type 4, abscissa frequency in Hz, response and reference
    direction +Z, ordinate numerator displacement/velocity/acceleration over
    excitation force according to ``kind``, complex double precision), then,
    if given, the coherence records (function type 6, real).

    Parameters
    ----------
    path : path-like
        Destination (conventionally ``.uff``).
    frf : FRF
        FRFs between ``w`` DOFs (rotational DOFs cannot be written).
    kind : {"receptance", "mobility", "accelerance"}
        Kind written to the file; the data are converted exactly.
    coherence : ndarray, shape (F, r, c), real, optional
        Coherence in [0, 1], aligned with ``frf``.
    binary : bool or None
        True: binary 58 records (IEEE doubles, every frequency exact); False:
        ASCII (refused when the 6-digit header cannot rebuild the axis exactly);
        None (default): ASCII when it is exact, binary otherwise.
    description : str
        ID line 1 of each record (at most 80 characters).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    DataError
        Rotational DOFs, non-finite values, fewer than 2 lines, bad coherence,
        or (ASCII) a frequency axis that the 6-digit UFF header cannot carry.
    """
    import pyuff

    if kind not in KINDS:
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {KINDS}")
    bad = [str(d) for d in (*frf.responses, *frf.references) if d.direction != "w"]
    if bad:
        raise DataError(f"UFF58 FRF files carry only transverse (w, +Z) DOFs; cannot write {bad}")
    if len(description) > 80:
        raise DataError("UFF ID lines hold at most 80 characters; shorten the description")
    out = frf.to(kind)
    hz = out.frequency.hz
    if hz.size < 2:
        raise DataError("pyuff cannot write a UFF58 record with fewer than 2 frequency lines")
    if not np.all(np.isfinite(out.data)):
        i, j, k = (int(v[0]) for v in np.nonzero(~np.isfinite(out.data)))
        raise DataError(
            f"FRF ({out.responses[j]}, {out.references[k]}) is not finite at {hz[i]:g} Hz; "
            "UFF writing would silently replace it"
        )
    coh = None
    if coherence is not None:
        coh = np.asarray(coherence)
        if coh.shape != out.shape:
            raise DataError(f"coherence has shape {coh.shape}, expected the FRF shape {out.shape}")
        if np.iscomplexobj(coh) or not np.all(np.isfinite(coh)) or np.any(coh < 0) or np.any(coh > 1 + 1e-12):
            raise DataError("coherence must be real, finite and within [0, 1]")
        coh = coh.astype(float)
    even, f0, df = _even_axis(hz)
    if binary is None:
        binary = not even
    if not even and not binary:
        raise DataError(
            f"the frequency axis ({_axis(hz)}) cannot be written to an ASCII UFF58 file exactly: "
            "its header stores the first line and the step with 6 significant digits (%13.5e) and "
            "pyuff writes uneven abscissae with 6 digits too; use binary=True, the CSV layout, "
            "or a grid whose start and step have at most 6 significant digits"
        )
    num_label, num_unit = _NUM_LABELS[kind]
    common = dict(
        binary=int(bool(binary)),
        id1=description,
        id2="NONE",
        id3="NONE",
        id4="NONE",
        id5="NONE",
        load_case_id=0,
        rsp_ent_name="NONE",
        ref_ent_name="NONE",
        abscissa_spacing=1 if even else 0,
        abscissa_spec_data_type=_FREQUENCY,
        abscissa_axis_units_lab="Hz",
        x=(f0 + np.arange(hz.size) * df) if even else np.array(hz, dtype=float),
    )
    sets: list[dict] = [
        pyuff.prepare_164(
            units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0, temp_offset=273.15
        )
    ]
    # one record per (response, reference): the FRFs, then their coherence
    records = [(FUNC_FRF, UFF_KIND_CODES[kind], num_unit, _FORCE, "N", out.data.astype(complex), num_label, "Force")]
    if coh is not None:
        records.append((FUNC_COHERENCE, 1, "-", 0, None, coh, "Coherence", None))
    func_id = 0
    for func_type, ord_type, ord_unit, den_type, den_unit, values, ord_label, den_label in records:
        for j, r in enumerate(out.responses):
            for k, c in enumerate(out.references):
                func_id += 1
                extra = {} if den_unit is None else {"orddenom_axis_units_lab": den_unit}
                d = pyuff.prepare_58(
                    func_type=func_type,
                    rsp_node=int(r.node),
                    rsp_dir=_Z,
                    ref_node=int(c.node),
                    ref_dir=_Z,
                    ordinate_spec_data_type=ord_type,
                    ordinate_axis_units_lab=ord_unit,
                    orddenom_spec_data_type=den_type,
                    data=np.array(values[:, j, k]),
                    **extra,
                    **common,
                )
                d.update(func_id=func_id, abscissa_axis_lab="Frequency", ordinate_axis_lab=ord_label)
                if den_label is not None:
                    d["orddenom_axis_lab"] = den_label
                sets.append(d)
    path = Path(path)
    with atomic_path(path) as tmp:
        if tmp.stat().st_size != 0:  # pragma: no cover - mkstemp gives an empty file
            raise DataError(f"temporary file {tmp} is not empty; refusing to append to it")
        try:
            pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
        except Exception as exc:  # pyuff raises bare Exception
            raise DataError(f"pyuff failed to write {path}: {exc}") from exc
    return path
