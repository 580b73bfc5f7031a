"""Run the comparative studies and write the report as one output set.

``run_reproduce`` opens the output directory first (a file, an unwritable
directory, one in use by another run, or a ``report.html`` there that jointid
did not write is refused before any study runs), then runs the selected studies
as independent tasks on the available cores (:func:`jointid.parallel.map_processes`:
forked processes with one BLAS thread each). A study is one task, or several when
its module splits it (``parts(config)`` and ``combine(config, results)``: the
noise-robustness study per case and noise realization, the virtual experiment per
material). Every task draws its own random numbers from the seed, so the numbers
are the same on one process or many. One line per study reports its time as it
finishes (``[3/7] noise-robustness: 21.4 s``), on a terminal or not.

The report, ``figures/*.png`` and ``data/*.csv`` are then written through
:class:`jointid.io.output_dir.OutputSet`: staged, and renamed into place only
when everything succeeded. An interrupted run or a failing study leaves the
directory as it was, never half a report; files in it that jointid did not
write are never touched (``--out .`` in a checkout is safe).
"""

from __future__ import annotations

import datetime
import importlib
import os
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Sequence

from .. import __version__
from ..errors import JointIdError, StudyError
from ..io.output_dir import OutputSet
from ..parallel import TaskFailed, map_processes, process_count, single_threaded_blas
from ..report.html import Section, Table, render_report
from .common import SUMMARY_BAND_HZ, Progress, StudyOutput, png
from .config import STUDY_NAMES, ReproduceConfig

__all__ = ["StudyFailed", "ReproduceResult", "run_reproduce", "parse_only", "load_study_module", "study_tasks", "STUDY_MODULES"]

#: Study name -> module under :mod:`jointid.reproduce` with ``run(config, progress) -> StudyOutput``
#: (and optionally ``parts(config)`` and ``combine(config, results)``, see :func:`study_tasks`).
STUDY_MODULES = {
    "direct": "direct_characterization",
    "conditioning": "conditioning",
    "verification": "verification",
    "model-error": "model_error",
    "accelerometers": "accelerometers",
    "experiment": "virtual_experiment",
    "noise-robustness": "noise_robustness",
    "real-world": "real_world",
}


class StudyFailed(JointIdError, RuntimeError):
    """A study raised; the message names it and says why. No report was written."""


@dataclass(frozen=True)
class ReproduceResult:
    """Outputs of a reproduce run.

    Attributes
    ----------
    outputs : tuple of StudyOutput
        In report order; figures as PNG bytes.
    seconds : dict
        Study name -> seconds of computation (wall clock summed over its tasks, whichever process ran them).
    report : Path
    workers : int
        Processes the studies ran on.
    wall_seconds : float
        Wall-clock time of the studies.
    cpu_seconds : dict
        Study name -> CPU seconds summed over its tasks.
    """

    outputs: tuple[StudyOutput, ...]
    seconds: dict
    report: Path
    workers: int = 1
    wall_seconds: float = 0.0
    cpu_seconds: dict = field(default_factory=dict)


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
    return importlib.import_module(f"jointid.reproduce.{STUDY_MODULES[name]}")


def _rendered(output: StudyOutput) -> StudyOutput:
    """``output`` with its figures as PNG bytes (the figures are closed): what crosses a process boundary."""
    figs = tuple((name, fig if isinstance(fig, bytes) else png(fig), caption) for name, fig, caption in output.figures)
    return replace(output, figures=figs)


def _run_whole(name: str, config: ReproduceConfig) -> StudyOutput:
    """A study that is one task: ``run`` with its figures rendered (in the worker)."""
    return _rendered(load_study_module(name).run(config, Progress()))


def study_tasks(name: str, config: ReproduceConfig) -> tuple[list[tuple[Callable, tuple, float]], Callable | None]:
    """The tasks of study ``name``: ``([(fn, args, cost), ...], combine)``.

    A module with ``parts(config) -> [(fn, args, cost), ...]`` and ``combine(config, results) -> StudyOutput``
    is split (``cost``: relative run time, to start the longest first); any other study is one task
    whose result is its output (``combine`` None).
    """
    module = load_study_module(name)
    if hasattr(module, "parts") and hasattr(module, "combine"):
        return list(module.parts(config)), module.combine
    return [(_run_whole, (name, config), getattr(module, "COST", 1.0))], None


