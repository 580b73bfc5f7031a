"""Run a campaign's tests: reuse what is stored, compute the rest on local cores or a Dask cluster.

Backends (the same task function, :func:`jointid.campaign.tasks.run_tasks`, so the results
are identical):

* one process (``workers=1``, or a single test to compute): in the calling process;
* a process pool (default: every core): :class:`concurrent.futures.ProcessPoolExecutor`
  (``forkserver`` processes), tests sent in small chunks to keep the per-test cost of
  the machinery low; each worker stores each finished test at once, so a killed
  campaign loses no finished test;
* ``scheduler="tcp://host:8786"``: a Dask distributed cluster (``dask.distributed``,
  imported only then: ``pip install jointid[dask]``); the workers need jointid installed
  and the test files at the same paths (a shared file system); this process stores
  each result as it arrives.

Progress is printed as lines (also when the output is not a terminal): tests done /
total, the rate and the ETA, at most about once per second.
"""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Callable, Sequence, TextIO

from ..errors import DataError
from .store import ResultStore
from .tasks import TestOutcome, TestTask, run_tasks

__all__ = ["execute_tasks", "ExecutionCounts", "ProgressPrinter", "default_workers", "START_METHOD"]

#: Start method of the pool's processes: ``fork`` on Linux, as jointid's other process pools
#: (:mod:`jointid.parallel`): a worker needs nothing of the caller's ``__main__``, so a plain script
#: without an ``if __name__ == "__main__":`` guard works (``forkserver``/``spawn`` re-run such a script in
#: every worker, which then dies); ``forkserver`` elsewhere, with jointid's step-sine modules preloaded.
START_METHOD = "fork" if sys.platform.startswith("linux") else "forkserver"


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _duration(seconds: float) -> str:
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


