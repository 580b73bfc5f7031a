"""Errors a real test has besides noise: wrong units, junk lines, a free model not updated; what the receptance method says.

Cases on the benchmark study (joint at mid-span, Material A, 5-1000 Hz, 1 Hz step), each
with 0.5 % complex relative noise on exact accelerances (``jointid.simulate``):

- ``clean``: the study's own model, no coherence;
- ``g/N unlabelled``: the FRFs divided by 9.80665 (a g/N file read as SI);
- ``g label on SI``: the FRFs times 9.80665 (a ``g`` label on values already in m/s^2);
- ``junk lines``: a study from 0 Hz with coherence ``1 / (1 + 0.005^2)`` and, on the four
  lines at 1-4 Hz, coherence 0.2 and 200 % noise;
- ``junk, coherence, no junk``: the same data without the junk lines (5-1000 Hz): the reference;
- ``wrong free model``: data from a finer mesh (16 elements per segment; the model's converged mesh has 8),
  the study's E 2 % high and density 1 % low;
- ``Euler-Bernoulli model``: the same data (a Timoshenko beam), the study's beam theory ``"euler-bernoulli"``
  (shear deformation and rotary inertia left out: a free model's error that grows with frequency);
- ``updated`` / ``updated, no [uncertainty]``: the same FRFs, identified after updating E, density and loss
  factor from a virtual free-free test of the true beam (1 % noise), with the fit's standard errors and
  correlation as ``[uncertainty]`` (what ``jointid update`` writes) and without them.

Per case and term: the median error of the lines flagged reliable, the fraction flagged
reliable, the 90 % band coverage on those lines, the fraction of reliable lines off by more
than 3 sigma, and the findings (or the refusal). Medians over ``--seeds`` noise realisations (the 3-sigma
fraction also as its mean over the seeds, its worst seed and the number of seeds above 10 %).
Not a test: ``python benchmarks/real_world_checks.py [--seeds 20] [--cases clean,junk]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections import Counter

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.errors import JointIdError
from jointid.pipeline import identify, simulate, simulate_free, update
from jointid.study import TruthSpec, UncertaintySpec
from jointid.reproduce.noise_robustness import TERMS, term_errors, within_band

NOISE = 0.005
CASES = ("clean", "gN", "gsi", "junk", "junkref", "model", "euler", "updated", "updated0")
NAMES = {"clean": "clean", "gN": "g/N unlabelled", "gsi": "g label on SI", "junk": "junk lines",
         "junkref": "junk, coherence, no junk", "model": "wrong free model", "euler": "Euler-Bernoulli model", "updated": "updated",
         "updated0": "updated, no [uncertainty]"}
TRUE_MESH = 16


def study(start: float = 5.0, **beam):
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=start, stop=1000.0, step=1.0))
    return dataclasses.replace(st, structure=dataclasses.replace(st.structure, **beam)) if beam else st


def noisy(frf, rng, coherence=False):
    z = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2)
    coh = np.full(frf.data.shape, 1 / (1 + NOISE ** 2)) if coherence else None
    return dataclasses.replace(frf, data=frf.data * (1 + NOISE * z), coherence=coh)


class Data:
    """The exact FRFs of each case's test article, made once."""

    def __init__(self):
        self.st = study()
        self.vt = simulate(self.st)
        self.st0 = study(start=0.0)
        self.vt0 = simulate(self.st0)
        self.fine = simulate(study(elements_per_segment=TRUE_MESH))
        b = self.st.structure
        self.true = {"elastic_modulus": b.elastic_modulus, "density": b.density}
        self.wrong = study(elastic_modulus=b.elastic_modulus * 1.02, density=b.density * 0.99)
        self.euler = study(theory="euler-bernoulli")

    def case(self, name, rng):
        """(study, measured FRF, truth on the FRF's lines)."""
        if name in ("clean", "gN", "gsi"):
            f = noisy(self.vt.frf, rng)
            scale = {"clean": 1.0, "gN": 1 / 9.80665, "gsi": 9.80665}[name]
            return self.st, dataclasses.replace(f, data=f.data * scale), self.vt.truth
        if name in ("junk", "junkref"):
            v = self.vt0
            f = noisy(v.frf, rng, coherence=True)
            hz = v.frf.frequency.hz
            bad = (hz >= 1) & (hz <= 4)
            d, coh = f.data.copy(), f.coherence.copy()
            z = (rng.standard_normal(d[bad].shape) + 1j * rng.standard_normal(d[bad].shape)) / np.sqrt(2)
            d[bad], coh[bad] = v.frf.data[bad] * (1 + 2.0 * z), 0.2
            f = dataclasses.replace(f, data=d, coherence=coh)
            if name == "junkref":
                keep = hz >= 5
                return self.st, f.band(5.0, 1000.0), v.truth[keep]
            return self.st0, f, v.truth
        frf = noisy(self.fine.frf, rng)
        if name in ("updated", "updated0"):
            seed = int(rng.integers(2 ** 31))
            free = simulate_free(dataclasses.replace(self.wrong, truth=TruthSpec(**self.true, elements_per_segment=TRUE_MESH)),
                                 noise=0.01, seed=seed)
            up = update(self.wrong, free)
            unc = up.uncertainty() if name == "updated" else {}
            corr = unc.pop("correlation", None)
            st = dataclasses.replace(self.wrong, structure=dataclasses.replace(self.wrong.structure, **{
                k: v for k, v in up.values.items() if "." not in k}),
                uncertainty=UncertaintySpec(unc, None if corr is None else tuple(map(tuple, corr))) if unc else None)
            return st, frf, self.fine.truth
        return (self.euler if name == "euler" else self.wrong), frf, self.fine.truth


