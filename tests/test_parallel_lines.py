"""Functions of independent lines computed on chunks of the lines on the cores (``jointid.parallel.map_lines``).

* ``map_lines`` joins what a per-line function returns on each chunk into what it returns on every
  line, runs the chunks on more than one thread, and calls the function once where chunking does not
  pay (few lines, or inside another ``map_lines``);
* the per-line kernels of the receptance path (the design, the column split, the calibration's sums,
  the model check's residual) are functions of independent lines: computed in chunks they give what
  one call gives, within the rounding of one line's sums (a kernel that mixed lines -- a running
  mean, a neighbour -- would differ by O(1) at the chunk edges).
"""

from __future__ import annotations

import dataclasses
import gc
import os
import threading

import numpy as np
import pytest

from jointid import parallel
from jointid.benchmark import benchmark_study
from jointid.parallel import map_lines
from jointid.pipeline import free_model, simulate

EPS = np.finfo(float).eps
LINES = 5 * parallel.MIN_THREAD_LINES


def _stacks(F: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((F, 21, 3)) + 1j * rng.standard_normal((F, 21, 3))
    B = rng.standard_normal((F, 21, 4)) + 1j * rng.standard_normal((F, 21, 4))
    return A, B


def _kernel(A, B):
    """Per line: the QR of A, and Q^H B (sums of 21 products per value)."""
    Q, R = np.linalg.qr(A)
    return Q, R, np.conj(np.swapaxes(Q, 1, 2)) @ B


def _within_line_rounding(a: np.ndarray, b: np.ndarray, terms: int) -> bool:
    """``|a - b| <= 4 terms eps`` of each line's largest value: two orders of one line's sums of ``terms`` products."""
    scale = np.max(np.abs(b).reshape(b.shape[0], -1), axis=1).reshape((-1,) + (1,) * (b.ndim - 1))
    return bool(np.all(np.abs(a - b) <= 4 * terms * EPS * scale))


def test_chunks_joined_equal_one_call_one_chunk_per_worker_thread():
    A, B = _stacks(LINES)
    calls = []

    def fn(a, b):
        calls.append((a.shape[0], threading.get_ident()))
        return _kernel(a, b)

    got = map_lines(fn, A, B)
    ref = _kernel(A, B)
    assert [x.shape for x in got] == [x.shape for x in ref]
    for g, r in zip(got, ref):
        assert _within_line_rounding(g, r, 21 * 3)
    workers = parallel.worker_count(LINES // parallel.MIN_THREAD_LINES)
    assert len(calls) == workers and sum(n for n, _ in calls) == LINES
    if workers > 1:  # chunks of near-equal size, none on the calling thread (a thread pool may reuse one of its threads)
        assert max(n for n, _ in calls) - min(n for n, _ in calls) <= 1
        assert all(t != threading.get_ident() for _, t in calls)


def test_one_array_out_is_joined_too():
    A, _ = _stacks(LINES, seed=1)
    got = map_lines(lambda a: np.abs(a).sum(axis=1), A)
    assert got.shape == (LINES, 3)
    assert np.array_equal(got, np.abs(A).sum(axis=1)) or _within_line_rounding(got, np.abs(A).sum(axis=1), 21)


def test_few_lines_are_one_call_in_this_thread():
    A, B = _stacks(2 * parallel.MIN_THREAD_LINES - 1)
    seen = []
    map_lines(lambda a, b: seen.append((a, threading.get_ident())) or _kernel(a, b), A, B)
    assert len(seen) == 1 and seen[0][0] is A and seen[0][1] == threading.get_ident()


def test_an_input_without_the_lines_on_its_first_axis_is_refused_with_few_lines_as_with_many():
    for F in (10, LINES):
        A, B = _stacks(F)
        with pytest.raises(ValueError, match=rf"^map_lines: every input needs the {F} lines on its first axis, got shapes "):
            map_lines(_kernel, A, B[0])
        with pytest.raises(ValueError, match="lines on its first axis"):
            map_lines(_kernel, A, np.concatenate([B, B[:1]]))


def test_a_map_lines_inside_another_runs_in_its_chunk_thread():
    A, B = _stacks(LINES, seed=2)
    inner = []

    def outer(a, b):
        me = threading.get_ident()
        return map_lines(lambda x, y: inner.append((me, threading.get_ident(), x.shape[0])) or _kernel(x, y), a, b)

    map_lines(outer, A, B)
    assert len(inner) == parallel.worker_count(LINES // parallel.MIN_THREAD_LINES)
    assert all(me == it for me, it, _ in inner)
    assert sum(n for _, _, n in inner) == LINES


@pytest.fixture(scope="module")
def blocks():
    """The benchmark's free-model blocks and a noisy measured receptance on 2 500 lines (100-1000 Hz)."""
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0, step=0.36))
    test = simulate(st)
    rng = np.random.default_rng(4)
    frf = test.frf.to("receptance")
    H = frf.data * (1 + 0.003 * (rng.standard_normal(frf.shape) + 1j * rng.standard_normal(frf.shape)) / np.sqrt(2))
    from jointid.physics.free_model import as_free_model

    n = st.joint.joint_dofs
    Y = as_free_model(free_model(st)).receptance(frf.frequency, tuple(frf.responses) + tuple(n), tuple(n) + tuple(frf.references))
    m, k = len(frf.responses), len(n)
    return Y[:, :m, :k], Y[:, m:, k:], Y[:, :m, k:], H, (0.003 * np.abs(H)) ** 2


def _one_call(monkeypatch):
    monkeypatch.setattr(parallel, "worker_count", lambda tasks: 1)


def test_the_receptance_kernels_are_functions_of_independent_lines(blocks, monkeypatch):
    from jointid.methods.receptance.coupling_lines import _line_design
    from jointid.methods.receptance.column_calibration import _calibration_lines
    from jointid.methods.receptance.force_noise import _split_lines
    from jointid.methods.receptance.model_check import design_residual

    Ymn, Yne, Yme, H, var = blocks
    F, m, _ = Ymn.shape
    e = Yne.shape[2]
    terms = 4 * m * e  # the longest sum of one line's values (Q^H of m e rows, times e columns)

    def every(monkeypatch_one: bool):
        if monkeypatch_one:
            _one_call(monkeypatch)
        sw, cs, Q, R = _line_design(Ymn, Yne, var, True)
        change = Yme - H
        return ((sw, cs, Q, R) + map_lines(_split_lines, change, H, sw, Q) + map_lines(_calibration_lines, change, H, sw, Q)
                + (map_lines(design_residual, change, sw, Q),))

    monkeypatch.setattr(parallel, "worker_count", lambda tasks: 3)  # chunked on any machine (one core too)
    chunked = every(False)
    whole = every(True)
    for c, w in zip(chunked, whole):
        assert c.shape == w.shape
        assert _within_line_rounding(c, w, terms)


def _threads_here() -> int:
    return parallel.worker_count(100)


@pytest.mark.skipif(parallel.process_count(2) < 2, reason="needs fork and two cores")
def test_worker_processes_use_one_thread_each():
    """Inside the processes of ``map_processes`` (their siblings have the other cores) line chunks stay in one thread."""
    assert _threads_here() == min(len(os.sched_getaffinity(0)), 4)
    assert parallel.map_processes([(_threads_here, ())] * 2, workers=2) == [1, 1]


class _Finalized:
    """Garbage in a reference cycle whose finalizer records the process that ran it."""

    def __init__(self, path):
        self.path, self.me = path, self

    def __del__(self):
        with open(self.path, "a") as f:
            f.write(f"{os.getpid()}\n")


def _collect_and_report() -> int:
    gc.collect()
    return os.getpid()


def test_pool_workers_do_not_finalize_the_parents_garbage(tmp_path):
    """A forked worker's collection ran the finalizer of an unclosed dask Client inherited from the parent, which
    waited 40 s for an event-loop thread the worker does not have: the workers leave the parent's garbage alone."""
    path = tmp_path / "finalized.txt"
    gc.disable()  # the cycle stays uncollected in this process until the workers have run
    try:
        _Finalized(path)
        workers = parallel.map_processes([(_collect_and_report, ())] * 4, 2)
    finally:
        gc.enable()
    assert not path.exists() and len(workers) == 4  # no worker ran it (collections off here: nor did this process)
    gc.collect()  # here it is collected, once
    assert path.read_text().split() == [str(os.getpid())]
