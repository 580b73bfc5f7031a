"""Plain CSV tables with a header row, written atomically."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .atomic import atomic_write_text

__all__ = ["write_csv", "format_csv"]


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
    text = [_column_text(c) if c.ndim == 1 else None for c in cols]
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
