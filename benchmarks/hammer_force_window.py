"""Virtual roving-hammer tests with a short force window: how honest the default identification is, 16 vs 16/32/64 functions.

Case: the benchmark study (beam, joint at mid-span, Material A, Model 3 layout with the
accelerometers, 5-1000 Hz; ``--study PATH`` for another). Each realization (one noise seed)
is the path a user takes:

1. time records: :func:`jointid.measurement.virtual_hammer.simulate_hits` on the test article
   (:func:`jointid.models.constrained_model`), ``HammerSettings(duration=2, averages=20,
   force_noise=--force-noise, response_noise=--response-noise)`` (a transient test, default
   pulse, no exponential window);
2. FRFs as ``jointid frf HITS --study STUDY --force-window-ms MS`` makes them
   (:func:`jointid.hits.frf_from_hits`, H1 with coherence, accelerance; the records are passed
   in memory, not written to .npz and frf.uff); ``--force-window-ms 0``: no force window;
3. :func:`jointid.pipeline.identify` with the study's options
   (:func:`jointid.pipeline.coupling_options`) in two variants: ``16``, the column calibration
   with 16 B-spline functions per excitation column (``calibration_basis=16``, what jointid did
   before), and ``default``, the data choosing 16, 32 or 64
   (:data:`jointid.methods.receptance.column_calibration.CALIBRATION_BASES`);
4. truth: the study's true joint on the identified lines
   (:func:`jointid.models.true_joint_matrix`).

Per realization, variant and term (K_ww, K_wtheta, K_thetatheta): the median relative error
over all lines, the fraction of lines flagged reliable (``reliable_terms``), the median error of
the reliable lines, the 90 % band coverage on the reliable lines (real and imaginary parts
pooled, :func:`jointid.reproduce.noise_robustness.within_band`), the fraction of reliable lines
with the truth more than 3 sigma off (real or imaginary part), the median |error| / sigma of
the reliable lines (sigma: ``hypot(std_real, std_imag)``; about 0.83 for a right band with
Gaussian errors, far below 1: a band wider than the error) and the calibration's ``n_basis``. Printed: medians over the seeds (the 3-sigma fraction also as its worst seed and
the seeds above 10 %), the distribution of the chosen ``n_basis``, the findings with their
counts, and one line per seed.

Not a test: ``nice python benchmarks/hammer_force_window.py [--seeds 20] [--force-window-ms 10]
[--force-noise 0.02] [--jobs 2]`` (one realization: ~20 s of simulated hits and ~15 s of
identification on one core).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import time
from collections import Counter

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.hits import frf_from_hits
from jointid.measurement.impact import ImpactOptions, ImpactRecord
from jointid.measurement.virtual_hammer import HammerSettings, simulate_hits
from jointid.models import constrained_model, true_joint_matrix
from jointid.parallel import map_processes
from jointid.pipeline import coupling_options, identify
from jointid.reproduce.noise_robustness import TERMS, term_errors, within_band
from jointid.study import load_study

#: Variant label -> ``calibration_basis`` (None: the study's option, the default tuple).
VARIANTS = {"16": 16, "default": None}
#: Columns of a term's row (per realization and variant).
COLUMNS = ("median error %", "reliable", "median error reliable %", "coverage reliable", "> 3 sigma reliable",
           "median |error| / sigma reliable")


def load(path: str | None):
    return benchmark_study() if path is None else load_study(path)


def finding(text: str) -> str:
    """A finding without its numbers in parentheses and its bands (to count it over seeds)."""
    while True:  # innermost parentheses first
        text, n = re.subn(r"\s*\([^()]*\)", "", text)
        if not n:
            break
    if "not identifiable" in text:
        text = text.split(" in ")[0]
    return text[:110]


def realization(path: str | None, seed: int, window_ms: float, force_noise: float, response_noise: float) -> dict:
    """One seed: {variant: (rows (3 terms, len(COLUMNS)), n_basis (0: no calibration estimated), applied, structured accepted,
    findings)}."""
    study = load(path)
    m = study.measurement
    settings = HammerSettings(duration=2.0, averages=20, force_noise=force_noise, response_noise=response_noise)
    hits = simulate_hits(constrained_model(study), m.observed_dofs, m.excited_dofs, settings, np.random.default_rng(seed))
    records = [ImpactRecord(h.force, h.responses, h.sample_rate, tuple(h.response_dofs), h.reference) for h in hits]
    # `jointid frf --force-window-ms MS`: ImpactOptions(force_window_s=MS / 1000), H1, written as accelerance
    options = ImpactOptions(force_window_s=window_ms / 1000.0 if window_ms > 0 else None)
    frf = frf_from_hits(records, options, "h1").frf.to("accelerance")
    base = coupling_options(study)
    out = {}
    for label, basis in VARIANTS.items():
        r = identify(study, frf, base if basis is None else dataclasses.replace(base, calibration_basis=basis))
        truth = true_joint_matrix(study, r.frequency.hz)
        rel = term_errors(r.stiffness, truth)
        inside = within_band(r.stiffness, r.std_real, r.std_imag, truth)  # (2, F, 3)
        far = ~within_band(r.stiffness, r.std_real, r.std_imag, truth, z=3.0).all(axis=0)  # (F, 3)
        rows = []
        for k, (_, i, j) in enumerate(TERMS):
            ok = r.reliable_terms[:, i, j]
            any_ = bool(ok.any())
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.abs(r.stiffness[:, i, j] - truth[:, i, j]) / np.hypot(r.std_real[:, i, j], r.std_imag[:, i, j])
            rows.append((100 * np.median(rel[:, k]), ok.mean(), 100 * np.median(rel[ok, k]) if any_ else np.nan,
                         inside[:, ok, k].mean() if any_ else np.nan, far[ok, k].mean() if any_ else 0.0,
                         np.median(z[ok]) if any_ else np.nan))
        cal = r.calibration
        st = r.structured
        out[label] = (np.array(rows), 0 if cal is None else int(cal.n_basis), bool(r.calibration_applied),
                      bool(st is not None and st.accepted), [finding(f) for f in r.findings()])
    return out


def report(results: list[dict], seeds: list[int]) -> None:
    n = len(results)
    for label in VARIANTS:
        a = np.array([res[label][0] for res in results])  # (seeds, terms, columns)
        nb = Counter(res[label][1] if res[label][2] else 0 for res in results)
        structured = sum(res[label][3] for res in results)
        print(f"\n  {label}: calibration n_basis applied "
              + ", ".join(f"{'none' if b == 0 else b}: {c}/{n}" for b, c in sorted(nb.items()))
              + f"; structured model accepted {structured}/{n}")
        for k, (name, _, _) in enumerate(TERMS):
            v = [np.nanmedian(a[:, k, c]) if np.isfinite(a[:, k, c]).any() else np.nan for c in range(len(COLUMNS))]
            far = a[:, k, 4]
            print(f"    {name:13s} median error {v[0]:7.3g} %  reliable {100 * v[1]:5.1f} %  median error reliable "
                  f"{v[2]:7.3g} %  coverage reliable {v[3]:5.2f}  > 3 sigma {100 * v[4]:5.1f} % (worst seed "
                  f"{100 * far.max():5.1f} %, seeds above 10 %: {int(np.sum(far > 0.1))})  median |error| / sigma {v[5]:6.3g}")
        notes = Counter(f for res in results for f in set(res[label][4]))
        for text, count in notes.most_common(8):
            print(f"    [{count}/{n}] {text}")
    print("\n  per seed: n_basis (default); per term median error reliable % and > 3 sigma % (16 -> default)")
    for seed, res in zip(seeds, results):
        cells = []
        for k, (name, _, _) in enumerate(TERMS):
            a, b = res["16"][0][k], res["default"][0][k]
            cells.append(f"{name} {a[2]:6.3g} -> {b[2]:6.3g} %, {100 * a[4]:4.1f} -> {100 * b[4]:4.1f}")
        nbd = res["default"][1] if res["default"][2] else 0
        print(f"    seed {seed:3d}  n {nbd:2d}  " + "  ".join(cells))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="noise realizations (seeds 0..N-1)")
    ap.add_argument("--force-window-ms", type=float, default=10.0, help="flat force window, ms (0: none)")
    ap.add_argument("--force-noise", type=float, default=0.02, help="force noise, of the peak force")
    ap.add_argument("--response-noise", type=float, default=0.02, help="response noise, of the response rms")
    ap.add_argument("--jobs", type=int, default=2, help="processes")
    ap.add_argument("--study", default=None, help="study file (default: the built-in benchmark study)")
    args = ap.parse_args()
    seeds = list(range(args.seeds))
    window = "no force window" if args.force_window_ms <= 0 else f"a {args.force_window_ms:g} ms force window"
    print(f"virtual roving-hammer test, 20 hits per node, force noise {args.force_noise:g}, response noise "
          f"{args.response_noise:g}, H1, {window}; {args.seeds} seeds; calibration_basis 16 vs default (16/32/64)")
    t = time.perf_counter()
    tasks = [(realization, (args.study, s, args.force_window_ms, args.force_noise, args.response_noise)) for s in seeds]
    results = map_processes(tasks, args.jobs)
    print(f"({time.perf_counter() - t:.0f} s)")
    report(results, seeds)


if __name__ == "__main__":
    main()
