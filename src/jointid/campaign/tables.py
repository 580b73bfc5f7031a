"""The campaign's tables (Apache Arrow, written as Parquet and CSV): readable without jointid.

``results``: one row per test and frequency line (and joint term, for ``identify``
tests): ``manifest_row``, the manifest's columns (``file``, ``specimen``,
``temperature_c``, ``amplitude_m``, ``preload_n``, ``kind``, ``parallel_joints``,
``study`` when present, the free columns as text), then ``term`` (``K21`` for a direct
test: the blocked transfer stiffness per joint), ``frequency_hz``, ``stiffness_real``,
``stiffness_imag`` (N/m), ``magnitude``, ``loss_factor``, ``stiffness_real_std``,
``stiffness_imag_std`` (1-sigma, where the method gives them: ``identify``; else null),
``amplitude_ok``, ``amplitude_ratio`` (``direct``), ``reliable`` (``identify``),
``log10_shift`` and ``reduced_frequency_hz`` (``f aT``): the shift of the specimen's master
curve at the test's temperature from its preferred law (WLF or Arrhenius; the measured
shift when no law was fitted), null without a master curve and for a temperature left out
of it (a curve that does not overlap the others: a law fitted without it would only
extrapolate to it); ``shift_reference_c``: the temperature these shifts are relative to, deg C (the
master curve's: the requested reference, or the measured temperature nearest it when no shift law
could move the shifts there), null with the shift.

``tests``: one row per test: ``manifest_row``, the manifest's columns, ``status``
(``ok``/``failed``), ``reason``, ``file_sha256``, the per-test parameters of the
processing (lines, band, achieved amplitude, median storage and loss factor, force
distortion and fit residuals; for ``identify``: method, reliable fraction),
``log10_shift``, ``shift_reference_c`` and ``warning``: why the test's numbers are not a material's, null when
nothing is wrong (a direct test whose loss factor is negative on most lines: a reversed phase
sign, :mod:`jointid.methods.direct.phase_sign`; such a test is left out of the master curve).

``amplitude`` / ``preload``: one row per Kraus / preload fit (specimen, temperature,
preload or amplitude, frequency) with the fit's parameters and their ``_std``; the
amplitude table also has the Kraus loss fit (``loss_kinf_n_m``, ``loss_kmax_n_m``, ...).

A value that is not given is null (empty in CSV); a computed value that is not a
number (a loss factor over a zero storage part) is NaN (``nan``).
"""

from __future__ import annotations

import io
import json
import math

import numpy as np

__all__ = ["results_table", "tests_table", "test_warning", "fit_table", "table_csv", "table_parquet", "STANDARD_LINE_COLUMNS",
           "COMPUTED_COLUMNS"]

#: Line columns of the results table, in order (absent from a method: null).
STANDARD_LINE_COLUMNS = (
    "term", "frequency_hz", "stiffness_real", "stiffness_imag", "magnitude", "loss_factor",
    "stiffness_real_std", "stiffness_imag_std", "amplitude_ok", "amplitude_ratio", "reliable",
)
_BOOL = {"amplitude_ok", "reliable"}
#: Columns jointid computes into the results and tests tables besides the line columns and each test's parameters
#: (a manifest's own free column must not be named like one of them).
COMPUTED_COLUMNS = ("manifest_row", "status", "reason", "file_sha256", "log10_shift", "reduced_frequency_hz",
                    "shift_reference_c", "warning", *STANDARD_LINE_COLUMNS)


def _meta_columns(manifest) -> list[tuple[str, str]]:
    """(column, arrow type name) of the manifest's columns in the tables."""
    cols = [("file", "string"), ("specimen", "string"), ("temperature_c", "float64"), ("amplitude_m", "float64"),
            ("preload_n", "float64"), ("kind", "string"), ("parallel_joints", "int64")]
    if "study" in manifest.columns:
        cols.append(("study", "string"))
    cols += [(c, "string") for c in manifest.extra_columns]
    return cols


def _meta_value(test, column: str):
    v = {"file": test.value("file"), "specimen": test.specimen, "temperature_c": test.temperature_c,
         "amplitude_m": test.amplitude_m, "preload_n": test.preload_n, "kind": test.kind,
         "parallel_joints": test.parallel_joints, "study": test.value("study") or None}.get(column)
    if v is None and column not in ("study",):
        v = test.value(column)
    if isinstance(v, float) and math.isnan(v):
        return None
    return v


def _array(values, typename: str):
    import pyarrow as pa

    return pa.array(values, type=getattr(pa, typename)())


def _shift_reference(analysis, test) -> float | None:
    """The temperature the test's ``log10_shift`` is relative to, deg C; None when it has no shift."""
    if _log10_shift(analysis, test) is None:
        return None
    return float(analysis[test.specimen].master_curve.reference_temperature_c)