def run_reproduce(config: ReproduceConfig, out: str | os.PathLike, only: Sequence[str] | None = None, quiet: bool = False,
                  workers: int | None = None, stream=None) -> ReproduceResult:
    """Run the studies ``only`` (default: all) and write the report into ``out``.

    ``out`` is validated and locked, and a ``report.html`` in it that jointid did not write
    is refused, before the first study runs; see :class:`jointid.io.output_dir.OutputSet`
    for what is replaced in it.

    Parameters
    ----------
    config : ReproduceConfig
    out : path-like
    only : sequence of str, optional
        Study names (:data:`~jointid.reproduce.config.STUDY_NAMES`).
    quiet : bool
        No progress lines.
    workers : int, optional
        Processes (default: the cores this process may use; 1 runs everything here).
        The numbers do not depend on it.
    stream : file, optional
        Where the progress lines go (default ``sys.stdout``), flushed line by line.

    Raises
    ------
    StudyFailed
        Naming the study that failed and why; ``out`` is left as it was.
    OutputError
        ``out`` is a file, not writable, in use, or holds a ``report.html`` that jointid did not
        write; raised before any study runs (for another name clash, before anything is written).
    """
    with OutputSet(out, command="reproduce") as target:
        target.check("report.html")  # a user's report.html is refused before any study runs
        outputs, seconds, cpu, used, wall = _run_studies(config, only, quiet, workers, stream)
        report = _write(target, config, outputs, seconds, cpu, used, wall)
    return ReproduceResult(tuple(outputs), seconds, report, used, wall, cpu)


def _run_studies(config: ReproduceConfig, only: Sequence[str] | None, quiet: bool, workers: int | None, stream) -> tuple:
    names = tuple(only) if only else STUDY_NAMES
    stream = stream or sys.stdout

    def say(text: str) -> None:
        if not quiet:
            print(text, file=stream, flush=True)

    tasks, owner, combiners = [], [], {}
    for name in names:
        parts, combiners[name] = study_tasks(name, config)
        for fn, args, cost in parts:
            tasks.append((cost, len(tasks), fn, args))
            owner.append(name)
    order = sorted(range(len(tasks)), key=lambda i: (-tasks[i][0], i))  # longest first, else in report order
    used = process_count(len(tasks), workers)
    if "noise-robustness" in names:
        s = config.robustness_seeds
        say(f"running {len(names)} stud{'ies' if len(names) != 1 else 'y'} as {len(tasks)} tasks on {used} process{'es' if used != 1 else ''} "
            f"(noise-robustness: {s} noise realization{'s' if s != 1 else ''} per level; --seeds N for more)")
    else:
        say(f"running {len(names)} stud{'ies' if len(names) != 1 else 'y'} as {len(tasks)} tasks on {used} process{'es' if used != 1 else ''}")
    left = {n: owner.count(n) for n in names}
    results: dict = {n: {} for n in names}
    seconds = {n: 0.0 for n in names}
    cpu = {n: 0.0 for n in names}
    outputs: dict = {}

    def failed(name: str, exc: BaseException, kind: str | None = None, message: str | None = None) -> StudyFailed:
        kind = kind or type(exc).__name__
        message = str(exc) if message is None else message
        return StudyFailed(f"study {name!r} failed: {kind}: {message}; no report was written")

    def on_done(k: int, value, times: tuple) -> None:
        i = order[k]
        name = owner[i]
        results[name][i] = value
        seconds[name] += times[0]
        cpu[name] += times[1]
        left[name] -= 1
        if left[name]:
            return
        t, c = time.perf_counter(), time.process_time()
        if combiners[name] is None:
            outputs[name] = value
        else:
            try:
                parts = [results[name][j] for j in sorted(results[name])]
                outputs[name] = _rendered(combiners[name](config, parts))
            except Exception as exc:
                raise failed(name, exc) from exc
        seconds[name] += time.perf_counter() - t
        cpu[name] += time.process_time() - c
        results[name] = None
        say(f"[{len(outputs)}/{len(names)}] {name}: {seconds[name]:.1f} s (CPU {cpu[name]:.1f} s)")

    t0 = time.perf_counter()
    try:
        # the combiners run here, in this process, as the tasks finish: on one BLAS thread as the tasks do, so the
        # report's numbers are the same bits on 1 or N processes whatever OPENBLAS_NUM_THREADS says
        with single_threaded_blas():
            map_processes([(tasks[i][2], tasks[i][3]) for i in order], used, on_done)
    except TaskFailed as exc:
        name = owner[order[exc.index]]
        err = failed(name, exc, exc.kind, exc.message)
        if exc.__cause__ is None:  # from a worker process: its traceback as a note (shown with --debug)
            err.add_note(exc.trace)
        raise err from (exc.__cause__ or exc)
    wall = time.perf_counter() - t0
    return [outputs[n] for n in names], seconds, cpu, used, wall


