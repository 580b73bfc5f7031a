"""The fast paths of ``jointid identify`` give what the plain paths give (issue 24 item 6).

* the figure worker (a forked process) returns the PNG bytes this process draws, raises what it
  raised, passes its warnings back, and ends when closed; the FRF file it reads first is the one this
  process reads, and when that read fails (or the worker is lost) this process reads the file itself;
* the column calibration's banded sums and its covariance formed from factors equal the dense
  sums and ``G G^H`` within their rounding bounds;
* the per-line design built from the parameter pairs equals ``kron(...) @ P`` within its rounding bound;
* the structured model's Jacobian written in place equals the one built from its factors.
"""

from __future__ import annotations

import dataclasses
import os
import warnings

import numpy as np
import pytest

from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.pipeline import free_model, identify, simulate

EPS = np.finfo(float).eps
posix_only = pytest.mark.skipif(not hasattr(os, "fork"), reason="the figure worker forks (POSIX)")


@pytest.fixture(scope="module")
def case():
    """A noisy virtual test of the benchmark (300 lines), its identification and the free-model blocks."""
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0, step=3.0))
    test = simulate(st)
    rng = np.random.default_rng(3)
    d = test.frf.data * (1 + 0.003 * (rng.standard_normal(test.frf.shape) + 1j * rng.standard_normal(test.frf.shape)) / np.sqrt(2))
    measured = FRF(test.frf.frequency, d, test.frf.responses, test.frf.references, test.frf.kind)
    return st, measured, identify(st, measured)


@posix_only
@pytest.mark.parametrize("prepare", [None, ("joint_stiffness", (2,))])
def test_the_worker_draws_the_png_this_process_draws(case, prepare):
    """Also with the figure made ahead (``prepare``: the joint's 2 DOFs)."""
    from jointid.plots.figure_worker import FigureWorker
    from jointid.plots.stiffness_data import JointStiffnessData
    from jointid.io.png import figure_png

    _, _, result = case
    here = figure_png(result.plot())
    with FigureWorker.start(prepare=prepare) as worker:
        pending = worker.submit("joint_stiffness", JointStiffnessData.of(result))
        assert pending.result() == here
        assert pending.result() == here  # kept
    assert worker.pid == -1  # reaped


def test_a_figure_made_ahead_is_drawn_into_and_gives_the_same_png(case):
    """The joint stiffness figure drawn into the empty figure made ahead is that figure, with the PNG of the figure
    made at once; an empty figure of another size is not used."""
    from jointid.io.png import figure_png
    from jointid.plots.joint_stiffness import joint_stiffness_figure, plot_joint_stiffness

    _, _, result = case
    here = figure_png(plot_joint_stiffness(result))
    ahead = joint_stiffness_figure(2)
    fig = plot_joint_stiffness(result, prepared=ahead)
    assert fig is ahead[0] and figure_png(fig) == here
    other = joint_stiffness_figure(3)
    assert plot_joint_stiffness(result, prepared=other) is not other[0]


@posix_only
def test_a_worker_error_is_raised_here_and_its_warnings_come_back():
    from jointid.plots import figure_worker
    from jointid.plots.figure_worker import FigureWorker

    figure_worker.FIGURES["_test_warns"] = ("warnings", "warn")  # warnings.warn(data) -> None: a warning, then an error
    try:
        with FigureWorker.start() as worker:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                with pytest.raises(AttributeError):  # None.savefig in figure_png
                    worker.submit("_test_warns", "a warning from the worker").result()
            assert any("a warning from the worker" in str(w.message) for w in caught)
    finally:
        del figure_worker.FIGURES["_test_warns"]


@posix_only
def test_an_unused_worker_is_ended_at_once():
    import time

    from jointid.plots.figure_worker import FigureWorker

    worker = FigureWorker.start()
    pid = worker.pid
    t = time.perf_counter()
    worker.close()
    assert time.perf_counter() - t < 5.0  # terminated, not left to finish importing matplotlib
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)  # reaped


