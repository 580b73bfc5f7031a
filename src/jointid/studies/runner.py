"""Run the comparative studies and write the report as one output set.

``run_reproduce`` opens the output directory first (a file, an unwritable
directory or one in use by another run is refused before any study runs), runs
the selected studies in order, each with its own progress bar on a terminal,
then writes ``report.html``, ``figures/*.png`` and ``data/*.csv`` through
:class:`jointid.io.output_dir.OutputSet`: staged, and renamed into place only
when everything succeeded. An interrupted run or a failing study leaves the
directory as it was, never half a report; files in it that jointid did not
write are never touched (``--out .`` in a checkout is safe).
"""

from __future__ import annotations

import datetime
import importlib
import io
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .. import __version__
from ..errors import JointIdError, StudyError
from ..io.output_dir import OutputSet
from ..report.html import Section, Table, render_report
from .common import SUMMARY_BAND_HZ, Progress, StudyOutput
from .config import STUDY_NAMES, ReproduceConfig

__all__ = ["StudyFailed", "ReproduceResult", "run_reproduce", "parse_only", "load_study_module", "STUDY_MODULES"]

#: Study name -> module under :mod:`jointid.studies` with ``run(config, progress) -> StudyOutput``.
STUDY_MODULES = {
    "direct": "direct_characterization",
    "conditioning": "conditioning",
    "verification": "verification",
    "model-error": "model_error",
    "accelerometers": "accelerometers",
    "experiment": "virtual_experiment",
    "noise-robustness": "noise_robustness",
}


class StudyFailed(JointIdError, RuntimeError):
    """A study raised; the message names it and says why. No report was written."""


@dataclass(frozen=True)
class ReproduceResult:
    """Outputs of a reproduce run: the study outputs, seconds per study, the report path."""

    outputs: tuple[StudyOutput, ...]
    seconds: dict
    report: Path


def parse_only(text: str | None) -> tuple[str, ...]:
    """Study names from ``--only a,b`` (all when None), in report order; unknown names are an error."""
    if not text:
        return STUDY_NAMES
    names = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [n for n in names if n not in STUDY_NAMES]
    if unknown:
        raise StudyError(f"--only: unknown study {unknown[0]!r}; expected a comma-separated subset of: {', '.join(STUDY_NAMES)}")
    return tuple(n for n in STUDY_NAMES if n in names)


def load_study_module(name: str):
    """The module of study ``name`` (it has ``run(config, progress) -> StudyOutput``)."""
    return importlib.import_module(f"jointid.studies.{STUDY_MODULES[name]}")


def _bar(name: str, quiet: bool):
    if quiet:
        return None
    from tqdm import tqdm

    return tqdm(desc=f"{name:>15s}", total=1, unit="step", leave=True, file=sys.stderr,
                disable=not sys.stderr.isatty(), bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}]")


def run_reproduce(config: ReproduceConfig, out: str | os.PathLike, only: Sequence[str] | None = None, quiet: bool = False) -> ReproduceResult:
    """Run the studies ``only`` (default: all) and write the report into ``out``.

    ``out`` is validated and locked before the first study runs; see
    :class:`jointid.io.output_dir.OutputSet` for what is replaced in it.

    Raises
    ------
    StudyFailed
        Naming the study that failed and why; ``out`` is left as it was.
    OutputError
        ``out`` is a file, not writable, in use, or holds a file of the same
        name that jointid did not write; raised before any study runs (or,
        for a name clash, before anything is written).
    """
    with OutputSet(out, command="reproduce") as target:
        outputs, seconds = _run_studies(config, only, quiet)
        report = _write(target, config, outputs, seconds)
    return ReproduceResult(tuple(outputs), seconds, report)


def _run_studies(config: ReproduceConfig, only: Sequence[str] | None, quiet: bool) -> tuple[list, dict]:
    names = tuple(only) if only else STUDY_NAMES
    outputs, seconds = [], {}
    for name in names:
        module = load_study_module(name)
        bar = _bar(name, quiet)

        def on_total(n, bar=bar):
            if bar is not None:
                bar.total = n
                bar.refresh()

        def on_update(k, bar=bar):
            if bar is not None:
                bar.update(k)

        t = time.perf_counter()
        try:
            outputs.append(module.run(config, Progress(on_total, on_update)))
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # any failure of a study is reported with its name
            raise StudyFailed(f"study {name!r} failed: {type(exc).__name__}: {exc}; no report was written") from exc
        finally:
            if bar is not None:
                bar.close()
        seconds[name] = time.perf_counter() - t
    return outputs, seconds


def _summary_section(outputs: Sequence[StudyOutput], config: ReproduceConfig, seconds: dict) -> Section:
    rows = []
    for o in outputs:
        for label, mag, eta in o.summary:
            rows.append([o.title, label, f"{100 * mag:.3g} %", f"{eta:.3g}"])
    findings = " ".join(s for o in outputs for s in o.findings)
    lo, hi = SUMMARY_BAND_HZ
    return Section(
        "Summary",
        "summary",
        paragraphs=(findings,) if findings else (),
        tables=(
            Table(
                f"Identified translational stiffness against truth, {lo:g}-{hi:g} Hz: median relative error of |K_ww| and median absolute error of its loss factor",
                ["study", "case", "|K_ww| error", "loss-factor error"],
                rows,
            ),
            Table("Run time per study", ["study", "seconds"], [[k, f"{v:.1f}"] for k, v in seconds.items()]),
        ),
    )


def _write(target: OutputSet, config: ReproduceConfig, outputs: Sequence[StudyOutput], seconds: dict) -> Path:
    """Stage ``report.html``, ``figures/*.png`` and ``data/*.csv`` in ``target``; returns the report's final path."""
    sections = [_summary_section(outputs, config, seconds)]
    for o in outputs:
        for name, columns in o.data.items():
            target.write_csv(f"data/{name}.csv", columns)
        figs = []
        for name, fig, caption in o.figures:
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=110)
            png = buf.getvalue()
            target.write_bytes(f"figures/{name}.png", png)
            figs.append((name, png, caption))
        sections.append(Section(o.title, o.name, o.paragraphs, o.tables, tuple(figs)))
    meta = (
        f"jointid {__version__}, {datetime.datetime.now().isoformat(timespec='seconds')}; seed {config.seed}; "
        f"beam {config.beam.length:g} m, {config.beam.nodes} nodes; joint at node {config.joint_node}; "
        f"grid {config.start:g}-{config.stop:g} Hz step {config.step:g} Hz"
    )
    html = render_report("jointid: direct and inverse identification of an elastomeric joint", meta, sections)
    return target.write_text("report.html", html)
