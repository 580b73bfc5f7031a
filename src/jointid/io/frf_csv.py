"""FRFs as a plain CSV table (long format), exact to float precision.

Layout
------
::

    # jointid FRF CSV
    # kind = accelerance
    frequency_hz,response,reference,real,imag
    5,3w,9w,-0.0123,0.00045
    5,4w,9w,...

* Lines starting with ``#`` are comments. One of them must declare the kind,
  ``# kind = receptance|mobility|accelerance`` — or the table has a ``kind``
  column holding the same value on every row (if both are given they must
  agree). The kind is never guessed.
* The header row names the columns ``frequency_hz``, ``response``,
  ``reference``, ``real``, ``imag`` (any order; an optional ``kind`` column).
* One row per frequency line and (response, reference) pair, in any order.
  ``response`` / ``reference`` are DOF labels: ``3w`` (transverse, +Z, m),
  ``3theta`` (rotation, rad, ``theta = dw/dx``), or a bare node number
  meaning ``w``.
* Values are SI: Hz; receptance m/N, mobility (m/s)/N, accelerance
  (m/s^2)/N (rad and N*m for ``theta`` DOFs).
* Every (response, reference) pair appears exactly once per line, and every
  pair has the same frequency lines. Row numbers in error messages are line
  numbers of the file (1-based, comments and header included).

The writer prints shortest round-trip floats (``repr``), so a written file
reads back bit-exactly. Responses and references keep the order of their
first appearance in the file.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections import Counter
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..dofs import DIRECTIONS, Dof, parse_dof, parse_dofs
from ..errors import DataError, JointIdError
from ..frequency import Frequency
from ..frf import FRF, KINDS
from .atomic import atomic_path
from .text import check_separator, read_utf8

__all__ = ["read_frf_csv", "write_frf_csv", "CSV_COLUMNS"]

CSV_COLUMNS: tuple[str, ...] = ("frequency_hz", "response", "reference", "real", "imag")
_KIND_LINE = re.compile(r"^#\s*kind\s*[=:]\s*(\S+)\s*$", re.IGNORECASE)


def _label(text: str, lineno: int, column: str, cache: dict[str, Dof], path: Path) -> Dof:
    dof = cache.get(text)
    if dof is None:
        t = text.strip()
        try:
            dof = parse_dof(int(t)) if t.isdigit() else parse_dof(t)
        except JointIdError as exc:
            raise DataError(f"row {lineno} of {path}: cannot read the {column} DOF {text!r}: {exc}") from exc
        if dof.direction not in DIRECTIONS:
            raise DataError(f"row {lineno} of {path}: cannot read the {column} DOF {text!r}: this CSV layout holds beam DOFs only (w, theta)")
        cache[text] = dof
    return dof


def _select_rows(
    path: Path,
    resp: list[Dof],
    ref: list[Dof],
    linenos: list[int],
    n_nodes: int | None,
    points: Mapping[int, int] | None,
    responses: set[Dof] | None,
    references: set[Dof] | None,
) -> tuple[list[int], list[Dof], list[Dof], Counter]:
    """Rows to keep (indices), their mapped DOFs, and the count of skipped rows by reason."""
    keep: list[int] = []
    out_r: list[Dof] = []
    out_c: list[Dof] = []
    skipped: Counter = Counter()
    for i, (a, b, ln) in enumerate(zip(resp, ref, linenos)):
        if points is not None:
            if a.node not in points or b.node not in points:
                skipped["at points not in the point map"] += 1
                continue
            a, b = Dof(points[a.node], a.direction), Dof(points[b.node], b.direction)
        for d, column in ((a, "response"), (b, "reference")):
            if n_nodes is not None and d.node > n_nodes:
                raise DataError(f"row {ln} of {path}: {column} {d} is outside the beam (nodes 1..{n_nodes})")
        if (responses is not None and a not in responses) or (references is not None and b not in references):
            skipped["at DOFs not in the study"] += 1
            continue
        keep.append(i)
        out_r.append(a)
        out_c.append(b)
    return keep, out_r, out_c, skipped


def _floats(values: list[str], linenos: list[int], column: str, path: Path) -> np.ndarray:
    try:
        return np.array(values, dtype=float)
    except ValueError:
        for v, ln in zip(values, linenos):
            try:
                float(v)
            except ValueError:
                raise DataError(f"row {ln} of {path}: column {column!r} holds {v!r}, not a number") from None
        raise  # pragma: no cover


def read_frf_csv(
    path: str | os.PathLike,
    n_nodes: int | None = None,
    kind: str | None = None,
    *,
    points: Mapping[int, int] | None = None,
    responses: Iterable | None = None,
    references: Iterable | None = None,
) -> FRF:
    """Read FRFs from the CSV layout documented in :mod:`jointid.io.frf_csv`.

    Parameters
    ----------
    path : path-like
        CSV file.
    n_nodes : int, optional
        Number of beam nodes; DOFs on nodes above it are an error.
    kind : {"receptance", "mobility", "accelerance"}, optional
        Convert the result exactly to this kind (default: the file's kind).
    points : mapping of int to int, optional
        The file's node numbers -> model nodes; rows at nodes it does not
        list are skipped (``FRF.notes`` counts them).
    responses, references : iterables of DOF labels, optional
        Keep only rows between these (model) DOFs; the others are skipped.

    Raises
    ------
    DataError
        Not UTF-8, separated by semicolons, missing kind, bad header, unreadable cell, non-finite value, node
        outside the beam (naming the row); duplicated row for a pair and line
        (naming both rows); missing pair or different frequency lines (naming
        the pair).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"FRF file {path} does not exist")
    if kind is not None and kind not in KINDS:
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {KINDS}")
    text = read_utf8(path, "FRF CSV file")
    lines = text.splitlines()
    file_kind: str | None = None
    header: list[str] | None = None
    header_line = 0
    body: list[list[str]] = []
    linenos: list[int] = []
    for lineno, line in enumerate(lines, start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = _KIND_LINE.match(s)
            if m:
                if file_kind is not None and m.group(1) != file_kind:
                    raise DataError(f"{path} line {lineno}: second kind declaration {m.group(1)!r} contradicts {file_kind!r}")
                file_kind = m.group(1)
            continue
        row = next(csv.reader(io.StringIO(line)))
        if header is None:
            header = [c.strip() for c in row]
            header_line = lineno
            check_separator(path, header, lineno)
            continue
        body.append(row)
        linenos.append(lineno)
    if header is None:
        raise DataError(f"{path} has no header row; expected columns {', '.join(CSV_COLUMNS)}")
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise DataError(f"{path} line {header_line}: header {header} lacks column(s) {missing}; expected {list(CSV_COLUMNS)}")
    col = {c: header.index(c) for c in header}
    for row, ln in zip(body, linenos):
        if len(row) != len(header):
            raise DataError(f"row {ln} of {path} has {len(row)} cells, the header has {len(header)}")
    if "kind" in col:
        kinds = {row[col["kind"]].strip() for row in body}
        if len(kinds) > 1:
            raise DataError(f"{path}: column 'kind' must hold one value on every row, found {sorted(kinds)}")
        if kinds:
            k = kinds.pop()
            if file_kind is not None and k != file_kind:
                raise DataError(f"{path}: column 'kind' ({k!r}) contradicts the comment '# kind = {file_kind}'")
            file_kind = k
    if file_kind is None:
        raise DataError(
            f"{path} does not declare the FRF kind; add a comment line '# kind = accelerance' "
            f"(or receptance, mobility) or a 'kind' column"
        )
    if file_kind not in KINDS:
        raise DataError(f"{path}: unknown FRF kind {file_kind!r}; expected one of {KINDS}")
    if not body:
        raise DataError(f"{path} holds no FRF rows")

    cache: dict[str, Dof] = {}
    resp = [_label(row[col["response"]], ln, "response", cache, path) for row, ln in zip(body, linenos)]
    ref = [_label(row[col["reference"]], ln, "reference", cache, path) for row, ln in zip(body, linenos)]
    keep, resp, ref, skipped = _select_rows(
        path, resp, ref, linenos, n_nodes,
        None if points is None else {int(k): int(v) for k, v in points.items()},
        None if responses is None else set(parse_dofs(responses)),
        None if references is None else set(parse_dofs(references)),
    )
    n_skip = sum(skipped.values())
    note = (
        f"skipped {n_skip} row{'s' if n_skip != 1 else ''}: "
        + ", ".join(f"{c} {w}" for w, c in sorted(skipped.items(), key=lambda kv: (-kv[1], kv[0])))
        if n_skip else None
    )
    if not keep:
        raise DataError(f"{path} holds no FRF row to read; {note}")
    if n_skip:
        body = [body[i] for i in keep]
        linenos = [linenos[i] for i in keep]
    freq = _floats([row[col["frequency_hz"]] for row in body], linenos, "frequency_hz", path)
    re_ = _floats([row[col["real"]] for row in body], linenos, "real", path)
    im_ = _floats([row[col["imag"]] for row in body], linenos, "imag", path)
    ln_arr = np.asarray(linenos)
    bad = ~(np.isfinite(freq) & np.isfinite(re_) & np.isfinite(im_))
    if bad.any():
        raise DataError(f"row {ln_arr[bad][0]} of {path} holds a non-finite value")
    if np.any(freq < 0):
        raise DataError(f"row {ln_arr[freq < 0][0]} of {path}: frequency must be >= 0 Hz")

    responses = list(dict.fromkeys(resp))
    references = list(dict.fromkeys(ref))
    ri = {d: i for i, d in enumerate(responses)}
    ci = {d: i for i, d in enumerate(references)}
    r_idx = np.fromiter((ri[d] for d in resp), dtype=np.int64, count=len(resp))
    c_idx = np.fromiter((ci[d] for d in ref), dtype=np.int64, count=len(ref))
    pair = r_idx * len(references) + c_idx
    order = np.lexsort((freq, pair))
    pair_s, freq_s = pair[order], freq[order]
    dup = np.flatnonzero((pair_s[1:] == pair_s[:-1]) & (freq_s[1:] == freq_s[:-1]))
    if dup.size:
        a, b = sorted((ln_arr[order][dup[0]], ln_arr[order][dup[0] + 1]))
        p = int(pair_s[dup[0]])
        raise DataError(
            f"{path}: rows {a} and {b} both give the pair (response {responses[p // len(references)]}, "
            f"reference {references[p % len(references)]}) at {freq_s[dup[0]]:.10g} Hz"
        )
    n_pairs = len(responses) * len(references)
    counts = np.bincount(pair, minlength=n_pairs)
    for p in range(n_pairs):
        if counts[p] == 0:
            raise DataError(
                f"{path}: the pair (response {responses[p // len(references)]}, reference "
                f"{references[p % len(references)]}) is missing; every (response, reference) pair must be given"
            )
    starts = np.concatenate(([0], np.cumsum(counts)))
    axis = freq_s[starts[0]:starts[1]]
    for p in range(1, n_pairs):
        fp = freq_s[starts[p]:starts[p + 1]]
        if fp.size != axis.size or not np.array_equal(fp, axis):
            extra = np.setdiff1d(fp, axis)
            lack = np.setdiff1d(axis, fp)
            detail = (
                f"it has {fp.size} lines, the pair (response {responses[0]}, reference {references[0]}) has {axis.size}"
                + (f"; extra line {extra[0]:.10g} Hz" if extra.size else "")
                + (f"; missing line {lack[0]:.10g} Hz" if lack.size else "")
            )
            raise DataError(
                f"{path}: the pair (response {responses[p // len(references)]}, reference "
                f"{references[p % len(references)]}) is on a different frequency axis ({detail})"
            )
    values = (re_ + 1j * im_)[order].reshape(n_pairs, axis.size)
    data = values.T.reshape(axis.size, len(responses), len(references))
    frf = FRF(Frequency(axis), data, tuple(responses), tuple(references), file_kind, notes=(note,) if note else ())
    return frf.to(kind) if kind is not None else frf


def write_frf_csv(path: str | os.PathLike, frf: FRF) -> Path:
    """Write ``frf`` in the CSV layout of :mod:`jointid.io.frf_csv` (atomically); returns the path.

    Rows are ordered by frequency, then response, then reference. Values are
    written as shortest round-trip floats, so reading gives the same numbers.
    """
    if not np.all(np.isfinite(frf.data)):
        i, j, k = (int(v[0]) for v in np.nonzero(~np.isfinite(frf.data)))
        raise DataError(f"FRF ({frf.responses[j]}, {frf.references[k]}) is not finite at {frf.frequency.hz[i]:g} Hz")
    F, r, c = frf.shape
    hz = [repr(float(v)) for v in frf.frequency.hz]
    rl = [str(d) for d in frf.responses]
    cl = [str(d) for d in frf.references]
    re_ = frf.data.real.reshape(-1).tolist()
    im_ = frf.data.imag.reshape(-1).tolist()
    out = [
        "# jointid FRF CSV: one row per frequency line and (response, reference) pair; SI units",
        f"# kind = {frf.kind}",
        ",".join(CSV_COLUMNS),
    ]
    n = 0
    for f in range(F):
        for j in range(r):
            for k in range(c):
                out.append(f"{hz[f]},{rl[j]},{cl[k]},{re_[n]!r},{im_[n]!r}")
                n += 1
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path