@posix_only
def test_the_worker_yields_the_cores_once_its_first_task_is_done():
    """After the first task (the FRF file), the worker lowers its priority by WORKER_NICE: its imports and drawing
    give way to this process's threads."""
    import time

    from jointid.plots.figure_worker import WORKER_NICE, FigureWorker

    own = os.getpriority(os.PRIO_PROCESS, 0)
    with FigureWorker.start(first=lambda: 42) as worker:
        assert worker.first() == 42  # sent before the worker lowers its priority
        deadline = time.monotonic() + 10.0
        while os.getpriority(os.PRIO_PROCESS, worker.pid) == own and time.monotonic() < deadline:
            time.sleep(0.01)
        assert os.getpriority(os.PRIO_PROCESS, worker.pid) == min(own + WORKER_NICE, 19)


def test_no_worker_when_switched_off(monkeypatch):
    from jointid.plots.figure_worker import FigureWorker

    monkeypatch.setenv("JOINTID_FIGURE_WORKER", "0")
    assert FigureWorker.start() is None


@posix_only
def test_identify_writes_the_same_files_with_and_without_the_worker(case, tmp_path, monkeypatch):
    """The whole command: CSV and PNG byte for byte the same whether the figure is drawn here, in the worker, or here
    after the worker was lost."""
    from jointid.cli.main import main
    from jointid.io.uff import write_uff_frf

    st, measured, _ = case
    uff = tmp_path / "frf.uff"
    write_uff_frf(uff, measured, kind="receptance")
    study = tmp_path / "study.toml"
    text = open(st.source).read() if st.source and os.path.exists(st.source) else None
    if text is None:
        pytest.skip("the benchmark study has no file")
    study.write_text(text)
    import signal

    from jointid.plots.figure_worker import FigureWorker

    start = FigureWorker.start

    def lost(**kwargs):  # a worker killed at once: the command reads the file and draws the figure itself
        worker = start(**kwargs)
        os.kill(worker.pid, signal.SIGKILL)
        return worker

    outs = {}
    for flag in ("0", "1", "lost"):
        monkeypatch.setenv("JOINTID_FIGURE_WORKER", "0" if flag == "0" else "1")
        if flag == "lost":
            monkeypatch.setattr(FigureWorker, "start", staticmethod(lost))
        assert main(["identify", str(study), "--frf", str(uff), "--out", str(tmp_path / flag)]) == 0
        outs[flag] = {name: (tmp_path / flag / name).read_bytes() for name in ("joint_stiffness.csv", "joint_stiffness.png")}
    assert outs["0"] == outs["1"] == outs["lost"]


def _blocks(case):
    st, measured, _ = case
    from jointid.physics.free_model import as_free_model

    frf = measured.to("receptance")
    n_dofs = st.joint.joint_dofs
    Y = as_free_model(free_model(st)).receptance(frf.frequency, tuple(frf.responses) + tuple(n_dofs), tuple(n_dofs) + tuple(frf.references))
    m, k = len(frf.responses), len(n_dofs)
    return frf.frequency.hz, Y[:, :m, :k], Y[:, m:, k:], Y[:, :m, k:], frf.data  # Ymn, Yne, Yme, H


def test_banded_gram_sums_equal_the_dense_sums(case):
    """``sum_f v[f,k] B[f,b] B[f,c]``: the sparse pair products add the same terms in another order (F eps of the term sum)."""
    from jointid.methods.receptance.column_calibration import _gram, _pair_products
    from jointid.methods.receptance.smoothing import bspline_basis

    hz = _blocks(case)[0]
    rng = np.random.default_rng(0)
    v = rng.standard_normal((hz.size, 5)) + 1j * rng.standard_normal((hz.size, 5))
    Bs = bspline_basis(hz, 16)
    B = Bs.toarray()
    ref = np.einsum("fk,fb,fc->bkc", v, B, B)
    mag = np.einsum("fk,fb,fc->bkc", np.abs(v), np.abs(B), np.abs(B))
    got = _gram(_pair_products(Bs), v, 16)
    assert np.all(np.abs(got - ref) <= 2 * hz.size * EPS * mag + 1e-300)


