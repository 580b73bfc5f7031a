"""``jointid reproduce``: every study on the built-in benchmark, as one HTML report."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..studies.config import STUDY_NAMES, load_config
from .common import add_out_argument

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "reproduce",
        help="run every study on the built-in benchmark and write an HTML report",
        description="Run the comparative studies of direct and inverse identification on the built-in benchmark "
        "(or a --config override) and write DIR/report.html (self-contained), DIR/figures/*.png and DIR/data/*.csv. "
        "The outputs appear whole or not at all. Studies: " + ", ".join(STUDY_NAMES) + ".",
    )
    add_out_argument(p)
    p.add_argument("--only", metavar="NAMES", help="comma-separated subset of studies, e.g. conditioning,model-error")
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML overriding layouts, materials, noise levels, frequency grid")
    p.add_argument("--seed", type=int, default=None, help="random seed (default 0; the config's seed if it sets one)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..studies.runner import parse_only, run_reproduce

    only = parse_only(args.only)
    config = load_config(args.config, seed=args.seed)
    result = run_reproduce(config, args.out, only, quiet=args.quiet)
    total = sum(result.seconds.values())
    print(f"wrote {result.report} ({len(result.outputs)} studies, {total:.1f} s)")
    return 0
