"""One campaign test -> its result: a pure function of (the file's content, the options).

:func:`run_tasks` is what the process pool and the Dask workers run (a chunk of
tests per call, to keep the per-test cost of the machinery small). It never
raises for a test: a test that cannot be processed gives a failed
:class:`TestOutcome` with a one-line reason, so one bad test never loses the others.

* ``direct`` tests: :func:`~jointid.measurement.stepsine.read_stepsine_csv` and
  :func:`~jointid.measurement.stepsine.process_stepsine` (commanded amplitude: the
  manifest's ``amplitude_m``), one line per test frequency: the blocked transfer
  stiffness per joint (term ``K21``), ``amplitude_ok``, ``amplitude_ratio``.
* ``identify`` tests: the study's :func:`~jointid.pipeline.identify` on the FRF file,
  one line per frequency and joint term (``K_w_w``, ... or ``<joint>:K_x_x`` for a
  structure study with several joints), with the 1-sigma ``_std`` columns and ``reliable``
  when the method gives them.

The worker reads the file and checks its SHA-256 against the one the campaign was
keyed with, so a file edited during the run fails ("changed") instead of being
stored under the old content's key. BLAS is held to one thread in the workers
(the pool runs one test per core).
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import JointIdError

__all__ = ["ProcessingOptions", "TestTask", "TestOutcome", "run_test", "run_tasks", "sha256_file", "campaign_columns"]


@dataclass(frozen=True)
class ProcessingOptions:
    """Options of the per-test processing (part of every test's cache key).

    Parameters
    ----------
    tolerance : float
        Relative amplitude deviation above which a step-sine line is flagged ``amplitude_ok = False``.
    harmonics, settle_tolerance, min_cycles
        See :func:`jointid.measurement.stepsine.process_block`.
    columns, scale : tuple of (str, str) and of (str, float)
        How the step-sine files name their columns and the factors from their units to SI, per quantity
        (:func:`jointid.measurement.stepsine.read_stepsine_csv`; ``jointid campaign --column/--scale``).
    """

    tolerance: float = 0.05
    harmonics: int = 5
    settle_tolerance: float = 0.02
    min_cycles: int = 2
    columns: tuple = ()
    scale: tuple = ()

    def __post_init__(self) -> None:
        import math

        from ..errors import DataError

        for name, ok in (("tolerance", self.tolerance > 0), ("settle_tolerance", self.settle_tolerance > 0),
                         ("harmonics", self.harmonics >= 1), ("min_cycles", self.min_cycles >= 1)):
            value = getattr(self, name)
            if not (ok and math.isfinite(value)):
                raise DataError(f"ProcessingOptions.{name} must be positive (harmonics, min_cycles: integers >= 1), got {value!r}")


@dataclass(frozen=True)
class TestTask:
    """What a worker needs to process one test (picklable; no manifest metadata that does not change the result).

    Parameters
    ----------
    key : str
        Cache key (:func:`jointid.campaign.store.task_key`).
    kind : str
        ``"direct"`` or ``"identify"``.
    file : str
        Absolute path of the data file.
    sha256 : str
        SHA-256 of the file's content when the campaign was planned.
    parallel_joints : int
        Joints loaded in parallel (``direct``).
    amplitude_m : float
        Commanded amplitude, m, peak (``direct``).
    options : ProcessingOptions
        Processing options.
    study : str or None
        Absolute path of the study TOML (``identify``).
    """

    __test__ = False  # not a pytest class

    key: str
    kind: str
    file: str
    sha256: str
    parallel_joints: int
    amplitude_m: float
    options: ProcessingOptions
    study: str | None = None


@dataclass(frozen=True, eq=False)
class TestOutcome:
    """The result of one test.

    Parameters
    ----------
    key : str
        The task's cache key.
    ok : bool
        Whether the test was processed.
    reason : str
        One line saying why not ("" when ``ok``).
    cacheable : bool
        A failure that the same content and options always give (bad data): stored and
        reused like a result. Anything else (an unexpected error, a file changed during
        the run) is tried again by the next run.
    lines : dict of str to ndarray
        Per frequency line (and term): ``term``, ``frequency_hz``, ``stiffness_real``,
        ``stiffness_imag``, ``magnitude``, ``loss_factor`` and what the method gives
        (``amplitude_ok``, ``amplitude_ratio``; ``stiffness_real_std``,
        ``stiffness_imag_std``, ``reliable``), equal lengths.
    parameters : dict of str to float, int, bool or str
        Per-test figures (lines, band, quality measures) for ``tests.parquet``.
    seconds : float
        CPU time of the processing in the worker, s (for the benchmark; not in the tables).
    """

    __test__ = False

    key: str
    ok: bool
    reason: str = ""
    cacheable: bool = False
    lines: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    seconds: float = 0.0


def sha256_file(path: str | Path) -> str:
    """SHA-256 (hex) of a file's content."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _one_line(text: str) -> str:
    return " ".join(str(text).split()) or "no message"


def _stiffness_lines(term, f, k, std_real=None, std_imag=None) -> dict:
    k = np.asarray(k, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = k.imag / k.real
    out = {
        "term": np.full(f.shape, term, dtype=object),
        "frequency_hz": np.asarray(f, dtype=float),
        "stiffness_real": k.real.copy(),
        "stiffness_imag": k.imag.copy(),
        "magnitude": np.abs(k),
        "loss_factor": eta,
    }
    if std_real is not None:
        out["stiffness_real_std"] = np.asarray(std_real, dtype=float)
        out["stiffness_imag_std"] = np.asarray(std_imag, dtype=float)
    return out


def campaign_columns(path: str | Path, columns: tuple = (), scale: tuple = ()) -> tuple[dict, dict, str]:
    """How a campaign reads one step-sine file: :func:`~jointid.measurement.stepsine_files.resolve_columns` with the
    campaign's ``--column``/``--scale`` (they apply to every file and win) and its advice for a column it cannot find.

    Returns
    -------
    columns : dict of str to str
    scale : dict of str to float
    converted : str
        ``"displacement_mm x 0.001 (to m), force_kN x 1000 (to N)"``, or ``""``.
    """
    from ..measurement.stepsine_files import resolve_columns

    return resolve_columns(path, dict(columns), dict(scale), remedy="map it for every file of the campaign with")


def _direct(task: TestTask) -> tuple[dict, dict]:
    from ..measurement.stepsine import process_stepsine, read_stepsine_csv

    o = task.options
    columns, scale, converted = campaign_columns(task.file, o.columns, o.scale)
    blocks = read_stepsine_csv(task.file, columns=columns or None, scale=scale or None)
    r = process_stepsine(blocks, parallel_joints=task.parallel_joints, commanded_amplitude_m=task.amplitude_m,
                         tolerance=o.tolerance, harmonics=o.harmonics, settle_tolerance=o.settle_tolerance,
                         min_cycles=o.min_cycles)
    lines = _stiffness_lines("K21", r.frequency_hz, r.stiffness)
    lines["amplitude_ok"] = np.asarray(r.amplitude_ok, dtype=bool)
    lines["amplitude_ratio"] = np.asarray(r.amplitude_ratio, dtype=float)
    ok = r.amplitude_ok
    storage = r.stiffness.real[ok] if ok.any() else r.stiffness.real
    params = {
        "lines": int(r.frequency_hz.size),
        "lines_amplitude_ok": int(ok.sum()),
        "frequency_min_hz": float(r.frequency_hz[0]),
        "frequency_max_hz": float(r.frequency_hz[-1]),
        "achieved_amplitude_m": float(np.median(r.displacement_amplitude_m)),
        "median_storage_n_m": float(np.median(storage)),
        "median_loss_factor": float(np.median(lines["loss_factor"][ok] if ok.any() else lines["loss_factor"])),
        "max_force_thd": float(np.max(r.force_thd)),
        "max_force_residual": float(np.max(r.force_residual)),
        "max_displacement_residual": float(np.max(r.displacement_residual)),
        "max_settled_time_s": float(np.max(r.settled_time_s)),
        # the lines the processing flagged and why (clipped, distorted, drifting): named in the tests table and findings
        "lines_not_used": "; ".join(r.distortion),
        # the test-level notes of the processing (a drift: StepSineResult.notes): named in the findings and the warning
        "notes": "; ".join(r.notes),
        # the columns read from unit-suffixed names and converted to SI (campaign_columns): named in the findings
        "columns_converted": converted,
    }
    return lines, params


def _identify(task: TestTask) -> tuple[dict, dict]:
    from ..pipeline import identify, read_measured, split_joints
    from ..study import load_study

    study = load_study(task.study)
    result = identify(study, read_measured(study, task.file))
    f = result.frequency.hz
    several = len(study.joints) > 1
    chunks = []
    for name, part in split_joints(study, result).items():
        prefix = f"{name}:" if several else ""
        std = part.has_uncertainty  # no std: empty, never 0
        for a, b, term in part.term_names():
            c = _stiffness_lines(f"{prefix}{term}", f, part.stiffness[:, a, b],
                                 part.std_real[:, a, b] if std else None, part.std_imag[:, a, b] if std else None)
            c["reliable"] = np.asarray(part.reliable_terms[:, a, b], dtype=bool)
            chunks.append(c)
    lines = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    params = {
        "lines": int(f.size),
        "frequency_min_hz": float(f[0]),
        "frequency_max_hz": float(f[-1]),
        "method": result.method,
        "reliable_fraction": float(np.mean(result.reliable)),
    }
    return lines, params


def run_test(task: TestTask) -> TestOutcome:
    """Process one test; never raises for the test's own problems (see :class:`TestOutcome`).

    Parameters
    ----------
    task : TestTask

    Returns
    -------
    TestOutcome
        ``ok`` with the lines and parameters, or a failure with a one-line reason.
    """
    t0 = time.process_time()
    try:
        if sha256_file(task.file) != task.sha256:
            return TestOutcome(task.key, False, "the file changed while the campaign ran; run the campaign again",
                               seconds=time.process_time() - t0)
        lines, params = (_direct if task.kind == "direct" else _identify)(task)
    except JointIdError as exc:
        return TestOutcome(task.key, False, _one_line(exc), cacheable=True, seconds=time.process_time() - t0)
    except OSError as exc:
        return TestOutcome(task.key, False, _one_line(f"cannot read {exc.filename or task.file}: {exc.strerror or exc}"),
                           seconds=time.process_time() - t0)
    except MemoryError:
        return TestOutcome(task.key, False, "out of memory", seconds=time.process_time() - t0)
    except Exception as exc:  # a bug: still one line, and the other tests go on
        return TestOutcome(task.key, False, _one_line(f"internal error: {type(exc).__name__}: {exc}"),
                           seconds=time.process_time() - t0)
    return TestOutcome(task.key, True, lines=lines, parameters=params, seconds=time.process_time() - t0)


_blas_limited = False


def run_tasks(tasks: list[TestTask], single_thread: bool = True) -> list[TestOutcome]:
    """Process a chunk of tests (the function the pool and the Dask workers call).

    Parameters
    ----------
    tasks : list of TestTask
    single_thread : bool
        Hold BLAS to one thread in this process from now on (a worker process of
        the pool: one test per core); False in the calling process itself.

    Returns
    -------
    list of TestOutcome
        In the order of ``tasks``.
    """
    global _blas_limited
    if single_thread and not _blas_limited:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1, user_api="blas")
        _blas_limited = True
    return [run_test(t) for t in tasks]