def test_calibration_covariance_from_factors_equals_the_factor_products(case):
    """``x_covariance`` (``U_f M_f U_f^H``, no (F, p, e nb) array) equals ``x_factor x_factor^H`` within the rounding of
    the two sums of e nb terms: ``4 e nb eps |G_f|^2`` per line."""
    from jointid.methods.receptance.column_calibration import estimate_column_calibration

    hz, Ymn, Yne, Yme, H = _blocks(case)
    var = (0.003 * np.abs(H)) ** 2
    cal = estimate_column_calibration(hz, Ymn, Yne, Yme - H, H, var)
    G = cal.x_factor
    ref = G @ np.conj(np.swapaxes(G, 1, 2))
    norm2 = np.sum(np.abs(G) ** 2, axis=2)  # |G_f row|^2
    bound = 4 * G.shape[2] * EPS * np.sqrt(norm2[:, :, None] * norm2[:, None, :])
    assert np.all(np.abs(cal.x_covariance - ref) <= bound)
    assert G.shape == (hz.size, 3, 3 * cal.n_basis)


def test_line_design_equals_the_kronecker_product_with_the_duplication_matrix(case):
    """``Q R`` reproduces the equilibrated design ``kron(Y[n,e]^T, Y[m,n]) P`` weighted, within ``10 m e eps`` of each column."""
    from jointid.methods.receptance.coupling_lines import symmetric_parametrization, whitened_line_design

    _, Ymn, Yne, _, H = _blocks(case)
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    var = (0.003 * np.abs(H)) ** 2
    for symmetric in (True, False):
        P = symmetric_parametrization(n, symmetric)
        A = np.einsum("fkc,fri->frcik", Yne, Ymn).reshape(F, m * e, n * n) @ P
        Aw = A / np.sqrt(var.reshape(F, m * e))[:, :, None]
        sw, cs, Q, R = whitened_line_design(Ymn, Yne, var, symmetric)
        ref_cs = np.linalg.norm(Aw, axis=1)
        assert np.all(np.abs(cs - ref_cs) <= 4 * m * e * EPS * ref_cs)
        assert np.all(np.abs(Q @ R - Aw / cs[:, None, :]) <= 10 * m * e * EPS)  # columns of unit norm


def test_structured_jacobian_equals_its_factors():
    """``dDu'/dtheta`` written in place: ``jc[k] jm[k]`` per parameter, ``b_j dg`` and ``i b_j dg`` for the spline of g."""
    from jointid.methods.receptance.structured_model import StructuredModel, structured_stiffness, structured_terms

    model = StructuredModel(2, 2, 4, True, (300.0, 5.0), 1000.0, (5.0, 1000.0))
    rng = np.random.default_rng(1)
    theta = rng.standard_normal(model.n_params)
    hz = np.linspace(5.0, 1000.0, 257)
    D, J = structured_stiffness(theta, hz, model, jacobian=True)
    _, _, (jc, jm, dg, Gd) = structured_terms(theta, hz, model, jacobian=True)
    nl = jc.shape[0]
    ref_l = jc.T[:, None, None, :] * np.moveaxis(jm, 0, -1)[None]
    ref_g = dg[..., None] * Gd[:, None, None, :]
    assert J.shape == (hz.size, 2, 2, model.n_params)
    tol = 2 * EPS  # one rounding per product
    assert np.all(np.abs(J[..., :nl] - ref_l) <= tol * np.abs(ref_l))
    assert np.all(np.abs(J[..., nl::2] - ref_g) <= tol * np.abs(ref_g))
    assert np.all(np.abs(J[..., nl + 1::2] - 1j * ref_g) <= tol * np.abs(ref_g))
    # the same function without the Jacobian: the same sum of K products, so equal within its rounding bound
    # K eps sum_k |coef_k| |mat_k| (whatever order a BLAS kernel sums them in)
    coefs, mats, _ = structured_terms(theta, hz, model)
    K = len(mats)
    bound = K * EPS * (np.abs(coefs).T @ np.abs(mats).reshape(K, -1)).reshape(D.shape)
    assert np.all(np.abs(D - structured_stiffness(theta, hz, model)) <= bound)


