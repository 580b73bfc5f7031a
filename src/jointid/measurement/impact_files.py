"""Impact-test time records on disk: NumPy ``.npz``, long CSV and UFF58 time records.

* **NumPy** ``.npz`` (one file per excited node, :func:`write_impact_npz` /
  :func:`read_impact_npz`): arrays ``force`` (n_hits, n_samples),
  ``responses`` (n_hits, n_channels, n_samples), ``sample_rate_hz`` (scalar),
  ``response_dofs`` (n_channels,) str, ``reference`` str, optional ``kind``
  str (default ``"accelerance"``) and optional ``time_s`` (n_samples,), which,
  if present, must be uniform and agree with ``sample_rate_hz``.
* **CSV** (one long file for all excited nodes, :func:`write_impact_csv` /
  :func:`read_impact_csv`): header ``excited_node, hit, time_s, force_n,
  <response label>...`` e.g. ``excited_node,hit,time_s,force_n,1w,3w,6w``; one
  row per sample; ``excited_node`` is a DOF label (``9w``); ``hit`` an integer
  (its value is kept only for ordering, hits are numbered 0.. in the order of
  appearance within their excited node); ``time_s`` must be uniform within a
  hit and give the same sample rate for all hits. Responses are accelerations
  (m/s^2).
* **UFF58** time records (:func:`read_impact_uff`): datasets 58 with function
  type 1 (time response), grouped by reference ``(ref_node, ref_dir)`` and
  by ``load_case_id`` = hit number. The force record has ordinate specific data
  type 13 (excitation force); responses have 12 (acceleration), 11 (velocity)
  or 8 (displacement), all the same. Directions and points are mapped as
  FRF records are (:mod:`jointid.io.uff_records`): the file's ``axis``
  (default +Z, code 3) is ``w``, a signal recorded along the opposite
  direction is sign-flipped (a time record is one signal: only its own
  direction counts), records in other directions are skipped and counted;
  ``points`` maps file point ids (1001, ...) to nodes; ``axis=None`` reads 3-D
  components (codes 1-6 = x .. rz). Units: each record's ordinate label (``g``,
  ``mm/s^2``, ``lbf``, ...) or the file's dataset 164, converted exactly to SI
  or refused naming the record (:func:`jointid.io.uff_units.signal_units`).
  Reference direction
  0 means "no reference", as acquisition systems write time records: the
  excited DOF is then the node of the load case's force record (one force
  record per load case, so every hit needs its own ``load_case_id``). The
  sample interval of an evenly spaced record is stored with 6 significant
  digits (``%13.5e``); when an integer sample rate (Hz) rounds to exactly
  that increment it is taken (exact for the usual 8192, 25600, 51200 Hz ...),
  otherwise ``1 / increment`` (relative error <= 5e-6).

"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..dofs import Dof
from ..errors import DataError
from .impact import ImpactRecord, where_hit
from ..io.atomic import atomic_path
from ..io.uff import FUNC_TIME, write_uff_datasets

__all__ = ["read_impact_npz", "write_impact_npz", "read_impact_csv", "write_impact_csv", "read_impact_uff", "write_impact_uff"]

_Z = 3  # UFF direction code of +Z, the transverse direction w; -Z records are sign-flipped
_UFF_KIND = {12: "accelerance", 11: "mobility", 8: "receptance"}
_UFF_SPEC = {v: k for k, v in _UFF_KIND.items()}
_UFF_FORCE = 13
_UFF_UNITS = {13: (0, 1, "N"), 12: (1, 0, "m/s^2"), 11: (1, 0, "m/s"), 8: (1, 0, "m")}



def write_impact_npz(path: str | Path, record: ImpactRecord) -> Path:
    """Write one record (one excited node) in the documented ``.npz`` layout.

    Parameters
    ----------
    path : str or Path
        Output file (``.npz``).
    record : ImpactRecord
        Hits at one excited node.
    """
    path = Path(path)
    with atomic_path(path, suffix=".npz") as tmp, open(tmp, "wb") as fh:
        np.savez(
            fh,
            force=record.force,
            responses=record.responses,
            sample_rate_hz=np.float64(record.sample_rate_hz),
            response_dofs=np.array([str(d) for d in record.response_dofs]),
            reference=np.array(str(record.reference)),
            kind=np.array(record.kind),
        )
    return path


def read_impact_npz(path: str | Path) -> ImpactRecord:
    """Read one record (one excited node) from the documented ``.npz`` layout.

    Raises
    ------
    DataError
        Missing arrays, inconsistent ``time_s``, or any :class:`ImpactRecord` check.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in ("force", "responses", "sample_rate_hz", "response_dofs", "reference") if k not in z]
            if missing:
                raise DataError(f"{path}: missing array(s) {missing}; see jointid.measurement.impact for the layout")
            arrays = {k: z[k] for k in ("force", "responses", "sample_rate_hz", "response_dofs", "reference", "time_s", "kind")
                      if k in z}  # read inside the try: a member cut short fails only here
    except DataError:
        raise
    except Exception as e:  # noqa: BLE001 - any parse failure of a user file (BadZipFile, EOFError, zlib.error) is a data error
        raise DataError(f"{path}: cannot read as .npz ({' '.join(str(e).split()) or type(e).__name__})") from None
    ref = str(arrays["reference"])
    try:
        fs = float(arrays["sample_rate_hz"])
    except (TypeError, ValueError):
        raise DataError(f"{path}: sample_rate_hz is not a number") from None
    if "time_s" in arrays:
        fs_t = _rate_from_time(np.asarray(arrays["time_s"], dtype=float), f"{path}: excited node {ref}, all hits")
        if not math.isclose(fs_t, fs, rel_tol=1e-6):
            raise DataError(
                f"{path}: excited node {ref}, all hits: time_s gives {fs_t:g} Hz but sample_rate_hz is {fs:g} Hz"
            )
    try:
        return ImpactRecord(
            force=arrays["force"],
            responses=arrays["responses"],
            sample_rate_hz=fs,
            response_dofs=tuple(str(x) for x in arrays["response_dofs"]),
            reference=ref,
            kind=str(arrays["kind"]) if "kind" in arrays else "accelerance",
        )
    except DataError as e:
        raise DataError(f"{path}: {e}") from None


