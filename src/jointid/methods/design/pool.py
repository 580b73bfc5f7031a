"""Evaluate many test layouts on the available cores (the search of :mod:`jointid.methods.design.layout`).

Each step of the design's search (the seed sets, one greedy growth step, one
exchange pass) is a batch of independent layouts, each a few small batched
LAPACK calls and NumPy overhead. Threads would
contend for the GIL on such small arrays, and BLAS threads only contend on
them, so the batch is split over **forked** worker processes that inherit the
layout predictor (its receptances are computed once, before the fork, and
shared copy-on-write), each with one BLAS thread. A layout's value does not
depend on which process computes it or with which other layouts, so the result
is the same as a sequential evaluation. Where ``fork`` is not safe (other systems
than Linux), inside a daemonic worker (a study run in a process pool), or
with one core, the batch is evaluated in this process.
"""

from __future__ import annotations

import itertools
import math
import multiprocessing
import os
import sys
from typing import Callable, Sequence

import numpy as np

from ...parallel import forked_pool, single_threaded_blas

__all__ = ["LayoutPool", "pool_workers", "seed_sets", "MAX_SEED_SETS"]

#: Largest number of |n|-node seed sets evaluated exhaustively (more: a fixed-seed random sample).
MAX_SEED_SETS = 2000

#: Set in the parent just before the fork: the function the workers apply to each item.
_TASK: Callable | None = None


def pool_workers(tasks: int) -> int:
    """Worker processes for ``tasks`` layouts: the available cores (at most 4), 1 where fork is not possible."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    if cores < 2 or tasks < 2 or multiprocessing.current_process().daemon:
        return 1
    if not sys.platform.startswith("linux") or "fork" not in multiprocessing.get_all_start_methods():
        return 1  # fork is unsafe with macOS' system libraries and absent on Windows
    return min(cores, 4, tasks)


def _run_chunk(items: Sequence) -> list:
    with single_threaded_blas():
        return [_TASK(*item) for item in items]


class LayoutPool:
    """``map(items) -> [task(*item) for item in items]`` over forked workers (or in this process).

    Parameters
    ----------
    task : callable
        A function of one item's fields, returning a picklable value (a layout's cost).
    workers : int
        Processes; 1 evaluates in this process (no fork).

    Use as a context manager: the workers are forked on entry (inheriting ``task`` and
    everything it refers to) and ended on exit.
    """

    def __init__(self, task: Callable, workers: int):
        self.task = task
        self.workers = int(workers)
        self._pool = None

    def __enter__(self) -> "LayoutPool":
        global _TASK
        if self.workers > 1:
            _TASK = self.task
            try:
                self._pool = forked_pool(self.workers)  # workers: SIGTERM ends them, Ctrl-C is the parent's
            except OSError:  # no processes left: evaluate here
                self._pool = None
        return self

    def __exit__(self, exc_type, *exc) -> None:
        global _TASK
        if self._pool is not None:
            if exc_type is None:
                self._pool.close()  # the workers are idle: let them exit
            else:
                self._pool.terminate()
            self._pool.join()
            self._pool = None
        _TASK = None

    def map(self, items: Sequence) -> list:
        """The task on every item, in order."""
        items = list(items)
        if self._pool is None or len(items) < 2:
            with single_threaded_blas():
                return [self.task(*item) for item in items]
        k = self.workers
        size = -(-len(items) // k)
        chunks = [items[a:a + size] for a in range(0, len(items), size)]
        return [x for part in self._pool.map(_run_chunk, chunks) for x in part]


def seed_sets(cands: tuple, n: int) -> list[tuple]:
    """Every n-subset of the candidates, or (more than MAX_SEED_SETS) a fixed-seed random sample of them.

    Up to a million subsets they are listed and sampled (as always); beyond, drawn directly.
    """
    if math.comb(len(cands), n) <= 1_000_000:
        seeds = list(itertools.combinations(cands, n))
        if len(seeds) > MAX_SEED_SETS:
            rng = np.random.default_rng(0)
            seeds = [seeds[i] for i in sorted(rng.choice(len(seeds), MAX_SEED_SETS, replace=False))]
        return seeds
    rng = np.random.default_rng(0)
    drawn: dict = {}
    while len(drawn) < MAX_SEED_SETS:
        drawn.setdefault(tuple(sorted(rng.choice(len(cands), n, replace=False).tolist())), None)
    return [tuple(cands[i] for i in idx) for idx in sorted(drawn)]
