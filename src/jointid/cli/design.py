"""``jointid design``: choose observed and excited nodes for the best-determined joint (test design)."""

from __future__ import annotations

import argparse
import json
import math

from ..dofs import parse_dof
from ..errors import DofError, StudyError
from ..io.output_dir import OutputSet
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run", "parse_nodes", "parse_dof_labels", "parse_weights", "parse_targets", "summary_lines",
           "verdict", "target_lines", "MIN_TARGET_PERCENT"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "design",
        help="choose observed and excited nodes that minimize the predicted uncertainty of the joint terms",
        description="Search K observed and L excited nodes among the candidates (greedy forward, pairwise "
        "exchange, then the best re-ranked on every line) that minimize the predicted error of the default "
        "identification (smoothed over frequency, with and without its column calibration, for relative and "
        "additive FRF noise) over the study's band, weighted per term, for a stated FRF noise, with the study's "
        "[joint.model] as the expected joint and its [accelerometers] (on the observed nodes, they move with them); "
        "layouts predicted worse than the study's in any scenario are penalized. "
        "A [structure] study: candidates are DOFs (default: x, y, z of every node the study observes or excites), "
        "the criterion is over every [[joint]]'s own terms (named JOINT:K_x_x with several joints); for a mount of 4-6 "
        "DOFs the prediction is the Cramer-Rao bound of the joint spline fit that identifies it. --target says per term "
        "whether the chosen and the current layout reach a stated accuracy, --monte-carlo N confirms it by the "
        "identification itself on N noise realizations. "
        "Writes DIR/design.json (chosen and current layout, median predicted relative error per term and scenario) "
        "and DIR/design.png (per-term predicted relative error vs frequency, both layouts); prints a progress line per "
        "step of the search, then per term the chosen and current layout's figures and which is better. "
        "See jointid.methods.design.layout.",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.add_argument("--observed", type=int, default=None, metavar="K",
                   help="observed nodes, or DOFs of a [structure] study (default: as in the study)")
    p.add_argument("--excited", type=int, default=None, metavar="L",
                   help="excited nodes, or DOFs of a [structure] study (default: as in the study)")
    p.add_argument("--candidates", default=None, metavar="NODES",
                   help="nodes that may be observed or excited, e.g. 1..19 or 1,3,5..9 (default: every beam node); "
                        "a [structure] study: DOF labels, e.g. 12x,12y,40z (default: x, y, z of the study's "
                        "observed and excited nodes; at most 300)")
    p.add_argument("--noise", type=float, default=0.01, help="relative 1-sigma FRF noise (default 0.01 = 1 %%)")
    p.add_argument("--weights", default=None, metavar="TERM=W,...",
                   help="term weights, e.g. K_theta_theta=4 (default 1 each; 0 ignores a term)")
    p.add_argument("--band-hz", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="band (default: [frequency] start..stop)")
    p.add_argument("--search-lines", type=int, default=300, metavar="N",
                   help="lines of the search grid, spread over the band (default 300)")
    p.add_argument("--target", default=None, metavar="TERM=PCT,...",
                   help="target median relative error per term, in PERCENT (0.2 means 0.2 %%; each in [0.01, 100]), "
                        "e.g. K_x_x=0.2,K_rx_rx=5 -- unlike the study's [identification.targets], which are fractions "
                        "(0.002 = 0.2 %%) and are used when --target is not given: says per term whether the chosen and "
                        "the current layout reach it (predicted, and with --monte-carlo confirmed)")
    p.add_argument("--monte-carlo", type=int, default=0, metavar="N",
                   help="check the best layouts and the current one by the identification itself on N noise "
                        "realizations per noise model (default 0: prediction only)")
    p.add_argument("--no-plots", action="store_true", help="skip the figure")
    p.set_defaults(func=run)


