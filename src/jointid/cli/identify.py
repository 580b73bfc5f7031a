"""``jointid identify``: the joint's dynamic stiffness from measured FRFs (inverse method)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from .common import Once, add_out_argument, add_study_argument, study_from_args

__all__ = [
    "add_parser", "run", "summary", "write_identification", "stiffness_file", "MAX_PRINTED_FINDINGS",
    "identify_file", "identification_lines", "term_lines", "output_files", "truth_errors", "truth_error_lines",
]

#: Findings printed on the console (all of them are in summary.json): a 12 x 12 joint may have dozens.
MAX_PRINTED_FINDINGS = 8


def add_parser(sub) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the joint's dynamic stiffness (2x2 beam joint; any [[joint]] of a [structure] study) from measured FRFs",
        description="Identify the joint's complex dynamic stiffness matrix (default: weighted receptance coupling with per-term uncertainty; [identification] method = \"hong-lee\" for the paper's method) from FRFs of the "
        "constrained beam (UFF58 .uff/.unv or the documented CSV layout) and the study's free-beam FE model. "
        "Uses the file's lines inside the study's [frequency] start..stop. Writes DIR/joint_stiffness.csv, "
        "DIR/summary.json, DIR/joint_stiffness.png and DIR/report.html (self-contained: findings, figures, what to trust, inputs). Units: K_w_w N/m, K_w_theta N/rad, K_theta_w N*m/m, "
        "K_theta_theta N*m/rad; theta = dw/dx (rad). A [structure] study identifies all its [[joint]]s at once "
        "(one DIR/joint_stiffness_<name>.csv each when there are several; K_x_ry for a joint on one node, K_101x_201x on two).",
    )
    add_study_argument(p)
    p.add_argument("--frf", required=True, type=Path, metavar="FILE", action=Once, help="measured FRFs (.uff, .unv, .csv)")
    add_out_argument(p)
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(func=run)


def stiffness_file(study, name: str) -> str:
    """The CSV of a joint: ``joint_stiffness.csv`` for a study with one joint, else ``joint_stiffness_<name>.csv``."""
    return "joint_stiffness.csv" if len(study.joints) == 1 else f"joint_stiffness_{name}.csv"


def summary(result, study, source: Path) -> dict:
    """JSON-ready summary of an identification: the study's layout, then per joint the estimate's own summary.

    Every estimator's result is a :class:`~jointid.methods.estimate.JointEstimate`; its
    :meth:`~jointid.methods.estimate.JointEstimate.to_json` gives the per-term figures, units,
    estimator, options, diagnostics and findings.
    """
    from ..pipeline import cross_joint_ratio, split_joints

    whole = result.to_json()
    out = {
        "study": study.source,
        "frf_file": str(source),
        "method": whole["method"],
        "free_structure": study.structure.describe(),
        "joint_dofs": whole["joint_dofs"],
        "observed": [str(d) for d in study.measurement.observed_dofs],
        "excited": [str(d) for d in study.measurement.excited_dofs],
        "lines": whole["lines"],
        "frequency_hz": whole["frequency_hz"],
        "reliable_fraction": whole["reliable_fraction"],
        "estimator": whole["estimator"],
        "options": whole["options"] | {"model_accelerometers": study.identification.model_accelerometers},
        "diagnostics": whole["diagnostics"],
        "findings": whole["findings"],
        "joints": {},
    }
    if study.beam is not None:
        out["options"]["elements_per_segment"] = study.beam.mesh_refinement(study.frequency.stop)
    for (name, part), joint in zip(split_joints(study, result).items(), study.joints):
        j = whole if part is result else part.to_json()  # one joint: the estimate itself, summarized once
        out["joints"][name] = {
            "file": stiffness_file(study, name),
            "dofs": [str(d) for d in joint.dofs],
            "other": [str(d) for d in joint.other],
            "reliable_fraction": j["reliable_fraction"],
            "terms": j["terms"],
            "units": j["units"],
        }
    if len(study.joints) == 1:  # the one joint's figures at the top level too (the beam's K_w_w ...)
        only = next(iter(out["joints"].values()))
        out["terms"], out["units"] = only["terms"], only["units"]
    out["cross_joint_ratio"] = cross_joint_ratio(study, result.stiffness)
    if len(study.joints) > 1:
        out["cross_joint_note"] = (
            "largest |K_ij| between DOFs of different joints over the largest within-joint |K_ij| (all joints identified "
            "together; the true matrix is block diagonal, so this should be small)"
        )
    if any(d.direction == "theta" for d in result.joint_dofs):
        out["theta_convention"] = "theta = dw/dx, rad, positive when the beam rises with increasing x"
    out["columns"] = ("K_{i}_{j}_real/_imag: estimate; _real_std/_imag_std: 1-sigma (empty: the method gives none); "
                      "reliable_{i}_{j}: the term is determined on that line (0/1); reliable: all terms")
    return out


def write_identification(out: OutputSet, result, study, source: Path, plots: bool = True, truth=None, notes=(), worker=None) -> None:
    """Stage the joint stiffness CSV(s), ``summary.json``, ``report.html`` and (``plots``) the figures in ``out``.

    A beam study, or a structure study with one joint: ``joint_stiffness.csv``
    and ``joint_stiffness.png``; a structure study with several joints: per
    joint ``joint_stiffness_<name>.csv`` and ``joint_stiffness_<name>.png``.
    Structure studies also get ``joint_matrix[_<name>].png`` (|K_ij| of every
    term at a few frequencies). ``source`` is the FRF file named in
    ``summary.json``; ``truth`` (F, n, n) on ``result.joint_dofs``, optional,
    is drawn dashed. ``report.html`` (:func:`jointid.report.identification_report`)
    holds the findings, the figures (embedded), what to trust and the inputs
    (``notes``: the FRF file's unit conversions and skipped records). The files
    appear when ``out`` commits. ``worker``: a
    :class:`~jointid.plots.figure_worker.FigureWorker` that draws the joint stiffness figures
    while this process writes the CSV and summary (the same PNG bytes; None: drawn here).
    """
    from ..pipeline import split_joints
    from ..report.identification import identification_report

    figures = []  # (file name, PNG bytes or a PendingFigure, caption) for the report

    def figure(name: str, fig, caption: str) -> None:
        from ..io.png import figure_png

        figures.append((name, figure_png(fig), caption))

    caption = "|K| with its 90 % band (log axis), loss factor or phase of the diagonal terms; shaded: term unreliable"
    i = 0
    for name, part in split_joints(study, result).items():
        k = len(part.joint_dofs)
        csv = stiffness_file(study, name)
        if plots:
            t = None if truth is None else truth[:, i:i + k, i:i + k]
            title = f"joint {name}: " if len(study.joints) > 1 else ""
            name_png = csv.replace(".csv", ".png")
            if worker is not None and k <= 3:  # drawn by the worker while the CSV and summary are written here
                from ..plots.stiffness_data import JointStiffnessData

                pending = worker.submit("joint_stiffness", JointStiffnessData.of(part), truth=t)
                figures.append((name_png, (pending, lambda part=part, t=t: part.plot(truth=t)), f"{title}{caption}"))
            else:
                figure(name_png, part.plot(truth=t), f"{title}{caption}")
            if k > 2:
                from ..plots.joint_matrix import plot_joint_matrix

                figure(csv.replace("joint_stiffness", "joint_matrix").replace(".csv", ".png"), plot_joint_matrix(part, title=name),
                       f"joint {name}: |K_ij| of every term at a few frequencies")
        out.write_csv(csv, part.columns())  # after the figure is sent: the worker draws while this is formatted
        i += k
    info = summary(result, study, source)
    out.write_text("summary.json", json_text(info))
    lines = identification_lines(result, study, max_findings=None)
    if truth is not None:  # a virtual test: how far the identification is from the true joint
        lines += truth_error_lines(study, result, truth)
    figures = [(name, png if isinstance(png, bytes) else _worker_png(*png), caption) for name, png, caption in figures]
    for name, png, _ in figures:
        out.write_bytes(name, png)
    out.write_text("report.html", identification_report(info, lines, notes, figures))


def _worker_png(pending, draw) -> bytes:
    """The worker's PNG, or (the worker ended without one) the figure ``draw()`` makes here."""
    from ..plots.figure_worker import WorkerLost

    try:
        return pending.result()
    except WorkerLost:  # only then matplotlib in this process (its import alone costs ~0.4 s)
        from ..io.png import figure_png

        return figure_png(draw())


def truth_errors(study, result, truth) -> dict:
    """Relative error ``|K - K_true| / |K_true|`` per line of each diagonal term, shape (F,) each.

    ``truth`` (F, n, n) on ``result``'s lines and joint DOFs. Keys: ``K_i_i``;
    a structure study of several joints, ``<joint>_K_i_i`` with each joint's
    own labels (as in its ``joint_stiffness_<joint>.csv``).
    """
    from ..terms import dof_term_labels

    n = len(result.joint_dofs)
    diag = np.arange(n)
    err = np.abs(result.stiffness[:, diag, diag] - truth[:, diag, diag]) / np.abs(truth[:, diag, diag])  # (F, n)
    out, i = {}, 0
    for joint in study.joints:
        prefix = "" if len(study.joints) == 1 else f"{joint.name}_"
        for a, lab in enumerate(dof_term_labels(joint.joint_dofs)):
            out[f"{prefix}K_{lab}_{lab}"] = err[:, i + a]
        i += len(joint.joint_dofs)
    return out


def truth_error_lines(study, result, truth) -> list[str]:
    """The lines ``experiment`` prints (and its report shows): each diagonal term's error against the truth over the band."""
    f = result.frequency.hz
    lines = [f"error against the true joint over the study's band {f[0]:g}-{f[-1]:g} Hz ({f.size} lines), |K - K_true| / |K_true|:"]
    for name, e in truth_errors(study, result, truth).items():
        lines.append(f"{name}: median {100 * np.median(e):.3g} %, 90th percentile {100 * np.percentile(e, 90):.3g} %")
    return lines


def identify_file(study, path: Path, out: OutputSet, *, plots: bool = True, truth=None, shown: Path | None = None, worker=None):
    """The ``jointid identify`` path: read ``path`` as the study describes it, identify, stage the outputs in ``out``.

    One function for ``identify`` and ``experiment`` (which runs it on the
    ``frf.uff`` it staged), so both identify from the same data (FRFs *and*
    coherence, :func:`jointid.pipeline.read_measured`) in the same way.
    Prints the file's notes (units converted, records skipped) as
    ``<shown>: <note>``; stages the CSV(s), ``summary.json``, the figures
    (``plots``) and ``report.html`` (:func:`write_identification`).

    Parameters
    ----------
    path : Path
        The FRF file to read (for ``experiment``: the staged file).
    shown : Path, optional
        The name of the file in messages, ``summary.json`` and the report (default ``path``).
    worker : FigureWorker, optional
        Draws the joint stiffness figures in a second process (:func:`write_identification`). When it was started
        with ``first`` reading ``path`` (:func:`jointid.study.measured.read_study_frf`, as :func:`run` does), the FRF it
        read is used (:meth:`~jointid.plots.figure_worker.FigureWorker.first`; none: ``path`` is read here).
    truth : ndarray, shape (F_file, n, n), optional
        True joint stiffness on the file's lines, drawn dashed in the figures
        (cut here to the lines identified).

    Returns
    -------
    result : JointEstimate
    measured : FRF
        The file as read (its ``notes`` say what was converted or skipped).
    """
    from ..pipeline import identify, read_measured

    shown = path if shown is None else shown
    # the pipeline's imports above ran while the worker (if any) read the file
    measured = read_measured(study, path, preread=None if worker is None else worker.first())
    for note in measured.notes:  # unit conversion, skipped records
        print(f"{shown}: {note}")
    result = identify(study, measured)
    if truth is not None:
        truth = np.asarray(truth)[np.isin(measured.frequency.hz, result.frequency.hz)]
    write_identification(out, result, study, shown, plots=plots, truth=truth, notes=measured.notes, worker=worker)
    return result, measured


def term_lines(result, study) -> list[str]:
    """One console line per term (each independent term of a joint of up to 3 DOFs, else the diagonal ones).

    The figures are those of ``summary.json`` (``terms``): median ``|K|`` with
    its unit, median loss factor (where ``Re K > 0``), and, for the receptance
    method, the median predicted relative error and the fraction of reliable lines.
    """
    s = summary(result, study, Path("-"))
    blocks = [(f"{name}: " if len(s["joints"]) > 1 else "", j["terms"], j["units"]) for name, j in s["joints"].items()]
    lines = []
    for prefix, terms, units in blocks:
        names = list(terms)  # K_{a}_{b}, row-major over the joint's DOFs
        n = int(round(len(names) ** 0.5))
        for idx, name in enumerate(names):
            i, j = divmod(idx, n)
            if j < i or (n > 3 and i != j):
                continue
            t = terms[name]
            text = f"{prefix}{name}: median |K| {t['median_magnitude']:.4g} {units.get(name, '')}"
            eta = t.get("median_loss_factor")
            if i == j:  # a loss factor of a coupling term means nothing
                text += f", loss factor {eta:.3g}" if eta is not None else ", no loss factor (Re K <= 0 on every line)"
            if result.has_uncertainty:
                err = t.get("median_predicted_relative_std")
                if t["reliable_fraction"] == 0 and err is not None and err < result.options_summary().get("max_relative_std", np.inf):
                    # flagged on every line by a check (the findings), not by its band: the band's figure is not the error
                    text += (f", reliable on no line (the findings say why; its band's {100 * err:.2g} % holds only for data "
                             "the free model and the joint model explain)")
                else:
                    text += f", predicted error {100 * err:.2g} %" if err is not None else ", no predicted error"
                    text += f", reliable on {100 * t['reliable_fraction']:.0f} % of lines"
            lines.append(text)
    return lines


def identification_lines(result, study, wrote=(), max_findings: int | None = MAX_PRINTED_FINDINGS) -> list[str]:
    """What ``jointid identify`` prints after an identification: a summary line, the estimator, a line per term, the findings.

    ``wrote``: paths named at the end of the first line; ``max_findings``: the
    findings shown (None: all; the rest are counted, they are all in ``summary.json``).
    """
    f = result.frequency.hz
    what = f"{len(study.joints)} joints, " if len(study.joints) > 1 else ""
    first = (f"identified {what}{len(result.joint_dofs)}x{len(result.joint_dofs)} joint stiffness on {f.size} lines "
             f"({f[0]:g}-{f[-1]:g} Hz); {100 * np.mean(result.reliable):.0f}% of lines reliable")
    n = len(result.joint_dofs)
    diagonal = float(np.mean(result.reliable_terms[:, np.arange(n), np.arange(n)].all(axis=1)))
    if n > 1 and round(100 * diagonal) != round(100 * np.mean(result.reliable)):  # couplings near 0 are never reliable
        first += f" on every term, {100 * diagonal:.0f}% on every diagonal term"
    lines = [first + (f"; wrote {', '.join(str(p) for p in wrote)}" if wrote else "")]
    lines.append(f"estimator: {result.describe_estimator()}")
    lines.extend(term_lines(result, study))
    findings = result.findings()
    shown = findings if max_findings is None else findings[:max_findings]
    lines.extend(shown)
    if len(findings) > len(shown):
        lines.append(f"... and {len(findings) - len(shown)} more findings in summary.json")
    return lines


def output_files(study) -> list[str]:
    """The joint stiffness CSV(s) and ``report.html``: the files ``identify`` names on its summary line."""
    files = [stiffness_file(study, j.name) for j in study.joints]
    return files + ["report.html"]


def run(args: argparse.Namespace) -> int:
    import contextlib
    import functools

    from ..plots.figure_worker import FigureWorker
    from ..study.measured import read_study_frf

    study = study_from_args(args)
    # the figure's process starts first: it reads the FRF file while this one imports the estimators, then imports
    # matplotlib and makes the joint stiffness figure's axes while this one identifies
    n = len(study.joints[0].joint_dofs) if len(study.joints) == 1 else 0
    worker = None if args.no_plots else FigureWorker.start(first=functools.partial(read_study_frf, study, args.frf),
                                                           prepare=("joint_stiffness", (n,)) if 0 < n <= 3 else None)
    with contextlib.ExitStack() as stack:
        if worker is not None:
            stack.enter_context(worker)
        with OutputSet(args.out, command="identify") as out:
            result, _ = identify_file(study, args.frf, out, plots=not args.no_plots, worker=worker)
    for line in identification_lines(result, study, wrote=[out.path(x) for x in output_files(study)]):
        print(line)
    return 0
