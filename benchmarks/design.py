"""Test design (``jointid design``) on the benchmark: chosen layout vs Model 3, predicted and actual errors.

For the benchmark study (Material A, joint at mid-span, 100-1000 Hz), 7 observed
and 3 excited nodes from all 19, the rotational term first (weights K_w_w = K_w_theta = 0):

1. ``design_study`` (1 % FRF noise, ``--mc`` Monte Carlo seeds for the final check):
   the chosen layout, its predicted median relative error per term and scenario,
   Model 3's, and the time;
2. the actual identification error (default method, median over 100-1000 Hz,
   per term) of the chosen layout and of Model 3 for seeds ``100..100+seeds-1``
   (not the design's Monte Carlo seeds 0..mc-1): (a) 1 % complex relative noise on
   exact FRFs, (b) the virtual roving-hammer test ``experiment(study, seed,
   periodic=True)`` with response noise only, (c) the same with the benchmark's
   1 % force noise as well. Printed: the median over seeds per term and K_theta_theta per seed.

With ``--default-search`` it only runs the default search of ``jointid design`` on the
benchmark study (7 x 3 of 19 nodes, 5-1000 Hz, every term weighted 1, no Monte Carlo)
and prints its wall and CPU time (this process and its workers), the layouts
evaluated and the chosen vs current layout per term.

Not a test: run ``python benchmarks/design.py [--seeds 5] [--mc 4] [--no-hammer] [--default-search]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.design import design_study, with_layout
from jointid.frf import FRF
from jointid.pipeline import experiment, identify, simulate

TERMS = [(0, 0, "K_w_w"), (0, 1, "K_w_theta"), (1, 1, "K_theta_theta")]


def fmt(v):
    return " / ".join(f"{x:.3g}" for x in v)


def median_errors(K, truth):
    rel = np.abs(K - truth) / np.abs(truth)
    return np.array([100 * np.median(rel[:, i, j]) for i, j, _ in TERMS])


def synthetic(study, seed):
    test = simulate(study)
    rng = np.random.default_rng(seed)
    d = test.frf.data
    noisy = d * (1 + 0.01 * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)) / np.sqrt(2))
    frf = FRF(test.frf.frequency, noisy, test.frf.responses, test.frf.references, test.frf.kind)
    return median_errors(identify(study, frf).stiffness, test.truth)


def hammer(study, seed, force_noise):
    st = dataclasses.replace(study, experiment=dataclasses.replace(study.experiment, force_noise=force_noise))
    ex = experiment(st, seed, periodic=True)
    return median_errors(identify(st, ex.frf.band(100, 1000)).stiffness, ex.truth)


def default_search() -> None:
    """``jointid design`` on the benchmark with the default search: time, layouts and per-term figures."""
    import os
    import resource

    from jointid.cli.design import summary_lines

    t, c = time.perf_counter(), time.process_time()
    d = design_study(benchmark_study(), progress=lambda line: print("  " + line, flush=True))
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    workers = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"default search: {d.evaluations} layouts on {d.search_lines} lines; wall {wall:.1f} s, CPU {cpu:.1f} s "
          f"in this process + {workers.ru_utime + workers.ru_stime:.1f} s in its workers ({os.cpu_count()} cores)")
    for line in summary_lines(d):
        print(line)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--mc", type=int, default=4, help="Monte Carlo seeds of the design's final check (0: none)")
    ap.add_argument("--no-hammer", action="store_true")
    ap.add_argument("--default-search", action="store_true", help="only time the default search of jointid design")
    args = ap.parse_args()
    if args.default_search:
        default_search()
        return
    base = benchmark_study()
    base = dataclasses.replace(base, frequency=dataclasses.replace(base.frequency, start=100.0))
    layouts = {"Model 3": base}
    t = time.perf_counter()
    d = design_study(base, 7, 3, weights={"K_w_w": 0, "K_w_theta": 0}, monte_carlo=args.mc)
    dt = time.perf_counter() - t
    print(f"design, 7 observed x 3 excited from nodes 1..19, 100-1000 Hz, 1 % noise, K_theta_theta first, "
          f"Monte Carlo {args.mc} seeds: observed {d.observed} excited {d.excited}; {d.evaluations} layouts in {dt:.1f} s")
    cur = d.scenario_medians(True)
    print("predicted median relative error % (K_w_w / K_w_theta / K_theta_theta), chosen vs Model 3:")
    for name, med in d.scenario_medians().items():
        print(f"  {name:34s}: {fmt(100 * np.array(list(med.values())))}   vs {fmt(100 * np.array(list(cur[name].values())))}")
    for c, o, e, med in d.checked:
        print(f"  Monte Carlo {'Model 3' if c is None else str(o) + ' ' + str(e)}: relative {fmt(100 * np.array(med[0]))}, "
              f"additive {fmt(100 * np.array(med[1]))}")
    layouts["design"] = with_layout(base, d.observed, d.excited)
    cases = [("1 % relative noise on exact FRFs", synthetic)]
    if not args.no_hammer:
        cases += [("hammer test, 1 % response noise", lambda s, k: hammer(s, k, 0.0)),
                  ("hammer test, 1 % response + 1 % force noise", lambda s, k: hammer(s, k, 0.01))]
    seeds = range(100, 100 + args.seeds)
    for label, run in cases:
        print(f"{label}: actual median error % over 100-1000 Hz, median over seeds {seeds.start}..{seeds.stop - 1} "
              "(K_w_w / K_w_theta / K_theta_theta)")
        for name, st in layouts.items():
            t = time.perf_counter()
            errs = np.array([run(st, seed) for seed in seeds])
            print(f"  {name:8s}: {fmt(np.median(errs, axis=0))}   per seed K_theta_theta: {fmt(errs[:, 2])}"
                  f"  ({(time.perf_counter() - t) / args.seeds:.1f} s a seed)", flush=True)


if __name__ == "__main__":
    main()
