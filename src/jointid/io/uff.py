"""FRF files in Universal File Format dataset 58 (ASCII and binary), via pyuff.

Conventions
-----------
* **Points** are beam node numbers (1..n_nodes), or file point ids mapped to
  nodes by ``points`` (e.g. the test geometry's 1001, 1002, ... -> 1, 2, ...;
  records at points the map does not list are skipped).
* **Direction**: the transverse beam displacement ``w`` is the file's
  ``axis`` (default +Z, direction code ``3``; any of ``+X .. -Z``). A record
  measured along the opposite direction (e.g. -Z, code ``-3``) is
  sign-flipped, on the response and on the reference side independently
  (two flips cancel). Records in any other direction (triaxial X/Y channels,
  rotations, scalar) are skipped and counted: rotational DOFs are not
  measured, and this module never guesses how they map onto ``theta``.
  With ``axis=None`` (3-D models, a ``[structure]`` study) every record's
  direction code 1-6 is the DOF's component ``x, y, z, rx, ry, rz``, a
  negative code (e.g. -X) flips the sign; the writer writes ``w`` as +Z and
  ``x .. rz`` as codes 1-6.
* **Kind** comes from record 9 (ordinate numerator) and record 10 (ordinate
  denominator) *specific data type*: numerator 8 = displacement
  (receptance), 11 = velocity (mobility), 12 = acceleration (accelerance);
  denominator 13 = excitation force. Anything else is an error naming the
  record. Records of different kinds in one file are converted exactly to
  the kind of the first FRF record, or, when the axis holds a 0 Hz line and a
  record is of a higher kind, to the highest kind present (converting down
  would divide by zero at 0 Hz; :func:`common_kind`, said in the notes).
* **Units** come from the records' units labels (``g``, ``mm/s^2``,
  ``in/s``, ``lbf``, ``g/N``, ...), or, where a label is blank or ``NONE``,
  from the units dataset 164 (SI, BG, MG, BA, MM, CM, IN, GM, user
  defined), or SI when the file has none; values are converted exactly to
  SI (m, N, s, Hz). An unknown label, or one that contradicts the record's
  data type or a non-SI dataset 164, is an error naming the record
  (:mod:`jointid.io.uff_units` has the table and the rules). The FRF's
  ``notes`` say in one line what was converted.
* **Abscissa** is frequency in Hz (record 8 specific data type 18, or units
  label ``Hz``), evenly or unevenly spaced.
* **Records** are numbered 1, 2, ... in the order of the datasets in the file
  (every dataset counts, whatever its type); error messages name the file
  and the record so.
* Only FRF records (function type 4) build the FRF matrix; coherence records
  (function type 6, "Coherence" in the UFF58 specification) are read on
  request; every other record (time histories, type 1; auto-/cross-spectra;
  ...), and FRFs the caller does not want (``responses``/``references``) are
  skipped, and the FRF's ``notes`` count them in one line ("skipped 42
  records: 20 in X/Y, 19 coherence, 3 at DOFs not in the study"). Only a
  record that is kept and cannot be read is an error. Other datasets
  (geometry, ...) are ignored.

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
* Numbers written with Fortran ``D`` exponents (``1.0D+00``) are read as with
  ``E``, exactly; a tab that shifts the fixed-width columns and a binary file
  damaged by a text-mode transfer (CR LF inserted into its values) are refused
  naming the record and what to do (:mod:`jointid.io.uff_ascii58`).
* pyuff replaces NaN/inf by numbers on writing (``numpy.nan_to_num``), so the
  writer refuses non-finite data itself.
* pyuff's ``mode="overwrite"`` truncates binary 58 files; the writer always
  uses ``mode="add"`` on a fresh, empty temporary file that is renamed onto
  the destination when complete (:func:`jointid.io.atomic.atomic_path`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..dofs import parse_dof, parse_dofs
from ..errors import DataError, JointIdError
from ..frf import FRF, KINDS, kind_factor
from .atomic import atomic_path
from .uff_records import (FUNC_COHERENCE, FUNC_FRF, FUNC_TIME, LEAKAGE_MARK, Selection, assemble, axis_text, coherence_matrix, marks_line,
                          read_records, units_line)

__all__ = ["read_uff_frf", "write_uff_frf", "write_uff_datasets", "common_kind", "UFF_KIND_CODES", "FUNC_TIME", "FUNC_FRF", "FUNC_COHERENCE",
           "LEAKAGE_MARK"]

#: Record 9 (ordinate numerator) specific data type of each FRF kind; denominator is 13.
UFF_KIND_CODES: dict[str, int] = {"receptance": 8, "mobility": 11, "accelerance": 12}
_FORCE = 13
_FREQUENCY = 18
_Z = 3
#: UFF direction code written for each DOF direction (the beam's ``w`` is +Z).
_DIR_CODES = {"w": _Z, "x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6}
_NUM_LABELS = {"receptance": ("Displacement", "m"), "mobility": ("Velocity", "m/s"), "accelerance": ("Acceleration", "m/s^2")}


def read_uff_frf(
    path: str | os.PathLike,
    n_nodes: int | None = None,
    coherence: bool = False,
    kind: str | None = None,
    *,
    points: Mapping[int, int] | None = None,
    axis: str | None = "+Z",
    responses: Iterable | None = None,
    references: Iterable | None = None,
    attach: bool = False,
) -> "FRF | tuple[FRF, np.ndarray | None]":
    """Read FRFs from a UFF dataset 58 file (ASCII or binary), in SI.

    Parameters
    ----------
    path : path-like
        ``.uff`` / ``.unv`` / ``.58`` file.
    n_nodes : int, optional
        Number of beam nodes; nodes outside ``1..n_nodes`` are an error.
    coherence : bool
        Also read the coherence records (function type 6) of the kept FRFs.
    kind : {"receptance", "mobility", "accelerance"}, optional
        Convert the result exactly to this kind (default: the kind of the file).
    points : mapping of int to int, optional
        File point id -> model node. Records at points it does not list are
        skipped. Default: point ids are node numbers.
    axis : {"+Z", "-Z", "+X", "-X", "+Y", "-Y"} or None
        The file's direction that is the model's ``w``; records along the
        opposite direction are sign-flipped, records in other directions skipped.
        ``None`` (3-D models): each record's direction code 1-6 is the DOF's
        component ``x, y, z, rx, ry, rz``; a negative code flips the sign
        (scalar records, code 0, are skipped).
    responses, references : iterables of DOF labels, optional
        Keep only FRFs between these (model) DOFs; default: every mapped record.
    attach : bool
        With ``coherence``: return only the FRF, its ``coherence`` attribute
        holding the coherence (instead of the pair ``(FRF, coherence)``).

    Returns
    -------
    FRF
        Responses and references in order of first appearance; ``kind`` from
        the records' ordinate characteristics (or ``kind`` if given); values
        in SI whatever the file's units. ``FRF.notes``: one line on the unit
        conversion (if any), one on the skipped records (if any), one on
        coherence that could not be used (if any).
    (FRF, ndarray or None)
        If ``coherence`` and not ``attach``: also the coherence, real, shape
        (F, r, c) aligned with the FRF, or ``None`` when there is none.

    Raises
    ------
    DataError
        Naming the file and record: node outside the beam, unknown or
        contradictory units label or ordinate characteristics, non-finite
        value, different frequency axis, duplicated pair; or naming the
        missing pair; or no FRF record to keep (with what was skipped).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"FRF file {path} does not exist")
    if kind is not None and kind not in KINDS:
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {KINDS}")
    sel = Selection(
        n_nodes=n_nodes,
        points=None if points is None else {int(k): int(v) for k, v in points.items()},
        axis=axis,
        responses=None if responses is None else set(parse_dofs(responses)),
        references=None if references is None else set(parse_dofs(references)),
        coherence=coherence,
    )
    frf_records, coh_records = read_records(path, sel)
    if not frf_records:
        skipped = sel.skipped_line(examples=True)
        hint = ""
        if any(k.startswith("in ") for k in sel.skipped):
            hint = "; if the beam was measured along another direction, give that axis (the study's [measurement].axis)"
        elif not sel.skipped:  # not one dataset recognized
            hint = ("; no UFF dataset was found in it at all: datasets are delimited by lines that read exactly '    -1' "
                    "(six characters: check for trailing spaces, tabs or another file format)")
        raise DataError(
            f"{path} holds no FRF record to read (UFF dataset 58, function type 4, along {axis[1] if axis else 'X/Y/Z/RX/RY/RZ'})"
            + (f"; {skipped}" if skipped else "") + hint
        )
    base, kind_note = common_kind(frf_records)
    for r in frf_records:
        factor = r.sign * r.factor
        if r.kind != base:
            try:  # on the record's own axis (a different one is refused by assemble, naming both)
                factor = factor * kind_factor(2.0 * np.pi * r.x, r.kind, base)  # type: ignore[arg-type]
            except JointIdError as exc:
                raise DataError(f"{r.name()} in {path}: cannot convert {r.kind} to {base}: {exc}") from exc
        r.data = np.asarray(r.data, dtype=complex) * factor
    frequency, data, resp, refs = assemble(frf_records, path, "FRF")
    coh, coh_note = (None, sel.coherence_problem)
    if coherence and coh_records and coh_note is None:
        coh, coh_note = coherence_matrix(coh_records, path, frequency, resp, refs, sel)
    elif coh_records:
        sel.skipped["coherence"] += len(coh_records)
    notes = tuple(n for n in (units_line(frf_records), kind_note, sel.skipped_line(), coh_note, marks_line(frf_records)) if n)
    frf = FRF(frequency, data, resp, refs, base, coh if attach else None, notes,
              tuple((r.response, r.reference, r.mark) for r in frf_records if r.mark))
    if kind is not None:
        try:
            frf = frf.to(kind)
        except JointIdError as exc:  # at 0 Hz: name the file
            raise DataError(f"{path}: {exc}") from exc
    if not coherence or attach:
        return frf
    return frf, coh

