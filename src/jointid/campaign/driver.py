"""A whole campaign: manifest -> per-test results (resumable) -> tables, master curves, report.

:func:`run_campaign` is what ``jointid campaign`` runs::

    from jointid.campaign import run_campaign
    result = run_campaign("tests/manifest.csv", "out")          # every core
    result.summary                # campaign.json: tests, computed, reused, failed
    result.analysis["S1"].master_curve.to_dict()

Files in ``DIR`` (one :class:`~jointid.io.output_dir.OutputSet`, committed together at
the end, also when some tests failed): ``results.parquet``/``.csv``,
``tests.parquet``/``.csv``, ``amplitude.parquet``/``.csv`` and ``preload.parquet``/``.csv``
(when there are such fits), ``master_curve.json``, ``campaign.json``, ``report.html`` and its figures ``figures/*.png``.
The per-test results are stored as each test finishes under ``DIR/.jointid-cache/``
(:mod:`jointid.campaign.store`), so a killed campaign loses no finished test and a re-run
computes only what is missing or changed.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, TextIO

from ..errors import DataError
from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from .manifest import Manifest, read_manifest
from .runner import execute_tasks
from .store import ResultStore, task_key
from .tasks import ProcessingOptions, TestTask, sha256_file

__all__ = ["CampaignOptions", "CampaignResult", "run_campaign", "plan_tasks", "campaign_summary", "campaign_findings"]


@dataclass(frozen=True)
class CampaignOptions:
    """Options of a campaign.

    Parameters
    ----------
    processing : ProcessingOptions
        Per-test processing (part of each test's cache key).
    reference_temperature_c : float, optional
        Reference temperature of the master curves, degrees C (default: per specimen,
        the tested temperature nearest the median).
    vertical_shift : bool
        Also shift the master curves vertically (density-temperature factor).
    plots : bool
        Figures in the report.
    """

    processing: ProcessingOptions = field(default_factory=ProcessingOptions)
    reference_temperature_c: float | None = None
    vertical_shift: bool = False
    plots: bool = True


@dataclass(frozen=True, eq=False)
class CampaignResult:
    """What a campaign produced.

    Parameters
    ----------
    manifest : Manifest
    outcomes : dict of int to TestOutcome
        By manifest row.
    analysis : dict of str to SpecimenAnalysis
        By specimen.
    summary : dict
        The content of ``campaign.json``.
    directory : Path
        ``DIR``.
    """

    manifest: Manifest
    outcomes: dict
    analysis: dict
    summary: dict
    directory: Path

    @property
    def failed(self) -> list[dict]:
        """``{"row", "file", "reason"}`` of every test that failed."""
        return self.summary["failed"]


def plan_tasks(manifest: Manifest, processing: ProcessingOptions) -> tuple[dict[int, TestTask], dict[int, str]]:
    """The task of every manifest row (hashing each file) and each row's file SHA-256.

    Raises
    ------
    DataError
        A file that cannot be read, naming the row and the column; two rows of the same kind whose files (and
        studies) have the same content: the same test listed twice would count twice in the master curve and
        the fits (bands too narrow), naming both rows.
    """
    hashes: dict[Path, str] = {}
    seen: dict[tuple, object] = {}  # (kind, file SHA-256, study SHA-256) -> the first row with it

    def digest(path: Path, row, column) -> str:
        if path not in hashes:
            try:
                hashes[path] = sha256_file(path)
            except OSError as exc:
                raise DataError(f"{manifest.path}: row {row.row} (line {row.line}), column {column!r}: cannot read {path} "
                                f"({exc.strerror or exc})") from None
        return hashes[path]

    tasks, sha = {}, {}
    for t in manifest.tests:
        h = digest(t.file, t, "file")
        study_h = digest(t.study, t, "study") if t.study is not None else None
        first = seen.setdefault((t.kind, h, study_h), t)
        if first is not t:
            raise DataError(f"{manifest.path}: row {t.row} (line {t.line}, {t.value('file')}) has the same content (SHA-256) as "
                            f"row {first.row} (line {first.line}, {first.value('file')}): one test listed twice would count "
                            "twice in the master curve and the fits (bands too narrow); remove one of the rows")
        key = task_key(t.kind, h, processing, parallel_joints=t.parallel_joints, amplitude_m=t.amplitude_m, study_sha256=study_h)
        tasks[t.row] = TestTask(key=key, kind=t.kind, file=str(t.file.resolve()), sha256=h, parallel_joints=t.parallel_joints,
                                amplitude_m=t.amplitude_m, options=processing,
                                study=str(t.study.resolve()) if t.study is not None else None)
        sha[t.row] = h
    return tasks, sha


def campaign_findings(analysis: dict) -> list[str]:
    """The campaign's findings, one line each, in the order ``jointid campaign`` prints them (every specimen's).

    Parameters
    ----------
    analysis : dict of str to SpecimenAnalysis
        By specimen.

    Returns
    -------
    list of str
        ``"specimen A: master curve: ..."``, the same text as the terminal's notes, ``master_curve.json`` and
        ``campaign.json`` (``findings``).
    """
    return [f for a in analysis.values() for f in a.findings]


def campaign_summary(manifest: Manifest, outcomes: dict, computed_rows: set, analysis: dict | None = None) -> dict:
    """``campaign.json``: ``{"tests", "computed", "reused", "failed": [{"row", "file", "reason"}], "manifest", "findings"}``.

    ``findings`` (:func:`campaign_findings`) holds every finding the terminal prints, same text (``[]`` without
    ``analysis``).
    """
    return {
        "tests": len(manifest.tests),
        "computed": sum(t.row in computed_rows for t in manifest.tests),
        "reused": sum(t.row not in computed_rows for t in manifest.tests),
        "failed": [{"row": t.row, "file": t.value("file"), "reason": outcomes[t.row].reason}
                   for t in manifest.tests if not outcomes[t.row].ok],
        "manifest": str(manifest.path),
        "findings": campaign_findings(analysis or {}),
    }


def _json(obj) -> str:
    return json_text(obj, note_key=None)


def run_campaign(
    manifest: Manifest | str | os.PathLike,
    out: str | os.PathLike,
    options: CampaignOptions | None = None,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    stream: TextIO | None = None,
    on_done: Callable | None = None,
) -> CampaignResult:
    """Run a campaign into ``out`` (see the module docstring).

    Parameters
    ----------
    manifest : Manifest or path-like
        The manifest (read and validated first if a path).
    out : path-like
        ``DIR``.
    options : CampaignOptions, optional
    workers : int, optional
        Local processes (default: every core; 1: this process).
    scheduler : str, optional
        A Dask scheduler's address: the tests run on that cluster.
    stream : text stream, optional
        Progress lines (default ``sys.stdout``).
    on_done : callable, optional
        Called with each computed :class:`~jointid.campaign.tasks.TestOutcome` once it is stored.

    Returns
    -------
    CampaignResult
        Failed tests are listed in ``summary["failed"]``; the others are in the files.

    Raises
    ------
    DataError
        A bad manifest, a missing or unreadable file, ``--scheduler`` without dask or
        unreachable: before anything is computed.
    """
    from .analysis import analyze_specimens

    options = options or CampaignOptions()
    if not isinstance(manifest, Manifest):
        manifest = read_manifest(manifest)
    if workers is not None and workers < 1:
        raise DataError(f"--workers must be >= 1, got {workers}")
    if scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise DataError("--scheduler needs dask.distributed, which is not installed: pip install 'jointid[dask]'") from None
    stream = stream if stream is not None else sys.stdout
    with OutputSet(out, command="campaign") as o:
        o.check(*ALWAYS_WRITTEN)  # a user's file of one of these names is refused before any test runs
        tasks, sha = plan_tasks(manifest, options.processing)
        outcomes_by_key, counts = execute_tasks(list(tasks.values()), ResultStore(o.directory), workers=workers,
                                                scheduler=scheduler, stream=stream, on_done=on_done)
        outcomes = {row: outcomes_by_key[task.key] for row, task in tasks.items()}
        computed_rows = {row for row, task in tasks.items() if task.key in counts.computed}
        analysis = analyze_specimens(manifest.tests, outcomes, reference_temperature_c=options.reference_temperature_c,
                                     vertical_shift=options.vertical_shift)
        summary = campaign_summary(manifest, outcomes, computed_rows, analysis)
        _write_outputs(o, manifest, outcomes, analysis, summary, sha, options)
    return CampaignResult(manifest, outcomes, analysis, summary, Path(out))


#: The files every campaign writes (``amplitude``/``preload`` tables and ``figures/`` only when there is something to show).
ALWAYS_WRITTEN = ("results.parquet", "results.csv", "tests.parquet", "tests.csv", "master_curve.json", "campaign.json",
                  "report.html")


def _write_outputs(o: OutputSet, manifest, outcomes, analysis, summary, sha, options) -> None:
    from .report import campaign_report
    from .tables import fit_table, results_table, table_csv, table_parquet, tests_table

    tables = {"results": results_table(manifest, outcomes, analysis), "tests": tests_table(manifest, outcomes, analysis, sha)}
    kraus = [(s, {"temperature_c": k["temperature_c"], "preload_n": k["preload_n"], "frequency_hz": k["frequency_hz"],
                  "amplitudes": len(k["amplitude_m"])}, k["fit"], {"loss": k["loss_fit"]}) for s, a in analysis.items() for k in a.kraus]
    preload = [(s, {"temperature_c": k["temperature_c"], "amplitude_m": k["amplitude_m"], "frequency_hz": k["frequency_hz"],
                    "preloads": len(k["preload_n"])}, k["fit"]) for s, a in analysis.items() for k in a.preload]
    if kraus:
        tables["amplitude"] = fit_table(kraus)
    if preload:
        tables["preload"] = fit_table(preload)
    for name, table in tables.items():
        o.write_bytes(f"{name}.parquet", table_parquet(table))
        o.write_bytes(f"{name}.csv", table_csv(table))
    master = {
        "specimens": {s: {"reference_amplitude_m": a.reference_amplitude_m, "reference_preload_n": a.reference_preload_n,
                          **(a.master_curve.to_dict() if a.master_curve is not None else {"master_curve": None})}
                      for s, a in analysis.items()},
        "findings": summary["findings"],
    }
    o.write_text("master_curve.json", _json(master))
    o.write_text("campaign.json", _json(summary))
    html, figures = campaign_report(manifest, outcomes, analysis, summary, plots=options.plots)
    for name, png in figures.items():
        o.write_bytes(name, png)
    o.write_text("report.html", html)
