"""The design's search on forked workers gives exactly the sequential result, and reports each step."""

from __future__ import annotations

import dataclasses

import numpy as np

import jointid.methods.design.layout as design_module
from jointid.benchmark import benchmark_study
from jointid.design import design_study
from jointid.methods.design.pool import LayoutPool, pool_workers


def _square(x, y):
    return x * x + y


def test_pool_maps_in_order_on_workers_and_in_process():
    items = [(k, 1) for k in range(11)]
    with LayoutPool(_square, 2) as pool:
        assert pool.map(items) == [k * k + 1 for k in range(11)] and pool.map([]) == []
    with LayoutPool(_square, 1) as pool:
        assert pool.map(items) == [k * k + 1 for k in range(11)]
    assert pool_workers(1) == 1


def test_search_on_two_workers_equals_the_sequential_search(monkeypatch):
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, step=50.0))
    runs = {}
    for workers in (1, 2):
        monkeypatch.setattr(design_module, "pool_workers", lambda tasks, k=workers: min(k, tasks))
        lines = []
        runs[workers] = (design_study(st, 3, 2, candidates=range(1, 20, 3), search_lines=12, progress=lines.append), lines)
    (a, steps), (b, _) = runs[1], runs[2]
    assert (a.observed, a.excited, a.evaluations, a.history, a.ranked) == (b.observed, b.excited, b.evaluations, b.history, b.ranked)
    assert np.array_equal(a.relative_std, b.relative_std) and a.criterion == b.criterion
    # one progress line per step of the search, in the order of the history
    assert [line.partition(":")[0] for line in steps] == [s for s, _ in a.history]
    assert all("layouts evaluated, criterion" in line and line.endswith(" s") for line in steps)
    assert a.history[-1][0] == "re-rank"
