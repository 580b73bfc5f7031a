"""``jointid frf``: roving-hammer time histories -> H1/H2 + coherence (UFF58), rejected hits, figure."""

from __future__ import annotations

import argparse
import math

from ..errors import DataError
from ..frf import KINDS
from .common import add_out_argument

__all__ = ["add_parser", "run", "impact_options_from_args", "parse_points", "mapping_from_args"]

#: (flag, ImpactOptions field, must be > 0 (else >= 0)) of the window options given in ms (converted x / 1000).
_MS_OPTIONS = (
    ("force_window_ms", "force_window_s", True),
    ("pretrigger_ms", "force_pretrigger_s", False),
    ("force_taper_ms", "force_taper_s", False),
    ("exp_tau_ms", "exp_tau_s", True),
)


def add_parser(sub) -> None:
    p = sub.add_parser(
        "frf",
        help="impact-hammer time histories -> H1/H2 and coherence (frf.uff), rejected hits, figure",
        description="Estimate FRFs from roving-hammer hits (.npz per excited node, long .csv, or UFF58 time records "
        ".uff/.unv/.58; layouts in jointid.measurement.impact_files): double-hit and overload checks, optional force and "
        "exponential windows (the exponential window's damping corrected mode by mode), H1 or H2 averaged over "
        "the accepted hits. Writes DIR/frf.uff (UFF58 FRF records plus coherence records), DIR/rejected_hits.csv "
        "(one row per finding: excited_dof, hit, check, channel, value, threshold, unit, time_s, reason) and "
        "DIR/frf.png (magnitude, coherence beneath). Acquisition checks: a force window that ends before the pulse is "
        "refused; a DC offset on the force (the pre-trigger mean) is subtracted and said; a hit without pre-trigger, force "
        "noise outside the pulse without --force-window-ms, responses still ringing at the record's end (leakage) and a "
        "response whose coherence is that of noise are printed, one line each.",
    )
    p.add_argument("hits", nargs="+", metavar="HITS", help="hit files (.npz, .csv, .uff/.unv/.58)")
    add_out_argument(p)
    p.add_argument("--estimator", choices=("h1", "h2"), default="h1", help="FRF estimator written (default h1)")
    p.add_argument("--kind", choices=KINDS, default="accelerance",
                   help="FRF kind written to frf.uff, converted exactly (default accelerance)")
    p.add_argument("--band-hz", nargs=2, type=float, metavar=("LO", "HI"), default=None,
                   help="output band, Hz (default: first line above 0 Hz to Nyquist)")
    p.add_argument("--force-window-ms", metavar="MS", type=float, default=None,
                   help="flat length of the force window, ms, from --pretrigger-ms before the pulse's start; it must hold the "
                        "whole pulse (default: no force window)")
    p.add_argument("--pretrigger-ms", metavar="MS", type=float, default=0.0,
                   help="start of the force window and of the exponential decay before the pulse start, ms (default 0)")
    p.add_argument("--force-taper-ms", metavar="MS", type=float, default=0.0, help="half-cosine taper on both sides of the force window, ms")
    p.add_argument("--exp-tau-ms", metavar="MS", type=float, default=None,
                   help="exponential window time constant, ms (default: no exponential window)")
    p.add_argument("--no-exp-correction", action="store_true",
                   help="keep the exponential window's added damping (default: corrected mode by mode)")
    p.add_argument("--mode-band-hz", nargs=2, type=float, action="append", metavar=("LO", "HI"), default=None,
                   help="a band around one isolated mode for the window correction, Hz (repeat; default: detected)")
    p.add_argument("--n-fft", metavar="N", type=int, default=None, help="FFT length >= samples per hit (zero padding; default: record length)")
    p.add_argument("--double-hit-fraction", metavar="X", type=float, default=0.1,
                   help="a force sample outside the main pulse above this fraction of the peak is a double hit (default 0.1)")
    p.add_argument("--force-clip-n", metavar="N", type=float, default=None, help="force channel full scale, N (overload check)")
    p.add_argument("--response-clip", metavar="X", type=float, default=None,
                   help="response channels' full scale, in the response unit (m/s^2 for accelerations)")
    p.add_argument("--overload-fraction", metavar="X", type=float, default=0.99,
                   help="a sample at this fraction of the full scale is an overload (default 0.99)")
    p.add_argument("--flat-top-samples", metavar="N", type=int, default=3,
                   help="consecutive samples at a channel's maximum that mean saturation (0: off; default 3)")
    p.add_argument("--n-nodes", metavar="N", type=int, default=None, help="number of beam nodes: a DOF outside 1..N is an error")
    p.add_argument("--axis", choices=("+Z", "-Z", "+X", "-X", "+Y", "-Y"), default=None,
                   help="UFF time records: the file's direction that is the beam's w (default +Z; write a negative one as --axis=-Y); signals along the "
                        "opposite direction are sign-flipped, other directions skipped")
    p.add_argument("--points", nargs="+", metavar="P=N", default=None,
                   help="UFF time records: file point id = model node, e.g. 1001=1 1003=3 (records at other points are skipped)")
    p.add_argument("--study", metavar="STUDY", default=None,
                   help="take the axis, point map and node count from this study's [measurement] (and [beam].nodes)")
    p.add_argument("--no-plots", action="store_true", help="skip DIR/frf.png")
    p.set_defaults(func=run)