def test_a_design_is_reused_only_for_the_same_blocks_and_a_variance_within_its_rounding(case):
    """The kept design comes back for a variance 1 ulp away (weights within 2 eps: the rounding of 1/sqrt itself),
    read-only; another variance, other blocks or the other parametrization compute a new one."""
    from jointid.methods.receptance.coupling_lines import DESIGN_VARIANCE_RTOL, _line_design, whitened_line_design

    _, Ymn, Yne, _, H = _blocks(case)
    var = (0.003 * np.abs(H)) ** 2
    first = whitened_line_design(Ymn, Yne, var)
    near = var * (1 + 2 * EPS)
    again = whitened_line_design(Ymn.copy(), Yne.copy(), near)
    assert all(a is b for a, b in zip(first, again)) and not first[2].flags.writeable
    fresh = _line_design(Ymn, Yne, near, True)
    assert np.all(np.abs(again[0] - fresh[0]) <= (DESIGN_VARIANCE_RTOL / 2 + 2 * EPS) * fresh[0])  # sw = 1/sqrt(var)
    assert whitened_line_design(Ymn, Yne, var * 1.001)[0] is not first[0]
    assert whitened_line_design(Ymn, Yne, var, False)[2].shape[2] == 4
    Y2 = Ymn.copy()
    Y2[0, 0, 0] *= 1 + 4 * EPS
    assert whitened_line_design(Y2, Yne, var)[2] is not first[2]


def test_a_subset_design_not_kept_leaves_the_whole_one(case):
    """The noise-model choice asks for designs of a subset of the lines between the junk-line test and the
    calibration with ``keep=False``: the whole design stays kept for the calibration."""
    from jointid.methods.receptance.coupling_lines import whitened_line_design

    _, Ymn, Yne, _, H = _blocks(case)
    var = (0.003 * np.abs(H)) ** 2
    whole = whitened_line_design(Ymn, Yne, var)
    sub = slice(0, 40)
    for scale in (1.0, 2.0):  # as the relative and the floor noise model ask for
        whitened_line_design(Ymn[sub], Yne[sub], scale * var[sub], keep=False)
    assert whitened_line_design(Ymn, Yne, var)[2] is whole[2]
    whitened_line_design(Ymn[sub], Yne[sub], var[sub])  # kept (the default): replaces it
    assert whitened_line_design(Ymn, Yne, var)[2] is not whole[2]


@posix_only
def test_a_lost_worker_is_reported_as_such():
    """A worker that ends without an answer raises WorkerLost (the command then draws the figure itself)."""
    import signal

    from jointid.plots.figure_worker import FigureWorker, WorkerLost

    with FigureWorker.start() as worker:
        os.kill(worker.pid, signal.SIGKILL)
        with pytest.raises(WorkerLost):
            worker.submit("joint_stiffness", None).result()


def test_a_signal_handler_of_the_caller_never_runs_the_caller_twice(tmp_path, monkeypatch):
    """A test runner or dask may install a Python SIGTERM handler that raises. A SIGTERM reaching the child before it is
    inside the block that ends in os._exit (here: sent by the child itself the moment the fork returns) must not make
    the child return into the caller's code -- it did: a second copy of the test run, and a parent waiting for it
    forever. Every marker is written by this process alone, and close() returns."""
    import signal
    import time

    from jointid.plots.figure_worker import FigureWorker

    def raising(signum, frame):
        raise KeyboardInterrupt

    real_fork = os.fork

    def fork_then_signal():
        pid = real_fork()
        if pid == 0:  # the child, before start() sees the pid: a signal now
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)
        return pid

    parent = os.getpid()
    monkeypatch.setattr(os, "fork", fork_then_signal)
    old = signal.signal(signal.SIGTERM, raising)
    try:
        for i in range(3):
            try:
                worker = FigureWorker.start()
            except KeyboardInterrupt:  # the child escaped start(): leave the evidence, never run on
                (tmp_path / f"escaped-{os.getpid()}").touch()
                os._exit(0)
            (tmp_path / f"{os.getpid()}-{i}").touch()
            if worker is not None:
                worker.close()
    finally:
        signal.signal(signal.SIGTERM, old)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{parent}-{i}" for i in range(3))


