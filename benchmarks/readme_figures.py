"""The headline figures the README quotes, computed now and written to ``docs/figures.md``.

Run ``make readme-figures`` (or ``python benchmarks/readme_figures.py [--seeds N] [--out FILE]``).
Every number the README's *What the benchmark shows* section points to is printed here by
code, on the built-in benchmark (Material A, joint at mid-span, Model 3 layout, 100-1000 Hz):

1. exact FRFs -> the joint to round-off (largest relative error per term);
2. ``--seeds`` realizations of 0.5 % and 1 % complex relative noise on the exact
   accelerances, identified by the default estimator and by plain Hong & Lee: median
   relative error per term, and the fraction of lines whose truth lies inside the
   default's 90 % band (real and imaginary part, +-1.645 sigma);
3. the virtual roving-hammer test (1 % response + 1 % force noise, 5 hits per node, H1 with
   coherence, seed 0) over the benchmark's band and over 100-1000 Hz: median error per term, the
   fraction of lines flagged reliable and the median error on those;
4. the direct method on the built-in example step-sine test: E, eta, rho against the truth;
5. the wall time of one default identification of the 901 lines;
6. with ``--reproduce``: the wall and CPU time of the main job, ``jointid reproduce`` (what
   ``make run`` runs after the install), on this machine.

The file starts with the command, the date and the commit, so a reader sees where the
numbers came from. Not a test (it takes about a minute); the tests check the same
properties on small cases with fixed seeds.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import jointid
from jointid.frf import FRF
from jointid.methods.hong_lee.inverse import InverseOptions

TERMS = (("K_ww", 0, 0), ("K_wtheta", 0, 1), ("K_thetatheta", 1, 1))
Z90 = 1.6448536269514722  # two-sided 90 % normal quantile


def study():
    """The benchmark study over 100-1000 Hz (Material A, mid-span, Model 3 layout)."""
    st = jointid.benchmark_study()
    return dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))


def noisy(frf: FRF, level: float, rng: np.random.Generator) -> FRF:
    """``frf`` times (1 + level * complex unit-variance Gaussian noise) on every value."""
    z = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2.0)
    return FRF(frf.frequency, frf.data * (1.0 + level * z), frf.responses, frf.references, frf.kind)


def relative_errors(K: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Relative error per line and term, shape (F, 3): |K_ij - T_ij| / |T_ij|."""
    return np.stack([np.abs(K[:, i, j] - truth[:, i, j]) / np.abs(truth[:, i, j]) for _, i, j in TERMS], axis=1)


def coverage(result, truth: np.ndarray) -> np.ndarray:
    """Fraction of lines with the truth inside the 90 % band, per term and part, shape (3, 2)."""
    out = np.empty((3, 2))
    for k, (_, i, j) in enumerate(TERMS):
        d = result.stiffness[:, i, j] - truth[:, i, j]
        out[k, 0] = np.mean(np.abs(d.real) <= Z90 * result.std_real[:, i, j])
        out[k, 1] = np.mean(np.abs(d.imag) <= Z90 * result.std_imag[:, i, j])
    return out


def _direct(result):
    """(frequency_hz, stiffness) of a step-sine result, the material fit's inputs."""
    return result.frequency_hz, result.stiffness


