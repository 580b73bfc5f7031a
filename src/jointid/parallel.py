"""Work on the available cores: chunks of frequency lines on threads, independent tasks on processes.

* :func:`map_lines`: a function of independent lines (frequency first, every output
  too) computed on one chunk of the lines per core and joined, the same way.
* :func:`map_chunks`: each chunk is a few batched LAPACK calls and BLAS products,
  which release the GIL, so threads scale. BLAS is held to one thread while the
  workers run: BLAS threads inside worker threads oversubscribe the cores
  (measured: the identification of 20 000 lines takes 0.9 s instead of 0.5 s on 2 cores).
* :func:`map_processes`: independent tasks of seconds each (the studies of
  ``jointid reproduce``, noise realizations) on forked worker processes, each
  with one BLAS thread. A task's result does not depend on which process runs it
  or when, and the serial path (one worker) also runs with one BLAS thread, so a
  run gives the same numbers on 1 or N processes.
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence

import numpy as np
from threadpoolctl import threadpool_limits

__all__ = ["map_lines", "map_chunks", "single_threaded_blas", "worker_count", "map_processes", "forked_pool", "process_count", "TaskFailed"]

_lock = threading.Lock()
_users = 0
_limiter = None


def worker_count(tasks: int) -> int:
    """Threads for ``tasks`` independent chunks: the available cores, at most 4; 1 inside a worker process of
    :func:`map_processes` (a daemonic process: its siblings have the other cores)."""
    if multiprocessing.current_process().daemon:
        return 1
    return max(1, min(tasks, _cores(), 4))


def _cores() -> int:
    """The cores this process may run on (its CPU affinity where the OS has one, e.g. under ``taskset``)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Hold BLAS to one thread; re-entrant and safe when several threads use it at once.

    ``threadpool_limits`` changes a process-wide setting, so nested or concurrent
    uses are reference-counted: the first entry sets the limit, the last exit
    restores what was there before.
    """
    global _users, _limiter
    with _lock:
        if _users == 0:
            _limiter = threadpool_limits(1, user_api="blas")
        _users += 1
    try:
        yield
    finally:
        with _lock:
            _users -= 1
            if _users == 0:
                _limiter.restore_original_limits()
                _limiter = None


def map_chunks(fn: Callable[..., None], lines: np.ndarray, chunk: int, **kwargs) -> None:
    """Call ``fn(lines[a:a + chunk], **kwargs)`` for every chunk, on the available cores.

    Parameters
    ----------
    fn : callable
        Writes its results for the given lines; chunks must write disjoint outputs.
    lines : ndarray of int, shape (F,)
        Line indices.
    chunk : int
        Lines per call (bounds the memory of the batched arrays).
    """
    chunks = [lines[a : a + chunk] for a in range(0, lines.size, chunk)]
    workers = worker_count(len(chunks))
    if workers == 1:
        for c in chunks:
            fn(c, **kwargs)
        return
    with single_threaded_blas(), ThreadPoolExecutor(workers) as pool:
        list(pool.map(lambda c: fn(c, **kwargs), chunks))


#: Fewest lines per thread for :func:`map_lines` (below: one call in the calling thread). A thread costs ~0.1 ms
#: to start and join; 1000 lines of a 7 x 3 layout's batched per-line algebra take ~5 ms.
MIN_THREAD_LINES = 1000

_inside = threading.local()


def map_lines(fn: Callable[..., Any], *arrays: np.ndarray, min_lines: int = MIN_THREAD_LINES) -> Any:
    """``fn(*arrays)`` for a function of independent lines, computed on one chunk of the lines per core and joined.

    Parameters
    ----------
    fn : callable
        ``fn(*chunks)`` -> ndarray or tuple of ndarrays, each with the lines on its first axis; line ``f``
        of every output depends on line ``f`` of the inputs only (no sum, running mean or neighbour over lines).
    *arrays : ndarray
        Inputs with the F lines on their first axis.
    min_lines : int
        Fewest lines per thread; fewer lines in all (or a call from inside another ``map_lines``): one call here.

    Returns
    -------
    What ``fn`` returns, its arrays joined along the first axis (``fn(*arrays)`` up to the rounding of the
    batched kernels, which may group a chunk's lines differently than the whole's).

    Raises
    ------
    ValueError
        An input without the F lines of the first on its first axis (in one call it might broadcast, in
        chunks it would not: the result must not depend on the number of cores).

    Notes
    -----
    numpy's batched LAPACK and matmul loops release the GIL, so the chunks run at once on the cores; BLAS is held
    to one thread meanwhile (:func:`single_threaded_blas`).
    """
    F = arrays[0].shape[0]
    if any(np.ndim(x) == 0 or np.shape(x)[0] != F for x in arrays):
        raise ValueError(f"map_lines: every input needs the {F} lines on its first axis, got shapes {[np.shape(x) for x in arrays]}")
    workers = worker_count(F // max(int(min_lines), 1))
    if workers <= 1 or getattr(_inside, "active", False):
        return fn(*arrays)
    edges = np.linspace(0, F, workers + 1).astype(int)

    def part(a: int, b: int):
        _inside.active = True
        try:
            return fn(*(x[a:b] for x in arrays))
        finally:
            _inside.active = False

    with single_threaded_blas(), ThreadPoolExecutor(workers) as pool:
        parts = list(pool.map(part, edges[:-1], edges[1:]))
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate(p) for p in zip(*parts))
    return np.concatenate(parts)


def process_count(tasks: int, requested: int | None = None) -> int:
    """Worker processes for ``tasks`` independent tasks.

    ``requested`` (>= 1) or else the cores this process may use (``os.sched_getaffinity``),
    at most ``tasks``; 1 where ``fork`` is unavailable (Windows, macOS' default) or inside a
    daemonic worker.
    """
    if requested is None:
        requested = _cores()
    if "fork" not in multiprocessing.get_all_start_methods() or multiprocessing.current_process().daemon:
        return 1
    return max(1, min(int(requested), int(tasks)))


class TaskFailed(RuntimeError):
    """A task of :func:`map_processes` raised: its index, the exception's type name, message and traceback text."""

    def __init__(self, index: int, kind: str, message: str, trace: str):
        super().__init__(f"{kind}: {message}")
        self.index, self.kind, self.message, self.trace = index, kind, message, trace


def _init_process() -> None:
    """A worker of :func:`map_processes`: one BLAS thread."""
    global _worker_limiter
    _worker_limiter = threadpool_limits(1, user_api="blas")


#: Signals that stop a run; blocked while a pool forks its workers and starts its threads (:func:`forked_pool`).
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def forked_pool(processes: int, initializer: Callable[[], None] | None = None):
    """A fork-context ``multiprocessing.Pool`` started with SIGINT and SIGTERM held back; each worker runs ``initializer``.

    A stop signal that came while the pool forked used to run its handler at an arbitrary point: inside an
    at-fork callback (logging's ``_releaseLock``), where the exception it raised was swallowed ("Exception
    ignored") and the signal lost, or inside ``Pool()``, leaving a half-made pool that hung the exit. So,
    in the main thread, the handlers only record a signal while the pool is made, and the signals are
    blocked (the pool's threads, created so, keep them blocked: the kernel then delivers them to the main
    thread, whose wait for results they interrupt at once). Afterwards the handlers come back and a
    recorded signal is raised again; if its handler raises, the pool is ended before the exception leaves.
    Each worker first sets its own handlers -- SIGTERM ends it (``Pool.terminate`` sends it), SIGINT is
    ignored (Ctrl-C reaches the whole process group: the parent answers it) -- then runs ``initializer``,
    then unblocks the signals. (A worker that kept a handler inherited from the parent, such as the recording
    one above, swallowed the pool's SIGTERM, and ``terminate()`` then waited for it forever.) On Linux the
    workers end with the thread that made the pool (:func:`_end_with_parent`): make and use it in one thread.
    """
    got: list[int] = []
    main = threading.current_thread() is threading.main_thread()
    saved = {s: signal.signal(s, lambda signum, frame: got.append(signum)) for s in _STOP_SIGNALS} if main else {}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    pool = None
    try:
        gc.freeze()  # the workers never collect (nor finalize) this process's objects (:func:`_start_worker`)
        pool = multiprocessing.get_context("fork").Pool(processes, initializer=_start_worker,
                                                        initargs=(initializer, os.getpid()))
    finally:
        gc.unfreeze()
        signal.pthread_sigmask(signal.SIG_SETMASK, old)  # a pending signal is recorded now
        for s, handler in saved.items():
            signal.signal(s, handler)
        if got and pool is None:  # Pool() failed as well: the signal first
            signal.raise_signal(got[0])
    if got:
        try:
            signal.raise_signal(got[0])  # the run's own handler: raises (KeyboardInterrupt, Terminated)
        except BaseException:
            pool.terminate()
            pool.join()
            raise
    return pool


def _start_worker(initializer: Callable[[], None] | None, parent: int) -> None:
    """A worker's first step: its own stop-signal handlers, an end with its parent, ``initializer``, then the
    signals unblocked.

    The objects inherited from the parent are frozen out of the worker's garbage collection (``gc.freeze``; a
    worker the pool starts later, to replace one, inherits them unfrozen): a collection in the worker would
    otherwise run the finalizers of the parent's garbage. One was an unclosed dask ``Client`` left in a
    reference cycle by a failed connection, whose ``__del__`` waited 40 s for its event-loop thread, which a
    forked worker does not have (a 0.1 s test took 40 s in the suite)."""
    gc.freeze()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _end_with_parent(parent)
    if initializer is not None:
        initializer()
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)  # blocked by the parent across the fork


