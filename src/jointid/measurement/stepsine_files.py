"""Step-sine time histories in the CSV long format: reading (with column names and units mapped) and writing.

One row per sample: ``frequency_hz, time_s, displacement_m, force_n`` (the block's test frequency, Hz; time, s;
imposed displacement, m; transmitted force, N), blocks one after the other (:mod:`jointid.measurement.stepsine`
processes them). A file cut short -- its last line incomplete, or its last block with fewer cycles than every
other block -- is refused naming the line or the block: a truncated copy would silently lose its later blocks.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..errors import DataError

__all__ = ["StepSineBlock", "read_stepsine_csv", "write_stepsine_csv", "hz_text", "unit_column", "resolve_columns", "DEFAULT_COLUMNS",
           "TRUNCATED_CYCLES", "UNIT_SUFFIXES", "SI_UNITS"]

#: Logical quantity -> default CSV column name.
DEFAULT_COLUMNS: Mapping[str, str] = {
    "frequency": "frequency_hz",
    "time": "time_s",
    "displacement": "displacement_m",
    "force": "force_n",
}
#: The file's last block is taken as cut short when it holds fewer than this fraction of the cycles of the block that
#: holds fewest among the others (which agree within the same fraction).
TRUNCATED_CYCLES = 0.9


#: Unit suffixes of a step-sine file's column names that a campaign converts exactly to SI, per quantity
#: (``force_kN``, ``displacement_mm``, ``time_ms``; also ``force [kN]`` and ``force (kN)``): suffix -> factor to SI.
UNIT_SUFFIXES = {
    "frequency": {"Hz": 1.0, "hz": 1.0, "kHz": 1e3, "khz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "\u00b5s": 1e-6, "\u03bcs": 1e-6},
    "displacement": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "\u00b5m": 1e-6, "\u03bcm": 1e-6, "nm": 1e-9, "in": 0.0254},
    "force": {"N": 1.0, "n": 1.0, "kN": 1e3, "kn": 1e3, "mN": 1e-3, "lbf": 4.4482216152605},
}
#: The SI unit each quantity is converted to.
SI_UNITS = {"frequency": "Hz", "time": "s", "displacement": "m", "force": "N"}


def unit_column(quantity: str, name: str) -> float | None:
    """The factor to SI of a column named ``name`` for ``quantity`` with a unit suffix, or None.

    Parameters
    ----------
    quantity : str
        ``frequency``, ``time``, ``displacement`` or ``force``.
    name : str
        A column name: ``<quantity>_<unit>``, ``<quantity> [<unit>]`` or ``<quantity> (<unit>)`` with a unit of
        :data:`UNIT_SUFFIXES` (case as written: ``mN`` is milli-newton).

    Returns
    -------
    float or None
        The exact factor from the unit to SI (Hz, s, m, N), e.g. 1e-3 for ``displacement_mm``.
    """
    import re

    m = re.fullmatch(rf"{quantity}(?:_(\S+)|\s*\[\s*(\S+)\s*\]|\s*\(\s*(\S+)\s*\))", name.strip(), flags=re.IGNORECASE)
    if m is None:
        return None
    return UNIT_SUFFIXES.get(quantity, {}).get(next(g for g in m.groups() if g is not None))


def resolve_columns(path: str | os.PathLike, columns: Mapping[str, str] | None = None,
                    scale: Mapping[str, float] | None = None, *, remedy: str = "map it with") -> tuple[dict, dict, str]:
    """How to read one step-sine file: the column mapping, the factors to SI and what was converted (``jointid direct``
    and every file of ``jointid campaign``).

    A quantity that ``columns``/``scale`` do not map, whose default column (``force_n``, ...) the file lacks, is read
    from the one column named with a unit suffix (:func:`unit_column`: ``force_kN``, ``displacement [mm]``), converted
    exactly to SI.

    Parameters
    ----------
    path : path-like
        The step-sine CSV file (its header row is read).
    columns, scale : mapping, optional
        The user's mapping (``--column``/``--scale``): quantity -> column name, and -> factor to SI; they win.
    remedy : str
        How the message of a column neither present nor recognisable goes on: ``"... or <remedy> --column Q=NAME
        --scale Q=FACTOR_TO_SI"``.

    Returns
    -------
    columns : dict of str to str
        For :func:`read_stepsine_csv`.
    scale : dict of str to float
        Factors to SI (Hz, s, m, N) per quantity.
    converted : str
        ``"displacement_mm x 0.001 (to m), force_kN x 1000 (to N)"``, or ``""``.

    Raises
    ------
    DataError
        A column the file lacks and no unit-suffixed column stands for (or several could): naming it, the columns
        present and how to map it.
    """
    mapped, sc = dict(columns or {}), dict(scale or {})
    cols = {**DEFAULT_COLUMNS, **mapped}
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            header = [h.strip() for h in next(csv.reader([fh.readline()]), [])]
    except (OSError, UnicodeDecodeError):
        return mapped, sc, ""  # the reader says what is wrong with the file
    if len(header) < 2:
        return mapped, sc, ""  # not comma-separated, or empty: the reader's message
    converted = []
    for q, name in cols.items():
        if name in header:
            continue
        found = [(h, f) for h in header for f in [unit_column(q, h)] if f is not None]
        if len(found) == 1 and q not in mapped and q not in sc:
            (h, f), = found
            cols[q], sc[q] = h, f
            converted.append(f"{h} x {f:g} (to {SI_UNITS[q]})")
            continue
        which = f" ({len(found)} columns could be it: {', '.join(h for h, _ in found)})" if len(found) > 1 else ""
        raise DataError(f"{path}: missing column {name!r}{which} (columns present: {', '.join(header)}); name it {name} or "
                        f"{q}_UNIT (a unit jointid converts: {', '.join(UNIT_SUFFIXES[q])}), or {remedy} "
                        f"--column {q}=NAME --scale {q}=FACTOR_TO_SI")
    return cols, sc, ", ".join(converted)


def hz_text(f: float) -> str:
    """A test frequency as messages name it: ``"12.9155 Hz"``."""
    return f"{f:g} Hz"


@dataclass(frozen=True, eq=False)
class StepSineBlock:
    """Time histories recorded at one test frequency.

    Parameters
    ----------
    frequency_hz : float
        Test frequency, Hz.
    time_s : ndarray, shape (n,)
        Sample times, s, strictly increasing.
    displacement_m : ndarray, shape (n,)
        Imposed displacement, m.
    force_n : ndarray, shape (n,)
        Transmitted force, N (all joints in parallel).

    Raises
    ------
    DataError
        Naming the block's frequency: NaN/inf, unsorted time, fewer than 2
        whole cycles or 4 samples per cycle, constant displacement.
    """

    frequency_hz: float
    time_s: np.ndarray
    displacement_m: np.ndarray
    force_n: np.ndarray

    def __post_init__(self) -> None:
        f = float(self.frequency_hz)
        if not (math.isfinite(f) and f > 0):
            raise DataError(f"step-sine block: test frequency must be a positive number in Hz, got {self.frequency_hz!r}")
        object.__setattr__(self, "frequency_hz", f)
        arrays = {}
        for name in ("time_s", "displacement_m", "force_n"):
            a = np.array(getattr(self, name), dtype=float).reshape(-1)
            a.setflags(write=False)
            arrays[name] = a
            object.__setattr__(self, name, a)
        n = {a.size for a in arrays.values()}
        if len(n) != 1:
            raise DataError(
                f"block at {hz_text(f)}: time, displacement and force have different lengths "
                f"({', '.join(f'{k} {v.size}' for k, v in arrays.items())})"
            )
        for name, a in arrays.items():
            bad = ~np.isfinite(a)
            if bad.any():
                raise DataError(
                    f"block at {hz_text(f)}: {name} has {int(bad.sum())} NaN/missing/infinite value(s) "
                    f"(first at sample {int(np.argmax(bad))}); remove or repair those samples"
                )
        t = arrays["time_s"]
        if t.size < 2:
            raise DataError(f"block at {hz_text(f)}: only {t.size} sample(s); record at least 2 whole cycles")
        dt = np.diff(t)
        if np.any(dt <= 0):
            i = int(np.argmax(dt <= 0))
            raise DataError(
                f"block at {hz_text(f)}: time is not strictly increasing (sample {i + 1}: {float(t[i + 1])!r} s after {float(t[i])!r} s); "
                "sort the samples by time and remove duplicates"
            )
        spc = 1.0 / (f * float(np.median(dt)))
        if spc < 4:
            raise DataError(
                f"block at {hz_text(f)}: {spc:.2g} samples per cycle; the sample rate must be at least 4x the test frequency"
            )
        cycles = self.recorded_cycles
        if cycles < 2:
            raise DataError(
                f"block at {hz_text(f)}: only {cycles:.3g} cycles recorded; record at least 2 whole cycles "
                "(plus the settling transient)"
            )
        if np.ptp(arrays["displacement_m"]) == 0:
            raise DataError(f"block at {hz_text(f)}: the displacement is zero (constant); check the displacement channel")

    @property
    def sample_interval_s(self) -> float:
        """Median sample interval, s."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def recorded_cycles(self) -> float:
        """Number of cycles covered by the samples (each sample covering one interval), possibly non-integer."""
        return (float(self.time_s[-1] - self.time_s[0]) + self.sample_interval_s) * self.frequency_hz


