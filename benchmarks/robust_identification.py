"""Robust identification (default) against plain Hong & Lee on noisy FRFs: errors per term, band coverage, flags.

Prints, for Materials A and B and the joint at mid-span (node 10) and at the
beam end (node 1), Model 3 layout, 100-1000 Hz:

1. the virtual roving-hammer experiment (periodic hits, 5 averages, H1 with
   coherence): once with 1 % response noise only, once with the benchmark's
   1 % response and 1 % force noise;
2. ``--seeds N`` realizations (default 50) of 1 % complex relative noise on exact
   FRFs: median and 90th-percentile error per term, and the fraction of lines whose
   truth lies within +-1.645 sigma (real and imaginary part) per term;
3. ``--hammer-seeds N`` realizations of the virtual hammer test (1 % response
   noise and ``--force-noise`` of the peak force, default 1 %): the same figures,
   and the median error of lines flagged reliable and unreliable per term.

``--cases A10,B1`` restricts the cases (material and joint node), to split a long
run over processes.

Medians of the relative error per line. The error, noise and coverage helpers are
those of ``jointid reproduce``'s noise-robustness study
(:mod:`jointid.reproduce.noise_robustness`). Not a test: run
``python benchmarks/robust_identification.py [--seeds 50]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from jointid.dofs import Dof

from jointid.benchmark import benchmark_study
from jointid.methods.hong_lee.inverse import InverseOptions
from jointid.pipeline import experiment, identify, simulate
from jointid.reproduce.common import add_noise
from jointid.reproduce.noise_robustness import TERMS, term_errors, within_band


def study(material: str, node: int, **experiment_settings):
    st = benchmark_study()
    joint = dataclasses.replace(st.joint, dofs=tuple(Dof(node, d.direction) for d in st.joint.dofs), model=dataclasses.replace(st.joint.model, parameters={"material": material}))
    st = dataclasses.replace(st, joints=(joint,), frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))
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
                plain = identify(st, frf, InverseOptions(weighting="none"))
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


CASES = tuple((mat, node) for mat in "AB" for node in (10, 1))


def _realizations(st, n, hammer):
    """``(frf, truth)`` of ``n`` noise realizations: 1 % relative noise on exact FRFs, or virtual hammer tests."""
    if not hammer:
        test = simulate(st)
        for s in range(n):
            yield add_noise(test.frf, 0.01, np.random.default_rng(s)), test.truth
        return
    for s in range(n):
        ex = experiment(st, seed=s, periodic=True)
        yield ex.frf.band(100, 1000), ex.truth[ex.frf.frequency.mask(100, 1000)]


def seeds(n: int, cases=CASES, hammer: bool = False, force_noise: float = 0.01) -> None:
    what = (f"virtual hammer tests (1 % response + {100 * force_noise:g} % force noise)" if hammer
            else "1 % complex relative noise on exact FRFs")
    print(f"\n{n} realizations of {what}: median / p90 error %, coverage of +-1.645 sigma (re, im), "
          "median error % of lines flagged reliable | unreliable", flush=True)
    for mat, node in cases:
        st = study(mat, node, **({"force_noise": force_noise} if hammer else {}))
        rels, inside, hl, flags, used, secs = [], [], [], [], [], []
        for s, (frf, truth) in enumerate(_realizations(st, n, hammer)):
            t = time.perf_counter()
            r = identify(st, frf)
            secs.append(time.perf_counter() - t)
            used.append(r.estimator)
            rels.append(term_errors(r.stiffness, truth))
            inside.append(within_band(r.stiffness, r.std_real, r.std_imag, truth))
            flags.append(np.stack([r.reliable_terms[:, i, j] for _, i, j in TERMS], axis=-1))
            if s < 3:
                hl.append(term_errors(identify(st, frf, InverseOptions(weighting="none")).stiffness, truth))
        rels, inside, hl, flags = np.array(rels), np.array(inside), np.array(hl), np.array(flags)  # (seeds, F, 3), (seeds, 2, F, 3)
        med = list(100 * np.median(np.median(rels, axis=1), axis=0))
        p90 = list(100 * np.percentile(rels, 90, axis=(0, 1)))
        cov = [f"{inside[:, 0, :, t].mean():.2f},{inside[:, 1, :, t].mean():.2f}" for t in range(len(TERMS))]
        hlm = list(100 * np.median(hl, axis=(0, 1)))
        ru = []
        for t in range(len(TERMS)):
            ok = flags[..., t]
            a = 100 * np.median(rels[..., t][ok]) if ok.any() else np.nan
            b = 100 * np.median(rels[..., t][~ok]) if (~ok).any() else np.nan
            ru.append(f"{a:.3g}|{b:.3g}")
        kinds = {k: used.count(k) for k in sorted(set(used))}
        print(f"  {mat} node {node:2d}: median {fmt(med)}  p90 {fmt(p90)}  coverage {' '.join(cov)}  flags {' '.join(ru)}  "
              f"(hong-lee median {fmt(hlm)}; estimator {kinds}; {np.median(secs):.1f} s each)", flush=True)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=50)
    p.add_argument("--hammer-seeds", type=int, default=0)
    p.add_argument("--cases", default=",".join(f"{m}{n}" for m, n in CASES), help="e.g. A10,B1")
    p.add_argument("--skip-experiments", action="store_true")
    p.add_argument("--force-noise", type=float, default=0.01, help="of the peak force, for --hammer-seeds (0: response noise only)")
    a = p.parse_args()
    cases = [(c[0], int(c[1:])) for c in a.cases.split(",")]
    if not a.skip_experiments:
        experiments()
    if a.seeds:
        seeds(a.seeds, cases)
    if a.hammer_seeds:
        seeds(a.hammer_seeds, cases, hammer=True, force_noise=a.force_noise)
