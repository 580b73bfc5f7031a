"""Helpers shared by CLI subcommands: the study argument, output directory.

Every subcommand writes its files through :class:`jointid.io.output_dir.OutputSet`
(``with OutputSet(args.out, command="NAME") as out:`` opened *before* computing,
``out.write_csv/write_text/write_figure/write_bytes`` while computing; leaving
the block commits). See that module for what is replaced in ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..benchmark import benchmark_study_path
from ..errors import DataError, StudyError
from ..study import Study, load_study

__all__ = ["add_study_argument", "study_from_args", "add_out_argument", "out_dir", "OUT_HELP", "Once", "add_column_arguments",
           "quantity_pairs"]

#: Help text of ``--out DIR``.
OUT_HELP = (
    "output directory (created if missing); only files jointid wrote there (listed in DIR/.jointid-manifest.json) "
    "are replaced, all at once when the command succeeds"
)


def add_study_argument(p: argparse.ArgumentParser, required: bool = True) -> None:
    """Add the positional STUDY.toml argument (optional: the built-in benchmark)."""
    if required:
        p.add_argument("study", metavar="STUDY.toml", help="study file (TOML)")
    else:
        p.add_argument(
            "study", metavar="STUDY.toml", nargs="?", default=None,
            help="study file (TOML); default: the built-in benchmark",
        )



def study_from_args(args: argparse.Namespace) -> Study:
    """Load and validate the study named on the command line (or the built-in benchmark).

    Raises
    ------
    StudyError
        The study file is missing or invalid (one line naming the key).
    """
    return load_study(args.study if args.study else benchmark_study_path())


def add_out_argument(p: argparse.ArgumentParser) -> None:
    """Add the required ``--out DIR`` option."""
    p.add_argument("--out", required=True, type=out_dir, metavar="DIR", action=Once, help=OUT_HELP)


class Once(argparse.Action):
    """An option that may be given once: a second ``--frf`` or ``--out`` is a usage error, not the last one winning
    silently (the user may have meant both files to be read)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, "_given_" + self.dest, False):
            parser.error(f"{option_string} given twice ({getattr(namespace, self.dest)} and {values}); give it once")
        setattr(namespace, "_given_" + self.dest, True)
        setattr(namespace, self.dest, values)


def out_dir(text: str) -> Path:
    """``--out``: a directory path; an empty one is refused (it would be the current directory, unnamed)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a directory, got an empty path (for the current directory give '.')")
    return Path(text)


def add_column_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--column QUANTITY=NAME`` and ``--scale QUANTITY=FACTOR`` (how a step-sine CSV names its columns and their
    units; ``jointid direct`` and ``jointid campaign``)."""
    p.add_argument("--column", action="append", metavar="QUANTITY=NAME",
                   help="CSV column of a quantity (frequency, time, displacement, force); repeatable")
    p.add_argument("--scale", action="append", metavar="QUANTITY=FACTOR",
                   help="factor from the file's unit to SI for a quantity, e.g. displacement=1e-3 for mm; repeatable")


def quantity_pairs(items, what: str, number: bool) -> dict:
    """``--column``/``--scale`` values as ``{quantity: name or factor}``.

    Raises
    ------
    DataError
        An item that is not ``QUANTITY=VALUE`` (or, ``number``, whose value is not a number).
    """
    out = {}
    for item in items or ():
        if "=" not in item:
            raise DataError(f"--{what} {item!r}: expected QUANTITY=VALUE, e.g. displacement=disp_mm")
        k, v = item.split("=", 1)
        k, v = k.strip(), v.strip()
        if number:
            try:
                v = float(v)
            except ValueError:
                raise DataError(f"--{what} {item!r}: {v!r} is not a number") from None
        out[k] = v
    return out