def _mapping(columns: Mapping[str, str] | None, scale: Mapping[str, float] | None):
    cols = dict(DEFAULT_COLUMNS)
    for k, v in (columns or {}).items():
        if k not in DEFAULT_COLUMNS:
            raise DataError(f"columns: unknown quantity {k!r}; expected one of {', '.join(DEFAULT_COLUMNS)}")
        cols[k] = str(v)
    sc = {k: 1.0 for k in DEFAULT_COLUMNS}
    for k, v in (scale or {}).items():
        if k not in DEFAULT_COLUMNS:
            raise DataError(f"scale: unknown quantity {k!r}; expected one of {', '.join(DEFAULT_COLUMNS)}")
        try:
            sc[k] = float(v)
        except (TypeError, ValueError):
            raise DataError(f"scale[{k!r}] must be a number, got {v!r}") from None
        if not (math.isfinite(sc[k]) and sc[k] != 0):
            raise DataError(f"scale[{k!r}] must be finite and non-zero, got {v!r}")
    return cols, sc


def _to_float(values: list[str], name: str, path) -> np.ndarray:
    vals = ["nan" if v == "" else v for v in values]
    try:
        return np.array(vals, dtype=float)
    except ValueError:
        for i, v in enumerate(vals):
            try:
                float(v)
            except ValueError:
                raise DataError(f"{path}: column {name!r}, data line {i + 1}: {v!r} is not a number") from None
        raise