def _rate_from_time(t: np.ndarray, where: str) -> float:
    """Sample rate from a time column that must be finite, increasing and uniform."""
    if t.size < 2:
        raise DataError(f"{where}: fewer than 2 time samples")
    if not np.all(np.isfinite(t)):
        raise DataError(f"{where}: time column contains NaN/inf")
    dt = np.diff(t)
    step = (t[-1] - t[0]) / (t.size - 1)
    if not step > 0:
        raise DataError(f"{where}: time does not increase (sample rate would be <= 0)")
    dev = np.abs(dt - step).max()
    if dev > 1e-6 * step + 1e-12:
        k = int(np.argmax(np.abs(dt - step)))
        raise DataError(
            f"{where}: time column is not uniform (step {dt[k]:.6g} s at sample {k} vs mean {step:.6g} s); "
            "resample to a constant rate or check for dropped samples"
        )
    return 1.0 / step


def write_impact_csv(path: str | Path, records: Sequence[ImpactRecord]) -> Path:
    """Write records in the documented long CSV layout (full float precision, atomically).

    Parameters
    ----------
    path : str or Path
        Output file.
    records : sequence of ImpactRecord
        One per excited node, all with the same response DOFs.
    """
    from ..io.tables import write_csv

    records = [records] if isinstance(records, ImpactRecord) else list(records)
    labels = [str(d) for d in records[0].response_dofs]
    cols: dict[str, list] = {"excited_node": [], "hit": [], "time_s": [], "force_n": []}
    resp: list[list[np.ndarray]] = [[] for _ in labels]
    for rec in records:
        if [str(d) for d in rec.response_dofs] != labels:
            raise DataError(f"excited node {rec.reference}: response DOFs differ from the first record's {labels}")
        n, h = rec.n_samples, rec.n_hits
        cols["excited_node"].append(np.repeat(str(rec.reference), n * h))
        cols["hit"].append(np.repeat(np.arange(h), n))
        cols["time_s"].append(np.tile(rec.time_s, h))
        cols["force_n"].append(rec.force.reshape(-1))
        for c in range(len(labels)):
            resp[c].append(rec.responses[:, c, :].reshape(-1))
    out = {k: np.concatenate(v) for k, v in cols.items()}
    for lab, v in zip(labels, resp):
        out[lab] = np.concatenate(v)
    return write_csv(path, out)


