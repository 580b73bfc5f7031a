"""Figures drawn in a second process while the first one computes (a forked worker, POSIX only).

``jointid identify`` spends about half a second importing matplotlib and as much again drawing
and encoding ``joint_stiffness.png``; neither depends on the identification until its result is
there. :class:`FigureWorker` forks at the start of a command: the child imports matplotlib and
the figure modules while the parent reads the FRFs and identifies, then draws the figures the
parent sends (plain data: :class:`~jointid.plots.joint_stiffness.JointStiffnessData`) and returns
PNG bytes, while the parent writes its CSV and summary. The same function draws the same figure
as in the parent (:func:`render`): the PNG bytes are those the parent would have made.

The worker can also run one task before it imports matplotlib (``first``): ``jointid identify`` has
it read and parse the FRF file while the parent imports the estimators, and takes the FRF it sends
back (:meth:`FigureWorker.first`); when that task fails (an exception, a warning, the worker lost) the
parent is told nothing but "no result" and does the task itself, so its errors, warnings and
messages are the parent's own, as without the worker.

The worker runs at a lower priority (:data:`WORKER_NICE`) once the ``first`` task is done: its
matplotlib import then yields to the parent's threads, which do the identification's per-line algebra on
every core (on 2 cores: the identification of 19 901 lines 1.83 s instead of 2.14 s, the whole
``jointid identify`` 0.22 s shorter, medians of 12 interleaved runs). After the identification the parent
has one thread left and the worker a core of its own.

The CPU time is the same, the wall time shorter on a machine with a core to spare. Without
``os.fork`` (Windows), or when the fork fails, :meth:`FigureWorker.start` returns None and the
caller draws in its own process. Python warnings the child raises while drawing are sent back
and raised again in the parent (the CLI summarizes a run's warnings); an exception in the child is
raised in the parent by :meth:`PendingFigure.result`. The child ignores SIGINT (the parent handles
an interrupt) and exits when the parent closes the pipe or dies.
"""

from __future__ import annotations

import gc
import os
import pickle
import select
import signal
import struct
import threading
import traceback
import warnings
from typing import Any, Callable

__all__ = ["FigureWorker", "PendingFigure", "WorkerLost", "render", "FIGURES", "PREPARE", "WORKER_NICE"]

#: Figure name -> (module, function) of the drawing functions the worker runs: ``f(data, **kwargs) -> Figure``.
FIGURES = {
    "joint_stiffness": ("jointid.plots.joint_stiffness", "plot_joint_stiffness"),
}

#: Figure name -> (module, function) making the empty figure ahead (``f(*args) -> (fig, axes)``), drawn into later
#: with ``prepared=(fig, axes)`` (:meth:`FigureWorker.start`'s ``prepare``).
PREPARE = {
    "joint_stiffness": ("jointid.plots.joint_stiffness", "joint_stiffness_figure"),
}

_HEADER = struct.Struct("<Q")


class WorkerLost(RuntimeError):
    """The worker process ended (or could not be reached) before it returned the figure: draw it here instead."""


def render(kind: str, data, kwargs: dict, dpi: int = 120) -> bytes:
    """Draw figure ``kind`` of :data:`FIGURES` from ``data`` and return it as PNG bytes (in any process)."""
    from importlib import import_module

    from ..io.png import figure_png

    module, name = FIGURES[kind]
    fig = getattr(import_module(module), name)(data, **kwargs)
    return figure_png(fig, dpi=dpi)


def _send(fd: int, obj) -> None:
    blob = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(blob)) + blob)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def _recv(fd: int):
    """The next object on ``fd``, or None at end of file."""
    head = _read_exactly(fd, _HEADER.size)
    if head is None:
        return None
    body = _read_exactly(fd, _HEADER.unpack(head)[0])
    if body is None:
        return None
    return pickle.loads(body)


def _read_exactly(fd: int, size: int) -> bytes | None:
    chunks, left = [], size
    while left:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


#: Niceness the worker adds to its own once the ``first`` task is done (module docstring; 0: none).
WORKER_NICE = 10

#: Seconds a figure may take in the worker before the caller draws it itself.
RESULT_SECONDS = 120.0
#: Seconds the caller waits for the ``first`` task's result (:meth:`FigureWorker.first`) before it ends the worker
#: and does the task itself.
FIRST_SECONDS = 120.0
#: Seconds close() waits for the worker to exit before it kills it (it exits at once when its pipe closes).
REAP_SECONDS = 10.0


def _reap(pid: int) -> None:
    """Wait for the worker ``pid`` to exit, at most :data:`REAP_SECONDS`, then kill it: closing never hangs."""
    import time

    deadline = time.monotonic() + REAP_SECONDS
    while True:
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            return
        if done:
            return
        if time.monotonic() > deadline:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
            return
        time.sleep(0.005)


