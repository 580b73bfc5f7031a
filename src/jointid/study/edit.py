"""Write new values into a study file's text, keeping everything else as the user wrote it.

``jointid update`` writes ``updated_study.toml``: the input study with fitted
values in place of the old ones. TOML is edited as text (line by line, within
the right table), not re-serialized, so comments, order and formatting
survive; each changed line gets a trailing comment with the old value, and a
header comment says where the values came from. The result is parsed again
and every value checked, so a layout this editor does not understand (dotted
keys, inline tables) is refused rather than written wrong.
"""

from __future__ import annotations

import json
import re
import tomllib
from typing import Mapping, Sequence

from ..errors import StudyError

__all__ = ["study_key", "replace_study_values", "replace_study_table"]

_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-\s\"]+?)\s*\]\s*(#.*)?$")
_ARRAY_HEADER = re.compile(r"^\s*\[\[")


def study_key(name: str) -> tuple[str, str]:
    """``"elastic_modulus"`` -> ``("beam", "elastic_modulus")``; ``"accelerometers.mass"`` -> ``("accelerometers", "mass")``."""
    if "." in name:
        table, key = name.rsplit(".", 1)
        return table, key
    return "beam", name


def _format(value: "float | str") -> str:
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string: JSON's escapes (\", \\, \n, \uXXXX) are TOML's
    return repr(float(value))  # shortest text that reads back as the same double; valid TOML


def replace_study_values(
    text: str, values: Mapping[str, "float | str"], header: Sequence[str] = (), source: str = "<study>", note: str = "jointid update"
) -> str:
    """``text`` (a study file) with ``values`` written in place.

    Parameters
    ----------
    text : str
        The study file's text.
    values : mapping of str to float or str
        Parameter name (see :func:`study_key`) -> new value (a number, or a string such as a file name).
    header : sequence of str
        Comment lines put at the top (without the ``#``).
    source : str
        The file's name, for messages.
    note : str
        Start of the trailing comment on each changed line.

    Raises
    ------
    StudyError
        A table to edit is missing, or the edited text does not read back
        with exactly the new values.
    """
    lines = text.splitlines(keepends=True)
    newline = "\r\n" if lines and lines[0].endswith("\r\n") else "\n"
    todo = {study_key(n): (n, v if isinstance(v, str) else float(v)) for n, v in values.items()}
    done: set = set()
    table = ""
    headers: dict[str, int] = {}
    for i, line in enumerate(lines):
        if _ARRAY_HEADER.match(line):
            table = None
            continue
        m = _HEADER.match(line.rstrip("\r\n"))
        if m:
            table = m.group(1).replace(" ", "").replace('"', "")
            headers.setdefault(table, i)
            continue
        for (t, key), (name, value) in todo.items():
            if t != table:
                continue
            km = re.match(rf"^(\s*)({re.escape(key)}|\"{re.escape(key)}\")([ \t]*=[ \t]*)([^#\r\n]*?)([ \t]*)(#[^\r\n]*)?(\r?\n)?$", line)
            if km:
                old = km.group(4).strip()
                extra = f" | {km.group(6)[1:].strip()}" if km.group(6) else ""
                end = km.group(7) or ""
                lines[i] = f"{km.group(1)}{km.group(2)}{km.group(3)}{_format(value)}  # {note} (was {old}){extra}{end}"
                done.add((t, key))
    inserts = []
    for (t, key), (name, value) in todo.items():
        if (t, key) in done:
            continue
        if t not in headers:
            raise StudyError(
                f"{source}: no [{t}] table header to write {name} into (inline tables are not edited); set it by hand"
            )
        inserts.append((headers[t], f"{key} = {_format(value)}  # {note} (was not set){newline}"))
    for at, line in sorted(inserts, reverse=True):
        lines.insert(at + 1, line)
    if lines and not lines[-1].endswith(("\n", "\r")):
        lines[-1] += newline
    out = "".join(f"# {h}{newline}" for h in header) + "".join(lines)
    try:
        expected = tomllib.loads(text)
        data = tomllib.loads(out)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{source}: could not write the new values into this study's text ({exc}); edit it by hand") from None
    for (t, key), (name, value) in todo.items():
        node = expected
        for part in t.split("."):
            node = node.setdefault(part, {}) if isinstance(node, dict) else None
        if not isinstance(node, dict):
            raise StudyError(f"{source}: [{t}] is not a table; cannot write {name} into it")
        node[key] = value
    if data != expected:
        raise StudyError(
            f"{source}: could not write {', '.join(values)} into this study's text without changing anything else "
            "(dotted keys or inline tables?); set the values of update.json by hand"
        )
    return out


def _value_text(value) -> str:
    """A number, string or (nested) list of numbers as TOML text."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value_text(v) for v in value) + "]"
    return _format(value)


def _key_text(key: str) -> str:
    """A TOML key: bare when it can be, else quoted (``"accelerometers.mass"`` is one key, not a dotted table)."""
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key)


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def replace_study_table(text: str, table: str, entries: Mapping[str, object], comment: Sequence[str] = (),
                        source: str = "<study>") -> str:
    """``text`` with the top-level table ``[table]`` replaced by ``entries`` (appended when it has none).

    Every other line is kept as written. ``comment`` lines go above the new table. Values: numbers,
    strings, lists (of lists) of numbers.

    Raises
    ------
    StudyError
        The table is given in a form this editor does not change (inline or dotted), or the result does not
        read back as the input with only that table replaced.
    """
    lines = text.splitlines(keepends=True)
    newline = "\r\n" if lines and lines[0].endswith("\r\n") else "\n"
    keep, inside = [], False
    for line in lines:
        m = _HEADER.match(line.rstrip("\r\n"))
        if m or _ARRAY_HEADER.match(line):
            inside = bool(m) and m.group(1).replace(" ", "").replace('"', "") == table
        if not inside:
            keep.append(line)
    if keep and not keep[-1].endswith(("\n", "\r")):
        keep[-1] += newline
    block = [newline] + [f"# {c}{newline}" for c in comment] + [f"[{table}]{newline}"]
    block += [f"{_key_text(k)} = {_value_text(v)}{newline}" for k, v in entries.items()]
    out = "".join(keep) + "".join(block)
    try:
        expected = tomllib.loads(text)
        data = tomllib.loads(out)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{source}: could not write [{table}] into this study's text ({exc}); edit it by hand") from None
    expected[table] = {k: ([list(r) if isinstance(r, (list, tuple)) else r for r in v] if isinstance(v, (list, tuple)) else v)
                       for k, v in entries.items()}
    if data != expected:
        raise StudyError(f"{source}: could not write [{table}] into this study's text without changing anything else "
                         f"(an inline or dotted {table} table?); write it by hand")
    return out
