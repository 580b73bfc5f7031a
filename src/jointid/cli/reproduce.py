"""``jointid reproduce``: every study on the built-in benchmark, as one HTML report."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..reproduce.config import STUDY_NAMES, load_config
from .common import add_out_argument

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "reproduce",
        help="run every study on the built-in benchmark and write an HTML report",
        description="Run the comparative studies of direct and inverse identification on the built-in benchmark "
        "(or a --config override) and write DIR/report.html (self-contained), DIR/figures/*.png and DIR/data/*.csv. "
        "The studies run as independent tasks on the available cores (the numbers do not depend on how many); "
        "one line per study reports its time. The outputs appear whole or not at all. Studies: " + ", ".join(STUDY_NAMES) + ".",
    )
    add_out_argument(p)
    p.add_argument("--only", metavar="NAMES", help="comma-separated subset of studies, e.g. conditioning,model-error")
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML overriding layouts, materials, noise levels, frequency grid")
    p.add_argument("--seed", type=int, default=None, help="random seed (default 0; the config's seed if it sets one)")
    p.add_argument("--seeds", type=int, default=None, metavar="N",
                   help="noise realizations per level and case in the noise-robustness study (default 1, or the config's "
                        "[noise_robustness] seeds; more gives firmer statistics and takes about N times as long)")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="processes (default: the cores available; 1: run in this process)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..reproduce.runner import parse_only, run_reproduce

    only = parse_only(args.only)
    config = load_config(args.config, seed=args.seed, seeds=args.seeds)
    if args.jobs is not None and args.jobs < 1:
        from ..errors import StudyError

        raise StudyError(f"--jobs: expected an integer >= 1, got {args.jobs}")
    result = run_reproduce(config, args.out, only, quiet=args.quiet, workers=args.jobs)
    n = len(result.outputs)
    print(f"wrote {result.report} ({n} stud{'ies' if n != 1 else 'y'}, {result.wall_seconds:.1f} s on {result.workers} "
          f"process{'es' if result.workers != 1 else ''})")
    return 0
