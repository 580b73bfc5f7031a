"""``jointid campaign``: many tests (temperatures, amplitudes, preloads, specimens) from one manifest.

Exit codes: 0 every test processed; 1 some tests failed (listed in ``DIR/campaign.json``
with a one-line reason each, printed on stderr; the others are written); 2 bad input
(manifest, missing file, ``--out``, ``--scheduler``), before anything is computed.
Heavy imports happen inside :func:`run` (``jointid --help`` stays fast).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .common import OUT_HELP, add_column_arguments, out_dir, quantity_pairs

__all__ = ["add_parser", "run", "MAX_PRINTED_NOTES", "master_curve_coverage"]

#: Most findings printed on the terminal (all are in ``campaign.json`` and the report).
MAX_PRINTED_NOTES = 20


def add_parser(sub) -> None:
    """Register the ``campaign`` subcommand on an argparse subparsers object."""
    p = sub.add_parser(
        "campaign",
        help="a test campaign: many direct (and inverse) tests from a manifest -> one results table, master curves, report",
        description="Process every test of MANIFEST.csv (one row per test: file, specimen, temperature_c, amplitude_m, "
        "preload_n; optional kind = direct|identify, study, parallel_joints; free columns are carried into the tables) "
        "on every core (or a Dask cluster with --scheduler) and write DIR/results.parquet and .csv (one row per test "
        "and frequency line), DIR/tests.parquet and .csv (one row per test), master_curve.json (time-temperature "
        "superposition per specimen: shift factors, WLF, Arrhenius, fitted modulus), amplitude/preload fits, "
        "campaign.json ({tests, computed, reused, failed, findings}) and report.html. Resumable: each test's result is stored "
        "under DIR/.jointid-cache as it finishes; a re-run computes only what is missing or changed. Exit code 1 when "
        "some tests failed (the others are written), 2 on bad input.",
    )
    p.add_argument("manifest", type=Path, metavar="MANIFEST.csv", help="the campaign manifest (CSV, one row per test)")
    p.add_argument("--out", required=True, type=out_dir, metavar="DIR", help=OUT_HELP)
    p.add_argument("--workers", type=int, default=None, metavar="N", help="local worker processes (default: every core; 1: no pool)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the tests on an existing Dask distributed cluster (e.g. tcp://host:8786; pip install 'jointid[dask]')")
    p.add_argument("--reference-temperature", type=float, default=None, metavar="C",
                   help="reference temperature of the master curves, C (default: per specimen, the tested one nearest the median)")
    p.add_argument("--vertical-shift", action="store_true", help="also shift the master curves vertically (density-temperature factor)")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="flag step-sine lines whose achieved amplitude is off by more than this fraction (default 0.05)")
    add_column_arguments(p)  # every direct test's file read so (as jointid direct reads one)
    p.add_argument("--no-plots", action="store_true", help="no figures (the report has the tables only)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``jointid campaign``; returns 0, or 1 when some tests failed."""
    import math

    from ..campaign.driver import CampaignOptions, run_campaign
    from ..campaign.tasks import ProcessingOptions
    from ..errors import DataError

    if not (math.isfinite(args.tolerance) and args.tolerance > 0):
        raise DataError(f"--tolerance must be a positive fraction (e.g. 0.05), got {args.tolerance}")
    if args.reference_temperature is not None and not (math.isfinite(args.reference_temperature) and args.reference_temperature > -273.15):
        raise DataError(f"--reference-temperature must be a temperature in degrees C, got {args.reference_temperature}")
    from ..measurement.stepsine import DEFAULT_COLUMNS

    columns = tuple(sorted(quantity_pairs(args.column, "column", False).items()))
    scale = tuple(sorted(quantity_pairs(args.scale, "scale", True).items()))
    for what, pairs in (("column", columns), ("scale", scale)):  # before any test is read (each would fail alike)
        unknown = [k for k, _ in pairs if k not in DEFAULT_COLUMNS]
        if unknown:
            raise DataError(f"--{what} {unknown[0]}=...: unknown quantity; expected one of {', '.join(DEFAULT_COLUMNS)}")
    processing = ProcessingOptions(tolerance=args.tolerance, columns=columns, scale=scale)
    options = CampaignOptions(processing=processing, reference_temperature_c=args.reference_temperature,
                              vertical_shift=args.vertical_shift, plots=not args.no_plots)
    result = run_campaign(args.manifest, args.out, options, workers=args.workers, scheduler=args.scheduler)
    s = result.summary
    notes = s["findings"]  # campaign.json's, same text
    for finding in notes[:MAX_PRINTED_NOTES]:
        print(f"jointid campaign: note: {finding}", file=sys.stderr)
    if len(notes) > MAX_PRINTED_NOTES:
        print(f"jointid campaign: note: ... and {len(notes) - MAX_PRINTED_NOTES} more in {args.out}/campaign.json (findings) "
              "and report.html", file=sys.stderr)
    for f in s["failed"]:
        print(f"jointid campaign: test failed: {args.manifest}: row {f['row']} ({f['file']}): {f['reason']}", file=sys.stderr)
    curves = sum(a.master_curve is not None for a in result.analysis.values())
    partial = master_curve_coverage(result)
    print(f"campaign: {s['tests']} tests ({s['computed']} computed, {s['reused']} reused, {len(s['failed'])} failed), "
          f"{curves} master curve(s){f' ({partial}; see the notes)' if partial else ''}; wrote {args.out}/results.parquet, tests.parquet, master_curve.json, campaign.json, report.html")
    return 1 if s["failed"] else 0


def master_curve_coverage(result) -> str:
    """The specimens whose master curve superposes fewer temperatures than were tested, for the summary line.

    Parameters
    ----------
    result : jointid.campaign.CampaignResult

    Returns
    -------
    str
        ``"specimen A: 1 of 4 temperatures superposed"`` (``, `` between specimens), or ``""`` when every master
        curve holds every temperature tested at its reference amplitude and preload.
    """
    parts = []
    for specimen, a in result.analysis.items():
        if a.master_curve is None:
            continue
        tested = {t.temperature_c for t in result.manifest.tests if t.kind == "direct" and t.specimen == specimen
                  and (t.amplitude_m, t.preload_n) == (a.reference_amplitude_m, a.reference_preload_n)}
        used = len(a.master_curve.shift_factors)
        if used < len(tested):
            parts.append(f"specimen {specimen}: {used} of {len(tested)} temperatures superposed")
    return ", ".join(parts)