def impact_options_from_args(args: argparse.Namespace):
    """The :class:`~jointid.measurement.impact.ImpactOptions` of the command line (ms -> s exactly as ``x / 1000``)."""
    from ..measurement.impact import ImpactOptions

    kw = {}
    for flag, field, positive in _MS_OPTIONS:
        v = getattr(args, flag)
        if v is None:
            continue
        if not (math.isfinite(v) and (v > 0 if positive else v >= 0)):
            raise DataError(f"--{flag.replace('_', '-')}: expected a number {'>' if positive else '>='} 0 (ms), got {v:g}")
        kw[field] = v / 1000.0
    if args.n_fft is not None and args.n_fft < 1:
        raise DataError(f"--n-fft: expected a positive integer, got {args.n_fft}")
    if args.n_nodes is not None and args.n_nodes < 1:
        raise DataError(f"--n-nodes: expected a positive integer, got {args.n_nodes}")
    for flag in ("band_hz", "mode_band_hz"):
        for band in ([getattr(args, flag)] if flag == "band_hz" else getattr(args, flag)) or []:
            if band is not None and not (0 <= band[0] < band[1] and math.isfinite(band[1])):
                raise DataError(f"--{flag.replace('_', '-')}: expected LO HI with 0 <= LO < HI, got {band[0]:g} {band[1]:g}")
    return ImpactOptions(
        **kw,
        correct_exponential=not args.no_exp_correction,
        mode_bands_hz=tuple(tuple(b) for b in args.mode_band_hz) if args.mode_band_hz else None,
        band_hz=tuple(args.band_hz) if args.band_hz else None,
        n_fft=args.n_fft,
        double_hit_fraction=args.double_hit_fraction,
        force_clip_n=args.force_clip_n,
        response_clip=args.response_clip,
        overload_fraction=args.overload_fraction,
        flat_top_samples=args.flat_top_samples,
    )


def parse_points(items) -> dict[int, int] | None:
    """``["1001=1", "1003=3"]`` (or comma-separated) -> {1001: 1, 1003: 3}; each point and node once."""
    if items is None:
        return None
    out: dict[int, int] = {}
    for item in (x for arg in items for x in arg.split(",") if x.strip()):
        key, sep, value = item.partition("=")
        try:
            point, node = int(key), int(value)
        except ValueError:
            point = node = 0
        if not sep or point < 1 or node < 1:
            raise DataError(f"--points: expected POINT=NODE with integers >= 1 (e.g. 1001=1), got {item!r}")
        if point in out:
            raise DataError(f"--points: point {point} is given twice")
        if node in out.values():
            other = next(k for k, v in out.items() if v == node)
            raise DataError(f"--points: points {other} and {point} both map to node {node}; map each node once")
        out[point] = node
    return out


def mapping_from_args(args: argparse.Namespace) -> tuple[dict[int, int] | None, str | None, int | None]:
    """(points, axis, n_nodes) of the command line, or of ``--study``'s ``[measurement]`` (the mapping ``identify`` uses)."""
    points = parse_points(args.points)
    if args.study is None:
        return points, args.axis or "+Z", args.n_nodes
    if args.points is not None or args.axis is not None:
        raise DataError("--study gives the axis and the point map ([measurement] axis and [measurement.points]); "
                        "drop --axis/--points or --study")
    from ..study import load_study

    study = load_study(args.study)
    m = study.measurement
    reading = study.structure.frf_reading(m)  # how the free structure's DOFs are named in files
    return m.point_map, reading.get("axis"), args.n_nodes or reading.get("n_nodes")


def run(args: argparse.Namespace) -> int:
    from ..hits import frf_from_hits
    from ..io.frf_files import write_frf
    from ..io.uff import LEAKAGE_MARK
    from ..io.output_dir import OutputSet
    from ..plots.impact import plot_impact_frf

    options = impact_options_from_args(args)
    points, axis, n_nodes = mapping_from_args(args)
    with OutputSet(args.out, command="frf") as out:  # validated and locked before computing
        result = frf_from_hits(args.hits, options, estimator=args.estimator, n_nodes=n_nodes, points=points, axis=axis)
        frf = result.frf.to(args.kind)  # fails here (one line), before any file is written, at a 0 Hz line
        rejected = result.rejected_table()
        figure = None if args.no_plots else plot_impact_frf(result.impact, args.estimator, kind=args.kind)
        for line in result.summary():
            print(line)
        for r in result.impact.rejected:
            print(f"rejected: {r.reason}")
        # every output is computed above; the files appear together when `out` commits
        # records whose response still rang at the record's end carry that mark into the file (ID line 4): identify says so
        marks = {pair: LEAKAGE_MARK for pair in result.impact.leaking}
        written = [out.write_file("frf.uff", lambda p: write_frf(p, frf, kind=args.kind, coherence=result.coherence, marks=marks))]
        written.append(out.write_csv("rejected_hits.csv", rejected))
        if figure is not None:
            written.append(out.write_figure("frf.png", figure))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0
