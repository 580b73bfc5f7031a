"""``jointid experiment``: a virtual roving-hammer test, processed and identified like real data."""

from __future__ import annotations

import argparse

import numpy as np

from ..errors import StudyError
from ..io.output_dir import OutputSet
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "experiment",
        help="virtual roving-hammer test: time histories -> H1 -> UFF58 -> identification",
        description="Simulate the study's roving-hammer test ([experiment]: hits per node, noise, pulse, window) on the "
        "constrained beam with its [accelerometers], estimate H1 and coherence, write DIR/frf.uff (UFF58 accelerance "
        "and coherence records) and DIR/true_joint.csv, then identify the joint from DIR/frf.uff exactly as "
        "`jointid identify` does (DIR/joint_stiffness.csv, summary.json, joint_stiffness.png) and write the "
        "translational-stiffness error per line against the truth (DIR/experiment_errors.csv).",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.add_argument("--seed", type=int, default=None, help="random seed (default: [experiment].seed)")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..io.uff import write_uff_frf
    from ..pipeline import experiment
    from .identify import identification_lines, identify_file, output_files, truth_error_lines, truth_errors
    from .simulate import write_true_joints

    study = study_from_args(args)
    if args.seed is not None and args.seed < 0:
        raise StudyError(f"--seed: expected an integer >= 0, got {args.seed}")
    with OutputSet(args.out, command="experiment") as out:
        result = experiment(study, seed=args.seed)
        for r in result.impact.rejected:
            print(f"rejected: {r.reason}")
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, result.frf, kind="accelerance", coherence=result.coherence))
        write_true_joints(out, study, result.frf.frequency, result.truth)
        # exactly `jointid identify STUDY --frf DIR/frf.uff`: the same reader (FRFs and coherence), the same identification
        identified, _ = identify_file(study, out.staged("frf.uff"), out, plots=not args.no_plots, truth=result.truth, shown=uff)
        f = identified.frequency.hz
        truth = result.truth[np.isin(result.frf.frequency.hz, f)]
        errors = truth_errors(study, identified, truth)
        columns = {"frequency_hz": f}
        if identified.joint_dofs[0].direction in ("w", "x", "y", "z"):  # the first term a translation: the paper's figures
            k, t = identified.stiffness[:, 0, 0], truth[:, 0, 0]
            columns.update({
                "translational_magnitude_error": np.abs(np.abs(k) / np.abs(t) - 1),
                "translational_relative_error": np.abs(k - t) / np.abs(t),
                "translational_loss_factor_error": np.abs(k.imag / k.real - t.imag / t.real),
            })
        columns.update({f"{name}_relative_error": e for name, e in errors.items()})
        columns["coherence_min"] = result.coherence.min(axis=(1, 2))[np.isin(result.frf.frequency.hz, f)]
        columns["reliable"] = identified.reliable
        out.write_csv("experiment_errors.csv", columns)
    wrote = [out.path(x) for x in ("frf.uff", *output_files(study), "experiment_errors.csv")]
    for line in identification_lines(identified, study, wrote=wrote):
        print(line)
    for line in truth_error_lines(study, identified, truth):
        print(line)
    return 0