def _run_first(first: Callable[[], Any]) -> tuple:
    """``("ok", first())``, or ``("failed",)`` when it raised or warned (the parent then runs it itself: its own
    exception, warnings and messages, as without the worker)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = first()
        except BaseException:  # noqa: BLE001 - the parent runs the task again and sees it itself
            return ("failed",)
    return ("failed",) if caught else ("ok", value)


def _child(requests: int, replies: int, first: Callable[[], Any] | None = None, prepare: tuple | None = None) -> None:
    """The worker's loop: run ``first`` and send its result (if given), import the figure modules, make the
    ``prepare`` figure ahead (if given), then draw each request until end of file."""
    if first is not None:
        reply = _run_first(first)
        try:
            _send(replies, reply)
        except (pickle.PicklingError, TypeError, AttributeError):  # a result that does not pickle: the parent runs it
            _send(replies, ("failed",))
    if WORKER_NICE:
        try:  # the imports and the drawing yield to the parent's threads (module docstring)
            os.nice(WORKER_NICE)
        except OSError:
            pass
    try:
        from importlib import import_module

        import matplotlib.backends.backend_agg  # noqa: F401  (what savefig uses: imported while the parent computes)

        for module, _ in FIGURES.values():
            import_module(module)
    except Exception:  # pragma: no cover - the request below reports it
        pass
    ready = {}  # figure name -> the empty figure made ahead, used by the first request of that figure
    if prepare is not None:
        try:
            module, name = PREPARE[prepare[0]]
            ready[prepare[0]] = getattr(import_module(module), name)(*prepare[1])
        except Exception:  # noqa: BLE001 - nothing made ahead: the request makes its figure
            pass
    while True:
        request = _recv(requests)
        if request is None:
            return
        kind, data, kwargs = request
        if kind in ready:
            kwargs = {**kwargs, "prepared": ready.pop(kind)}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                reply = ("ok", render(kind, data, kwargs))
            except BaseException as exc:  # noqa: BLE001 - sent to the parent, raised there
                reply = ("error", exc, traceback.format_exc())
        notes = [(str(w.message), w.category, w.filename, w.lineno) for w in caught]
        try:
            _send(replies, reply + (notes,))
        except (pickle.PicklingError, TypeError, AttributeError):  # an exception that does not pickle
            _send(replies, ("error", RuntimeError(reply[-1] if reply[0] == "error" else "figure worker failed"), "", notes))


class PendingFigure:
    """A figure being drawn by the worker; :meth:`result` waits for its PNG bytes."""

    def __init__(self, worker: "FigureWorker", sender: threading.Thread):
        self._worker = worker
        self._sender = sender
        self._png: bytes | None = None

    def result(self) -> bytes:
        """The PNG bytes (waits for the worker); raises what the worker raised, and re-raises its warnings here.

        Raises
        ------
        WorkerLost
            The worker ended without an answer (killed, crashed): the caller draws the figure itself.
        """
        if self._png is None:
            self._sender.join()
            self._worker._first_done()  # the first task's reply comes before the figures' on the same pipe
            if self._worker._send_error is not None:
                raise WorkerLost("the figure worker stopped") from self._worker._send_error
            try:
                ready, _, _ = select.select([self._worker._replies], [], [], RESULT_SECONDS)
                if not ready:  # a worker that hangs (a lock held at the fork): draw here instead
                    raise WorkerLost(f"the figure worker gave no answer in {RESULT_SECONDS:g} s")
                reply = _recv(self._worker._replies)
            except OSError as exc:
                raise WorkerLost("the figure worker could not be read") from exc
            if reply is None:
                raise WorkerLost("the figure worker stopped before returning the figure")
            for message, category, filename, lineno in reply[-1]:
                warnings.warn_explicit(message, category, filename, lineno)
            if reply[0] != "ok":
                raise reply[1]
            self._png = reply[1]
        return self._png


class FigureWorker:
    """A forked child process that imports matplotlib at once and draws figures on request (module docstring).

    Use :meth:`start` (None where it cannot fork) as a context manager; requests are answered in order.
    """

    def __init__(self, pid: int, requests: int, replies: int, first: bool = False):
        self.pid = pid
        self._requests = requests
        self._replies = replies
        self._send_error: BaseException | None = None
        self._pending: list[PendingFigure] = []
        self._first_reply: tuple | None = None
        self._first_reader: threading.Thread | None = None
        if first:  # read at once by a thread: the worker goes on to its imports without waiting for this process
            self._first_reader = threading.Thread(target=self._read_first, name="jointid-worker-first", daemon=True)
            self._first_reader.start()

    def _read_first(self) -> None:
        try:
            self._first_reply = _recv(self._replies)
        except Exception:  # noqa: BLE001 - unreadable or not unpickled here: no result, the caller runs the task
            self._first_reply = None

    def _first_done(self, timeout: float | None = None) -> bool:
        """Wait for the first task's reply to be read (at most ``timeout`` s); False when it is still being waited for."""
        if self._first_reader is None:
            return True
        self._first_reader.join(timeout)
        return not self._first_reader.is_alive()

    def first(self) -> Any:
        """What the ``first`` task given to :meth:`start` returned in the worker, or None: there was no such task, it
        raised or warned, its result did not pickle, or the worker ended or gave no answer in :data:`FIRST_SECONDS`
        (the worker is then ended: its figures are drawn here). The caller then runs the task itself."""
        if self._first_reader is None:
            return None
        if not self._first_done(FIRST_SECONDS):  # a worker that hangs: end it (the reader then sees end of file)
            self._terminate()
            self._first_done()
        reply = self._first_reply
        return reply[1] if reply is not None and reply[0] == "ok" else None

    def _terminate(self) -> None:
        try:
            os.kill(self.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass

    @classmethod
    def start(cls, first: Callable[[], Any] | None = None, prepare: tuple | None = None) -> "FigureWorker | None":
        """Fork the worker (it starts importing matplotlib); None without ``os.fork`` or when the fork fails.

        ``first``: a task the worker runs before its imports (e.g. reading a file); :meth:`first` gives its result.
        It runs in the forked copy of this process: it may use anything this process holds, and what it returns must
        pickle. ``prepare``: ``(figure name, args)`` of :data:`PREPARE`: that empty figure is made after the imports,
        while this process computes, and the first request of that figure draws into it (the same PNG bytes; one
        that does not fit the request, e.g. another number of terms, is not used).
        """
        if not hasattr(os, "fork") or os.environ.get("JOINTID_FIGURE_WORKER", "1") == "0":
            return None
        try:
            req_r, req_w = os.pipe()
            rep_r, rep_w = os.pipe()
        except OSError:
            return None
        # SIGINT/SIGTERM blocked across the fork: a Python-level handler the caller installed (a test runner's,
        # dask's) must not run in the child before it is inside the block that always ends in os._exit -- an
        # exception raised there would return the child into the caller's code (a second copy of the program)
        mask = {signal.SIGINT, signal.SIGTERM}
        old = signal.pthread_sigmask(signal.SIG_BLOCK, mask)
        try:
            pid = os.fork()
        except OSError:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
            for fd in (req_r, req_w, rep_r, rep_w):
                os.close(fd)
            return None
        if pid == 0:  # the child: never returns into the caller's code
            code = 1
            try:
                gc.freeze()  # the parent's garbage is not collected (nor finalized) here (jointid.parallel._start_worker)
                try:
                    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles an interrupt
                    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # close() ends a worker nobody waits for
                except ValueError:  # not the main thread: the inherited handlers stay (still inside this block)
                    pass
                signal.pthread_sigmask(signal.SIG_SETMASK, old - mask)
                os.close(req_w)
                os.close(rep_r)
                _child(req_r, rep_w, first, prepare)
                code = 0
            finally:
                os._exit(code)
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        os.close(req_r)
        os.close(rep_w)
        return cls(pid, req_w, rep_r, first=first is not None)

    def submit(self, kind: str, data, **kwargs) -> PendingFigure:
        """Send figure ``kind`` (:data:`FIGURES`) of ``data`` to the worker (a thread writes it: the call does not wait)."""

        def send():
            try:
                _send(self._requests, (kind, data, kwargs))
            except BaseException as exc:  # noqa: BLE001 - reported by PendingFigure.result
                self._send_error = exc

        sender = threading.Thread(target=send, name="jointid-figure-request", daemon=True)
        sender.start()
        pending = PendingFigure(self, sender)
        self._pending.append(pending)
        return pending

    def close(self) -> None:
        """Close the pipes (the worker exits) and reap it; a worker still drawing a figure nobody waits for is terminated."""
        if self.pid <= 0:
            return
        if not self._pending or any(p._png is None for p in self._pending):  # not needed (an error, an interrupt, no figure)
            self._terminate()
        for p in self._pending:
            p._sender.join()
        self._first_done()  # ends: the worker sent its reply or ended (end of file)
        for fd in (self._requests, self._replies):
            try:
                os.close(fd)
            except OSError:
                pass
        self._requests = self._replies = -1
        _reap(self.pid)
        self.pid = -1

    def __enter__(self) -> "FigureWorker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
