"""Robust identification (default) against plain Hong & Lee on noisy FRFs: errors per term, band coverage, flags.

Prints, for Materials A and B and the joint at mid-span (node 10) and at the
beam end (node 1), Model 3 layout, 100-1000 Hz:

1. the virtual roving-hammer experiment (periodic hits, 5 averages, H1 with
   coherence): once with 1 % response noise only, once with the benchmark's
   1 % response and 1 % force noise;
2. ``--seeds N`` realizations (default 50) of 1 % complex relative noise on exact
   FRFs: median and 90th-percentile error per term, and the fraction of lines whose
   truth lies within +-1.645 sigma (real and imaginary part) per term.

Medians of the relative error per line. The error, noise and coverage helpers are
those of ``jointid reproduce``'s noise-robustness study
(:mod:`jointid.studies.noise_robustness`). Not a test: run
``python benchmarks/robust_identification.py [--seeds 50]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.methods.inverse import InverseOptions
from jointid.pipeline import experiment, identify, simulate
from jointid.studies.common import add_noise
from jointid.studies.noise_robustness import TERMS, term_errors, within_band


def study(material: str, node: int, **experiment_settings):
    st = benchmark_study()
    joint = dataclasses.replace(st.joint, node=node, model=dataclasses.replace(st.joint.model, parameters={"material": material}))
    st = dataclasses.replace(st, joint=joint, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))
    if experiment_settings:
        st = dataclasses.replace(st, experiment=dataclasses.replace(st.experiment, **experiment_settings))
    return st


def errors(K, truth):
    """Relative error per line and term (F, 3) and its median per term in %."""
    rel = term_errors(K, truth)
    return rel, list(100 * np.median(rel, axis=0))


def fmt(v):
    return " / ".join(f"{x:.3g}" for x in v)


def experiments() -> None:
    print("virtual roving-hammer experiment (periodic, 5 averages, H1 + coherence), median error % (K_ww / K_wtheta / K_thetatheta)")
    for label, settings in (("response noise 1 %", {"force_noise": 0.0}), ("response 1 % + force 1 %", {})):
        for mat in "AB":
            for node in (10, 1):
                st = study(mat, node, **settings)
                ex = experiment(st, seed=0, periodic=True)
                frf = ex.frf.band(100, 1000)
                t = time.perf_counter()
                new = identify(st, frf)
                dt = time.perf_counter() - t
                plain = identify(st, frf, InverseOptions())
                truth = ex.truth[ex.frf.frequency.mask(100, 1000)]
                rel, e_new = errors(new.stiffness, truth)
                _, e_hl = errors(plain.stiffness, truth)
                flags = []
                for t, (_, i, j) in enumerate(TERMS):
                    ok = new.reliable_terms[:, i, j]
                    a = 100 * np.median(rel[ok, t]) if ok.any() else np.nan
                    b = 100 * np.median(rel[~ok, t]) if (~ok).any() else np.nan
                    flags.append(f"{a:.3g}|{b:.3g}")
                print(f"  {label:26s} {mat} node {node:2d}: default {fmt(e_new)}  hong-lee {fmt(e_hl)}  "
                      f"reliable|unreliable {' '.join(flags)}  ({dt:.2f} s)")


def seeds(n: int) -> None:
    print(f"\n{n} realizations of 1 % complex relative noise on exact FRFs: median / p90 error %, coverage of +-1.645 sigma (re, im)")
    for mat in "AB":
        for node in (10, 1):
            st = study(mat, node)
            test = simulate(st)
            rels, inside = [], []
            hl = []
            for s in range(n):
                frf = add_noise(test.frf, 0.01, np.random.default_rng(s))
                r = identify(st, frf)
                rels.append(term_errors(r.stiffness, test.truth))
                inside.append(within_band(r.stiffness, r.std_real, r.std_imag, test.truth))
                if s < 3:
                    hl.append(term_errors(identify(st, frf, InverseOptions()).stiffness, test.truth))
            rels, inside, hl = np.array(rels), np.array(inside), np.array(hl)  # (seeds, F, 3), (seeds, 2, F, 3)
            med = list(100 * np.median(rels, axis=(0, 1)))
            p90 = list(100 * np.percentile(rels, 90, axis=(0, 1)))
            cov = [f"{inside[:, 0, :, t].mean():.2f},{inside[:, 1, :, t].mean():.2f}" for t in range(len(TERMS))]
            hlm = list(100 * np.median(hl, axis=(0, 1)))
            print(f"  {mat} node {node:2d}: median {fmt(med)}  p90 {fmt(p90)}  coverage {' '.join(cov)}  (hong-lee median {fmt(hlm)})")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=50)
    p.add_argument("--skip-experiments", action="store_true")
    a = p.parse_args()
    if not a.skip_experiments:
        experiments()
    seeds(a.seeds)
