"""The ``jointid`` command: a thin layer over the Python API.

Every subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. Errors jointid raises on purpose (:class:`JointIdError`)
and file errors print as one line on stderr with exit code 2; an interrupt
exits 130. No traceback unless ``--debug``.
"""

from __future__ import annotations

import argparse
import sys
from importlib import import_module

from .. import __version__
from ..errors import JointIdError

__all__ = ["main", "build_parser", "COMMANDS"]

#: Subcommand modules under :mod:`jointid.cli`, in help order.
COMMANDS = ("reproduce", "modes", "simulate", "identify", "update", "experiment", "frf", "direct", "design")


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="jointid",
        description="Identify the frequency-dependent dynamic stiffness of elastomeric joints.",
    )
    parser.add_argument("--version", action="version", version=f"jointid {__version__}")
    parser.add_argument("--debug", action="store_true", help="show a traceback on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        import_module(f"jointid.cli.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 success, 2 error, 130 interrupted)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("jointid: interrupted; no partial output was written", file=sys.stderr)
        return 130
    except (JointIdError, OSError) as exc:
        if args.debug:
            raise
        msg = str(exc) if isinstance(exc, JointIdError) else f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": ")
        print(f"jointid {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except Exception as exc:  # pragma: no cover - last resort, still one line
        if args.debug:
            raise
        print(
            f"jointid {args.command}: internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)",
            file=sys.stderr,
        )
        return 3


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
