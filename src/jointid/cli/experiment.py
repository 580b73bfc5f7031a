"""``jointid experiment``: a virtual roving-hammer test, processed and identified like real data."""

from __future__ import annotations

import argparse

import numpy as np

from ..errors import StudyError
from ..io.output_dir import OutputSet
from ..methods.inverse import stiffness_columns
from ..pipeline import experiment, identify
from .common import add_out_argument, add_study_argument, study_from_args
from .identify import write_identification

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
    from ..io.frf_files import read_frf
    from ..io.uff import write_uff_frf

    study = study_from_args(args)
    if args.seed is not None and args.seed < 0:
        raise StudyError(f"--seed: expected an integer >= 0, got {args.seed}")
    with OutputSet(args.out, command="experiment") as out:
        result = experiment(study, seed=args.seed)
        for r in result.impact.rejected:
            print(f"rejected: {r.reason}")
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, result.frf, kind="accelerance", coherence=result.coherence))
        if study.is_structure:
            return _finish_structure(args, out, study, result, uff)
        out.write_csv("true_joint.csv", stiffness_columns(result.frf.frequency, study.joint.joint_dofs, result.truth))
        identified = identify(study, read_frf(out.staged("frf.uff"), n_nodes=study.beam.nodes))  # the same path as real data
        truth = result.truth
        write_identification(out, identified, study, uff, plots=not args.no_plots, truth=truth)
        k = identified.stiffness[:, 0, 0]
        t = truth[:, 0, 0]
        err = np.abs(k - t) / np.abs(t)
        eta_err = np.abs(k.imag / k.real - t.imag / t.real)
        f = identified.frequency.hz
        out.write_csv("experiment_errors.csv", {
            "frequency_hz": f, "translational_magnitude_error": np.abs(np.abs(k) / np.abs(t) - 1),
            "translational_relative_error": err, "translational_loss_factor_error": eta_err,
            "coherence_min": result.coherence.min(axis=(1, 2)), "reliable": identified.reliable,
        })
    band = (f >= 100) & (f <= 1000)
    if band.any():
        print(
            f"translational stiffness error over 100-1000 Hz: median {100 * np.median(err[band]):.2f}%, "
            f"90th percentile {100 * np.percentile(err[band], 90):.2f}% ({band.sum()} lines)"
        )
    print(f"wrote {uff}, {out.path('joint_stiffness.csv')} and {out.path('experiment_errors.csv')}")
    return 0


def _finish_structure(args, out, study, result, uff) -> int:
    """Structure study: true joints, identification from the written file, error of every diagonal term per line."""
    from ..methods.inverse import dof_term_labels
    from ..pipeline import read_measured
    from .simulate import write_true_joints

    write_true_joints(out, study, result.frf.frequency, result.truth)
    identified = identify(study, read_measured(study, out.staged("frf.uff")))  # the same path as real data
    write_identification(out, identified, study, uff, plots=not args.no_plots, truth=result.truth)
    f = identified.frequency.hz
    truth = result.truth[np.isin(result.frf.frequency.hz, f)]
    n = len(study.joint_dofs)
    diag = np.arange(n)
    err = np.abs(identified.stiffness[:, diag, diag] - truth[:, diag, diag]) / np.abs(truth[:, diag, diag])  # (F, n)
    columns = {"frequency_hz": f}
    i = 0
    for joint in study.joints:
        labels = dof_term_labels(joint.joint_dofs)
        prefix = "" if len(study.joints) == 1 else f"{joint.name}_"
        for a, lab in enumerate(labels):
            columns[f"{prefix}K_{lab}_{lab}_relative_error"] = err[:, i + a]
        i += len(labels)
    columns["coherence_min"] = result.coherence.min(axis=(1, 2))[np.isin(result.frf.frequency.hz, f)]
    out.write_csv("experiment_errors.csv", columns)
    med = np.median(err, axis=0)
    print(f"diagonal terms' median relative error: {100 * med.min():.2f}-{100 * med.max():.2f}% over {f.size} lines ({n} joint DOFs)")
    print(f"wrote {uff} and {out.path('experiment_errors.csv')}")
    return 0