def parse_nodes(text: str) -> list[int]:
    """``"1..19"`` or ``"1,3,5..9"`` -> node numbers (in order, without repeats)."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        lo, sep, hi = part.partition("..")
        try:
            nodes = range(int(lo), int(hi) + 1) if sep else [int(part)]
        except ValueError:
            raise StudyError(f"--candidates: expected node numbers and ranges like 1..19 or 1,3,5..9, got {text!r}") from None
        if sep and int(hi) < int(lo):
            raise StudyError(f"--candidates: the range {part} is empty; write low..high")
        out.extend(nodes)
    return list(dict.fromkeys(out))


def parse_dof_labels(text: str) -> list:
    """``"12x,12y,40z"`` -> DOFs (in order, without repeats)."""
    try:
        return list(dict.fromkeys(parse_dof(part.strip()) for part in text.split(",")))
    except DofError as exc:
        raise StudyError(f"--candidates: {exc}") from None


def parse_weights(text: str, option: str = "--weights", example: str = "K_theta_theta=4,K_w_w=1") -> dict[str, float]:
    """``"K_theta_theta=4,K_w_w=1"`` -> ``{"K_theta_theta": 4.0, "K_w_w": 1.0}`` (``option`` names the flag in errors)."""
    out: dict[str, float] = {}
    for part in text.split(","):
        name, sep, value = part.strip().partition("=")
        try:
            if not sep:
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise StudyError(f"{option}: expected TERM={'WEIGHT' if option == '--weights' else 'PERCENT'} pairs like "
                             f"{example}, got {text!r}") from None
    return out


#: Smallest ``--target``, percent: a smaller value is a fraction given where a percentage is expected.
MIN_TARGET_PERCENT = 0.01


def parse_targets(text: str) -> dict[str, float]:
    """``"K_x_x=0.2,K_rx_rx=5"`` (percent) -> ``{"K_x_x": 0.002, "K_rx_rx": 0.05}`` (relative).

    Each value is a percentage in ``[MIN_TARGET_PERCENT, 100]``. A value below
    :data:`MIN_TARGET_PERCENT` (0.01 %) is refused as a fraction written where a
    percentage is expected (``K_x_x=0.002`` copied from ``[identification.targets]``,
    which is a fraction: 0.002 = 0.2 %); no identification reaches 1e-4 anyway.

    Raises
    ------
    StudyError
        Not ``TERM=PERCENT`` pairs, a value outside (0, 100], or below 0.01 (one line each).
    """
    out = parse_weights(text, "--target", "K_x_x=0.2,K_rx_rx=5")
    for name, value in out.items():
        if not (math.isfinite(value) and 0 < value <= 100):
            raise StudyError(f"--target: {name}={value:g}; expected a percentage in (0, 100], e.g. {name}=5")
        if value < MIN_TARGET_PERCENT:
            raise StudyError(f"--target: {name}={value:g} would be {value:g} %, below {MIN_TARGET_PERCENT:g} %: --target is "
                             f"in percent (0.2 means 0.2 %); [identification.targets] is a fraction; for {100 * value:g} % "
                             f"give {name}={100 * value:g}")
    return {name: value / 100.0 for name, value in out.items()}


def run(args: argparse.Namespace) -> int:
    from ..design import design_study

    study = study_from_args(args)
    parse = parse_nodes if study.beam is not None else parse_dof_labels  # the beam shorthand: nodes
    candidates = parse(args.candidates) if args.candidates is not None else None
    weights = parse_weights(args.weights) if args.weights is not None else None
    targets = parse_targets(args.target) if args.target is not None else None
    if args.monte_carlo < 0:
        raise StudyError(f"--monte-carlo: expected a number of realizations >= 0, got {args.monte_carlo}")
    if not (math.isfinite(args.noise) and args.noise > 0):
        raise StudyError(f"--noise: expected a relative FRF noise level > 0 (0.01 = 1 %), got {args.noise:g}")
    goals = "" if targets is None else " for targets " + ", ".join(f"{t} {100 * v:g} %" for t, v in targets.items())
    header = (f"design: searching {args.observed or len(study.measurement.observed)} observed x "
              f"{args.excited or len(study.measurement.excited)} excited{goals} ...")
    started: list = []

    def progress(text: str) -> None:  # one line per step, flushed: visible in a log as well as on a terminal
        if not started:  # the header once the search runs: every option is checked by then (an error prints nothing here)
            started.append(header)
            print(header, flush=True)
        print(f"  {text}", flush=True)

    with OutputSet(args.out, command="design") as out:  # --out checked and locked before anything is printed
        d = design_study(
            study, args.observed, args.excited, candidates=candidates, noise=args.noise, weights=weights,
            band_hz=tuple(args.band_hz) if args.band_hz else None, search_lines=args.search_lines, progress=progress,
            monte_carlo=args.monte_carlo, targets=targets,
        )
        summary = d.to_dict()
        summary["study"] = str(study.source)
        path = out.write_text("design.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
        if not args.no_plots:
            out.write_figure("design.png", d.plot())
    for text in summary_lines(d):
        print(text)
    print(f"searched {d.evaluations} layouts on {d.search_lines} lines in {d.seconds:.1f} s; wrote {path}")
    return 0


def verdict(chosen: float, current: float) -> str:
    """``"better"``, ``"worse"`` or ``"same"`` (within 1 %) for a predicted error, chosen vs current layout."""
    if not (math.isfinite(chosen) and math.isfinite(current)) or current <= 0:
        return "not comparable"
    r = chosen / current
    if abs(r - 1) <= 0.01:
        return "same"
    return f"better ({1 / r:.2g}x lower)" if r < 1 else f"worse ({r:.2g}x higher)"


def target_lines(d) -> list[str]:
    """Per targeted term: the target, and whether the chosen and the current layout reach it (predicted, Monte Carlo)."""
    rows = d.target_report()
    if not rows:
        return []

    def pct(x):
        return "n/a" if x is None else f"{100 * x:.3g} %"

    def one(name, r):
        mc = f", Monte Carlo {pct(r['monte_carlo'])}" if r["monte_carlo"] is not None else ""
        return f"{name} {pct(r['predicted'])}{mc}: {'reaches it' if r['reaches'] else 'does NOT reach it'}"

    out = ["targets (median relative error; predicted" + (", and the identification on "
           f"{d.monte_carlo} noise realizations per noise model, the worse of them" if d.monte_carlo else "") + "):"]
    for r in rows:
        parts = [one("chosen", r["chosen"])] + ([one("current", r["current"])] if r["current"] is not None else [])
        out.append(f"  {r['term']:16s} target {pct(r['target'])}: " + "; ".join(parts))
    missed = [r["term"] for r in rows if not r["chosen"]["reaches"]]
    if missed:
        out.append(f"  no layout of {len(d.observed)} observed x {len(d.excited)} excited found reaches {', '.join(missed)}: "
                   "allow more candidates or more observed/excited (--observed, --excited), or accept a wider target")
    return out


def summary_lines(d) -> list[str]:
    """The printout: both layouts, then per term the chosen and current layout's figures and which is better."""
    def nodes(x):
        return ",".join(map(str, x))

    out = [f"predicted median relative error of the identification, {100 * d.noise:g} % FRF noise, "
           f"{d.frequency.hz[0]:g}-{d.frequency.hz[-1]:g} Hz (geometric mean over the scenarios):",
           f"  chosen layout : observed {nodes(d.observed)}; excited {nodes(d.excited)}"]
    if d.current_observed is None:
        out += [f"  {t:16s} chosen {100 * v:.3g} %" for t, v in d.median().items()]
        return out + target_lines(d)
    same = (tuple(sorted(map(str, d.observed))), tuple(sorted(map(str, d.excited)))) == (
        tuple(sorted(map(str, d.current_observed))), tuple(sorted(map(str, d.current_excited))))
    out.append(f"  current layout: observed {nodes(d.current_observed)}; excited {nodes(d.current_excited)}"
               + ("  (the study's; the search found none predicted better)" if same else "  (the study's)"))
    cur, cur_sc = d.median(True), d.scenario_medians(True)
    out.append(f"  {'term':16s} {'chosen':>9s} {'current':>9s}  chosen layout is")
    for t, v in d.median().items():
        note = "" if d.weights.get(t, 1) > 0 else "  (weight 0: not a design target)"
        out.append(f"  {t:16s} {100 * v:8.3g} % {100 * cur[t]:8.3g} %  {verdict(v, cur[t])}{note}")
    out.append("  per scenario, chosen (current):")
    for name, med in d.scenario_medians().items():
        terms = ", ".join(f"{t} {100 * v:.3g} % ({100 * cur_sc[name][t]:.3g} %)" for t, v in med.items()
                          if d.weights.get(t, 1) > 0)
        out.append(f"    {name}: {terms}")
    return out + target_lines(d)
