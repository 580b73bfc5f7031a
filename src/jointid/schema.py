"""Typed keys of TOML tables: the one schema mechanism of the study and reproduce configurations.

A table's schema maps each key to a :class:`Field` (kind, required or default, unit,
check); :func:`section` checks a parsed table against it and returns every key's typed
value (or default), :func:`typed` one value. Every complaint is one
:class:`~jointid.errors.StudyError` line naming the table and key, e.g.
``[beam].nodes: expected an integer, got 19.5``. Used by :mod:`jointid.study.parse` (study
files) and :mod:`jointid.reproduce.config` (``jointid reproduce --config``).

Kinds: ``"number"`` (int or float, finite, returned as float), ``"int"``, ``"bool"``,
``"str"``, ``"int_list"``, ``"str_list"``, ``"number_list"`` (lists: entries of that
kind, each once unless ``unique=False``, returned as a tuple), ``"any"`` (as written; the
check validates it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from .errors import StudyError

__all__ = [
    "Field", "typed", "section", "table", "positive", "nonneg", "choices", "format_number",
    "LENGTH", "MODULUS", "DENSITY", "SHEAR_COEFFICIENT", "LOSS_FACTOR", "FREQUENCY", "SCALE", "STIFFNESS", "GROWTH", "EXPONENT",
]

#: Lengths (m): beam length and section, elastomer length and diameter, cap sizes.
LENGTH = (1e-6, 1e4)
#: Elastic and shear moduli (Pa): from soft foams to diamond, with margin.
MODULUS = (1e3, 1e13)
#: Densities (kg/m^3): from foams to the densest metals, with margin.
DENSITY = (1.0, 1e5)
#: Timoshenko shear coefficients (5/6 for a rectangle, 0.9 for a circle; thin walls ~0.5).
SHEAR_COEFFICIENT = (0.1, 1.5)
#: Structural loss factors eta of K (1 + j eta) (metals ~1e-3, elastomers up to ~1.5).
LOSS_FACTOR = (0.0, 2.0)
#: Frequencies (Hz) of a study's band and reference frequencies.
FREQUENCY = (0.0, 1e6)
#: Scale factors of a [structure]'s matrices (stiffness_scale, mass_scale).
SCALE = (1e-6, 1e6)
#: Joint stiffnesses (N/m, N*m/rad, N/rad): from a soft suspension to a practically rigid bolt.
STIFFNESS = (1e-6, 1e15)
#: Frequency growth of a parametric joint model, K0 (1 + growth (f / f_ref)^exponent).
GROWTH = (0.0, 1e3)
#: Exponent of that growth.
EXPONENT = (1e-3, 10.0)


@dataclass(frozen=True)
class Field:
    """The schema of one key.

    Parameters
    ----------
    kind : str
        ``"number"``, ``"int"``, ``"bool"``, ``"str"``, ``"int_list"``, ``"str_list"`` or
        ``"number_list"``.
    required : bool
        A missing key is an error (else ``default`` is used).
    default : any
        Value of a missing optional key.
    unit : str
        Unit named in the messages (``"Pa"``).
    check : callable or None
        ``check(value)`` -> a complaint (``"a positive number"``) or None, on the typed value.
    bounds : (float, float) or None
        Numbers: the physical range ``lo <= value <= hi`` (in ``unit``), checked after ``check``.
    expected : str or None
        One description for every complaint about this key, type or check
        (``"an integer >= 1"``); the message then shows the value as written in the file.
    unique : bool
        Lists: each entry at most once (a list of stiffnesses may repeat values: False).
    """

    kind: str
    required: bool = False
    default: Any = None
    unit: str = ""
    check: Callable[[Any], str | None] | None = None  # returns a complaint or None
    expected: str | None = None
    unique: bool = True
    bounds: tuple[float, float] | None = None


def format_number(x: float) -> str:
    """``x`` short, exponents without ``+`` and leading zeros: ``1e-300``, ``1e13``, ``1e3``, ``0.1``, ``3.9e6``.

    Parameters
    ----------
    x : float
        Any finite number; ``|x|`` in [1e-3, 1e3) (or 0) is written with ``%.6g``, others as
        mantissa (up to 6 digits) and exponent.
    """
    if x == 0 or 1e-3 <= abs(x) < 1e3:
        return f"{x:.6g}"
    mant, exp = f"{x:.5e}".split("e")
    mant = mant.rstrip("0").rstrip(".")
    return f"{mant}e{int(exp)}"


def positive(v) -> str | None:
    """Complaint unless ``v > 0``."""
    return None if v > 0 else "a positive number"


def nonneg(v) -> str | None:
    """Complaint unless ``v >= 0``."""
    return None if v >= 0 else "a number >= 0"


def choices(*options: str) -> Callable[[Any], str | None]:
    """A check: complaint unless the value is one of ``options``."""

    def check(v):
        return None if v in options else "one of " + ", ".join(repr(o) for o in options)

    return check


def _number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def typed(section: str | None, key: str, f: Field, value: Any, label: str | None = None) -> Any:
    """``value`` of ``[section].key`` (``key`` alone when ``section`` is None) checked against ``f``.

    ``label`` replaces ``[section]`` in the messages (e.g. ``"[[joint]] 'front' [joint.model]"``).

    Raises
    ------
    StudyError
        ``"[section].key: expected <what> (<unit>), got <value>"``.
    """
    where = f"{label}.{key}" if label is not None else f"[{section}].{key}" if section is not None else key
    unit = f" ({f.unit})" if f.unit else ""
    raw = value

    def fail(what: str):
        if f.expected is not None:
            raise StudyError(f"{where}: expected {f.expected}{unit}, got {raw!r}")
        raise StudyError(f"{where}: expected {what}{unit}, got {value!r}")

    if f.kind == "number":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            fail("a number")
        value = float(value)
        if not math.isfinite(value):
            fail("a finite number")
    elif f.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            fail("an integer")
    elif f.kind == "bool":
        if not isinstance(value, bool):
            fail("true or false")
    elif f.kind == "str":
        if not isinstance(value, str):
            fail("a string")
    elif f.kind == "any":  # structured values (a list of lists): the check does the work
        pass
    elif f.kind in ("int_list", "str_list", "number_list"):
        if f.kind == "number_list":
            ok = isinstance(value, list) and all(_number(x) for x in value)
            what = "numbers"
        else:
            item = int if f.kind == "int_list" else str
            ok = isinstance(value, list) and all(isinstance(x, item) and not isinstance(x, bool) for x in value)
            what = "integers" if item is int else "strings"
        if not ok:
            fail(f"a list of {what}")
        if f.unique and len(set(value)) != len(value):
            raise StudyError(f"{where}: repeated entries in {value!r}; list each once")
        value = tuple(float(x) for x in value) if f.kind == "number_list" else tuple(value)
    if f.check is not None:
        complaint = f.check(value)
        if complaint is not None:
            fail(complaint)
    if f.bounds is not None and f.kind in ("number", "number_list"):
        lo, hi = f.bounds
        span = f"{format_number(lo)}-{format_number(hi)}"
        if f.kind == "number_list":
            for i, v in enumerate(value, 1):
                if not lo <= v <= hi:
                    raise StudyError(f"{where}: entry {i} ({format_number(v)}) is outside {span}" + (f" ({f.unit})" if f.unit else ""))
        elif not lo <= value <= hi:
            u = f" {f.unit}" if f.unit else ""
            raise StudyError(f"{where}: {format_number(value)}{u} is outside {span}{u}" + (f"; give it in {f.unit}" if f.unit else ""))
    return value


def section(
    data: Mapping, section: str, fields: Mapping[str, Field], sub: tuple[str, ...] = (), listing: str = "one of: ",
    label: str | None = None,
) -> dict:
    """Every key of ``fields`` typed (or its default) from the table ``[section]``.

    Parameters
    ----------
    data : mapping
        The parsed table.
    section : str
        Its name in the messages (``"beam"``, ``"layouts.model_1"``).
    fields : mapping of str to Field
    sub : tuple of str
        Names of sub-tables allowed in ``data`` and left to the caller.
    listing : str
        Words before the allowed keys in the unknown-key message (``"expected one of: a, b"``).
    label : str, optional
        The table's name in the messages instead of ``[section]`` (an array-of-tables entry:
        ``"[[joint]] 'front' [joint.model]"``).

    Raises
    ------
    StudyError
        Not a table, an unknown key (the allowed ones listed), a missing required key,
        or a bad value (see :func:`typed`).
    """
    name = label if label is not None else f"[{section}]"
    if not isinstance(data, Mapping):
        raise StudyError(f"{name} must be a table, got {data!r}")
    unknown = [k for k in data if k not in fields and k not in sub]
    if unknown:
        raise StudyError(
            f"{name}: unknown key {unknown[0]!r}; expected {listing}" + ", ".join(list(fields) + list(sub))
        )
    out = {}
    for key, f in fields.items():
        if key in data:
            out[key] = typed(section, key, f, data[key], label)
        elif f.required:
            raise StudyError(f"{name}: missing key {key!r}" + (f" ({f.unit})" if f.unit else ""))
        else:
            out[key] = f.default
    return out


def table(where: str, value: Any) -> Mapping[str, Any]:
    """``value`` if it is a table, else :class:`StudyError` ``"<where>: expected a table, got ..."``."""
    if not isinstance(value, Mapping):
        raise StudyError(f"{where}: expected a table, got {value!r}")
    return value
