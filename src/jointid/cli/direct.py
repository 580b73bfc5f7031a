"""``jointid direct``: step-sine time histories of the direct test to the joint's dynamic stiffness and material."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ..errors import DataError
from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from .common import OUT_HELP, add_column_arguments, out_dir, quantity_pairs

__all__ = ["add_parser", "run", "direct_summary", "zener_line", "material_warnings"]


def add_parser(sub) -> None:
    """Register the ``direct`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "direct",
        help="direct method: step-sine tests to K21(f), loss factor and elastomer material",
        description="Process step-sine time histories of the direct test (imposed displacement, transmitted "
        "force; CSV long format with columns frequency_hz, time_s, displacement_m, force_n, one block per test "
        "frequency) into the complex blocked transfer stiffness per joint, fit the elastomer's E, loss factor "
        "and density with the FE joint model, and write DIR/direct_stiffness.csv (N/m per joint), "
        "DIR/direct_fit.json, DIR/direct_stiffness.png and DIR/report.html (self-contained). Every fitted parameter comes with a standard error and "
        "a status; one the data cannot determine (e.g. the density on a band far below the joint's internal mode) "
        "is held at a default or reported as not identified, with a warning. "
        "`jointid direct --example OUT.csv` writes built-in example data to try the command on.",
    )
    p.add_argument("data", type=Path, nargs="?", metavar="DATA.csv", help="step-sine time histories (CSV long format)")
    p.add_argument("--out", type=out_dir, metavar="DIR", help=OUT_HELP + "; required with DATA.csv")
    p.add_argument("--example", type=Path, metavar="OUT.csv",
                   help="write the built-in example step-sine test (Material B, 25-1500 Hz, two joints, 1%% noise) to OUT.csv and stop")
    p.add_argument("--parallel-joints", type=int, default=2, metavar="N", help="joints loaded in parallel (default 2, double shear)")
    p.add_argument("--amplitude", type=float, default=None, metavar="X",
                   help="commanded displacement amplitude, m, peak (default: the median achieved amplitude)")
    p.add_argument("--tolerance", type=float, default=0.05, help="flag lines whose amplitude is off by more than this fraction (default 0.05)")
    p.add_argument("--length", type=float, default=0.0254, metavar="M", help="elastomer length, m (default 0.0254)")
    p.add_argument("--diameter", type=float, default=0.0254, metavar="M", help="elastomer diameter, m (default 0.0254)")
    p.add_argument("--poisson-ratio", type=float, default=0.49, help="elastomer Poisson ratio (default 0.49)")
    p.add_argument("--static-lines", type=int, default=2, metavar="N", help="lowest lines for the static G, E (default 2)")
    add_column_arguments(p)
    p.add_argument("--density", type=float, default=None, metavar="KG_M3",
                   help="known elastomer density, kg/m^3: held, only E and the loss factor are fitted")
    p.add_argument("--zener", action="store_true", help="also fit a fractional-derivative Zener model to E*(f)")
    p.add_argument("--no-plots", action="store_true", help="skip the figure")
    p.set_defaults(func=run)


def direct_summary(args, result, static, fit, modulus, zener=None, converted: str = "") -> dict:
    """JSON-ready summary of a direct identification (values only for identified parameters; see ``fit.parameters``)."""
    flagged = result.frequency_hz[~result.amplitude_ok]
    return {
        "data_file": str(args.data),
        "columns_converted": converted,
        "parallel_joints": result.parallel_joints,
        "commanded_amplitude_m": float(result.commanded_amplitude_m[0]),
        "commanded_amplitude_source": "--amplitude" if args.amplitude is not None else "median achieved amplitude",
        "tolerance": result.tolerance,
        "lines": int(result.frequency_hz.size),
        "band_hz": [float(result.frequency_hz.min()), float(result.frequency_hz.max())],
        "flagged_lines_hz": [float(x) for x in flagged],
        "distorted_lines_hz": [] if result.distorted is None else [float(x) for x in result.frequency_hz[result.distorted]],
        "distortion": list(result.distortion),
        "test_notes": list(result.notes),
        "max_force_thd": float(np.max(result.force_thd)),
        "max_force_residual": float(np.max(result.force_residual)),
        "static": static.to_dict(),
        "fit": fit.to_dict(),
        "complex_modulus": modulus.to_dict(),
        **({"zener": zener.to_dict()} if zener is not None else {}),
        "units": {
            "stiffness": "N/m per joint",
            "modulus": "Pa",
            "density": "kg/m^3",
            "amplitude": "m, peak",
        },
        "warnings": list(material_warnings(fit, zener)),
        "notes": "fit and E*(f) use the lines that reached the commanded amplitude; static G = k L / A "
        "under-reads G for L = d (guided Timoshenko stiffness ~ guided_ratio GA/L); the corrected value divides by it; "
        "a parameter's value is given only when its status is 'identified' (held values are assumptions, under held_value); "
        "std_error is the first-order standard error s^2 (J^T J)^-1 of the least-squares fit in the parameter's unit; "
        "E*(f) per line uses the fit's density (density_used_kg_m3), held or identified",
    }


def run(args: argparse.Namespace) -> int:
    """Run ``jointid direct``; returns 0. Raises JointIdError subclasses on bad input (nothing written)."""

    if args.example is not None:
        return _write_example(args)
    if args.data is None or args.out is None:
        raise DataError("give DATA.csv and --out DIR (or --example OUT.csv to write example data to try the command on)")
    if args.density is not None and not 0 < args.density < 1e5:
        raise DataError(f"--density must be the elastomer density in kg/m^3 (e.g. 1100), got {args.density}")
    if args.parallel_joints < 1:
        raise DataError(f"--parallel-joints must be >= 1, got {args.parallel_joints}")
    if args.amplitude is not None and not args.amplitude > 0:
        raise DataError(f"--amplitude must be a positive displacement amplitude in m (peak), got {args.amplitude}")
    with OutputSet(args.out, command="direct") as out:  # validated and locked before computing
        return _run(args, out)


def _run(args: argparse.Namespace, out: OutputSet) -> int:
    """Compute and stage the outputs of ``jointid direct`` in ``out``."""
    from ..physics.elastomer_joint import ElastomerJoint
    from ..methods.direct.material_fit import complex_modulus_per_line, fit_material, fit_zener, static_estimate
    from ..measurement.stepsine import process_stepsine, read_stepsine_csv

    from ..measurement.stepsine_files import resolve_columns

    # unit-suffixed columns (force_kN, 'displacement [mm]') read and converted exactly to SI, as a campaign reads them
    columns, scale, converted = resolve_columns(args.data, quantity_pairs(args.column, "column", False),
                                                quantity_pairs(args.scale, "scale", True))
    blocks = read_stepsine_csv(args.data, columns=columns, scale=scale)
    try:
        result = process_stepsine(blocks, parallel_joints=args.parallel_joints, commanded_amplitude_m=args.amplitude,
                                  tolerance=args.tolerance)
    except DataError as exc:  # about the blocks of this file: name it
        raise DataError(f"{args.data}: {exc}") from None
    ok = result.amplitude_ok
    if ok.sum() < 2:
        raise DataError(
            f"{args.data}: only {int(ok.sum())} of {ok.size} lines reached the commanded amplitude within {args.tolerance:.0%}; "
            "check --amplitude (m, peak) or widen --tolerance"
        )
    f, k = result.frequency_hz[ok], result.stiffness[ok]
    template = ElastomerJoint(10e6, 0.1, 1100.0, args.length, args.diameter, args.poisson_ratio)
    try:
        static = static_estimate(f, k, lines=args.static_lines, length_m=args.length, diameter_m=args.diameter,
                                 poisson_ratio=args.poisson_ratio)
    except DataError as exc:  # about the lines of this file (e.g. a negative storage stiffness): name it
        raise DataError(f"{args.data}: {exc}") from None
    noise = float(np.median(result.force_residual[ok]))  # the sine fits' residual over the fundamental, for scale
    fit = fit_material(f, k, joint=template, density_kg_m3=args.density, signal_noise=noise)
    modulus = complex_modulus_per_line(f, k, fit.density_kg_m3, joint=template)
    zener = None
    if args.zener:
        c = modulus.converged
        if c.sum() < 3:
            raise DataError(f"--zener: E*(f) converged on only {int(c.sum())} lines; a Zener fit needs at least 3")
        zener = fit_zener(f[c], modulus.modulus_pa[c])

    csv_columns = result.columns()
    text = json_text(direct_summary(args, result, static, fit, modulus, zener, converted))
    png = None
    if not args.no_plots:
        from ..plots.direct import plot_direct_stiffness

        from ..io.png import figure_png

        png = figure_png(plot_direct_stiffness(result, fit), dpi=120)
    # everything is computed: stage the files (they appear together when `out` commits)
    out.write_csv("direct_stiffness.csv", csv_columns)
    out.write_text("direct_fit.json", text)
    if png is not None:
        out.write_bytes("direct_stiffness.png", png)
    n_flag = int((~ok).sum())
    E, eta, rho = fit.parameters
    line = (f"direct: {ok.size} lines ({n_flag} flagged), {E.describe(1e6, 'MPa')}, {eta.describe()}, "
            f"{rho.describe()}, residual {fit.residual_rms:.2%}")
    from ..report.command_reports import direct_report

    lines = [line]
    if converted:
        lines.append(f"columns converted to SI: {converted}")
    if zener is not None:
        lines.append(zener_line(zener))
    if result.distortion:
        lines.append(f"{len(result.distortion)} of {ok.size} lines not used: clipped or distorted ({result.distortion[0]})")
    lines.extend(f"note: {n}" for n in result.notes)  # test-level (a drift along the blocks), one line each
    figures = [] if png is None else [("direct_stiffness.png", png, "|K21| per joint, loss factor or phase: measured and fitted")]
    out.write_text("report.html", direct_report(json.loads(text), lines, figures))
    print(f"{line}; wrote {out.directory}")
    for extra in lines[1:]:
        print(f"jointid direct: {extra}")
    for w in material_warnings(fit, zener):
        print(f"jointid direct: warning: {w}", file=sys.stderr)
    return 0


def zener_line(zener) -> str:
    """The terminal line of ``--zener``: E0, Einf (MPa), tau (ms), alpha with standard errors, and the residual."""
    E0, Einf, tau, alpha = zener.parameters
    return (f"zener: {E0.describe(1e6, 'MPa')}, {Einf.describe(1e6, 'MPa')}, {tau.describe(1e-3, 'ms')}, "
            f"{alpha.describe()}, residual {zener.residual_rms:.2%}")


def material_warnings(fit, zener=None) -> tuple[str, ...]:
    """The warnings of the constant-modulus fit, then the Zener fit's; with ``--zener`` the misfit's advice
    (:data:`~jointid.methods.direct.material_fit.MISFIT_REMEDY`) points to the Zener fit instead."""
    from ..methods.direct.material_fit import MATERIAL_MISFIT_RMS, MISFIT_REMEDY

    if zener is None:
        return tuple(fit.warnings)
    if zener.identified and zener.residual_rms <= MATERIAL_MISFIT_RMS:
        instead = f"the fractional Zener fit describes them (residual {zener.residual_rms:.1%}; the zener: line)"
    else:
        instead = f"the fractional Zener fit is not identified either (residual {zener.residual_rms:.0%})"
    return tuple(w.replace(MISFIT_REMEDY, instead) for w in fit.warnings) + tuple(zener.warnings)


def _write_example(args) -> int:
    """``--example OUT.csv``: write the built-in example step-sine data.

    Written through :class:`~jointid.io.output_dir.OutputSet` in OUT.csv's
    directory, like every output: a second run replaces the file jointid wrote
    (listed in that directory's manifest, unchanged since), and a file jointid
    did not write (or that was edited) is refused. Each example file name is
    its own set, so writing ``a.csv`` then ``b.csv`` keeps both.
    """
    from ..io.output_dir import OutputError
    from ..measurement.stepsine import write_stepsine_csv
    from ..measurement.stepsine_synth import EXAMPLE, example_stepsine

    if args.data is not None or args.out is not None:
        raise DataError("--example OUT.csv writes example data only; run `jointid direct OUT.csv --out DIR` on it afterwards")
    target = Path(args.example)
    if not target.name or target.name in (".", "..") or target.is_dir():
        raise DataError(f"--example {args.example}: give a file name, e.g. --example example.csv")
    if target.name.startswith(".jointid"):
        raise DataError(f"--example {args.example}: names starting with '.jointid' are jointid's own; give another file name")
    blocks = example_stepsine()
    try:
        with OutputSet(target.parent, command=f"direct --example {target.name}") as out:
            path = out.write_file(target.name, lambda p: write_stepsine_csv(p, blocks))
    except OutputError as exc:  # OutputSet speaks of --out DIR; here the user gave --example FILE
        msg = str(exc).replace("choose another --out", "give --example another file name").replace(f"--out {target.parent}", f"--example {args.example}: {target.parent}")
        raise OutputError(msg) from None
    e = EXAMPLE
    print(
        f"direct: wrote example step-sine data to {path} (Material {e['material']}: E 8.8 MPa, eta 0.15, rho 1100 kg/m^3; "
        f"{e['start_hz']:g}-{e['stop_hz']:g} Hz every {e['step_hz']:g} Hz, {e['amplitude_m']:g} m peak, "
        f"{e['parallel_joints']} joints, {e['noise']:.0%} noise); next: jointid direct {path} --out DIR"
    )
    return 0