def read_impact_csv(path: str | Path, kind: str = "accelerance") -> tuple[ImpactRecord, ...]:
    """Read records (one per excited node, in order of appearance) from the documented long CSV layout.

    Raises
    ------
    DataError
        Not UTF-8 or not comma-separated, missing columns, unreadable numbers, a non-uniform time column or a
        sample rate that differs between hits (naming the excited node and hit),
        or any :class:`ImpactRecord` check.
    """
    import csv

    import io

    from ..io.text import check_separator, read_utf8

    path = Path(path)
    rows = list(csv.reader(io.StringIO(read_utf8(path, "impact CSV file"), newline="")))
    rows = [r for r in rows if r]
    if not rows:
        raise DataError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    check_separator(path, header)
    need = ["excited_node", "hit", "time_s", "force_n"]
    missing = [h for h in need if h not in header]
    labels = [h for h in header if h not in need]
    if missing or not labels:
        raise DataError(
            f"{path}: header must be 'excited_node,hit,time_s,force_n,<response label>...', got {header}"
        )
    body = rows[1:]
    ncol = len(header)
    cols = list(zip(*[(r + [""] * ncol)[:ncol] for r in body])) if body else [()] * ncol
    col = dict(zip(header, cols))
    exc = np.array([v.strip() for v in col["excited_node"]])
    hit = np.array([v.strip() for v in col["hit"]])

    def num(name: str) -> np.ndarray:
        v = col[name]
        try:
            return np.array([float(x) if x.strip() else np.nan for x in v])
        except ValueError:
            bad = next(i for i, x in enumerate(v) if not _is_float(x))
            raise DataError(
                f"{path}: row {bad + 2}, column {name!r}: {str(v[bad])!r} is not a number "
                f"({where_hit(exc[bad], hit[bad])})"
            ) from None

    t = num("time_s")
    f = num("force_n")
    Y = np.stack([num(lab) for lab in labels])
    records = []
    for ref in dict.fromkeys(exc):
        on = exc == ref
        hits = list(dict.fromkeys(hit[on]))
        forces, resps, fs0 = [], [], None
        for i, h in enumerate(hits):
            rows_h = on & (hit == h)
            where = f"{path}: {where_hit(ref, i)} (hit column {str(h)!r})"
            fs = _rate_from_time(t[rows_h], where)
            if fs0 is None:
                fs0 = fs
            elif not math.isclose(fs, fs0, rel_tol=1e-6):
                raise DataError(
                    f"{where}: sample rate {fs:g} Hz differs from {fs0:g} Hz of hit 0; all hits need the same rate"
                )
            forces.append(f[rows_h])
            resps.append(Y[:, rows_h])
        try:
            records.append(ImpactRecord(forces, resps, fs0, tuple(labels), ref, kind))
        except DataError as e:
            raise DataError(f"{path}: {e}") from None
    return tuple(records)


def _is_float(x: str) -> bool:
    try:
        float(x)
        return True
    except ValueError:
        return not x.strip()


def _uff_rate(s: dict, where: str, seconds: float = 1.0) -> float:
    """Sample rate of a UFF58 time record (see the module docstring on the 6-digit increment); ``seconds``: abscissa unit, s."""
    fs = _rate_from_time(np.asarray(s["x"], dtype=float) * seconds, where)
    inc = float(s.get("abscissa_inc") or 0.0) * seconds
    if int(s.get("abscissa_spacing", 0) or 0) == 1 and inc > 0:
        cand = round(1.0 / inc)
        half_digit = 0.5 * 10.0 ** (math.floor(math.log10(inc / seconds)) - 5) * seconds
        if cand > 0 and abs(1.0 / cand - inc) <= half_digit * (1.0 + 1e-9):
            return float(cand)
    return fs


