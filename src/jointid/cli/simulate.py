"""``jointid simulate``: a virtual test of the study's constrained beam (exact FRFs)."""

from __future__ import annotations

import argparse

from ..io.output_dir import OutputSet
from ..methods.inverse import stiffness_columns
from ..pipeline import simulate
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help="synthesize the constrained beam's FRFs (a virtual test) and the true joint",
        description="Synthesize the FRFs of the study's beam attached to ground through its [joint.model] "
        "(with the [accelerometers] on the test article, if given) at the observed x excited coordinates, "
        "and write DIR/frf.uff (UFF58 accelerance, (m/s^2)/N, like a real test) and DIR/true_joint.csv "
        "(the true joint matrix, columns as `jointid identify` writes them).",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..io.uff import write_uff_frf

    study = study_from_args(args)
    with OutputSet(args.out, command="simulate") as out:
        test = simulate(study)
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, test.frf, kind="accelerance"))
        csv = out.write_csv("true_joint.csv", stiffness_columns(test.frequency, test.joint_dofs, test.truth))
    f = test.frequency.hz
    print(
        f"wrote {uff} ({len(test.frf.responses)} x {len(test.frf.references)} accelerances, "
        f"{f.size} lines {f[0]:g}-{f[-1]:g} Hz) and {csv}"
    )
    return 0