def reproduce_timing() -> str:
    """One line: wall and CPU seconds of ``jointid reproduce`` in a temporary directory (a child process)."""
    import os
    import resource
    import shutil
    import tempfile

    exe = shutil.which("jointid") or os.path.join(os.path.dirname(sys.executable), "jointid")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run([exe, "reproduce", "--out", tmp, "--quiet"], check=True)
        wall = time.perf_counter() - t0
        figures = len(list(Path(tmp, "figures").glob("*.png")))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return (f"* `jointid reproduce` (the main job of `make run`, after the install): {wall:.0f} s wall, {cpu:.0f} s CPU "
            f"on {os.cpu_count()} cores, {figures} figures.")


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def pct(values) -> str:
    return " / ".join(f"{100 * v:.3g} %" for v in values)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="noise realizations per level (default 5)")
    parser.add_argument("--reproduce", action="store_true", help="also time `jointid reproduce` (the main job)")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "figures.md"))
    args = parser.parse_args(argv)

    st = study()
    test = jointid.simulate(st)
    truth = test.truth
    lines = []
    say = lines.append
    say("# Figures the README quotes")
    say("")
    say(f"Written by `python benchmarks/readme_figures.py --seeds {args.seeds}` (`make readme-figures`) "
        f"on {_dt.date.today().isoformat()}, commit `{commit()}`. Benchmark: Material A, joint at node 10 "
        "(mid-span), Model 3 layout (observed 1, 3, 6, 9, 12, 15, 19; excited 3, 9, 15), 100-1000 Hz, "
        f"{test.frf.frequency.hz.size} lines. Errors are relative, per line; medians over the lines (and seeds). "
        "Terms: K_ww / K_wtheta / K_thetatheta.")
    say("")

    exact = jointid.identify(st, test.frf)
    say(f"* Exact FRFs, default estimator: largest error {pct(relative_errors(exact.stiffness, truth).max(axis=0))}.")

    t0 = time.perf_counter()
    jointid.identify(st, noisy(test.frf, 0.005, np.random.default_rng(0)))
    seconds = time.perf_counter() - t0

    say("")
    say("| FRF noise | estimator | median error | 90 % band holds the truth (re / im) |")
    say("| --- | --- | --- | --- |")
    for level in (0.005, 0.01):
        errs, cov, errs_hl = [], [], []
        for seed in range(args.seeds):
            data = noisy(test.frf, level, np.random.default_rng(1000 + seed))
            res = jointid.identify(st, data)
            errs.append(relative_errors(res.stiffness, truth))
            cov.append(coverage(res, truth))
            hl = jointid.identify(st, data, InverseOptions(weighting="none"))  # the paper's unweighted two steps
            errs_hl.append(relative_errors(hl.stiffness, truth))
            print(f"noise {level:g}, seed {seed}: done", file=sys.stderr, flush=True)
        med = np.median(np.concatenate(errs), axis=0)
        medhl = np.median(np.concatenate(errs_hl), axis=0)
        c = np.mean(cov, axis=0)
        bands = " · ".join(f"{a:.2f}/{b:.2f}" for a, b in c)
        say(f"| {100 * level:g} % relative, {args.seeds} seeds | default | {pct(med)} | {bands} |")
        say(f"| | Hong & Lee (paper) | {pct(medhl)} | - |")
    say("")

    for label, hst in (("the benchmark's 5-1000 Hz band (what `jointid experiment` runs)", jointid.benchmark_study()),
                       ("100-1000 Hz", st)):
        ex = jointid.experiment(hst, seed=0)
        res = jointid.identify(hst, dataclasses.replace(ex.frf, coherence=ex.coherence))  # as read back from its UFF
        err = relative_errors(res.stiffness, ex.truth)
        rel = np.stack([res.reliable_terms[:, i, j] for _, i, j in TERMS], axis=1)
        flagged = " / ".join(f"{100 * rel[:, k].mean():.0f} %" for k in range(3))
        on_reliable = " / ".join(f"{100 * np.median(err[rel[:, k], k]):.3g} %" if rel[:, k].any() else "-" for k in range(3))
        say(f"* Virtual roving-hammer test over {label} (1 % response + 1 % force noise of the peak, 5 hits per node, "
            f"H1 with coherence, seed 0), default estimator: median error {pct(np.median(err, axis=0))}; lines flagged "
            f"reliable {flagged}, median error on those {on_reliable}.")

    from jointid.measurement.stepsine import process_stepsine
    from jointid.measurement.stepsine_synth import EXAMPLE, example_stepsine
    from jointid.methods.direct.material_fit import fit_material
    from jointid.physics.elastomer_material import MATERIALS

    true = MATERIALS[EXAMPLE["material"]]

    fit = fit_material(*_direct(process_stepsine(example_stepsine(), parallel_joints=EXAMPLE["parallel_joints"])))
    say("* Direct method, built-in example step-sine test (Material B, 1 % noise): "
        f"E {fit.elastic_modulus_pa / 1e6:.4g} MPa (true {true.elastic_modulus / 1e6:.4g}), "
        f"eta {fit.loss_factor:.4g} (true {true.loss_factor:.4g}), "
        f"rho {fit.density_kg_m3:.5g} kg/m^3 (true {true.density:.5g}).")
    say(f"* One default identification of the {test.frf.frequency.hz.size} lines (0.5 % noise) took {seconds:.2f} s wall "
        "on this machine (in-process, after imports).")

    if args.reproduce:
        say(reproduce_timing())

    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    print(text)
    print(f"written: {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