def run(data: Data, name: str, rng):
    st, frf, truth = data.case(name, rng)
    try:
        r = identify(st, frf)
    except JointIdError as exc:
        return None, str(exc)
    truth = truth[np.isin(frf.frequency.hz, r.frequency.hz)]
    rel = term_errors(r.stiffness, truth)
    inside = within_band(r.stiffness, r.std_real, r.std_imag, truth).mean(axis=0)
    far = ~within_band(r.stiffness, r.std_real, r.std_imag, truth, z=3.0).all(axis=0)
    rows = []
    for k, (_, i, j) in enumerate(TERMS):
        ok = r.reliable_terms[:, i, j]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.abs(r.stiffness[:, i, j] - truth[:, i, j]) / np.hypot(r.std_real[:, i, j], r.std_imag[:, i, j])
        rows.append((100 * np.median(rel[ok, k]) if ok.any() else np.nan, ok.mean(),
                     inside[ok, k].mean() if ok.any() else np.nan, far[ok, k].mean() if ok.any() else 0.0,
                     np.median(z[ok]) if ok.any() else np.nan))
    return np.array(rows), r.findings()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args()
    data = Data()
    for name in args.cases.split(","):
        t = time.perf_counter()
        rows, notes = [], Counter()
        for seed in range(args.seeds):
            res, found = run(data, name, np.random.default_rng(seed))
            if res is None:
                notes["refused: " + found] += 1
                continue
            rows.append(res)
            for f in found:
                notes[f.split(" (")[0][:110]] += 1
        print(f"\n{NAMES[name]} ({args.seeds} seeds, {time.perf_counter() - t:.0f} s)")
        if rows:
            a = np.array(rows)  # (seeds, terms, 5)
            for k, (label, _, _) in enumerate(TERMS):
                med, frac, cov, far = (np.nanmedian(a[:, k, c]) if np.isfinite(a[:, k, c]).any() else np.nan for c in range(4))
                worst, mean = np.nanmax(a[:, k, 3]), np.nanmean(a[:, k, 3])
                print(f"  {label:13s} reliable {100 * frac:5.1f} %  median error {med:8.3g} %  coverage {cov:5.2f}  "
                      f"> 3 sigma {100 * far:4.1f} % (mean over seeds {100 * mean:4.1f} %, worst seed {100 * worst:4.1f} %, "
                      f"seeds above 10 %: {int(np.sum(a[:, k, 3] > 0.1))})")
            z = a[:, :, 4][np.isfinite(a[:, :, 4])]
            if z.size:
                # a band that is right, with an error smooth over frequency (one complex Gaussian draw per seed and
                # term): the per-seed median |error| / sigma is Rayleigh, quantile q at sqrt(-ln(1 - q))
                q = np.array([0.5, 0.9, 0.99])
                print(f"  per seed and term, median |error| / sigma (reliable lines): 50/90/99th percentile "
                      f"{' / '.join(f'{v:.2f}' for v in np.quantile(z, q))}; a right band with errors smooth over "
                      f"frequency: {' / '.join(f'{v:.2f}' for v in np.sqrt(-np.log1p(-q)))}; above 2.15 (1 % expected): "
                      f"{int(np.sum(z > 2.146))} of {z.size}")
        for text, count in notes.most_common(6):
            print(f"  [{count}/{args.seeds}] {text}")


if __name__ == "__main__":
    main()