def _same_frf(a, b) -> None:
    """Every field of two FRFs equal, arrays bit for bit and read-only alike."""
    assert a.frequency.hz.tobytes() == b.frequency.hz.tobytes()
    assert a.data.tobytes() == b.data.tobytes() and a.data.dtype == b.data.dtype and a.data.shape == b.data.shape
    assert (a.coherence is None) == (b.coherence is None)
    if a.coherence is not None:
        assert a.coherence.tobytes() == b.coherence.tobytes() and not b.coherence.flags.writeable
    assert (a.responses, a.references, a.kind, a.notes) == (b.responses, b.references, b.kind, b.notes)
    assert not b.data.flags.writeable and not b.frequency.hz.flags.writeable


@posix_only
@pytest.mark.parametrize("with_coherence", [False, True])
def test_the_file_the_worker_reads_first_is_the_file_read_here(case, tmp_path, with_coherence):
    """FigureWorker.start(first=read_study_frf): the FRF the worker sends back equals the one read here (data,
    coherence, labels, notes); the worker still draws the figure afterwards."""
    import functools

    from jointid.io.uff import write_uff_frf
    from jointid.pipeline import read_measured
    from jointid.plots.figure_worker import FigureWorker
    from jointid.plots.stiffness_data import JointStiffnessData
    from jointid.io.png import figure_png
    from jointid.study.measured import read_study_frf

    st, measured, result = case
    uff = tmp_path / "frf.uff"
    extra = FRF(measured.frequency, np.concatenate([measured.data, measured.data[:, :1]], axis=1),
                tuple(measured.responses) + ("2w",), measured.references, measured.kind)  # a DOF the study does not use
    coherence = np.full(extra.shape, 0.97) if with_coherence else None
    write_uff_frf(uff, extra, kind="accelerance", coherence=coherence)
    here = read_measured(st, uff)
    assert here.notes  # the records skipped
    with FigureWorker.start(first=functools.partial(read_study_frf, st, uff)) as worker:
        there = worker.first()
        assert there is not None
        _same_frf(here, there)
        _same_frf(here, read_measured(st, uff, preread=there))
        assert worker.first() is there  # asked again: the same answer
        assert worker.submit("joint_stiffness", JointStiffnessData.of(result)).result() == figure_png(result.plot())


@posix_only
def test_a_first_task_that_fails_or_warns_gives_no_result():
    """An exception or a warning of the first task, a result that does not pickle, a lost worker: None (the caller
    then runs the task itself, so its errors and warnings are its own); a worker without a first task: None."""
    import signal
    import threading

    from jointid.plots.figure_worker import FigureWorker

    def raises():
        raise ValueError("bad file")

    def warns():
        warnings.warn("odd file")
        return 1

    for task in (raises, warns, lambda: threading.Lock()):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with FigureWorker.start(first=task) as worker:
                assert worker.first() is None
        assert not caught  # nothing of the worker's is raised or warned here
    with FigureWorker.start(first=lambda: 42) as worker:
        assert worker.first() == 42
    with FigureWorker.start() as worker:
        assert worker.first() is None
    with FigureWorker.start(first=lambda: __import__("time").sleep(60)) as worker:
        os.kill(worker.pid, signal.SIGKILL)
        assert worker.first() is None


