"""Test design (``jointid design``) on the benchmark: chosen layout vs Model 3, predicted and actual errors.

For the benchmark study (Material A, joint at mid-span, 100-1000 Hz), 7 observed
and 3 excited nodes from all 19:

1. ``design_study`` (1 % relative FRF noise): the chosen layout, its predicted
   per-line median relative standard deviation per term, Model 3's, and the search time;
2. the actual identification error (default method, median over 100-1000 Hz,
   per term) of the chosen layout and of Model 3, median over ``--seeds`` seeds:
   (a) 1 % complex relative noise on exact FRFs, (b) the virtual roving-hammer
   test ``experiment(study, seed, periodic=True)`` with response noise only,
   (c) the same with the benchmark's 1 % force noise as well.

Not a test: run ``python benchmarks/design.py [--seeds 5] [--no-hammer]``.
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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--no-hammer", action="store_true")
    args = ap.parse_args()
    base = benchmark_study()
    base = dataclasses.replace(base, frequency=dataclasses.replace(base.frequency, start=100.0))
    layouts = {"Model 3": base}
    print("design, 7 observed x 3 excited from nodes 1..19, 100-1000 Hz, 1 % noise; predicted per-line median "
          "relative std % (K_w_w / K_w_theta / K_theta_theta)")
    for model in ("relative",):
        t = time.perf_counter()
        d = design_study(base, 7, 3)
        dt = time.perf_counter() - t
        print(f"  {model:8s}: observed {d.observed} excited {d.excited}: {fmt(100 * np.array(list(d.median().values())))}"
              f"  (Model 3: {fmt(100 * np.array(list(d.median(True).values())))}); {d.evaluations} layouts in {dt:.1f} s")
        layouts["design"] = with_layout(base, d.observed, d.excited)
    cases = [("1 % relative noise on exact FRFs", synthetic)]
    if not args.no_hammer:
        cases += [("hammer test, 1 % response noise", lambda s, k: hammer(s, k, 0.0)),
                  ("hammer test, 1 % response + 1 % force noise", lambda s, k: hammer(s, k, 0.01))]
    for label, run in cases:
        print(f"{label}: actual median error % over 100-1000 Hz, median over {args.seeds} seeds (K_w_w / K_w_theta / K_theta_theta)")
        for name, st in layouts.items():
            t = time.perf_counter()
            errs = np.array([run(st, seed) for seed in range(args.seeds)])
            print(f"  {name:18s}: {fmt(np.median(errs, axis=0))}   per seed K_theta_theta: {fmt(errs[:, 2])}"
                  f"  ({(time.perf_counter() - t) / args.seeds:.1f} s a seed)", flush=True)


if __name__ == "__main__":
    main()