def _end_with_parent(parent: int) -> None:
    """Have the kernel send this worker SIGTERM when the thread that forked it ends (Linux ``PR_SET_PDEATHSIG``).

    A worker outliving its parent (killed with SIGKILL, or ended by a test runner's timeout) finished its task first
    (a whole study: seconds to minutes), and one waiting for the queue's lock that the parent held when it died (it
    does while it ends the pool) waited forever -- holding the pipes it inherited, so whoever read the parent's output
    never saw its end. Elsewhere nothing is done. A parent already gone before the call (``getppid`` changed) ends it
    at once. The signal comes when the *thread* that forked the worker ends: a pool is made and used in one thread.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - no libc symbol: the worker ends with the pool as before
        return
    if os.getppid() != parent:
        os._exit(1)


#: prctl(2) option: the signal the calling process gets when its parent (thread) dies.
_PR_SET_PDEATHSIG = 1

_worker_limiter = None


def _call(job: tuple) -> tuple:
    """Run ``fn(*args)``; returns ``(index, True, result, (wall, cpu))`` or ``(index, False, (kind, message, trace), (wall, cpu))``."""
    index, fn, args = job
    t, c = time.perf_counter(), time.process_time()
    try:
        ok, value = True, fn(*args)
    except Exception as exc:  # reported in the parent as TaskFailed
        ok, value = False, (type(exc).__name__, str(exc), traceback.format_exc())
    return index, ok, value, (time.perf_counter() - t, time.process_time() - c)


def map_processes(tasks: Sequence[tuple[Callable, tuple]], workers: int,
                  on_done: Callable[[int, Any, tuple], None] | None = None) -> list:
    """``[fn(*args) for fn, args in tasks]`` on ``workers`` forked processes, each with one BLAS thread.

    Parameters
    ----------
    tasks : sequence of (callable, tuple)
        Module-level functions and their (picklable) arguments; started in this order
        (put the longest first), results returned in this order.
    workers : int
        Processes (:func:`process_count`); 1 runs the tasks here, in order, with one BLAS thread.
    on_done : callable, optional
        ``on_done(index, result, (wall, cpu))``, called in this process as each task finishes
        (completion order), with the task's own wall-clock and CPU seconds.

    Raises
    ------
    TaskFailed
        The first task that raised (by completion); the other tasks are stopped. In this
        process (one worker) it is raised ``from`` the original exception.
    """
    jobs = [(i, fn, tuple(args)) for i, (fn, args) in enumerate(tasks)]
    results: list = [None] * len(jobs)

    def take(out):
        index, ok, value, times = out
        if not ok:
            raise TaskFailed(index, *value)
        results[index] = value
        if on_done is not None:
            on_done(index, value, times)

    if workers <= 1 or len(jobs) < 2:
        with single_threaded_blas():
            for index, fn, args in jobs:
                t, c = time.perf_counter(), time.process_time()
                try:
                    value = fn(*args)
                except Exception as exc:
                    raise TaskFailed(index, type(exc).__name__, str(exc), traceback.format_exc()) from exc
                take((index, True, value, (time.perf_counter() - t, time.process_time() - c)))
        return results
    pool = forked_pool(min(workers, len(jobs)), _init_process)  # stop signals blocked across the fork
    try:
        for out in pool.imap_unordered(_call, jobs, chunksize=1):
            take(out)
        pool.close()
    except BaseException:
        pool.terminate()
        raise
    finally:
        pool.join()
    return results
