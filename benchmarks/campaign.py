"""1000 small synthetic step-sine tests through the campaign machinery on 2 cores: throughput, memory, overhead.

    .venv/bin/python benchmarks/campaign.py [--tests 1000] [--workers 2] [--keep DIR]

Prints
* the per-test processing CPU time (reading + step-sine processing, measured in the workers);
* the wall time and throughput of the first run (every test computed on ``--workers`` processes)
  and of a second run (every test reused from the store);
* the per-test CPU time of the campaign machinery: everything the campaign spends that is not the
  processing of a test (hashing the files, the store, the pool's start-up and messages, progress,
  the results tables): (CPU of this process + CPU of the worker processes - processing CPU) / tests,
  and its ratio to the processing time (goal < 10 %). CPU times, not wall times: the machine may be
  shared. The workers are started with ``fork`` here so that their CPU time shows in
  ``RUSAGE_CHILDREN`` once the pool has shut down (``jointid campaign`` itself uses ``forkserver``);
* the peak resident memory of this process and of the largest worker.

The master curves and Kraus fits (the campaign's analysis, not its machinery) are timed separately.
The campaign: specimens x 25 temperatures x 2 amplitudes; each test is the issue's synthetic step-sine
test (``synthesize_campaign`` defaults: 10 lines log-spaced 1-100 Hz, 8.4 cycles at 32 samples per cycle,
~2700 CSV rows, ~110 kB per file). The machinery's cost per test is nearly fixed, so its ratio falls
as the tests grow: the ms figure says what it would be for other tests.
"""

from __future__ import annotations

import argparse
import io
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _cpu_self() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tests", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", type=Path, default=None, help="keep the data and outputs in this directory")
    args = ap.parse_args()

    import jointid.campaign.runner as runner
    from jointid.campaign.analysis import analyze_specimens
    from jointid.campaign.driver import campaign_summary, plan_tasks
    from jointid.campaign.manifest import read_manifest
    from jointid.campaign.store import ResultStore
    from jointid.campaign.tables import results_table, table_csv, table_parquet, tests_table
    from jointid.campaign.tasks import ProcessingOptions
    from jointid.measurement.campaign_synth import DEFAULT_FREQUENCIES_HZ, synthesize_campaign

    runner.START_METHOD = "fork"
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="jointid-campaign-bench-"))
    temps = tuple(float(t) for t in range(-20, 105, 5))  # 25 temperatures
    specimens = tuple(f"S{i}" for i in range(max(1, args.tests // (2 * len(temps)))))
    t0 = time.perf_counter()
    manifest_path = synthesize_campaign(root / "data", temperatures_c=temps, amplitudes_m=(2e-5, 6e-5),
                                        frequencies_hz=DEFAULT_FREQUENCIES_HZ, specimens=specimens, seed=0)
    manifest = read_manifest(manifest_path)
    n = len(manifest.tests)
    size = sum(t.file.stat().st_size for t in manifest.tests) / n
    print(f"campaign: {n} tests ({len(specimens)} specimens x {len(temps)} temperatures x 2 amplitudes, "
          f"{len(DEFAULT_FREQUENCIES_HZ)} lines 1-100 Hz each), "
          f"{size / 1e3:.0f} kB per file; generated in {time.perf_counter() - t0:.1f} s")

    out = root / "out"
    out.mkdir(parents=True, exist_ok=True)
    sink = io.StringIO()
    options = ProcessingOptions()

    def run() -> tuple[float, float, float, dict, object]:
        cpu0, ch0, w0 = _cpu_self(), _cpu_children(), time.perf_counter()
        tasks, sha = plan_tasks(manifest, options)
        by_key, counts = runner.execute_tasks(list(tasks.values()), ResultStore(out), workers=args.workers, stream=sink)
        outcomes = {row: by_key[t.key] for row, t in tasks.items()}
        wall_exec = time.perf_counter() - w0
        results = results_table(manifest, outcomes)
        per_test = tests_table(manifest, outcomes, None, sha)
        for table in (results, per_test):
            table_parquet(table)
            table_csv(table)
        campaign_summary(manifest, outcomes, {r for r, t in tasks.items() if t.key in counts.computed})
        wall = time.perf_counter() - w0
        print(f"  CPU: this process {_cpu_self() - cpu0:.2f} s, worker processes {_cpu_children() - ch0:.2f} s")
        return wall_exec, wall, (_cpu_self() - cpu0) + (_cpu_children() - ch0), outcomes, counts

    wall_exec, wall, cpu, outcomes, counts = run()
    processing = sum(o.seconds for o in outcomes.values())
    failed = sum(not o.ok for o in outcomes.values())
    machinery = cpu - processing
    print(f"first run ({len(counts.computed)} computed on {args.workers} worker processes, {failed} failed): "
          f"{wall_exec:.1f} s wall for the tests ({n / wall_exec:.0f} tests/s), {wall:.1f} s with the tables")
    print(f"  processing: {processing / n * 1e3:.2f} ms CPU per test (read + step-sine, in the workers)")
    print(f"  campaign machinery: {machinery / n * 1e3:.2f} ms CPU per test = {machinery / processing:.1%} of the processing "
          f"(goal < 10 %; total CPU {cpu:.1f} s)")
    print(f"  peak memory: this process {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB, "
          f"largest worker {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024:.0f} MB")

    wall_exec2, wall2, cpu2, _, counts2 = run()
    print(f"second run ({len(counts2.reused)} reused, {len(counts2.computed)} computed): {wall2:.2f} s wall, "
          f"{cpu2 / n * 1e3:.2f} ms CPU per test")

    t1, c1 = time.perf_counter(), time.process_time()
    analysis = analyze_specimens(manifest.tests, outcomes)
    curves = sum(a.master_curve is not None for a in analysis.values())
    print(f"analysis: {curves} master curves of {len(analysis)} specimens in {time.perf_counter() - t1:.1f} s wall "
          f"({time.process_time() - c1:.1f} s CPU)")
    if not args.keep:
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