def _log10_shift(analysis, test) -> float | None:
    """The test's log10 aT from its specimen's master curve (preferred law), None without one."""
    from ..errors import JointIdError

    a = analysis.get(test.specimen)
    if a is None or a.master_curve is None or test.kind != "direct":
        return None
    if not any(abs(t - test.temperature_c) <= 1e-9 for t in a.master_curve.measured_shift):
        return None  # left out of the master curve (its findings say why): no shift, rather than a law's extrapolation
    try:
        x = float(a.master_curve.log10_shift(test.temperature_c))
    except JointIdError:  # no shift law fitted and the temperature is not on the master curve
        return None
    return x if math.isfinite(x) else None


def test_warning(test, outcome, analysis=None) -> str | None:
    """Why a processed test's numbers are not a material's (the ``warning`` column), None when nothing is wrong.

    * A direct test whose loss factor ``Im K21 / Re K21`` is negative on most of its lines at the
      commanded amplitude has its phase sign reversed
      (:func:`~jointid.methods.direct.phase_sign.reversed_phase`).
    * A direct test whose stiffness is a unit factor off the other tests' at its temperature (``unit_slips`` of the
      specimen's analysis): the factor, the probable cause and the fix.
    * A direct test with a test-level note of its processing (a drift along the blocks:
      :attr:`~jointid.measurement.stepsine.StepSineResult.notes`): the note, after anything above or below.
    * A test whose measured shift factor does not fall as the temperature rises from its
      neighbour's on the master curve (``log10 aT(T_j) > log10 aT(T_i)`` with ``T_j > T_i``): one of
      the two temperatures is wrong, and no shift law was fitted.
    """
    from ..methods.direct.phase_sign import reversed_phase

    if not outcome.ok or test.kind != "direct":
        return None
    lines = outcome.lines
    ok = np.asarray(lines.get("amplitude_ok", np.ones(len(lines["frequency_hz"]), bool)), dtype=bool)
    k = np.asarray(lines["stiffness_real"], float)[ok] + 1j * np.asarray(lines["stiffness_imag"], float)[ok]
    why = reversed_phase(k)
    note = outcome.parameters.get("notes") or None
    if why is not None:
        return "; ".join(w for w in (f"{why}; left out of the master curve", note) if w)
    a = (analysis or {}).get(test.specimen)
    if a is not None and test.row in a.unit_slips:  # a unit factor off the other tests: named, left out
        return "; ".join(w for w in (a.unit_slips[test.row], note) if w)
    if a is None or a.master_curve is None:
        return note
    shifts = sorted(a.master_curve.measured_shift.items())
    for (ti, si), (tj, sj) in zip(shifts, shifts[1:]):
        if sj > si and any(abs(t - test.temperature_c) <= 1e-9 for t in (ti, tj)):
            return "; ".join(w for w in (f"the shift factor rises with the temperature from {ti:g} to {tj:g} deg C ({si:+.3f} -> "
                                         f"{sj:+.3f} decades): one of the two temperatures is wrong (typed in K?); no shift "
                                         "law was fitted", note) if w)
    return note


def results_table(manifest, outcomes, analysis=None):
    """The results table (see the module docstring) as a :class:`pyarrow.Table`.

    Parameters
    ----------
    manifest : Manifest
    outcomes : mapping of int to TestOutcome
        By manifest row; failed tests have no rows.
    analysis : mapping of str to SpecimenAnalysis, optional
        For the shift columns.
    """
    import pyarrow as pa

    analysis = analysis or {}
    meta = _meta_columns(manifest)
    parts = {name: [] for name, _ in meta}
    lines = {name: [] for name in STANDARD_LINE_COLUMNS}
    masks = {name: [] for name in STANDARD_LINE_COLUMNS}
    rows, shift, reduced, refs = [], [], [], []
    for t in manifest.tests:
        o = outcomes[t.row]
        if not o.ok:
            continue
        n = len(o.lines["frequency_hz"])
        rows.append(np.full(n, t.row, dtype=np.int64))
        for name, _ in meta:
            parts[name].extend([_meta_value(t, name)] * n)
        for name in STANDARD_LINE_COLUMNS:
            if name in o.lines:
                lines[name].append(np.asarray(o.lines[name]))
                masks[name].append(np.zeros(n, dtype=bool))
            else:
                lines[name].append(np.zeros(n, dtype=bool if name in _BOOL else float))
                masks[name].append(np.ones(n, dtype=bool))
        s = _log10_shift(analysis, t)
        if s is None:
            shift.append(np.full(n, np.nan))
            reduced.append(np.full(n, np.nan))
            refs.append(np.full(n, np.nan))
        else:
            shift.append(np.full(n, s))
            reduced.append(np.asarray(o.lines["frequency_hz"], dtype=float) * 10.0**s)
            refs.append(np.full(n, _shift_reference(analysis, t)))
    cols = {"manifest_row": pa.array(np.concatenate(rows) if rows else np.zeros(0, np.int64))}
    for name, typ in meta:
        cols[name] = _array(parts[name], typ)
    for name in STANDARD_LINE_COLUMNS:
        if not lines[name]:
            cols[name] = _array([], "string" if name == "term" else "bool_" if name in _BOOL else "float64")
            continue
        values = np.concatenate(lines[name])
        mask = np.concatenate(masks[name])
        if name == "term":
            cols[name] = pa.array(values.astype(str).tolist(), type=pa.string())
        else:
            cols[name] = pa.array(values, mask=mask if mask.any() else None)
    for name, vals in (("log10_shift", shift), ("reduced_frequency_hz", reduced), ("shift_reference_c", refs)):
        v = np.concatenate(vals) if vals else np.zeros(0)
        cols[name] = pa.array(v, mask=np.isnan(v) if np.isnan(v).any() else None)
    return pa.table(cols)


