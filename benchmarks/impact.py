"""Benchmark impact-test FRF estimation: 7 responses x 3 excited nodes, 5 hits of 8192 samples each.

Times :func:`jointid.measurement.impact.estimate_frfs` (hit checks, windows, one
batched rfft per excited node, H1/H2/coherence) without and with the
exponential window and its correction (modes detected automatically).
Run: python benchmarks/impact.py
"""

from __future__ import annotations

import time

import numpy as np

from jointid.measurement.impact import ImpactOptions, ImpactRecord, estimate_frfs

FS = 4096.0
N = 8192
HITS = 5
RESPONSES = [f"{n}w" for n in (1, 3, 6, 9, 12, 15, 19)]
EXCITED = ["3w", "9w", "15w"]
MODES_HZ = np.array([45.0, 130.0, 260.0, 430.0, 640.0, 890.0])


def make_records(rng: np.random.Generator) -> list[ImpactRecord]:
    """Synthetic hits: a 1 ms half-sine pulse and damped-sine responses with 1 % noise."""
    t = np.arange(N) / FS
    w = 2 * np.pi * MODES_HZ
    sig = 0.01 * w
    recs = []
    for _ in EXCITED:
        t0 = 0.02 + rng.uniform(0, 0.005, HITS)
        tau = t[None, :] - t0[:, None]
        f = np.where((tau >= 0) & (tau <= 1e-3), 100 * np.sin(np.pi * np.clip(tau, 0, 1e-3) / 1e-3), 0.0)
        phi = rng.standard_normal((len(RESPONSES), MODES_HZ.size))
        tp = np.clip(tau, 0, None)[:, None, :, None]
        y = (phi[None, :, None, :] * np.exp(-sig * tp) * np.sin(w * tp) * (tau >= 0)[:, None, :, None]).sum(-1)
        y += 0.01 * y.std() * rng.standard_normal(y.shape)
        recs.append(ImpactRecord(f + 0.1 * rng.standard_normal(f.shape), y, FS, RESPONSES, _))
    return recs


def main() -> None:
    recs = make_records(np.random.default_rng(0))
    cases = [
        ("H1/H2/coherence, force window", ImpactOptions(force_window_s=4e-3, force_pretrigger_s=1e-3, force_taper_s=1e-3)),
        ("+ exponential window, corrected", ImpactOptions(force_window_s=4e-3, force_pretrigger_s=1e-3, force_taper_s=1e-3,
                                                          exp_tau_s=0.3, band_hz=(10.0, 1000.0))),
    ]
    print(f"{len(RESPONSES)} x {len(EXCITED)} FRFs, {HITS} hits x {N} samples per excited node")
    for name, opts in cases:
        estimate_frfs(recs, opts)  # warm-up
        reps = 10
        t = time.perf_counter()
        for _ in range(reps):
            res = estimate_frfs(recs, opts)
        dt = (time.perf_counter() - t) / reps
        print(f"  {name:34s}: {dt:.4f} s  ({res.h1.shape[0]} lines, {len(res.window_modes)} modes corrected)")


if __name__ == "__main__":
    main()