def read_stepsine_csv(
    path: str | os.PathLike,
    columns: Mapping[str, str] | None = None,
    scale: Mapping[str, float] | None = None,
) -> tuple[StepSineBlock, ...]:
    """Read step-sine time histories in the CSV long format (see the module docstring).

    Parameters
    ----------
    path : path-like
        CSV file.
    columns : mapping, optional
        Logical quantity (``frequency``, ``time``, ``displacement``, ``force``) ->
        column name in the file.
    scale : mapping, optional
        Logical quantity -> factor converting the file's values to SI (Hz, s, m, N).

    Returns
    -------
    tuple of StepSineBlock
        In ascending test frequency.

    Raises
    ------
    DataError
        Not UTF-8 or not comma-separated, missing column (naming it and the
        columns present), a value that is not a number, or a bad block (naming
        its frequency).
    """
    from ..io.text import check_separator, read_utf8

    cols, sc = _mapping(columns, scale)
    rows = list(csv.reader(io.StringIO(read_utf8(path, "step-sine CSV file"), newline="")))
    if not rows:
        raise DataError(f"{path}: empty file; expected a header row with {', '.join(DEFAULT_COLUMNS.values())}")
    header = [h.strip() for h in rows[0]]
    check_separator(path, header)
    missing = [c for c in cols.values() if c not in header]
    if missing:
        raise DataError(
            f"{path}: missing column {missing[0]!r} (columns present: {', '.join(header)}); "
            "rename it or map it with columns={...} / --column QUANTITY=NAME"
        )
    numbered = [(n, r) for n, r in enumerate(rows[1:], start=2) if r and any(c.strip() for c in r)]
    if not numbered:
        raise DataError(f"{path}: no data rows after the header")
    last_line, last = numbered[-1]
    if len(last) < len(header) or not last[-1].strip():
        raise DataError(f"{path}: line {last_line}, the last one, is incomplete ({sum(bool(c.strip()) for c in last)} of "
                        f"{len(header)} values): the file is cut short; copy the whole file again")
    body = [r for _, r in numbered]
    data = {}
    for key, name in cols.items():
        j = header.index(name)
        data[key] = _to_float([r[j].strip() if j < len(r) else "" for r in body], name, path) * sc[key]
    fcol = data["frequency"]
    if np.any(~np.isfinite(fcol)):
        i = int(np.argmax(~np.isfinite(fcol)))
        raise DataError(f"{path}: data line {i + 1}: missing or non-finite {cols['frequency']!r}; every row needs its block's test frequency")
    _check_last_block(path, fcol, data["time"])
    blocks = []
    for f in np.unique(fcol):
        m = fcol == f
        try:
            blocks.append(StepSineBlock(float(f), data["time"][m], data["displacement"][m], data["force"][m]))
        except DataError as exc:  # a block's own check: name the file too
            raise DataError(f"{path}: {exc}") from None
    return tuple(blocks)


