"""Reading the dataset 58 records of a UFF file: which ones to keep, where they go, in what units.

Used by :func:`jointid.io.uff.read_uff_frf` (see its module docstring for the
conventions). A record goes through, in this order:

1. its function type: FRF (4) and, on request, coherence (6) are read; every
   other type (time, spectra, ...) is skipped and counted;
2. its directions: response and reference along the chosen axis (``+Z`` by
   default, any of ``+X .. -Z``) are the model's ``w``, the opposite sign
   flips the record; a record in another direction is skipped and counted;
3. its points: mapped to model nodes by ``points`` (file point id -> node;
   a point the map does not list is skipped), or taken as node numbers;
4. the DOFs wanted (``responses``/``references``): others are skipped;
5. only then its kind, units, abscissa and values are decoded, and anything
   wrong with them is a :class:`~jointid.errors.DataError` naming the file
   and the record.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Collection, Mapping

import numpy as np

from ..dofs import Dof
from ..errors import DataError, FrequencyError
from ..frequency import Frequency
from ..frf import LEAKAGE_MARK, MARK_PREFIX
from .uff_units import SI, UnitSystem, abscissa_factor, ordinate_units, units_from_164

__all__ = ["AXES", "FUNC_FRF", "FUNC_COHERENCE", "Record", "Selection", "read_records", "assemble", "axis_text", "coherence_matrix", "units_line", "marks_line", "MARK_PREFIX", "LEAKAGE_MARK", "map_record", "map_signal", "truncated_message", "unreadable_message"]

FUNC_TIME = 1
FUNC_FRF = 4
FUNC_COHERENCE = 6
#: UFF direction code of each axis name.
AXES: dict[str, int] = {"+X": 1, "-X": -1, "+Y": 2, "-Y": -2, "+Z": 3, "-Z": -3}
_FUNC_NAMES = {
    0: "general", 1: "time", 2: "auto-spectrum", 3: "cross-spectrum", 5: "transmissibility",
    6: "coherence", 7: "auto-correlation", 8: "cross-correlation", 9: "PSD", 10: "ESD", 12: "spectrum",
    18: "mode indicator", 21: "partial coherence", 26: "multiple coherence",
}
_CODE_KIND = {8: "receptance", 11: "mobility", 12: "accelerance"}
_FORCE = 13
_FREQUENCY = 18
_DATA_TYPES = {8: "displacement", 9: "reaction force", 11: "velocity", 12: "acceleration", 13: "excitation force", 0: "unknown", 1: "general"}
_DIRS = {0: "scalar", 1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
_COMPONENTS = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}


@dataclass
class Record:
    """One kept dataset 58 record, mapped to model DOFs, values in SI."""

    index: int  # 1-based position of the dataset in the file
    func_type: int
    response: Dof
    reference: Dof
    sign: float
    kind: str | None
    x: np.ndarray
    data: np.ndarray
    units: str = ""  # e.g. "g/N (labels)"
    factor: float = 1.0
    mark: str = ""  # ID line 4 when jointid wrote a processing mark there (LEAKAGE_MARK), else empty

    def name(self) -> str:
        return f"record {self.index} (response {self.response}, reference {self.reference})"


@dataclass
class Selection:
    """What to read: the point map, the axis, the wanted DOFs (``None``: all)."""

    n_nodes: int | None = None
    points: Mapping[int, int] | None = None
    axis: str | None = "+Z"  # None: 3-D, each record's direction code names the component
    responses: Collection[Dof] | None = None
    references: Collection[Dof] | None = None
    coherence: bool = False
    skipped: Counter = field(default_factory=Counter)
    unmatched: set = field(default_factory=set)  # DOFs of records skipped as not in the study (for the message)
    coherence_problem: str | None = None  # why the coherence records cannot be used (they are not needed)

    def skipped_line(self, examples: bool = False) -> str | None:
        """``skipped 42 records: 20 in X/Z, 19 coherence, 3 at DOFs not in the study`` (or None); ``examples``: with
        some of the DOFs not in the study and where to map them (when nothing could be read)."""
        n = sum(self.skipped.values())
        if not n:
            return None
        counts = Counter({k: v for k, v in self.skipped.items() if not k.startswith("in ")})
        dirs = sorted({d for k in self.skipped if k.startswith("in ") for d in k[3:].split("/")})
        if dirs:  # one entry for every other direction: "42 in X/Z"
            counts["in " + "/".join(dirs)] = sum(v for k, v in self.skipped.items() if k.startswith("in "))
        parts = [f"{c} {what}" for what, c in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))]
        line = f"skipped {n} record{'s' if n != 1 else ''}: " + ", ".join(parts)
        if examples and self.unmatched:
            seen = sorted(self.unmatched, key=lambda d: (d.node, d.direction))
            line += (f" (the file's DOFs include {', '.join(str(d) for d in seen[:6])}{', ...' if len(seen) > 6 else ''}: "
                     "if the file numbers its points otherwise, map them to the model's nodes in the study's [measurement.points])")
        return line


def _describe(path: Path, index: int, d: dict) -> str:
    return (
        f"record {index} of {path} (function type {d.get('func_type')}, response node {d.get('rsp_node')} "
        f"dir {d.get('rsp_dir')}, reference node {d.get('ref_node')} dir {d.get('ref_dir')})"
    )


def map_record(d: dict, sel: Selection, where: str) -> tuple[Dof, Dof, float] | str:
    """The record's (response, reference, sign) or the reason to skip it.

    ``sel.axis`` ``None`` (3-D models): direction codes 1-6 are the components
    ``x, y, z, rx, ry, rz`` and their negatives the same components sign-flipped;
    code 0 (scalar) is skipped.
    """
    dirs = (d.get("rsp_dir"), d.get("ref_dir"))
    if sel.axis is None:
        off = sorted({_DIRS.get(abs(x), f"direction {x}") if isinstance(x, (int, np.integer)) else f"direction {x}"
                      for x in dirs if not isinstance(x, (int, np.integer)) or not 1 <= abs(x) <= 6})
        if off:
            return "in " + "/".join(off)
        comps = [_COMPONENTS[abs(int(x))] for x in dirs]
        code = None
    else:
        code = AXES[sel.axis]
        off = sorted({_DIRS.get(abs(x), f"direction {x}") for x in dirs if not isinstance(x, (int, np.integer)) or abs(x) != abs(code)})
        if off:
            return "in " + "/".join(off)
        comps = ["w", "w"]
    dofs = []
    for side, what in (("rsp", "response"), ("ref", "reference")):
        node = d.get(f"{side}_node")
        if not isinstance(node, (int, np.integer)):
            raise DataError(f"{where}: {what} node {node!r} is not an integer")
        node = int(node)
        if sel.points is not None:
            if node not in sel.points:
                return "at points not in the point map"
            mapped = int(sel.points[node])
            if mapped < 1 or (sel.n_nodes is not None and mapped > sel.n_nodes):
                raise DataError(f"{where}: {what} point {node} is mapped to node {mapped}, outside the beam (nodes 1..{sel.n_nodes})")
            node = mapped
        elif node < 1 or (sel.n_nodes is not None and node > sel.n_nodes):
            rng = f"1..{sel.n_nodes}" if sel.n_nodes is not None else ">= 1"
            raise DataError(
                f"{where}: {what} node {node} is outside the beam (nodes {rng}); if the file numbers its points "
                "otherwise, map them to beam nodes (the study's [measurement.points])"
            )
        dofs.append(Dof(node, comps[len(dofs)]))
    if (sel.responses is not None and dofs[0] not in sel.responses) or (
        sel.references is not None and dofs[1] not in sel.references
    ):
        sel.unmatched.update(d for d, known in zip(dofs, (sel.responses, sel.references)) if known is not None and d not in known)
        return "at DOFs not in the study"
    if code is None:
        sign = (1.0 if dirs[0] > 0 else -1.0) * (1.0 if dirs[1] > 0 else -1.0)
    else:
        sign = (1.0 if dirs[0] == code else -1.0) * (1.0 if dirs[1] == code else -1.0)
    return dofs[0], dofs[1], sign



def map_signal(node, direction, sel: Selection, where: str) -> tuple[Dof, float] | str:
    """The model DOF and sign of one signal (a time record's node and direction), or why it is skipped.

    The same mapping as :func:`map_record` (axis, point map, beam range) applied to one
    signal instead of a response/reference pair.
    """
    if not isinstance(direction, (int, np.integer)):
        return f"in direction {direction}"
    ref_dir = abs(int(direction)) if sel.axis is None else AXES[sel.axis]
    mapped = map_record({"rsp_node": node, "rsp_dir": int(direction), "ref_node": node, "ref_dir": ref_dir}, sel, where)
    return mapped if isinstance(mapped, str) else (mapped[0], mapped[2])

def _kind(d: dict, where: str) -> str:
    num, den = d.get("ordinate_spec_data_type"), d.get("orddenom_spec_data_type")
    if num not in _CODE_KIND or den != _FORCE:
        raise DataError(
            f"{where}: cannot tell the FRF kind from the ordinate data characteristics "
            f"(numerator {num} = {_DATA_TYPES.get(num, 'unsupported')}, denominator {den} = "
            f"{_DATA_TYPES.get(den, 'unsupported')}); expected numerator 8 (displacement), 11 (velocity) "
            "or 12 (acceleration) over denominator 13 (excitation force)"
        )
    return _CODE_KIND[num]


def _abscissa(d: dict, where: str) -> np.ndarray:
    spec = d.get("abscissa_spec_data_type")
    factor = abscissa_factor(d, where)
    label = str(d.get("abscissa_axis_units_lab", "")).strip().lower()
    if spec != _FREQUENCY and label not in ("hz", "khz"):
        raise DataError(f"{where}: abscissa specific data type is {spec}, expected 18 (frequency, Hz)")
    x = np.asarray(d.get("x"), dtype=float).reshape(-1) * factor
    data = np.asarray(d.get("data")).reshape(-1)
    n = d.get("num_pts")
    if n is not None and (x.size != n or data.size != n):
        raise DataError(f"{where}: header announces {n} points but the record holds {data.size}")
    if x.size == 0:
        raise DataError(f"{where}: the record holds no data")
    return x


def _values(d: dict, where: str) -> tuple[np.ndarray, np.ndarray]:
    """The record's abscissa (Hz) and values, checked finite."""
    x = _abscissa(d, where)
    data = np.asarray(d["data"]).reshape(-1)
    bad = ~np.isfinite(data) | ~np.isfinite(x)
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        raise DataError(f"{where}: non-finite value at line {j + 1} ({x[j]:g} Hz)")
    return x, data


def truncated_message(path, line: int, complete: int) -> str:
    """The one line for a UFF file that ends inside a dataset (:func:`~.uff_ascii58.unclosed_dataset_line`)."""
    return (f"{path} ends inside a dataset (from line {line} on, after {complete} dataset(s), the text is not closed by a "
            "'    -1' line): the file is truncated or damaged (an interrupted copy or export?); copy or export it again")


def read_records(path: Path, sel: Selection) -> tuple[list[Record], list[Record]]:
    """The FRF and the coherence records ``sel`` keeps, in file order; skipped ones are counted in ``sel.skipped``.

    A record's header decides whether it is kept; only a kept record's values are
    decoded (:class:`~jointid.io.uff_ascii58.Uff58Reader`: vectorized, the same
    values as pyuff's).
    """
    from .uff_ascii58 import Uff58Reader, UffDamage

    if sel.axis is not None and sel.axis not in AXES:
        raise DataError(f"unknown measurement axis {sel.axis!r}; expected one of {', '.join(AXES)}")
    try:
        uff = Uff58Reader(path)
        types = uff.types
    except Exception as exc:  # pyuff raises bare Exception
        raise DataError(f"cannot read UFF file {path}: {exc}") from exc
    truncated_at = uff.unclosed_dataset_line()
    if truncated_at is not None:
        raise DataError(truncated_message(path, truncated_at, len(types)))
    system: UnitSystem = SI
    frfs: list[Record] = []
    cohs: list[Record] = []
    for i, t in enumerate(types):
        index = i + 1
        if t not in (58, 164):
            continue
        try:
            d = uff.header(i)
        except Exception as exc:
            raise DataError(unreadable_message(uff, i, path, exc)) from exc
        if t == 164:
            system = units_from_164(d, f"record {index} of {path}", index)
            continue
        ft = d.get("func_type")
        if ft not in (FUNC_FRF, FUNC_COHERENCE):
            sel.skipped[_FUNC_NAMES.get(ft, f"function type {ft}")] += 1
            continue
        if ft == FUNC_COHERENCE and not sel.coherence:
            sel.skipped["coherence"] += 1
            continue
        where = _describe(path, index, d)
        mapped = map_record(d, sel, where)
        if isinstance(mapped, str):
            sel.skipped["coherence" if ft == FUNC_COHERENCE else mapped] += 1
            continue
        response, reference, sign = mapped
        try:
            d = uff.values(i, d)
        except UffDamage as exc:
            raise DataError(f"record {index} of {path} {exc}") from None
        except Exception as exc:
            raise DataError(unreadable_message(uff, i, path, exc)) from exc
        if ft == FUNC_COHERENCE:
            try:
                x, data = _values(d, where)
            except DataError as exc:  # coherence is not needed: note it, do not stop
                sel.coherence_problem = sel.coherence_problem or f"coherence not used: {exc}"
                sel.skipped["coherence"] += 1
                continue
            cohs.append(Record(index, FUNC_COHERENCE, response, reference, 1.0, None, x, np.real(data).astype(float)))
            continue
        if d.get("ord_data_type") in _REAL_DATA_TYPES:  # magnitudes only (or real parts): no phase, not an FRF
            raise DataError(f"{where}: real-valued FRF data (ordinate data type {d['ord_data_type']}): an FRF is complex; "
                            "export it with real and imaginary parts (data type 5 or 6)")
        x, data = _values(d, where)
        kind = _kind(d, where)
        units = ordinate_units(d, d["ordinate_spec_data_type"], system, where, rotation=response.unit == "rad",
                               moment=reference.unit == "rad")
        text = f"{units.text} ({units.source})"
        id4 = str(d.get("id4", "")).strip()
        frfs.append(Record(index, FUNC_FRF, response, reference, sign, kind, x, data, text, units.factor,
                           id4 if id4.startswith(MARK_PREFIX) else ""))
    return frfs, cohs


def unreadable_message(uff, i: int, path: Path, exc: Exception) -> str:
    """The one line for dataset ``i`` (0-based) of ``path`` that pyuff cannot read (``exc``): its cause when it is a
    tab character (UFF's columns are fixed-width), else pyuff's message.

    Parameters
    ----------
    uff : Uff58Reader
        The file's reader (its ``types``, ``block`` and ``line_of``).
    """
    t = uff.types[i]
    block = uff.block(i)
    tab = block.find(b"\t")
    if tab >= 0:
        return (f"record {i + 1} of {path} (dataset {t}) cannot be read: line {uff.line_of(i, tab)} holds a tab character, "
                "which shifts UFF's fixed-width columns; re-export the file, or replace each tab by the spaces it stands "
                "for (e.g. `expand` for tab stops every 8 columns)")
    return f"record {i + 1} of {path}: pyuff cannot read dataset {t}: {exc}"


#: UFF58 ordinate data types of real values (2 single, 4 double precision); 5 and 6 are complex.
_REAL_DATA_TYPES = (2, 4)


def axis_text(x: np.ndarray) -> str:
    if x.size == 1:
        return f"1 line at {x[0]:.10g} Hz"
    return f"{x.size} lines, {x[0]:.10g}..{x[-1]:.10g} Hz, first step {x[1] - x[0]:.10g} Hz"


def assemble(records: list[Record], path: Path, what: str) -> tuple[Frequency, np.ndarray, tuple[Dof, ...], tuple[Dof, ...]]:
    """Stack records into an (F, r, c) array: one shared axis, every (response, reference) pair exactly once."""
    responses = tuple(dict.fromkeys(r.response for r in records))
    references = tuple(dict.fromkeys(r.reference for r in records))
    first = records[0]
    x0 = first.x
    tol = 1e-12 * max(1.0, float(np.max(np.abs(x0))))
    for r in records[1:]:
        if r.x.size != x0.size or not np.all(np.abs(r.x - x0) <= tol):
            raise DataError(
                f"{r.name()} in {path} is on a different frequency axis ({axis_text(r.x)}) than "
                f"{first.name()} ({axis_text(x0)}); all {what} records must share one axis"
            )
    try:
        frequency = Frequency(x0)
    except FrequencyError as exc:
        raise DataError(f"{first.name()} in {path}: invalid frequency axis: {exc}") from exc
    seen: dict[tuple[Dof, Dof], Record] = {}
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
    data = np.empty((frequency.size, len(responses), len(references)), dtype=complex if what == "FRF" else float)
    for r in records:
        data[:, ri[r.response], ci[r.reference]] = r.data
    return frequency, data, responses, references


def marks_line(records: list[Record], shown: int = 6) -> str | None:
    """One note on the records ``jointid frf`` marked as leaking (:data:`LEAKAGE_MARK`), or None."""
    marked = [r for r in records if r.mark == LEAKAGE_MARK]
    if not marked:
        return None
    names = ", ".join(f"{r.response}/{r.reference}" for r in marked[:shown]) + (", ..." if len(marked) > shown else "")
    return (f"{len(marked)} record(s) marked by jointid frf as leaking (the response still rang at the record's end: {names}): "
            "their FRFs are biased near the lightly damped modes, so a free model that does not fit these FRFs there may "
            "be this, not the model; process the hits again with longer records or an exponential window (--exp-tau-ms) "
            "before updating the model")


def units_line(records: list[Record]) -> str | None:
    """One line saying which records were converted to SI and how (None: nothing to say, all SI).

    e.g. ``units: 21 FRF records in g/N (labels) converted to SI: x 9.80665``.
    """
    groups: dict[tuple[str, float], list[int]] = {}
    for r in records:
        groups.setdefault((r.units, r.factor), []).append(r.index)
    parts = []
    for (text, factor), idx in groups.items():
        unlabelled = text.endswith("(default SI)")  # no labels, no dataset 164: an assumption worth a line
        if factor == 1.0 and not unlabelled:  # SI already (or an exactly neutral pair like mm over mN)
            continue
        n = f"{len(idx)} FRF record{'s' if len(idx) != 1 else ''}"
        if unlabelled:
            parts.append(f"{n} without units labels (and no units dataset 164) read as SI {text.split(' (')[0]}")
        else:
            parts.append(f"{n} in {text} converted to SI: x {factor:.12g}")
    if not parts:
        return None
    return "units: " + "; ".join(parts)


def coherence_matrix(
    records: list[Record], path: Path, frequency: Frequency, responses: tuple[Dof, ...], references: tuple[Dof, ...], sel: Selection
) -> tuple[np.ndarray | None, str | None]:
    """The coherence (F, r, c) aligned with the FRFs, or None and a one-line reason it is not used."""
    want = {(a, b) for a in responses for b in references}
    used = [r for r in records if (r.response, r.reference) in want]
    sel.skipped["coherence"] += len(records) - len(used)
    if not used:
        return None, None
    try:
        cf, coh, c_resp, c_ref = assemble(used, path, "coherence")
    except DataError as exc:
        return None, f"coherence not used: {exc}"
    if set(c_resp) != set(responses) or set(c_ref) != set(references):
        return None, (
            f"coherence not used: {path} has coherence records for responses {[str(d) for d in c_resp]} x references "
            f"{[str(d) for d in c_ref]}, not for every FRF"
        )
    if cf != frequency:
        return None, f"coherence not used: its axis ({axis_text(cf.hz)}) differs from the FRFs' ({axis_text(frequency.hz)})"
    if np.any(coh < -1e-6) or np.any(coh > 1 + 1e-6):
        return None, f"coherence not used: {path} holds coherence values outside [0, 1] ({coh.min():.6g}..{coh.max():.6g})"
    coh = np.clip(coh, 0.0, 1.0)  # rounding of exported values only
    coh = coh[:, [c_resp.index(d) for d in responses]][:, :, [c_ref.index(d) for d in references]]
    return coh, None
