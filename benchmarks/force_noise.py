"""Force noise without coherence in the file: band coverage and findings, before and with the force-noise model.

Case (issue 26): the benchmark study (beam, joint at mid-span, Material A, Model 3 layout,
5-1000 Hz, 1 Hz step), data from a finer mesh (:data:`FINE_MESH` elements per segment:
the beam of 18 segments has ~600 elements) by :func:`jointid.pipeline.simulate`; a roving
hammer's noise per line, the force error common to each excitation column::

    H_meas[f, :, j] = H[f, :, j] (1 + n_R[f, :, j]) / (1 + n_F[f, j])

``n_R``, ``n_F`` circular complex Gaussian, rms :data:`RESPONSE_NOISE` and ``--force``
(default :data:`FORCE_NOISE`); no coherence in the file. Identified by
:func:`jointid.pipeline.identify` with the study's options (``smoothing = "auto"``: the
structured model) and with ``smoothing = "gcv"``; the per-line estimates of the first run are
reported too (flagged reliable where their own predicted relative standard deviation is at most
``max_relative_std``). ``after``: the default, with the force-noise test of
:mod:`jointid.methods.receptance.force_noise` in ``identify_joint_coupling``; ``before``: the
same with that test switched off (what jointid did before it).

Per estimator and term: the 90 % band coverage over all lines and over the lines flagged
reliable, the median error of the reliable lines, the fraction flagged reliable, the fraction
of reliable lines beyond 3 sigma and beyond 10 % error; medians over ``--seeds``; the
findings with their counts; the detection rate of the force noise (also with ``--force 0``:
the false-positive rate). ``--hammer-seeds N``: also the virtual roving-hammer test
(:func:`jointid.pipeline.experiment`, periodic, 5 averages; its response noise is a floor, not
relative) with the coherence dropped, with and without its 1 % force noise: the test's F, its
detections and the default's coverage before/after (weights of the wrong shape: the test's
false-positive margin). Not a test:
``nice python benchmarks/force_noise.py [--seeds 50] [--force 0.01] [--runs before,after] [--hammer-seeds 4]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections import Counter

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.methods.receptance import coupling as coupling_module
from jointid.methods.receptance.options import CouplingOptions
from jointid.pipeline import coupling_options, identify, simulate
from jointid.reproduce.noise_robustness import TERMS, term_errors, within_band

RESPONSE_NOISE = 0.01
FORCE_NOISE = 0.01
#: Elements per segment of the data's beam (18 segments: 594 elements; the model: the study's default mesh).
FINE_MESH = 33

#: The package's force-noise test, and every result it gave in the "after" runs (detection rate, F statistics).
DETECT = coupling_module.detect_force_noise
TESTS: list = []


def _recorded(*args, **kwargs):
    out = DETECT(*args, **kwargs)
    TESTS.append(out)
    return out


def use(after: bool) -> None:
    """``after``: ``identify_joint_coupling`` with its force-noise test (recorded); before: the test switched off."""
    coupling_module.detect_force_noise = _recorded if after else (lambda *args, **kwargs: None)


def study(**beam):
    st = benchmark_study()
    return dataclasses.replace(st, structure=dataclasses.replace(st.structure, **beam)) if beam else st


class Data:
    """The exact FRFs of the fine-mesh beam, made once."""

    def __init__(self):
        self.st = study()
        self.fine = simulate(study(elements_per_segment=FINE_MESH))

    def case(self, rng, force: float):
        """(study, measured FRF, truth): response noise per value, force noise per column and line."""
        f = self.fine.frf
        F, m, e = f.data.shape

        def cn(*shape):
            return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

        data = f.data * (1 + RESPONSE_NOISE * cn(F, m, e)) / (1 + force * cn(F, 1, e))
        return self.st, dataclasses.replace(f, data=data, coherence=None), self.fine.truth


def scores(stiffness, std_re, std_im, truth, reliable):
    """Per term: coverage (all lines), coverage (reliable), median error (reliable) %, reliable fraction,
    > 3 sigma (reliable), > 10 % error (reliable)."""
    rel = term_errors(stiffness, truth)
    inside = within_band(stiffness, std_re, std_im, truth).mean(axis=0)
    far = ~within_band(stiffness, std_re, std_im, truth, z=3.0).all(axis=0)
    rows = []
    for k, (_, i, j) in enumerate(TERMS):
        ok = reliable[:, i, j]
        any_ = ok.any()
        rows.append((inside[:, k].mean(), inside[ok, k].mean() if any_ else np.nan,
                     100 * np.median(rel[ok, k]) if any_ else np.nan, ok.mean(),
                     far[ok, k].mean() if any_ else 0.0, (rel[ok, k] > 0.1).mean() if any_ else 0.0))
    return np.array(rows)


def run(data: Data, rng, force: float, after: bool):
    """{estimator: scores} and the findings of the default run."""
    use(after)
    st, frf, truth = data.case(rng, force)
    out = {}
    TESTS.clear()
    r = identify(st, frf)
    test = TESTS[0] if TESTS else None
    out["auto"] = scores(r.stiffness, r.std_real, r.std_imag, truth, r.reliable_terms)
    s = r.per_line_std / np.sqrt(2)  # circular: half the variance in each part
    with np.errstate(divide="ignore", invalid="ignore"):  # the per-line estimates' own flags: predicted relative std
        ok = r.per_line_std / np.abs(r.per_line) <= r.options.max_relative_std
    out["per-line"] = scores(r.per_line, s, s, truth, ok)
    g = identify(st, frf, dataclasses.replace(coupling_options(st), smoothing="gcv"))
    out["gcv"] = scores(g.stiffness, g.std_real, g.std_imag, truth, g.reliable_terms)
    return out, r.findings(), test


def report(name, rows, notes, seeds, elapsed, tests=()):
    print(f"\n{name} ({seeds} seeds, {elapsed:.0f} s)")
    for est in rows[0]:
        a = np.array([r[est] for r in rows])  # (seeds, terms, 6)
        print(f"  {est}")
        for k, (label, _, _) in enumerate(TERMS):
            v = [np.nanmedian(a[:, k, c]) if np.isfinite(a[:, k, c]).any() else np.nan for c in range(6)]
            print(f"    {label:13s} coverage {v[0]:5.2f} (reliable {v[1]:5.2f})  median error {v[2]:7.3g} %  "
                  f"reliable {100 * v[3]:5.1f} %  > 3 sigma {100 * v[4]:5.1f} %  > 10 % {100 * v[5]:5.1f} %")
    for text, count in notes.most_common(8):
        print(f"  [{count}/{seeds}] {text}")
    named = sum(c for t, c in notes.items() if t.startswith("the excitation columns share"))
    print(f"  force noise named: {named}/{seeds}")
    tests = [t for t in tests if t is not None]
    if tests:
        f = np.array([t.f_statistic for t in tests])
        lv = np.array([t.level for t in tests])
        print(f"  force-noise test: detected {sum(t.significant for t in tests)}/{len(tests)}; F median {np.median(f):.3g} "
              f"(range {f.min():.3g}-{f.max():.3g}); level per column median {np.median(lv, axis=0).round(5).tolist()} "
              f"(5-95 %: {np.percentile(lv, 5):.2g}-{np.percentile(lv, 95):.2g})")


def hammer(seeds: int) -> None:
    """The virtual roving-hammer test without its coherence (module docstring)."""
    from jointid.pipeline import experiment

    base = study()
    for force in (0.0, base.experiment.force_noise):
        st = dataclasses.replace(base, experiment=dataclasses.replace(base.experiment, force_noise=force))
        t = time.perf_counter()
        print(f"\nvirtual hammer test, {100 * force:g} % force noise, coherence dropped ({seeds} seeds)")
        for seed in range(seeds):
            ex = experiment(st, seed=seed, periodic=True)
            frf = dataclasses.replace(ex.frf, coherence=None)
            cov = []
            for after in (False, True):
                use(after)
                TESTS.clear()
                r = identify(st, frf)
                cov.append(scores(r.stiffness, r.std_real, r.std_imag, ex.truth, r.reliable_terms)[:, 0])
            fn = TESTS[0]
            print(f"  seed {seed}: F {fn.f_statistic:.3g}, level {np.round(100 * fn.level, 3).tolist()} %, "
                  f"{'detected' if fn.significant else 'not detected'}; coverage before {np.round(cov[0], 2).tolist()}, "
                  f"after {np.round(cov[1], 2).tolist()}", flush=True)
        print(f"  ({time.perf_counter() - t:.0f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--force", type=float, default=FORCE_NOISE, help="force noise rms (0: only response noise)")
    ap.add_argument("--runs", default="before,after")
    ap.add_argument("--hammer-seeds", type=int, default=0)
    args = ap.parse_args()
    data = Data()
    for which in filter(None, args.runs.split(",")):
        t = time.perf_counter()
        rows, notes, tests = [], Counter(), []
        for seed in range(args.seeds):
            res, found, test = run(data, np.random.default_rng(seed), args.force, which == "after")
            rows.append(res)
            tests.append(test)
            for f in found:
                notes[f.split(" (")[0][:110]] += 1
        report(f"{which}: {100 * RESPONSE_NOISE:g} % response + {100 * args.force:g} % force noise, no coherence",
               rows, notes, args.seeds, time.perf_counter() - t, tests)
    if args.hammer_seeds:
        hammer(args.hammer_seeds)


if __name__ == "__main__":
    main()