def _check_last_block(path, frequency: np.ndarray, time: np.ndarray) -> None:
    """Refuse a file whose last block (in file order) holds fewer cycles than every other one (module docstring)."""
    order = list(dict.fromkeys(frequency.tolist()))  # blocks in file order
    if len(order) < 3:
        return
    cycles = {}
    for f in order:
        t = time[frequency == f]
        if t.size < 2 or not np.all(np.isfinite(t)):
            return  # the block's own check names it
        cycles[f] = (t.max() - t.min()) * f
    others = np.array([cycles[f] for f in order[:-1]])
    if others.min() < TRUNCATED_CYCLES * others.max():
        return  # the blocks hold different numbers of cycles by design: no pattern to miss
    if cycles[order[-1]] < TRUNCATED_CYCLES * others.min():
        raise DataError(f"{path}: the file ends inside the block at {order[-1]:g} Hz ({cycles[order[-1]]:.3g} cycles, every "
                        f"other block {others.min():.3g} or more): the file is cut short; copy the whole file again")


def write_stepsine_csv(path: str | os.PathLike, blocks: Sequence[StepSineBlock]) -> Path:
    """Write blocks in the default CSV long format (SI units), atomically; returns the path."""
    from ..io.atomic import atomic_write_text

    buf = io.StringIO()
    buf.write(",".join(DEFAULT_COLUMNS.values()) + "\n")
    for b in blocks:
        arr = np.column_stack([np.full(b.time_s.size, b.frequency_hz), b.time_s, b.displacement_m, b.force_n])
        np.savetxt(buf, arr, delimiter=",", fmt="%.10g")
    return atomic_write_text(path, buf.getvalue())
