"""Strict JSON text (RFC 8259) of jointid's summaries: no NaN or Infinity, numpy scalars as Python numbers.

``json.dumps`` writes ``NaN``/``Infinity`` for non-finite floats, which strict readers
(JavaScript, DuckDB, jq) refuse. Every JSON file jointid writes goes through
:func:`json_text`: a non-finite number becomes ``null`` and, when ``note_key`` is given,
one entry at the top level says which paths were replaced.
"""

from __future__ import annotations

import json
import math

import numpy as np

__all__ = ["strict_json", "json_text"]


def strict_json(obj, path: str = "", replaced: list | None = None):
    """``obj`` with every non-finite float replaced by None and numpy values as Python values.

    Parameters
    ----------
    obj : dict, list, tuple, ndarray, number, str, bool or None
        A JSON-like tree.
    path : str
        The JSON path of ``obj`` (for the notes), e.g. ``"parameters[0].value"``.
    replaced : list, optional
        The paths of replaced values are appended to it.
    """
    if isinstance(obj, dict):
        return {str(k): strict_json(v, f"{path}.{k}" if path else str(k), replaced) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        obj = obj.tolist()
    if isinstance(obj, (list, tuple)):
        return [strict_json(v, f"{path}[{i}]", replaced) for i, v in enumerate(obj)]
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        if math.isfinite(obj):
            return float(obj)
        if replaced is not None:
            replaced.append(path)
        return None
    return obj


def json_text(obj, note_key: str | None = "non_finite_values", indent: int = 2) -> str:
    """``obj`` as strict JSON text ending in a newline.

    With ``note_key`` (and ``obj`` a dict with replaced values), ``obj[note_key]`` says how
    many values were NaN or infinite and where (the first five paths).
    """
    replaced: list = []
    clean = strict_json(obj, replaced=replaced)
    if replaced and note_key and isinstance(clean, dict):
        shown = ", ".join(replaced[:5]) + (f" and {len(replaced) - 5} more" if len(replaced) > 5 else "")
        clean[note_key] = f"{len(replaced)} value(s) were NaN or infinite and are written as null: {shown}"
    return json.dumps(clean, indent=indent, allow_nan=False) + "\n"