@posix_only
def test_a_worker_that_hangs_on_its_first_task_is_ended(monkeypatch):
    """No answer within FIRST_SECONDS: the worker is ended, the caller reads here and draws here (WorkerLost)."""
    import time

    from jointid.plots import figure_worker
    from jointid.plots.figure_worker import FigureWorker, WorkerLost

    monkeypatch.setattr(figure_worker, "FIRST_SECONDS", 0.2)
    t = time.perf_counter()
    with FigureWorker.start(first=lambda: time.sleep(60)) as worker:
        assert worker.first() is None
        with pytest.raises(WorkerLost):
            worker.submit("joint_stiffness", None).result()
    assert time.perf_counter() - t < 10.0


@posix_only
def test_identify_with_a_bad_file_says_the_same_with_and_without_the_worker(tmp_path, monkeypatch, capsys):
    """A file the worker cannot read: the command reads it itself and stops with the same one line and exit 2."""
    from jointid.cli.main import main
    from jointid.benchmark import benchmark_study_path

    study = tmp_path / "study.toml"
    study.write_text(open(benchmark_study_path()).read())
    bad = tmp_path / "frf.uff"
    bad.write_text("    -1\n    58\nnot a record\n    -1\n")
    said = {}
    for flag in ("0", "1"):
        monkeypatch.setenv("JOINTID_FIGURE_WORKER", flag)
        code = main(["identify", str(study), "--frf", str(bad), "--out", str(tmp_path / f"out{flag}")])
        out, err = capsys.readouterr()
        said[flag] = (code, out, err)
    assert said["0"] == said["1"]
    assert said["0"][0] == 2 and len(said["0"][2].strip().splitlines()) == 1 and str(bad) in said["0"][2]


def test_the_png_level_changes_the_bytes_not_the_pixels(case):
    """figure_png writes at PNG_COMPRESS_LEVEL (faster than PIL's default 6): the same pixels and metadata as the default."""
    import io

    from PIL import Image

    from jointid.io.png import PNG_COMPRESS_LEVEL, figure_png

    _, _, result = case
    fig = result.plot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    ours, default = Image.open(io.BytesIO(figure_png(fig))), Image.open(buf)
    assert PNG_COMPRESS_LEVEL < 6
    assert ours.size == default.size and ours.mode == default.mode and ours.info == default.info
    assert np.array_equal(np.asarray(ours), np.asarray(default))


def test_residual_statistics_are_reused_for_the_same_inputs_and_a_variance_within_its_rounding(case):
    """The junk-line test's statistics come back to the model check (the same blocks and residual, a variance 1 ulp
    away), read-only, equal to its own computation; another residual or variance computes new ones."""
    from jointid.methods.receptance import model_check
    from jointid.methods.receptance.model_check import residual_statistics

    _, Ymn, Yne, Yme, H = _blocks(case)
    var = (0.003 * np.abs(H)) ** 2
    first = residual_statistics(Ymn, Yne, Yme - H, var)
    again = residual_statistics(Ymn.copy(), Yne.copy(), Yme - H, var * (1 + 2 * EPS))
    assert again is first and not first.chi2.flags.writeable and not first.noise.flags.writeable
    fresh = model_check._statistics(Ymn, Yne, Yme - H, var * (1 + 2 * EPS), True)
    assert np.allclose(fresh.chi2, first.chi2, rtol=1e-12, atol=0) and np.allclose(fresh.lag_correlation, first.lag_correlation, rtol=1e-9)
    other = residual_statistics(Ymn, Yne, Yme - 1.001 * H, var)
    assert other is not first
    assert residual_statistics(Ymn, Yne, Yme - 1.001 * H, var * 1.001) is not other


def test_identify_computes_the_residual_statistics_once_when_no_line_is_left_out(case, monkeypatch):
    """No junk line and no column correction: the junk-line test and the model check share one computation, and the
    identification is the one computed with both."""
    from jointid.methods.receptance import model_check

    st, measured, result = case
    calls = []
    real = model_check._statistics

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(model_check, "_statistics", counted)
    model_check._LAST_STATISTICS.entry = None
    again = identify(st, measured)
    assert not any("junk" in f or "calibration" in f for f in again.findings())
    assert len(calls) == 1
    assert np.array_equal(again.stiffness, result.stiffness) and np.array_equal(again.reliable_terms, result.reliable_terms)
