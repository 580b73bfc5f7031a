"""``jointid update``: update the free model (a beam's E, density, loss factor, ...; a structure's stiffness and
mass scales and loss factor) from a free-free test."""

from __future__ import annotations

import argparse
import datetime
import os
from pathlib import Path

from ..errors import StudyError
from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from ..methods.updating.parameters import (
    DEFAULT_MAX_EVALUATIONS, DEFAULT_PARAMETERS, DEFAULT_STRUCTURE_PARAMETERS, PARAMETERS, STRUCTURE_PARAMETERS,
    check_parameter_names,
)
from ..study.edit import replace_study_table, replace_study_values
from .common import Once, add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run", "parse_parameters", "structure_paths_for"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "update",
        help="update the free beam's E, density and loss factor (a structure's stiffness/mass scales, loss factor) from free-free FRFs",
        description="Fit the study's free beam (with its [accelerometers], no joint) to FRFs measured on the free "
        "(suspended) structure: any kind, any subset of the beam's nodes, UFF58 or CSV, read like `identify` reads "
        "them ([measurement] axis and points), over the study's [frequency] band. The fit is on the FRFs themselves "
        "(log-magnitude and phase, weighted by coherence where the file has it), so E and density separate through "
        "the FRF level. Writes DIR/update.json (values with standard errors, correlation, residual before/after), "
        "DIR/updated_study.toml (the study with the determined values written in), DIR/update.png (FRF overlay) and "
        "DIR/report.html (self-contained: findings, figure, what to trust, inputs). "
        "A parameter the FRFs cannot determine is reported as such and keeps the study's value. "
        "A [structure] study fits stiffness_scale, mass_scale and loss_factor of its free model "
        "stiffness_scale K (1 + j loss_factor) - w^2 mass_scale M on the observed x excited FRFs; updated_study.toml "
        "then names the matrix files relative to DIR.",
    )
    add_study_argument(p)
    p.add_argument("--frf", required=True, type=Path, metavar="FILE", action=Once, help="free-free FRFs (.uff, .unv, .csv)")
    add_out_argument(p)
    p.add_argument(
        "--parameters", metavar="NAMES", default=None,
        help=f"comma-separated parameters to fit (default {','.join(DEFAULT_PARAMETERS)}); any of {', '.join(PARAMETERS)}; "
        f"a [structure] study: default and any of {','.join(DEFAULT_STRUCTURE_PARAMETERS)}",
    )
    p.add_argument("--max-evaluations", type=int, default=DEFAULT_MAX_EVALUATIONS, metavar="N",
                   help="model evaluations allowed to the fit (default %(default)s); more is reported as not converged")
    p.add_argument("--no-plots", action="store_true", help="skip the figure")
    p.set_defaults(func=run)


def parse_parameters(text: str, known=None, what: str = "") -> tuple[str, ...]:
    """``--parameters`` as names, validated against ``known`` (default: a beam's; one-line error naming a bad one)."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    check_parameter_names(names, prefix=f"--parameters{what}: ", known=known)
    return names


def structure_paths_for(study, directory: Path) -> dict:
    """The free structure's file keys (``structure.mass`` / ``.stiffness`` / ``.dofs``; a beam has none) -> the
    file names as a study in ``directory`` must write them.

    Relative names are relative to the study file's directory; an updated study
    written elsewhere names the same files relative to its own directory
    (absolute when no relative path exists, e.g. another drive).
    """
    spec = study.structure
    out = {}
    for key in spec.file_keys:
        name = getattr(spec, key)
        if Path(name).is_absolute():
            continue
        target = os.path.abspath(os.path.join(spec.base, name))
        try:
            new = Path(os.path.relpath(target, os.path.abspath(directory))).as_posix()
        except ValueError:
            new = Path(target).as_posix()
        if new != name:
            out[f"{spec.study_table}.{key}"] = new
    return out


def run(args: argparse.Namespace) -> int:
    from ..methods.updating.fit import UpdateOptions
    from ..pipeline import read_free_measured, update

    if args.max_evaluations < 1:
        raise StudyError(f"--max-evaluations: expected an integer >= 1, got {args.max_evaluations}")
    study = study_from_args(args)
    known, default = study.structure.update_parameter_names()
    what = "" if study.beam is not None else f" (a [{study.structure.study_table}] study)"
    names = parse_parameters(args.parameters if args.parameters is not None else ",".join(default), known, what)
    if study.accelerometers is None and any(n.startswith("accelerometers.") for n in names):
        raise StudyError(f"--parameters: {study.source} has no [accelerometers] section to fit")
    text = Path(args.study).read_text(encoding="utf-8-sig")
    measured = read_free_measured(study, args.frf)
    for note in measured.notes:
        print(f"{args.frf}: {note}")
    options = UpdateOptions(parameters=names, max_evaluations=args.max_evaluations)
    with OutputSet(args.out, command="update") as out:
        result = update(study, measured, options)
        determined = result.determined()
        # the free structure's keys (accelerometers.* as they are); its files named relative to DIR
        edits = {(k if "." in k else f"{study.structure.study_table}.{k}"): v for k, v in determined.items()}
        edits.update(structure_paths_for(study, args.out))
        header = [
            f"Updated by `jointid update` on {datetime.date.today().isoformat()} from the free-free FRFs {args.frf}",
            f"(fit of {', '.join(names)} on {result.measured.frequency.size} lines x {len(result.measured.responses)} x "
            f"{len(result.measured.references)} FRFs; residual {result.residual_before:.3g} -> {result.residual_after:.3g};",
            "values with standard errors in update.json).",
        ] + [f"  {line}" for line in result.describe()]
        if not determined:
            header = header + ["No parameter was determined: the study is unchanged" + (" (but for its file names)." if edits else ".")]
        new_text = replace_study_values(text, edits, header, source=str(args.study)) if edits else \
            "".join(f"# {h}\n" for h in header) + text
        std = result.uncertainty()
        if std:  # the fit's covariance: identify propagates it into the joint's bands
            new_text = replace_study_table(new_text, "uncertainty", std, (
                "1-sigma of the updated parameters and their correlation (jointid update's fit); `jointid identify`",
                "adds their effect to the joint's bands (remove this table to leave it out)"), source=str(args.study))
        report = result.to_dict()
        report.update({"study": study.source, "frf_file": str(args.frf), "fitted": list(names)})
        out.write_text("update.json", json_text(report))
        out.write_text("updated_study.toml", new_text)
        figures = []
        if not args.no_plots:
            from ..io.png import figure_png

            png = figure_png(result.plot())
            out.write_bytes("update.png", png)
            figures.append(("update.png", png, "measured FRFs, the initial and the updated model"))
        residual = f"residual (rms |ln(H_model / H_measured)|) {result.residual_before:.3g} -> {result.residual_after:.3g}"
        from ..report.command_reports import update_report

        out.write_text("report.html", update_report(report, [*result.describe(), residual], figures))
    for line in result.describe():
        print(line)
    print(f"{residual}; wrote {out.path('updated_study.toml')}, {out.path('update.json')} and {out.path('report.html')}")
    return 0