def read_impact_uff(
    path: str | Path,
    *,
    points: Mapping[int, int] | None = None,
    axis: str | None = "+Z",
    n_nodes: int | None = None,
    with_notes: bool = False,
) -> "tuple[ImpactRecord, ...] | tuple[tuple[ImpactRecord, ...], tuple[str, ...]]":
    """Read UFF58 time records (function type 1) as records, one per reference DOF, in SI.

    Hits are told apart by ``load_case_id``; the force record of a hit has
    ordinate specific data type 13, the responses 12/11/8 (see module docstring).
    Records with reference direction 0 (no reference) belong to the excited
    DOF of their load case's force record.

    Parameters
    ----------
    path : str or Path
        ``.uff`` / ``.unv`` / ``.58`` file.
    points : mapping of int to int, optional
        File point id -> model node (e.g. 1001 -> 1); records at points it does
        not list are skipped. Default: point ids are node numbers.
    axis : {"+Z", "-Z", "+X", "-X", "+Y", "-Y"} or None
        The file's direction that is the model's ``w``: a signal recorded along
        the opposite direction is sign-flipped, records in other directions are
        skipped and counted. ``None`` (3-D models): direction codes 1-6 are the
        components ``x .. rz``, negative codes flip the sign. The mapping is the
        FRF reader's (:mod:`jointid.io.uff_records`).
    n_nodes : int, optional
        Number of model nodes: a (mapped) node outside ``1..n_nodes`` is an error.
    with_notes : bool
        Also return the notes: one line on the unit conversion (if any), one on
        the point map and axis (if not the default), one on skipped records (if any).

    Returns
    -------
    tuple of ImpactRecord
        Values in SI (N, m/s^2, m/s, m; s) whatever the file's units
        (:func:`jointid.io.uff_units.signal_units`: labels, dataset 164).
    (records, notes)
        If ``with_notes``.

    Raises
    ------
    DataError
        No time records, a hit without force, an unknown or contradictory units
        label (naming the record), a load case without reference whose force
        record is missing or ambiguous, a non-uniform or inconsistent abscissa
        (naming the excited node and hit).
    """
    import pyuff

    from ..io.uff_ascii58 import unclosed_dataset_line
    from ..io.uff_records import AXES, Selection, map_signal, truncated_message
    from ..io.uff_units import SI, conversion_line, signal_units, time_factor, units_from_164

    path = Path(path)
    if axis is not None and axis not in AXES:
        raise DataError(f"unknown measurement axis {axis!r}; expected one of {', '.join(AXES)}")
    try:
        uff = pyuff.UFF(str(path))
        sets = uff.read_sets()
    except Exception as e:  # pyuff raises bare Exceptions on malformed files
        raise DataError(f"{path}: cannot read as UFF ({e})") from None
    line = unclosed_dataset_line(path.read_bytes(), uff._block_ind)
    if line is not None:
        raise DataError(truncated_message(path, line, len(uff._block_ind)))
    if isinstance(sets, dict):
        sets = [sets]
    sel = Selection(n_nodes=n_nodes, points=None if points is None else {int(k): int(v) for k, v in points.items()}, axis=axis)

    # pass 1: units, mapping, values in SI; every 58 record counts in the numbering (as in the FRF reader)
    system = SI
    units: dict[tuple[str, str, float], int] = {}
    kept: list[dict] = []
    n_time = 0
    for i, s in enumerate(sets):
        index = i + 1
        if s.get("type") == 164:
            system = units_from_164(s, f"record {index} of {path}", index)
            continue
        if s.get("type") != 58 or int(s.get("func_type", 0)) != FUNC_TIME:
            continue
        n_time += 1
        h = int(s.get("load_case_id", 0))
        where = (f"record {index} of {path} (time record, node {s.get('rsp_node')} dir {s.get('rsp_dir')}, "
                 f"load case {h})")
        spec = int(s.get("ordinate_spec_data_type", 0))
        if spec not in (_UFF_FORCE, *_UFF_KIND):
            raise DataError(f"{where}: ordinate specific data type {spec} is not a force (13), acceleration (12), "
                            "velocity (11) or displacement (8)")
        sig = map_signal(s.get("rsp_node"), s.get("rsp_dir"), sel, where)
        if isinstance(sig, str):
            sel.skipped[sig] += 1
            continue
        ref = None
        if int(s.get("ref_dir", 0) or 0) != 0:
            r = map_signal(s.get("ref_node"), s.get("ref_dir"), sel, where)
            if isinstance(r, str):
                sel.skipped[r if not r.startswith("in ") else r + " (reference)"] += 1
                continue
            ref = r[0]
        u = signal_units(s, spec, system, where)
        what = "force" if spec == _UFF_FORCE else "response"
        key = (what, f"{u.text} ({u.source})", u.factor)
        units[key] = units.get(key, 0) + 1
        seconds = time_factor(s, where)
        kept.append({"set": s, "case": h, "dof": sig[0], "ref": ref, "force": spec == _UFF_FORCE, "spec": spec,
                     "data": sig[1] * u.factor * np.real(np.asarray(s["data"])),
                     "seconds": seconds})
    if not n_time:
        raise DataError(f"{path}: no UFF58 time-response records (function type 1)")
    skipped = sel.skipped_line()
    if not kept:
        raise DataError(f"{path}: no time record along {axis or 'X/Y/Z/RX/RY/RZ'} at a mapped point"
                        + (f"; {skipped}" if skipped else "") + "; give the measurement axis (--axis) or the point map (--points)")

    # records without a reference (direction 0) take the excited DOF from their load case's force record
    case_force: dict[int, set[Dof]] = {}
    for k in kept:
        if k["ref"] is None and k["force"]:
            case_force.setdefault(k["case"], set()).add(k["dof"])
    groups: dict[Dof, dict[int, dict]] = {}
    for k in kept:
        h = k["case"]
        if k["ref"] is None:
            refs = case_force.get(h, set())
            if len(refs) != 1:
                found = "no force record" if not refs else f"force records at {sorted(str(d) for d in refs)}"
                raise DataError(
                    f"{path}: load case {h}: time records without a reference (direction 0) and {found} "
                    "(ordinate specific data type 13) to tell the excited node; give each hit its own load case "
                    "with one force record, or write the reference node and direction"
                )
            ref = next(iter(refs))
        else:
            ref = k["ref"]
        g = groups.setdefault(ref, {}).setdefault(h, {"force": None, "resp": {}})
        if k["force"]:
            g["force"] = k
        else:
            g["resp"][k["dof"]] = k
    records = []
    for ref, hits in groups.items():
        labels = None
        forces, resps, fs0, kind = [], [], None, None
        for i, (h, g) in enumerate(sorted(hits.items())):
            where = f"{path}: {where_hit(ref, i)} (load case {h})"
            if g["force"] is None:
                raise DataError(f"{where}: no force record (ordinate specific data type 13)" + (f"; {skipped}" if skipped else ""))
            if labels is None:
                labels = sorted(g["resp"])
            if sorted(g["resp"]) != labels:
                raise DataError(f"{where}: response DOFs {[str(d) for d in sorted(g['resp'])]} differ from hit 0's")
            if not labels:
                raise DataError(f"{where}: no response records" + (f"; {skipped}" if skipped else ""))
            fs = None
            for name, k in [("force", g["force"])] + [(f"response {d}", g["resp"][d]) for d in labels]:
                fs_s = _uff_rate(k["set"], f"{where}, {name}", k["seconds"])
                if fs is None:
                    fs = fs_s
                elif not math.isclose(fs_s, fs, rel_tol=1e-6):
                    raise DataError(f"{where}: {name} sampled at {fs_s:g} Hz, the force at {fs:g} Hz")
            if fs0 is None:
                fs0 = fs
            elif not math.isclose(fs, fs0, rel_tol=1e-6):
                raise DataError(f"{where}: sample rate {fs:g} Hz differs from {fs0:g} Hz of hit 0")
            ks = {_UFF_KIND[g["resp"][d]["spec"]] for d in labels}
            if len(ks) != 1:
                raise DataError(f"{where}: responses must all be acceleration (12), velocity (11) or displacement (8)")
            kind = ks.pop()
            forces.append(g["force"]["data"])
            resps.append([g["resp"][d]["data"] for d in labels])
        try:
            records.append(ImpactRecord(forces, resps, fs0, tuple(labels), ref, kind))
        except DataError as e:
            raise DataError(f"{path}: {e}") from None
    if not with_notes:
        return tuple(records)
    notes = [conversion_line(units)]
    if points is not None or axis != "+Z":
        pm = sel.points or {}
        where_pts = f"points {_ranges(sorted(pm))} mapped to nodes {_ranges(sorted(pm[p] for p in pm))}" if pm else "point ids are node numbers"
        along = ("direction codes 1-6 are x .. rz (negative codes sign-flipped)" if axis is None
                 else f"{axis} is w (signals along {('-' if axis[0] == '+' else '+') + axis[1]} sign-flipped)")
        notes.append(f"{path.name}: {where_pts}; {along}")
    notes.append(skipped and f"{path.name}: {skipped}")
    return tuple(records), tuple(n if not n or n.startswith(path.name) else f"{path.name}: {n}" for n in notes if n)


