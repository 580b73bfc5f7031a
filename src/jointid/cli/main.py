"""The ``jointid`` command: a thin layer over the Python API.

Every subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. Errors jointid raises on purpose (:class:`JointIdError`)
and file errors print as one line on stderr with exit code 2; an interrupt
(SIGINT) exits 130, SIGTERM 143, both after removing the run's staging area and
lock (no partial output). No traceback unless ``--debug`` (before or after the
subcommand); Python warnings of a run (numerical overflow, ...) become one
``finding`` line on stderr instead of raw warnings.
"""

from __future__ import annotations

import os
import sys

#: Subcommand modules under :mod:`jointid.cli`, in help order.
COMMANDS = ("reproduce", "modes", "simulate", "identify", "update", "experiment", "frf", "direct", "design", "campaign")


def _command_of(argv) -> str | None:
    """The subcommand ``argv`` (without the program name) names, or None (usable before argparse is imported)."""
    first = next((a for a in argv if not str(a).startswith("-")), None)
    return first if first in COMMANDS else None


def _interrupted_during_import(kind, value, tb) -> None:
    """``sys.excepthook`` while this module's own imports run (argparse, pathlib, ...: about 10 ms of the ``jointid``
    command's first 20 ms; the interpreter's start-up and the ``jointid`` and ``jointid.cli`` package imports come
    before this module runs, so they are not covered).

    A Ctrl-C then stops the console script's ``from jointid.cli.main import entry_point``
    before :func:`entry_point` can handle it: the interrupt's one line and exit code 130,
    as for a run (see :func:`_stopped`), instead of a traceback. Anything else, or an
    interrupt that did not stop this module's import, goes to the hook that was there before.
    """
    frame_tb = tb
    while frame_tb is not None:
        frame = frame_tb.tb_frame
        if frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == __name__:
            break
        frame_tb = frame_tb.tb_next
    if not (issubclass(kind, KeyboardInterrupt) and frame_tb is not None):
        return _previous_excepthook(kind, value, tb)
    command = _command_of(sys.argv[1:])
    line = f"jointid{' ' + command if command else ''}: interrupted; no partial output was written\n"
    try:
        sys.stdout.flush()
        sys.stderr.write(line)
        sys.stderr.flush()
    except (OSError, ValueError, AttributeError):  # a closed or absent stream: nothing more can be said
        pass
    os._exit(130)


_previous_excepthook = sys.excepthook
sys.excepthook = _interrupted_during_import  # until the imports below are done (restored after them)

import argparse  # noqa: E402  (after the interrupt hook: a Ctrl-C during these imports is one line, exit 130)
import contextlib  # noqa: E402
import signal  # noqa: E402
import traceback  # noqa: E402
import warnings  # noqa: E402
from importlib import import_module  # noqa: E402
from pathlib import Path  # noqa: E402

from .. import __version__  # noqa: E402
from ..errors import JointIdError, Terminated  # noqa: E402

if sys.excepthook is _interrupted_during_import:  # imported: entry_point handles an interrupt from here on
    sys.excepthook = _previous_excepthook

__all__ = ["main", "entry_point", "build_parser", "COMMANDS", "quiet_blas_threads", "BLAS_THREAD_TIMEOUT"]


