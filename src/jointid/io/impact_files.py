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
  or 8 (displacement), all the same. Direction codes: 3 (+Z) is ``w``; a
  signal recorded along -Z (-3) is sign-flipped; other directions (X, Y,
  rotations) are not accepted (they are never measured). Reference direction
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
from typing import Sequence

import numpy as np

from ..dofs import Dof
from ..errors import DataError
from ..measurement.impact import ImpactRecord, where_hit
from .atomic import atomic_path
from .uff import FUNC_TIME

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
        z = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise DataError(f"{path}: cannot read as .npz ({e})") from None
    with z:
        missing = [k for k in ("force", "responses", "sample_rate_hz", "response_dofs", "reference") if k not in z]
        if missing:
            raise DataError(f"{path}: missing array(s) {missing}; see jointid.measurement.impact for the layout")
        ref = str(z["reference"])
        fs = float(z["sample_rate_hz"])
        if "time_s" in z:
            fs_t = _rate_from_time(np.asarray(z["time_s"], dtype=float), f"{path}: excited node {ref}, all hits")
            if not math.isclose(fs_t, fs, rel_tol=1e-6):
                raise DataError(
                    f"{path}: excited node {ref}, all hits: time_s gives {fs_t:g} Hz but sample_rate_hz is {fs:g} Hz"
                )
        return ImpactRecord(
            force=z["force"],
            responses=z["responses"],
            sample_rate_hz=fs,
            response_dofs=tuple(str(x) for x in z["response_dofs"]),
            reference=ref,
            kind=str(z["kind"]) if "kind" in z else "accelerance",
        )


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

    from .text import check_separator, read_utf8

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
                f"{path}: row {bad + 2}, column {name!r}: {v[bad]!r} is not a number "
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
            where = f"{path}: {where_hit(ref, i)} (hit column {h!r})"
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


def _uff_rate(s: dict, where: str) -> float:
    """Sample rate of a UFF58 time record (see the module docstring on the 6-digit increment)."""
    fs = _rate_from_time(np.asarray(s["x"], dtype=float), where)
    inc = float(s.get("abscissa_inc") or 0.0)
    if int(s.get("abscissa_spacing", 0) or 0) == 1 and inc > 0:
        cand = round(1.0 / inc)
        half_digit = 0.5 * 10.0 ** (math.floor(math.log10(inc)) - 5)
        if cand > 0 and abs(1.0 / cand - inc) <= half_digit * (1.0 + 1e-9):
            return float(cand)
    return fs


def read_impact_uff(path: str | Path) -> tuple[ImpactRecord, ...]:
    """Read UFF58 time records (function type 1) as records, one per reference DOF.

    Hits are told apart by ``load_case_id``; the force record of a hit has
    ordinate specific data type 13, the responses 12/11/8 (see module docstring).
    Records with reference direction 0 (no reference) belong to the excited
    DOF of their load case's force record.

    Raises
    ------
    DataError
        No time records, a hit without force, unknown directions, a load case
        without reference whose force record is missing or ambiguous, a
        non-uniform or inconsistent abscissa (naming the excited node and hit).
    """
    import pyuff

    path = Path(path)
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as e:  # pyuff raises bare Exceptions on malformed files
        raise DataError(f"{path}: cannot read as UFF ({e})") from None
    if isinstance(sets, dict):
        sets = [sets]
    sets = [s for s in sets if s.get("type") == 58 and int(s.get("func_type", 0)) == FUNC_TIME]
    if not sets:
        raise DataError(f"{path}: no UFF58 time-response records (function type 1)")

    def dof(node, direction, what):
        if abs(int(direction)) != _Z:
            raise DataError(
                f"{path}: {what} direction code {direction} is not supported: impact records are transverse "
                "(+Z = 3 is w, -Z = -3 is w with the sign flipped; a reference direction 0 means no reference); "
                "X, Y and rotations are never measured"
            )
        return Dof(int(node), "w")

    def signed(s) -> np.ndarray:
        """The record's samples in the +Z convention: a signal measured along -Z is sign-flipped.

        A time record is one signal (its own direction ``rsp_dir``); the reference
        direction only names the excited DOF, it does not change the signal's sign.
        """
        return np.sign(int(s["rsp_dir"])) * np.real(np.asarray(s["data"]))

    def is_force(s) -> bool:
        return int(s.get("ordinate_spec_data_type", 0)) == _UFF_FORCE

    # records without a reference (direction 0) take the excited DOF from their load case's force record
    case_force: dict[int, set[Dof]] = {}
    for s in sets:
        if int(s["ref_dir"]) == 0 and is_force(s):
            case_force.setdefault(int(s.get("load_case_id", 0)), set()).add(dof(s["rsp_node"], s["rsp_dir"], "force"))
    groups: dict[Dof, dict[int, dict]] = {}
    for s in sets:
        h = int(s.get("load_case_id", 0))
        if int(s["ref_dir"]) == 0:
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
            ref = dof(s["ref_node"], s["ref_dir"], "reference")
        g = groups.setdefault(ref, {}).setdefault(h, {"force": None, "resp": {}})
        if is_force(s):
            g["force"] = s
        else:
            g["resp"][dof(s["rsp_node"], s["rsp_dir"], "response")] = s
    records = []
    for ref, hits in groups.items():
        labels = None
        forces, resps, fs0, kind = [], [], None, None
        for i, (h, g) in enumerate(sorted(hits.items())):
            where = f"{path}: {where_hit(ref, i)} (load case {h})"
            if g["force"] is None:
                raise DataError(f"{where}: no force record (ordinate specific data type 13)")
            if labels is None:
                labels = sorted(g["resp"])
            if sorted(g["resp"]) != labels:
                raise DataError(f"{where}: response DOFs {[str(d) for d in sorted(g['resp'])]} differ from hit 0's")
            if not labels:
                raise DataError(f"{where}: no response records")
            fs = None
            for name, s in [("force", g["force"])] + [(f"response {d}", g["resp"][d]) for d in labels]:
                fs_s = _uff_rate(s, f"{where}, {name}")
                if fs is None:
                    fs = fs_s
                elif not math.isclose(fs_s, fs, rel_tol=1e-6):
                    raise DataError(f"{where}: {name} sampled at {fs_s:g} Hz, the force at {fs:g} Hz")
            if fs0 is None:
                fs0 = fs
            elif not math.isclose(fs, fs0, rel_tol=1e-6):
                raise DataError(f"{where}: sample rate {fs:g} Hz differs from {fs0:g} Hz of hit 0")
            ks = {_UFF_KIND.get(int(g["resp"][d].get("ordinate_spec_data_type", 12)), None) for d in labels}
            if None in ks or len(ks) != 1:
                raise DataError(f"{where}: responses must all be acceleration (12), velocity (11) or displacement (8)")
            kind = ks.pop()
            forces.append(signed(g["force"]))
            resps.append([signed(g["resp"][d]) for d in labels])
        try:
            records.append(ImpactRecord(forces, resps, fs0, tuple(labels), ref, kind))
        except DataError as e:
            raise DataError(f"{path}: {e}") from None
    return tuple(records)


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
        try:
            pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
        except Exception as exc:  # pyuff raises bare Exception
            raise DataError(f"pyuff failed to write {path}: {exc}") from exc
    return path