def _ranges(xs: Sequence[int]) -> str:
    """``1001-1010, 1015`` for a sorted list of integers."""
    out, i = [], 0
    while i < len(xs):
        j = i
        while j + 1 < len(xs) and xs[j + 1] == xs[j] + 1:
            j += 1
        out.append(str(xs[i]) if i == j else f"{xs[i]}-{xs[j]}")
        i = j + 1
    return ", ".join(out)


def write_impact_uff(path: str | Path, records: Sequence[ImpactRecord]) -> Path:
    """Write records as ASCII UFF58 time records (function type 1), the layout :func:`read_impact_uff` reads.

    Parameters
    ----------
    path : str or Path
        Output file (replaced if it exists).
    records : sequence of ImpactRecord
        One per excited node; the hit index is written as ``load_case_id``.
    """
    import pyuff

    records = [records] if isinstance(records, ImpactRecord) else list(records)
    for rec in records:
        for d in (rec.reference, *rec.response_dofs):
            if d.direction != "w":
                raise DataError(f"excited node {rec.reference}: UFF58 impact records are transverse (w) only, got {d}")
    sets = []
    for rec in records:
        t = rec.time_s
        rn, rd = rec.reference.node, _Z
        for h in range(rec.n_hits):
            chans = [("force", rec.reference, _UFF_FORCE, rec.force[h])] + [
                ("response", d, _UFF_SPEC[rec.kind], rec.responses[h, c]) for c, d in enumerate(rec.response_dofs)
            ]
            for what, d, spec, y in chans:
                len_exp, force_exp, unit = _UFF_UNITS[spec]
                sets.append(
                    pyuff.prepare_58(
                        binary=0,
                        id1=f"{what} {d} hit {h}",
                        id2="jointid impact record",
                        id3="NONE",
                        id4="NONE",
                        id5="NONE",
                        func_type=FUNC_TIME,
                        ver_num=0,
                        load_case_id=h,
                        rsp_ent_name="beam",
                        rsp_node=d.node,
                        rsp_dir=_Z,
                        ref_ent_name="beam",
                        ref_node=rn,
                        ref_dir=rd,
                        abscissa_spec_data_type=17,
                        abscissa_len_unit_exp=0,
                        abscissa_force_unit_exp=0,
                        abscissa_temp_unit_exp=0,
                        abscissa_axis_units_lab="s",
                        ordinate_spec_data_type=spec,
                        ordinate_len_unit_exp=len_exp,
                        ordinate_force_unit_exp=force_exp,
                        ordinate_temp_unit_exp=0,
                        ordinate_axis_units_lab=unit,
                        orddenom_spec_data_type=0,
                        orddenom_len_unit_exp=0,
                        orddenom_force_unit_exp=0,
                        orddenom_temp_unit_exp=0,
                        orddenom_axis_units_lab="NONE",
                        z_axis_spec_data_type=0,
                        z_axis_len_unit_exp=0,
                        z_axis_force_unit_exp=0,
                        z_axis_temp_unit_exp=0,
                        z_axis_axis_units_lab="NONE",
                        z_axis_value=0.0,
                        abscissa_spacing=1,
                        abscissa_min=float(t[0]),
                        abscissa_inc=float(t[1] - t[0]),
                        data=np.asarray(y, dtype=float),
                        x=t,
                    )
                )
    path = Path(path)
    with atomic_path(path) as tmp:  # a fresh empty file: pyuff's "add" never appends to an old one
        write_uff_datasets(tmp, sets, path)
    return path
