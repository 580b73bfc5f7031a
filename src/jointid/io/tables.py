"""Plain CSV tables with a header row, written atomically."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .atomic import atomic_write_text

__all__ = ["write_csv", "format_csv", "read_csv_columns"]


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "1" if v else "0"  # numpy's loadtxt/genfromtxt read true/false as NaN (truthy)
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    return str(v)


def _column_text(col: np.ndarray) -> list[str] | None:
    """The CSV fields of a numeric column in bulk (as :func:`_fmt` writes each value); None for other dtypes."""
    if col.dtype == np.bool_:
        return np.where(col, "1", "0").tolist()
    if col.dtype.kind in "iu":
        return list(map(str, col.tolist()))
    if col.dtype.kind == "f":
        return list(map(repr, col.astype(float).tolist()))  # repr of a Python float: shortest round-trip text
    return None


def _columns_text(cols: list[np.ndarray]) -> list[list[str] | None]:
    """:func:`_column_text` of each column; a column bit-identical to an earlier one (a symmetric joint's mirrored
    terms) reuses its fields (the same text: the same bits format alike)."""
    out: list[list[str] | None] = []
    seen: dict[tuple, list[str]] = {}
    for c in cols:
        if c.ndim != 1:
            out.append(None)
            continue
        key = (c.dtype.str, c.tobytes()) if c.dtype.kind in "biuf" else None
        if key is not None and key in seen:
            out.append(seen[key])
            continue
        out.append(_column_text(c))
        if key is not None and out[-1] is not None:
            seen[key] = out[-1]
    return out


def format_csv(columns: Mapping[str, Sequence]) -> str:
    """The CSV text of equal-length ``columns`` (name -> values), header row first.

    Floats are written with full precision (``repr``), booleans as ``1``/``0`` (numbers every
    CSV reader parses: ``numpy.genfromtxt`` reads ``true``/``false`` as NaN, which is truthy).
    Numeric columns are formatted a column at a time, other columns a field at a time with the
    ``csv`` module's quoting.
    """
    names = list(columns)
    cols = [np.asarray(columns[k]) for k in names]
    n = {len(c) for c in cols}
    if len(n) > 1:
        raise ValueError(f"CSV columns have different lengths: {dict(zip(names, map(len, cols)))}")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    text = _columns_text(cols)
    if all(t is not None for t in text):
        if cols and len(cols[0]):
            buf.write("\n".join(map(",".join, zip(*text))))
            buf.write("\n")
        return buf.getvalue()
    for row in zip(*cols):
        w.writerow([_fmt(v) for v in row])
    return buf.getvalue()


def write_csv(path: str | os.PathLike, columns: Mapping[str, Sequence]) -> Path:
    """Write equal-length ``columns`` (name -> values) as CSV with a header, atomically.

    The text is that of :func:`format_csv`; returns the path.
    """
    return atomic_write_text(path, format_csv(columns))


def read_csv_columns(path: str | os.PathLike, what: str = "table") -> dict[str, np.ndarray]:
    """The numeric columns of a comma-separated table with one header line (``write_csv``'s layout), by name.

    Empty cells are NaN; ``true``/``false`` read as 1/0. Returns name -> float array, shape (rows,).

    Raises
    ------
    DataError
        The file cannot be read or decoded, has no header or no rows, a row of another length, or a cell
        that is not a number (one line naming the file, the line and the column).
    """
    from ..errors import DataError
    from .text import check_separator, read_utf8

    text = read_utf8(path, what)
    rows = list(csv.reader(text.splitlines()))
    rows = [r for r in rows if r and not r[0].startswith("#")]
    if len(rows) < 2:
        raise DataError(f"{path}: the {what} needs a header line and at least one row")
    header = [h.strip() for h in rows[0]]
    check_separator(path, header)
    out = {h: np.empty(len(rows) - 1) for h in header}
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise DataError(f"{path} line {i}: {len(row)} cells for {len(header)} columns")
        for h, cell in zip(header, row):
            c = cell.strip().lower()
            try:
                out[h][i - 2] = np.nan if c == "" else (1.0 if c == "true" else 0.0 if c == "false" else float(c))
            except ValueError:
                raise DataError(f"{path} line {i}, column {h}: {cell!r} is not a number") from None
    return out
