"""``jointid identify``: the joint's dynamic stiffness from measured FRFs (inverse method)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from ..io.output_dir import OutputSet
from ..methods.inverse import dof_term_labels, term_unit
from ..pipeline import identify, read_measured
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run", "summary", "write_identification", "stiffness_file", "MAX_PRINTED_FINDINGS"]

#: Findings printed on the console (all of them are in summary.json): a 12 x 12 joint may have dozens.
MAX_PRINTED_FINDINGS = 8


def add_parser(sub) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the joint's dynamic stiffness (2x2 beam joint; any [[joint]] of a [structure] study) from measured FRFs",
        description="Identify the joint's complex dynamic stiffness matrix (default: weighted receptance coupling with per-term uncertainty; [identification] method = \"hong-lee\" for the paper's method) from FRFs of the "
        "constrained beam (UFF58 .uff/.unv or the documented CSV layout) and the study's free-beam FE model. "
        "Uses the file's lines inside the study's [frequency] start..stop. Writes DIR/joint_stiffness.csv, "
        "DIR/summary.json and DIR/joint_stiffness.png. Units: K_w_w N/m, K_w_theta N/rad, K_theta_w N*m/m, "
        "K_theta_theta N*m/rad; theta = dw/dx (rad). A [structure] study identifies all its [[joint]]s at once "
        "(one DIR/joint_stiffness_<name>.csv each when there are several; K_x_ry for a joint on one node, K_101x_201x on two).",
    )
    add_study_argument(p)
    p.add_argument("--frf", required=True, type=Path, metavar="FILE", help="measured FRFs (.uff, .unv, .csv)")
    add_out_argument(p)
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=run)


def _terms(result) -> dict:
    """Per term: median magnitude and loss factor (and, for the receptance method, reliability and smoothing)."""
    terms = {}
    labels = dof_term_labels(result.joint_dofs)
    for a, la in enumerate(labels):
        for b, lb in enumerate(labels):
            k = result.stiffness[:, a, b]
            stiff = k.real > 0  # Im/Re is a loss factor only where the storage part is positive
            terms[f"K_{la}_{lb}"] = {
                "median_magnitude": float(np.median(np.abs(k))),
                "median_loss_factor": float(np.median(k.imag[stiff] / k.real[stiff])) if stiff.any() else None,
                "lines_with_positive_storage": int(stiff.sum()),
            }
    if getattr(result, "method", "hong-lee") == "receptance":
        rel = result.relative_std
        for a, b, name in result.term_names():
            terms[name]["reliable_fraction"] = float(np.mean(result.reliable_terms[:, a, b]))
            terms[name]["median_predicted_relative_std"] = float(np.nanmedian(rel[:, a, b])) if np.isfinite(rel[:, a, b]).any() else None
            terms[name]["smoothing_edf"] = result.smoothing_edf.get(name, result.smoothing_edf.get(f"K_{name.split('_', 2)[2]}_{name.split('_')[1]}"))
    return terms


def stiffness_file(study, name: str) -> str:
    """The CSV of a joint: ``joint_stiffness.csv`` for a study with one joint, else ``joint_stiffness_<name>.csv``."""
    return "joint_stiffness.csv" if not study.is_structure or len(study.joints) == 1 else f"joint_stiffness_{name}.csv"


def summary(result, study, source: Path) -> dict:
    """JSON-ready summary of an identification."""
    f = result.frequency.hz
    out = {
        "study": study.source,
        "frf_file": str(source),
        "method": getattr(result, "method", "hong-lee"),
        "joint_dofs": [str(d) for d in result.joint_dofs],
        "observed": [str(d) for d in study.measurement.observed_dofs],
        "excited": [str(d) for d in study.measurement.excited_dofs],
        "lines": int(f.size),
        "frequency_hz": [float(f[0]), float(f[-1])],
        "reliable_fraction": float(np.mean(result.reliable)),
    }
    if study.is_structure:
        from ..pipeline_structure import cross_joint_ratio, split_joints

        out["joints"] = {}
        for (name, part), joint in zip(split_joints(study, result).items(), study.joints):
            labels = dof_term_labels(part.joint_dofs)
            out["joints"][name] = {
                "file": stiffness_file(study, name),
                "dofs": [str(d) for d in joint.dofs],
                "other": [str(d) for d in joint.other],
                "reliable_fraction": float(np.mean(part.reliable)),
                "terms": _terms(part),
                "units": {f"K_{la}_{lb}": term_unit(di, dj) for la, di in zip(labels, part.joint_dofs) for lb, dj in zip(labels, part.joint_dofs)},
            }
        out["cross_joint_ratio"] = cross_joint_ratio(study, result.stiffness)
        out["cross_joint_note"] = (
            "largest |K_ij| between DOFs of different joints over the largest within-joint |K_ij| (all joints identified "
            "together; the true matrix is block diagonal, so this should be small)"
        )
    else:
        out["terms"] = _terms(result)
        out["units"] = {"K_w_w": "N/m", "K_w_theta": "N/rad", "K_theta_w": "N*m/m", "K_theta_theta": "N*m/rad"}
        out["theta_convention"] = "theta = dw/dx, rad, positive when the beam rises with increasing x"
    if out["method"] == "receptance":
        o = result.options
        out["options"] = {
            "symmetric": o.symmetric, "smoothing": o.smoothing, "weighting": result.weighting,
            "averages": o.averages, "max_relative_std": o.max_relative_std,
            "model_accelerometers": study.identification.model_accelerometers,
        }
        if not study.is_structure:
            out["options"]["elements_per_segment"] = study.beam.mesh_refinement(study.frequency.stop)
        out["estimator"] = result.estimator_summary()
        out["findings"] = result.findings()
        out["max_condition"] = float(np.max(result.condition))
        out["median_residual_scale"] = float(np.nanmedian(result.residual_scale)) if np.isfinite(result.residual_scale).any() else None
        out["columns"] = "K_{i}_{j}_real/_imag: estimate; _real_std/_imag_std: 1-sigma; reliable_{i}_{j}: predicted relative std <= max_relative_std, conditioning and passivity checks; reliable: all terms"
        return out
    out["options"] = {
        "symmetric": result.options.symmetric,
        "regularization": result.options.regularization,
        "model_accelerometers": study.identification.model_accelerometers,
        "estimation": result.options.estimation,
        "cond_rtol": result.options.cond_rtol,
    }
    out.update({
        "max_cond_A": float(np.max(result.cond_A)),
        "max_cond_A_relative_error_bound": float(np.max(result.cond_A_bound)),
        "max_cond_B": float(np.max(result.cond_B)),
        "max_cond_H": float(np.max(result.cond_H)),
        "reliability_thresholds": vars(result.options.reliability),
    })
    return out


def write_identification(out: OutputSet, result, study, source: Path, plots: bool = True, truth=None) -> None:
    """Stage the joint stiffness CSV(s), ``summary.json`` and (``plots``) the figures in ``out``.

    A beam study, or a structure study with one joint: ``joint_stiffness.csv``
    and ``joint_stiffness.png``; a structure study with several joints: per
    joint ``joint_stiffness_<name>.csv`` and ``joint_stiffness_<name>.png``.
    Structure studies also get ``joint_matrix[_<name>].png`` (|K_ij| of every
    term at a few frequencies). ``source`` is the FRF file named in
    ``summary.json``; ``truth`` (F, n, n) on ``result.joint_dofs``, optional,
    is drawn dashed. The files appear when ``out`` commits.
    """
    if not study.is_structure:
        out.write_csv("joint_stiffness.csv", result.columns())
        out.write_text("summary.json", json.dumps(summary(result, study, source), indent=2) + "\n")
        if plots:
            out.write_figure("joint_stiffness.png", result.plot(truth=truth))
        return
    from ..pipeline_structure import split_joints

    i = 0
    for name, part in split_joints(study, result).items():
        k = len(part.joint_dofs)
        csv = stiffness_file(study, name)
        out.write_csv(csv, part.columns())
        if plots:
            from ..plots.joint_matrix import plot_joint_matrix

            t = None if truth is None else truth[:, i:i + k, i:i + k]
            out.write_figure(csv.replace(".csv", ".png"), part.plot(truth=t))
            out.write_figure(csv.replace("joint_stiffness", "joint_matrix").replace(".csv", ".png"), plot_joint_matrix(part, title=name))
        i += k
    out.write_text("summary.json", json.dumps(summary(result, study, source), indent=2) + "\n")


def run(args: argparse.Namespace) -> int:
    study = study_from_args(args)
    measured = read_measured(study, args.frf)
    for note in measured.notes:  # unit conversion, skipped records
        print(f"{args.frf}: {note}")
    with OutputSet(args.out, command="identify") as out:
        result = identify(study, measured)
        write_identification(out, result, study, args.frf, plots=not args.no_plots)
    f = result.frequency.hz
    files = [stiffness_file(study, j.name) for j in study.joints] if study.is_structure else ["joint_stiffness.csv"]
    what = f"{len(study.joints)} joints, " if study.is_structure and len(study.joints) > 1 else ""
    print(
        f"identified {what}{len(result.joint_dofs)}x{len(result.joint_dofs)} joint stiffness on {f.size} lines "
        f"({f[0]:g}-{f[-1]:g} Hz); {100 * np.mean(result.reliable):.0f}% of lines reliable; "
        f"wrote {', '.join(str(out.path(x)) for x in files)}"
    )
    if hasattr(result, "describe_estimator"):
        print(f"estimator: {result.describe_estimator()}")
    findings = getattr(result, "findings", lambda: [])()
    for finding in findings[:MAX_PRINTED_FINDINGS]:
        print(finding)
    if len(findings) > MAX_PRINTED_FINDINGS:
        print(f"... and {len(findings) - MAX_PRINTED_FINDINGS} more findings in {out.path('summary.json')}")
    return 0