class _Parser(argparse.ArgumentParser):
    """argparse's parser whose usage errors are one line (the rule for bad input), pointing to ``--help``."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser with every subcommand registered."""
    parser = _Parser(
        prog="jointid",
        description="Identify the frequency-dependent dynamic stiffness of elastomeric joints.",
    )
    parser.add_argument("--version", action="version", version=f"jointid {__version__}")
    parser.add_argument("--debug", action="store_true", help="show a traceback on errors (also accepted after the subcommand)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        import_module(f"jointid.cli.{name}").add_parser(sub)
    return parser


def _split_debug(argv: list[str]) -> tuple[list[str], bool]:
    """``argv`` without ``--debug`` (accepted before or after the subcommand; not after ``--``), and whether it was there."""
    head, sep, tail = (argv[: argv.index("--")], ["--"], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [], [])
    kept = [a for a in head if a != "--debug"]
    return kept + sep + tail, len(kept) != len(head)


#: Stop signals received by this run, in order: a handler's exception can reach main() transformed (raised inside a
#: C extension's import it becomes "ImportError: initialization failed") -- the record says what stopped the run.
_received: list[int] = []


def _on_sigterm(signum, frame):
    _received.append(signum)
    raise Terminated(signum)


def _on_sigint(signum, frame):
    _received.append(signum)
    raise KeyboardInterrupt


@contextlib.contextmanager
def _signal_handlers():
    """SIGTERM raises :class:`~jointid.errors.Terminated`, SIGINT ``KeyboardInterrupt`` (also if it was ignored),
    so a run unwinds through its OutputSet's cleanup; the previous handlers come back afterwards."""
    saved = {}
    _received.clear()
    try:
        saved[signal.SIGTERM] = signal.signal(signal.SIGTERM, _on_sigterm)
        saved[signal.SIGINT] = signal.signal(signal.SIGINT, _on_sigint)
    except ValueError:  # not the main thread (main() called from a thread): leave the handlers alone
        pass
    try:
        yield
    finally:
        for s, h in saved.items():
            signal.signal(s, h)


@contextlib.contextmanager
def _quiet_logger(name: str):
    """Logger ``name`` says only errors while the run lasts (without --debug)."""
    import logging

    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _warning_line(command: str, caught: list) -> str | None:
    """One line for the warnings a run raised (numerical ones: overflow, invalid value), or None."""
    if not caught:
        return None
    w = caught[0]
    where = f"{Path(w.filename).name}:{w.lineno}"
    more = f" (and {len(caught) - 1} more)" if len(caught) > 1 else ""
    numerical = issubclass(w.category, RuntimeWarning)
    return (
        f"jointid {command}: finding: " + ("a numerical problem occurred: " if numerical else "")
        + f"{w.category.__name__}: {' '.join(str(w.message).split())} in {where}{more}"
        + ("; the inputs are probably out of range: check their units and values" if numerical else "")
        + " (rerun with --debug to see the warnings)"
    )


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 success, 2 error, 3 internal error, 130 interrupted, 143 terminated).

    ``--debug`` (before or after the subcommand) shows tracebacks and Python's warnings as they are;
    without it an error is one line on stderr, and the warnings of a successful run (overflow, invalid
    value, ...) are summarized in one ``finding`` line (after an error, the error line is all).
    SIGTERM and SIGINT unwind the run: no partial output.
    """
    argv, debug_anywhere = _split_debug(list(sys.argv[1:] if argv is None else argv))
    try:
        parser = build_parser()  # imports every subcommand's module: a Ctrl-C here is the run's interrupt too
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        return _stopped(_command_of(argv), signal.SIGINT)
    debug = bool(args.debug or debug_anywhere)
    args.debug = debug
    from ..io.output_manifest import commits

    start = len(commits())  # this run's commits follow (a stop signal after one: its output is complete)
    caught: list = []
    with contextlib.ExitStack() as stack:
        if not debug:
            caught = stack.enter_context(warnings.catch_warnings(record=True))
            warnings.simplefilter("always")
            for hidden in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
                warnings.simplefilter("ignore", hidden)  # hidden by Python's defaults too
            stack.enter_context(_quiet_logger("matplotlib"))  # its notices (an unwritable config directory) are not ours
        try:
            with _signal_handlers():
                code = int(args.func(args) or 0)
            for line in _taken_over_lines(args.command, commits()[start:]):
                print(line, file=sys.stderr)
            line = _warning_line(args.command, caught)  # on success only: an error is its own one line
            if line is not None:
                print(line, file=sys.stderr)
        except KeyboardInterrupt:
            return _stopped(args.command, signal.SIGINT, commits()[start:])
        except Terminated as exc:
            return _stopped(args.command, exc.signum, commits()[start:])
        except (JointIdError, OSError) as exc:
            if _received and not debug:  # the signal's exception, transformed on its way up
                return _stopped(args.command, _received[0], commits()[start:])
            if debug:
                raise
            msg = str(exc) if isinstance(exc, JointIdError) else f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": ")
            print(f"jointid {args.command}: error: {msg}", file=sys.stderr)
            return 2
        except Exception as exc:  # pragma: no cover - last resort, still one line
            if _received and not debug:  # e.g. "ImportError: initialization failed": a signal during an import
                return _stopped(args.command, _received[0], commits()[start:])
            if debug:
                raise
            print(
                f"jointid {args.command}: internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)",
                file=sys.stderr,
            )
            return 3
    return code


def _stopped(command: str | None, signum: int, done=()) -> int:
    """The one line of a run stopped by a signal; its exit code (130 SIGINT, 128 + signum otherwise).

    ``command``: the subcommand, or None when the run stopped before its command line was read.
    ``done``: the run's commits (:func:`~jointid.io.output_manifest.commits`); a signal that came while the
    output was being committed is raised once it is complete, and the line says so."""
    what = (f"its output in {done[-1].directory} was complete before it stopped" if done
            else "no partial output was written")
    who = f"jointid {command}" if command else "jointid"
    if signum == signal.SIGINT:
        print(f"{who}: interrupted; {what}", file=sys.stderr)
        return 130
    try:
        name = signal.Signals(signum).name
    except ValueError:
        name = f"signal {signum}"
    print(f"{who}: terminated ({name}); {what}", file=sys.stderr)
    return 128 + signum


def _taken_over_lines(command: str, done) -> list[str]:
    """One note per other command whose files in an output directory this run replaced (a file two commands write
    belongs to the one that wrote it last: :mod:`jointid.io.output_dir`)."""
    lines = []
    for c in done:
        by: dict = {}
        for name, other in c.taken_over.items():
            by.setdefault(other, []).append(name)
        for other, names in sorted(by.items()):
            lines.append(f"jointid {command}: note: replaced {', '.join(sorted(names))} in {c.directory}, written there before "
                         f"by `jointid {other}` (use another --out to keep both)")
    return lines


#: ``OPENBLAS_THREAD_TIMEOUT`` of the ``jointid`` command (unless the environment sets it): OpenBLAS's threads wait
#: 2^20 cycles (about 0.4 ms) for the next job before they sleep, instead of OpenBLAS's default 2^28 (about 0.1 s).
BLAS_THREAD_TIMEOUT = "20"


def quiet_blas_threads(environ=os.environ) -> None:
    """Have OpenBLAS's idle threads sleep after 2^20 cycles instead of spinning 2^28 (``environ``, before numpy loads).

    After each threaded BLAS call (and once at numpy's import), OpenBLAS's worker threads busy-wait for the next
    one for ``2^OPENBLAS_THREAD_TIMEOUT`` cycles, 2^28 by default: about 0.1 s of a core each time. On a 2-core
    machine that core may be one the line threads (:func:`jointid.parallel.map_lines`), the figure worker of
    ``identify`` or another program need. Measured: ``import numpy`` alone used 0.28 s of CPU instead of 0.12 s; the benchmark's
    19 901-line ``jointid identify`` used 4.06 s of CPU instead of 4.17 s (median of 14 interleaved pairs), in the
    same wall time (ratio 1.01: the spinning thread mostly took a core nothing else wanted). 2^20 cycles
    keep the threads awake between BLAS calls in a row (120 x 120 and 300 x 300 matrix products back to back take as long as
    with the default; 2^4 made small ones 30 % slower). OpenBLAS reads the variable once, when numpy loads it:
    set later, or in a process that imported numpy already, it changes nothing. A value the environment sets
    is kept.
    """
    environ.setdefault("OPENBLAS_THREAD_TIMEOUT", BLAS_THREAD_TIMEOUT)


def entry_point() -> None:
    """The ``jointid`` command: :func:`main`, then exit with its code at once.

    Once :func:`main` has returned, the run is over (its output committed, or its staging removed). A stop
    signal that stopped it could still be raised a second time while it unwound, and the interpreter's
    finalization then ran with the pool's threads still stopping: the process died by that signal (-2) or
    aborted ("Fatal Python error: PyThreadState_Get ... finalizing", -6) after printing its one line, on
    about one run in twenty stopped under load. So a repeat of the stop signal keeps the run's exit code,
    further ones are ignored, and the process ends with ``os._exit`` after flushing its output: there is
    nothing left to finalize. With ``--debug`` :func:`main` raises the error itself: its traceback is printed
    and the exit code is still 2 (bad input, a :class:`~jointid.errors.JointIdError` or file error) or 3 (a bug).
    """
    quiet_blas_threads()
    try:
        code = main()
    except KeyboardInterrupt:  # a repeat of the interrupt while the run unwound (its line is printed)
        code = 130
    except Terminated as exc:
        code = 128 + exc.signum
    except (JointIdError, OSError):  # --debug: main raised the error itself; the traceback, and bad input's exit code
        traceback.print_exc()
        code = 2
    except Exception:  # --debug: a bug's traceback, and its exit code
        traceback.print_exc()
        code = 3
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    entry_point()