class ProgressPrinter:
    """Progress lines ``campaign: 37/120 tests done (12 reused, 1 failed), 8.1 tests/s, ETA 10 s``.

    Parameters
    ----------
    total : int
        Tests in the campaign.
    reused : int
        Tests already done from the store.
    stream : text stream, optional
        Where to print (default ``sys.stdout``); flushed after each line.
    interval_s : float
        Minimum time between two lines (the first and the last are always printed).
    """

    def __init__(self, total: int, reused: int, stream: TextIO | None = None, interval_s: float = 1.0):
        self.total, self.reused, self.done, self.failed = total, reused, reused, 0
        self.stream = stream if stream is not None else sys.stdout
        self.interval_s = interval_s
        self.start = time.monotonic()
        self.last = -math.inf

    def update(self, n: int, failed: int = 0) -> None:
        """``n`` more tests done, ``failed`` of them failed."""
        self.done += n
        self.failed += failed
        now = time.monotonic()
        computed = self.done - self.reused
        if self.done < self.total and computed > n and now - self.last < self.interval_s:
            return
        self.last = now
        rate = computed / max(now - self.start, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else math.inf
        extra = [f"{self.reused} reused"] if self.reused else []
        extra += [f"{self.failed} failed"] if self.failed else []
        print(f"campaign: {self.done}/{self.total} tests done" + (f" ({', '.join(extra)})" if extra else "")
              + f", {rate:.3g} tests/s, " + ("done" if self.done >= self.total else f"ETA {_duration(eta)}"),
              file=self.stream, flush=True)


@dataclass(frozen=True)
class ExecutionCounts:
    """What :func:`execute_tasks` did: the keys ``computed`` now and those ``reused`` from the store."""

    computed: frozenset
    reused: frozenset


def _chunks(tasks: Sequence[TestTask], workers: int, limit: int) -> list[list[TestTask]]:
    size = max(1, min(limit, len(tasks) // (8 * workers)))
    return [list(tasks[i:i + size]) for i in range(0, len(tasks), size)]


def _pool_chunk(tasks: list[TestTask], store_dir: str) -> list[TestOutcome]:
    """Worker side of the process pool: run the chunk, storing each test as it finishes."""
    store = ResultStore.from_root(store_dir)
    out = []
    for t in tasks:
        (o,) = run_tasks([t])
        store.save(o)
        out.append(o)
    return out


def _dead(task: TestTask, store: ResultStore, reason: str) -> TestOutcome:
    return store.load(task.key) or TestOutcome(task.key, False, reason)


def _run_local(todo, store, workers, emit):
    from ..parallel import single_threaded_blas

    with single_threaded_blas():
        for t in todo:
            (o,) = run_tasks([t], single_thread=False)
            store.save(o)
            emit([o])


def _watch_parent(pid: int, interval_s: float = 1.0) -> None:
    """Pool worker initializer: exit when the campaign process ``pid`` is gone (killed with SIGKILL).

    A worker blocked on the pool's queue would otherwise wait forever after its
    campaign died; the check is one ``kill(pid, 0)`` per second in a daemon thread.
    """
    import threading

    def watch() -> None:
        while True:
            time.sleep(interval_s)
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                os._exit(1)
            except PermissionError:  # pragma: no cover - a pid reused by another user's process: ours is gone
                os._exit(1)

    threading.Thread(target=watch, name="jointid-campaign-parent-watch", daemon=True).start()


class _PoolUnusable(Exception):
    """The worker processes died before finishing any test (e.g. they cannot import the caller's main module)."""


def _run_pool(todo, store, workers, emit):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context(START_METHOD)
    if START_METHOD == "forkserver":
        ctx.set_forkserver_preload(["jointid.campaign.tasks", "jointid.measurement.stepsine"])
    chunks = _chunks(todo, workers, 16)
    finished = 0
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_watch_parent, initargs=(os.getpid(),)) as pool:
        futures = {pool.submit(_pool_chunk, c, str(store.root)): c for c in chunks}
        try:
            for fut in as_completed(futures):
                try:
                    outs = fut.result()
                except BrokenProcessPool as exc:
                    if not finished and not any(store.load(t.key) for t in futures[fut]):
                        raise _PoolUnusable(" ".join(str(exc).split())) from None
                    outs = [_dead(t, store, "a worker process died (killed, or out of memory) while running this test; "
                                  "run the campaign again to retry it") for t in futures[fut]]
                finished += len(outs)
                emit(outs)
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _run_dask(todo, store, scheduler, emit):
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise DataError("--scheduler needs dask.distributed, which is not installed: pip install 'jointid[dask]'") from None
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise DataError(f"--scheduler {scheduler}: cannot connect to the Dask scheduler ({' '.join(str(exc).split())}); "
                        "check the address, or leave --scheduler out to use this machine's cores") from None
    try:
        try:
            client.wait_for_workers(1, timeout=60)
        except (TimeoutError, OSError):
            raise DataError(f"--scheduler {scheduler}: the Dask cluster has no workers (waited 60 s); start workers "
                            "(dask worker ADDRESS) or leave --scheduler out to use this machine's cores") from None
        n = max(1, len(client.scheduler_info().get("workers", {})))
        chunks = _chunks(todo, n, 4)
        futures = client.map(run_tasks, chunks, pure=False)
        which = dict(zip((f.key for f in futures), chunks))
        for fut in as_completed(futures):
            try:
                outs = fut.result()
            except Exception as exc:  # a worker died too often (KilledWorker), lost connection...
                reason = f"the Dask cluster could not run this test ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})"
                outs = [_dead(t, store, reason) for t in which[fut.key]]
            for o in outs:
                store.save(o)
            emit(outs)
    finally:
        client.close()


def execute_tasks(
    tasks: Sequence[TestTask],
    store: ResultStore,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    stream: TextIO | None = None,
    on_done: Callable[[TestOutcome], None] | None = None,
) -> tuple[dict[str, TestOutcome], ExecutionCounts]:
    """Outcomes of ``tasks`` by key: stored ones reused, the others computed and stored as they finish.

    Parameters
    ----------
    tasks : sequence of TestTask
        Tests to run (tasks with the same key are computed once).
    store : ResultStore
        The campaign's per-test store.
    workers : int, optional
        Processes of the local pool (default: every core); 1 runs in this process.
    scheduler : str, optional
        Address of a Dask scheduler: run there instead of locally.
    stream : text stream, optional
        Progress lines (default ``sys.stdout``).
    on_done : callable, optional
        Called with each computed outcome after it is stored (tests use it to stop a run midway).

    Returns
    -------
    outcomes : dict of str to TestOutcome
    counts : ExecutionCounts
        The keys computed now and reused.
    """
    unique = list({t.key: t for t in tasks}.values())
    store.remove_temporary()
    outcomes: dict[str, TestOutcome] = {}
    for t in unique:
        o = store.load(t.key)
        if o is not None:
            outcomes[t.key] = o
    todo = [t for t in unique if t.key not in outcomes]
    n_reused = len(unique) - len(todo)
    progress = ProgressPrinter(len(unique), n_reused, stream)
    workers = default_workers() if workers is None else int(workers)
    where = (f"the Dask cluster at {scheduler}" if scheduler else
             "this process" if workers == 1 or len(todo) <= 1 else f"{min(workers, len(todo))} worker processes")
    print(f"campaign: {len(unique)} tests, {n_reused} stored by a previous run, {len(todo)} to compute on {where}",
          file=progress.stream, flush=True)

    def emit(outs: list[TestOutcome]) -> None:
        for o in outs:
            outcomes[o.key] = o
            if on_done is not None:
                on_done(o)
        progress.update(len(outs), sum(not o.ok for o in outs))

    if todo:
        if scheduler:
            _run_dask(todo, store, scheduler, emit)
        elif workers == 1 or len(todo) == 1:
            _run_local(todo, store, workers, emit)
        else:
            try:
                _run_pool(todo, store, min(workers, len(todo)), emit)
            except _PoolUnusable as exc:
                rest = [t for t in todo if t.key not in outcomes]
                print(f"campaign: the worker processes stopped before finishing a test ({exc}); running the "
                      f"{len(rest)} tests in this process", file=progress.stream, flush=True)
                _run_local(rest, store, 1, emit)
    return outcomes, ExecutionCounts(computed=frozenset(t.key for t in todo), reused=frozenset(outcomes) - {t.key for t in todo})