def _summary_section(outputs: Sequence[StudyOutput], config: ReproduceConfig, seconds: dict, cpu: dict, workers: int = 1, wall: float = 0.0) -> Section:
    rows = []
    for o in outputs:
        for label, mag, eta in o.summary:
            rows.append([o.title, label, f"{100 * mag:.3g} %", f"{eta:.3g}"])
    lo, hi = SUMMARY_BAND_HZ
    times = [[k, f"{v:.1f}", f"{cpu.get(k, float('nan')):.1f}"] for k, v in seconds.items()]
    times.append([f"all studies, on {workers} process{'es' if workers != 1 else ''} at once", f"{wall:.1f}", f"{sum(cpu.values()):.1f}"])
    return Section(
        "Summary",
        "summary",
        items=tuple(s for o in outputs for s in o.findings),  # one short statement per line, not one paragraph
        tables=(
            Table(
                f"Identified translational stiffness against truth, {lo:g}-{hi:g} Hz: median relative error of |K_ww| and median absolute error of its loss factor",
                ["study", "case", "|K_ww| error", "loss-factor error"],
                rows,
            ),
            Table("Run time per study: seconds of computation summed over its tasks (wall clock and CPU); the last row: "
                  "wall clock from the first task to the last", ["study", "seconds", "CPU seconds"], times),
        ),
    )


def _write(target: OutputSet, config: ReproduceConfig, outputs: Sequence[StudyOutput], seconds: dict, cpu: dict, workers: int = 1,
           wall: float = 0.0) -> Path:
    """Stage ``report.html``, ``figures/*.png`` and ``data/*.csv`` in ``target``;
    returns the report's final path."""
    sections = [_summary_section(outputs, config, seconds, cpu, workers, wall)]
    for o in outputs:
        for name, columns in o.data.items():
            target.write_csv(f"data/{name}.csv", columns)
        figs = []
        for name, png, caption in _rendered(o).figures:
            target.write_bytes(f"figures/{name}.png", png)
            figs.append((name, png, caption))
        sections.append(Section(o.title, o.name, o.paragraphs, o.tables, tuple(figs)))
    meta = (
        f"jointid {__version__}, {datetime.datetime.now().isoformat(timespec='seconds')}; seed {config.seed}; "
        f"beam {config.beam.length:g} m, {config.beam.nodes} nodes; joint at node {config.joint_node}; "
        f"grid {config.start:g}-{config.stop:g} Hz step {config.step:g} Hz"
    )
    if any(o.name == "noise-robustness" for o in outputs):
        s = config.robustness_seeds
        meta += f"; noise robustness: {s} noise realization{'s' if s != 1 else ''} per level and case (--seeds N)"
    html = render_report("jointid: direct and inverse identification of an elastomeric joint", meta, sections)
    return target.write_text("report.html", html)