def common_kind(records) -> tuple[str, str | None]:
    """The kind records of several kinds are converted to, and a note when it is not the first record's.

    The first record's kind, unless the axis holds a 0 Hz line and a record is of a higher kind
    (mobility, accelerance over receptance): a conversion down to the first record's kind would divide
    by ``j w = 0`` there, so the records are converted up, exactly on every line, to the highest kind
    present (receptance and mobility are 0 at 0 Hz as accelerance), as a file of that kind alone is read.

    Parameters
    ----------
    records : list of Record
        The FRF records, in file order (each with ``kind`` and its abscissa ``x``, Hz).

    Returns
    -------
    (str, str or None)
        The kind, and the note (None when it is the first record's kind).
    """
    first = records[0].kind
    kinds = {r.kind for r in records}
    top = max(kinds, key=KINDS.index)
    if KINDS.index(top) <= KINDS.index(first) or not any(np.any(r.x == 0.0) for r in records):
        return first, None
    lower = sorted({r.kind for r in records if r.kind != top}, key=KINDS.index)
    return top, (f"kind: records of {', '.join(lower)} and {top} read as {top} (not as the first record's {first}: "
                 f"the 0 Hz line of {top} cannot be converted to {first})")


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
    marks: Mapping | None = None,
) -> Path:
    """Write FRFs as UFF dataset 58, one record per (response, reference) pair, atomically.

    The file starts with a units dataset 164 (SI), then the FRF records
    (function type 4, abscissa frequency in Hz, response and reference
    direction +Z for the beam's ``w`` and the UFF codes 1-6 for the 3-D
    components ``x, y, z, rx, ry, rz``, ordinate numerator displacement/velocity/acceleration over
    excitation force according to ``kind``, complex double precision), then,
    if given, the coherence records (function type 6, real).

    Parameters
    ----------
    path : path-like
        Destination (conventionally ``.uff``).
    frf : FRF
        FRFs between ``w`` DOFs or 3-D DOFs (``x .. rz``); the beam's ``theta``
        and scalar points cannot be written (UFF has no code for them).
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
    marks : mapping of (response, reference) -> str, optional
        ID line 4 of those FRF records (at most 80 characters; e.g. :data:`LEAKAGE_MARK`, which
        :func:`read_uff_frf` turns into a note); the others get ``NONE``.

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
    bad = [str(d) for d in (*frf.responses, *frf.references) if d.direction not in _DIR_CODES]
    if bad:
        raise DataError(f"UFF58 FRF files carry transverse (w, +Z) and 3-D (x, y, z, rx, ry, rz) DOFs only; cannot write {bad}")
    if len(description) > 80:
        raise DataError("UFF ID lines hold at most 80 characters; shorten the description")
    marks = {(parse_dof(r), parse_dof(c)): str(v) for (r, c), v in (marks or {}).items()}
    if any(len(v) > 80 for v in marks.values()):
        raise DataError("UFF ID lines hold at most 80 characters; shorten the record marks")
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
            f"the frequency axis ({axis_text(hz)}) cannot be written to an ASCII UFF58 file exactly: "
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
                # SI labels of this pair: an angle for a rotational response, N*m for a moment excitation
                extra = {} if den_unit is None else {"orddenom_axis_units_lab": den_unit + ("*m" if c.unit == "rad" else "")}
                d = pyuff.prepare_58(
                    func_type=func_type,
                    rsp_node=int(r.node),
                    rsp_dir=_DIR_CODES[r.direction],
                    ref_node=int(c.node),
                    ref_dir=_DIR_CODES[c.direction],
                    ordinate_spec_data_type=ord_type,
                    ordinate_axis_units_lab=("rad" + ord_unit[1:]) if r.unit == "rad" and ord_unit.startswith("m") else ord_unit,
                    orddenom_spec_data_type=den_type,
                    data=np.array(values[:, j, k]),
                    **extra,
                    **common,
                )
                d.update(func_id=func_id, abscissa_axis_lab="Frequency", ordinate_axis_lab=ord_label)
                if func_type == FUNC_FRF and (r, c) in marks:
                    d["id4"] = marks[(r, c)]
                if den_label is not None:
                    d["orddenom_axis_lab"] = den_label
                sets.append(d)
    path = Path(path)
    with atomic_path(path) as tmp:
        if tmp.stat().st_size != 0:  # pragma: no cover - mkstemp gives an empty file
            raise DataError(f"temporary file {tmp} is not empty; refusing to append to it")
        write_uff_datasets(tmp, sets, path)
    return path


def write_uff_datasets(tmp: str | os.PathLike, sets: list[dict], path: str | os.PathLike) -> None:
    """Append pyuff datasets ``sets`` to the empty file ``tmp`` (the temporary file of ``path``, named in errors).

    pyuff's ``UFF.write_sets`` re-reads and re-indexes the whole file after every dataset it
    appends (``refresh``): writing ``n`` records costs ``O(n^2)`` (973 records of 196 lines: 16 s,
    against 0.6 s here). The writer here is pyuff's, with that re-index skipped: the object is never
    read from, and the bytes written are the same (``tests/test_io_uff.py`` compares them).

    Raises
    ------
    DataError
        pyuff failed (it raises bare ``Exception``), naming ``path``.
    """
    import pyuff

    class _AppendOnlyUFF(pyuff.UFF):
        def refresh(self):  # called by UFF.__init__ and after each dataset written; nothing reads this object
            self._refreshed = False
            return False

    try:
        _AppendOnlyUFF(str(tmp)).write_sets(sets, mode="add")
    except Exception as exc:  # pyuff raises bare Exception
        raise DataError(f"pyuff failed to write {path}: {exc}") from exc
