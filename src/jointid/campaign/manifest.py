"""The campaign manifest: one CSV row per test, validated whole before anything is computed.

Columns
-------
==================  ==========================================================================
``file``            the test's data file, relative to the manifest (step-sine CSV for
                    ``direct``; FRF file, ``.uff``/``.unv``/``.csv``, for ``identify``)
``specimen``        specimen name (text; the master curves are per specimen)
``temperature_c``   test temperature, degrees C (> -273.15)
``amplitude_m``     commanded dynamic displacement amplitude, m, peak (> 0; may be empty for
                    ``identify`` rows)
``preload_n``       static preload, N (any finite value; may be empty for ``identify`` rows)
``kind``            optional: ``direct`` (default; step-sine test) or ``identify`` (inverse
                    method: the FRF file with the study of the ``study`` column)
``study``           the study TOML of an ``identify`` row, relative to the manifest
``parallel_joints`` optional: joints loaded in parallel in a ``direct`` test (default 2)
anything else       free columns, carried as text into the results tables
==================  ==========================================================================

Every problem is a :class:`~jointid.errors.DataError` of one line naming the
manifest, the row (1-based data row, and its line in the file) and the column,
e.g. ``manifest.csv: row 3 (line 4), column 'temperature_c': expected a number
(degrees C), got 'warm'``. Files are checked to exist here, so a campaign with a
missing file stops before anything is computed.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import DataError
from ..io.text import check_separator, read_utf8
from .tables import COMPUTED_COLUMNS

__all__ = ["CampaignTest", "Manifest", "read_manifest", "REQUIRED_COLUMNS", "OPTIONAL_COLUMNS", "KINDS"]

#: Columns every manifest has.
REQUIRED_COLUMNS = ("file", "specimen", "temperature_c", "amplitude_m", "preload_n")
#: Columns with a meaning that a manifest may have.
OPTIONAL_COLUMNS = ("kind", "study", "parallel_joints")
#: Kinds of test.
KINDS = ("direct", "identify")
#: Joints loaded in parallel when the column is absent or empty (double shear, as ``jointid direct``).
DEFAULT_PARALLEL_JOINTS = 2


@dataclass(frozen=True)
class CampaignTest:
    """One test of a campaign (one manifest row).

    Parameters
    ----------
    row : int
        1-based data row of the manifest (the header is row 0).
    line : int
        Line of the row in the manifest file.
    file : Path
        The data file, resolved against the manifest's directory.
    specimen : str
        Specimen name.
    temperature_c : float
        Test temperature, degrees C.
    amplitude_m : float
        Commanded displacement amplitude, m, peak (NaN: not given, ``identify`` rows only).
    preload_n : float
        Static preload, N (NaN: not given, ``identify`` rows only).
    kind : str
        ``"direct"`` or ``"identify"``.
    study : Path or None
        Study file of an ``identify`` row.
    parallel_joints : int
        Joints loaded in parallel (``direct``).
    values : tuple of (str, str)
        Every cell of the row as written, by column name (manifest order).
    """

    row: int
    line: int
    file: Path
    specimen: str
    temperature_c: float
    amplitude_m: float
    preload_n: float
    kind: str
    study: Path | None
    parallel_joints: int
    values: tuple[tuple[str, str], ...]

    def value(self, column: str) -> str:
        """The cell of ``column`` as written ("" if the manifest has no such column)."""
        return dict(self.values).get(column, "")


@dataclass(frozen=True)
class Manifest:
    """A validated campaign manifest.

    Parameters
    ----------
    path : Path
        The manifest file.
    columns : tuple of str
        Its header, in order.
    tests : tuple of CampaignTest
        One per data row, in file order.
    """

    path: Path
    columns: tuple[str, ...]
    tests: tuple[CampaignTest, ...]

    @property
    def extra_columns(self) -> tuple[str, ...]:
        """The free columns (neither required nor optional), in manifest order."""
        known = set(REQUIRED_COLUMNS) | set(OPTIONAL_COLUMNS)
        return tuple(c for c in self.columns if c not in known)

    @property
    def specimens(self) -> tuple[str, ...]:
        """Specimen names in order of first appearance."""
        return tuple(dict.fromkeys(t.specimen for t in self.tests))


def _number(text: str, where: str, what: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise DataError(f"{where}: expected a number ({what}), got {text!r}") from None
    if not math.isfinite(x):
        raise DataError(f"{where}: expected a finite number ({what}), got {text!r}")
    return x


def _existing_file(base: Path, text: str, where: str, what: str) -> Path:
    if not text:
        raise DataError(f"{where}: empty; give the {what} (relative to the manifest)")
    p = Path(text)
    p = p if p.is_absolute() else base / p
    if not p.exists():
        raise DataError(f"{where}: {p} does not exist; give the {what} relative to the manifest")
    if not p.is_file():
        raise DataError(f"{where}: {p} is not a file; give the {what} relative to the manifest")
    if not os.access(p, os.R_OK):
        raise DataError(f"{where}: {p} is not readable")
    return p


def _parse_row(path: Path, header: list[str], cells: list[str], row: int, line: int) -> CampaignTest:
    if len(cells) > len(header):
        raise DataError(f"{path}: row {row} (line {line}): {len(cells)} cells but the header has {len(header)} columns")
    values = {h: (cells[i].strip() if i < len(cells) else "") for i, h in enumerate(header)}

    def where(col: str) -> str:
        return f"{path}: row {row} (line {line}), column {col!r}"

    kind = values.get("kind", "") or "direct"
    if kind not in KINDS:
        raise DataError(f"{where('kind')}: expected one of {', '.join(KINDS)}, got {kind!r}")
    specimen = values["specimen"]
    if not specimen:
        raise DataError(f"{where('specimen')}: empty; name the specimen")
    temperature = _number(values["temperature_c"], where("temperature_c"), "degrees C")
    if temperature <= -273.15:
        raise DataError(f"{where('temperature_c')}: {temperature:g} degrees C is below absolute zero; give degrees C")
    optional_numbers = kind == "identify"
    amplitude = math.nan
    if values["amplitude_m"] or not optional_numbers:
        amplitude = _number(values["amplitude_m"], where("amplitude_m"), "m, peak")
        if amplitude <= 0:
            raise DataError(f"{where('amplitude_m')}: expected a positive displacement amplitude (m, peak), got {values['amplitude_m']!r}")
    preload = math.nan
    if values["preload_n"] or not optional_numbers:
        preload = _number(values["preload_n"], where("preload_n"), "N")
    joints = DEFAULT_PARALLEL_JOINTS
    if values.get("parallel_joints", ""):
        text = values["parallel_joints"]
        try:
            joints = int(text)
        except ValueError:
            joints = 0
        if joints < 1:
            raise DataError(f"{where('parallel_joints')}: expected an integer >= 1 (joints loaded in parallel), got {text!r}")
    study = None
    if kind == "identify":
        if "study" not in values:
            raise DataError(f"{where('study')}: an identify row needs a study column (the study TOML, relative to the manifest)")
        study = _existing_file(path.parent, values["study"], where("study"), "study TOML")
    file = _existing_file(path.parent, values["file"], where("file"), "test's data file")
    return CampaignTest(
        row=row, line=line, file=file, specimen=specimen, temperature_c=temperature, amplitude_m=amplitude,
        preload_n=preload, kind=kind, study=study, parallel_joints=joints, values=tuple(values.items()),
    )


def read_manifest(path: str | os.PathLike) -> Manifest:
    """Read and validate a campaign manifest (see the module docstring).

    Parameters
    ----------
    path : path-like
        The manifest CSV (UTF-8, comma-separated, a header row).

    Returns
    -------
    Manifest

    Raises
    ------
    DataError
        One line naming the manifest, the row and the column: a missing or
        duplicated column, an empty manifest, a cell that is not what its column
        needs, a file that does not exist.
    """
    path = Path(path)
    text = read_utf8(path, "campaign manifest")
    reader = csv.reader(io.StringIO(text, newline=""))
    rows = []
    try:
        for cells in reader:
            rows.append((reader.line_num, cells))
    except csv.Error as exc:
        raise DataError(f"{path} line {reader.line_num}: not a valid CSV row ({exc})") from None
    rows = [(n, c) for n, c in rows if c and any(x.strip() for x in c)]
    if not rows:
        raise DataError(f"{path}: empty manifest; expected a header row with {', '.join(REQUIRED_COLUMNS)} and one row per test")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    check_separator(path, header, header_line)
    seen = set()
    for h in header:
        if not h:
            raise DataError(f"{path} line {header_line}: a column has no name; name every column of the header")
        if h in seen:
            raise DataError(f"{path} line {header_line}: column {h!r} appears twice; keep one")
        seen.add(h)
    computed = [h for h in header if h in COMPUTED_COLUMNS]
    if computed:
        raise DataError(f"{path} line {header_line}: column {computed[0]!r} is one jointid computes into its tables; "
                        "rename it (e.g. with a prefix)")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise DataError(f"{path}: missing column {missing[0]!r} (columns present: {', '.join(header)}); "
                        f"a manifest needs {', '.join(REQUIRED_COLUMNS)}")
    if len(rows) < 2:
        raise DataError(f"{path}: no tests; add one row per test after the header")
    tests = tuple(_parse_row(path, header, cells, i, line) for i, (line, cells) in enumerate(rows[1:], start=1))
    first: dict = {}
    for t in tests:  # one data file read twice would count twice in the specimen's fits (bands too narrow)
        key = (t.file.resolve(), t.kind, t.study)
        if key in first:
            raise DataError(f"{path}: rows {first[key].row} (line {first[key].line}) and {t.row} (line {t.line}) both use "
                            f"{t.file.name} as a {t.kind} test; a repeated test needs its own data file: remove one row")
        first[key] = t
    return Manifest(path=path, columns=tuple(header), tests=tests)