def tests_table(manifest, outcomes, analysis=None, sha256=None):
    """The per-test table (see the module docstring) as a :class:`pyarrow.Table`.

    Parameters
    ----------
    manifest : Manifest
    outcomes : mapping of int to TestOutcome
        By manifest row.
    analysis : mapping of str to SpecimenAnalysis, optional
    sha256 : mapping of int to str, optional
        The data file's SHA-256 by manifest row.
    """
    import pyarrow as pa

    analysis = analysis or {}
    sha256 = sha256 or {}
    meta = _meta_columns(manifest)
    names: dict[str, None] = {}
    for t in manifest.tests:
        names.update(dict.fromkeys(outcomes[t.row].parameters))
    clash = [c for c in manifest.extra_columns if c in names]
    if clash:  # a test's result of that name: both cannot be one column
        from ..errors import DataError

        raise DataError(f"{manifest.path}: column {clash[0]!r} is a result jointid writes for each test (tests.csv); "
                        "rename it in the manifest (the computed tests are kept: a rerun reuses them)")
    cols: dict[str, list] = {"manifest_row": [], **{m: [] for m, _ in meta}, "status": [], "reason": [], "file_sha256": []}
    cols.update({p: [] for p in names})
    cols["log10_shift"] = []
    cols["shift_reference_c"] = []
    cols["warning"] = []
    for t in manifest.tests:
        o = outcomes[t.row]
        cols["manifest_row"].append(t.row)
        for m, _ in meta:
            cols[m].append(_meta_value(t, m))
        cols["status"].append("ok" if o.ok else "failed")
        cols["reason"].append(None if o.ok else o.reason)
        cols["file_sha256"].append(sha256.get(t.row))
        for p in names:
            v = o.parameters.get(p)
            cols[p].append(v)
        cols["log10_shift"].append(_log10_shift(analysis, t) if o.ok else None)
        cols["shift_reference_c"].append(_shift_reference(analysis, t) if o.ok else None)
        cols["warning"].append(test_warning(t, o, analysis))
    types = dict(meta)
    out = {}
    for name, values in cols.items():
        if name in types:
            out[name] = _array(values, types[name])
        elif name == "manifest_row":
            out[name] = pa.array(values, type=pa.int64())
        else:
            out[name] = pa.array(values)  # inferred: float64, int64, bool or string, null where absent
    return pa.table(out)


def _flat(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        if "value" in value:
            out[prefix] = value.get("value")
            if "std" in value:
                out[f"{prefix}_std"] = value.get("std")
            return
        for k, v in value.items():
            _flat(f"{prefix}_{k}" if prefix else str(k), v, out)
    elif isinstance(value, (list, tuple)):
        out[prefix] = "; ".join(map(str, value)) if all(isinstance(v, str) for v in value) else json.dumps(value)
    else:
        out[prefix] = value


def fit_table(specimen_rows):
    """One row per fit: ``(specimen, keys, fit)`` items -> :class:`pyarrow.Table` with the fit's ``to_dict()`` flattened.

    Parameters
    ----------
    specimen_rows : iterable of (str, dict, object) or (str, dict, object, dict)
        The specimen, the row's leading columns (temperature, preload or amplitude,
        frequency, counts) and the fit (``to_dict()``: ``{"value", "std"}`` entries
        become ``name`` and ``name_std``; lists of findings become one text cell);
        optionally more fits by column prefix (``{"loss": loss_fit}`` -> ``loss_kmax_n_m``, ...).
    """
    import pyarrow as pa

    rows = []
    for specimen, keys, fit, *more in specimen_rows:
        flat: dict = {}
        _flat("", fit.to_dict(), flat)
        for prefix, other in (more[0].items() if more else ()):
            if other is not None:
                _flat(prefix, other.to_dict(), flat)
        rows.append({"specimen": specimen, **keys, **flat})
    names = list(dict.fromkeys(k for r in rows for k in r))
    return pa.table({n: pa.array([r.get(n) for r in rows]) for n in names})


def table_parquet(table) -> bytes:
    """``table`` as Parquet bytes."""
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


def table_csv(table) -> bytes:
    """``table`` as CSV bytes (header row; floats round-trip exactly; null: empty cell)."""
    import pyarrow.csv as pcsv

    buf = io.BytesIO()
    pcsv.write_csv(table, buf, write_options=pcsv.WriteOptions(quoting_style="needed"))
    return buf.getvalue()
