"""Benchmark FRF synthesis: seconds and peak memory, batched-direct and modal paths.

(a) benchmark beam, 19 nodes (38 DOFs), 7x3 FRFs, 1000 lines;
(b) 2000-node beam (4000 DOFs), 7x3 FRFs, 2000 lines.
Run: python benchmarks/frf_synthesis.py
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

from jointid.benchmark import benchmark_study
from jointid.frequency import Frequency
from jointid.physics.structure import build_beam
from jointid.physics.synthesis import synthesize_frf


def measure(structure, freq, resp, ref, method):
    tracemalloc.start()
    t = time.perf_counter()
    frf = synthesize_frf(structure, freq, resp, ref, method=method)
    dt = time.perf_counter() - t
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return frf.data, dt, peak


def main() -> None:
    spec = benchmark_study().beam
    cases = []
    small = spec.structure()
    cases.append(("(a) 19 nodes, 38 DOFs, 7x3, 1000 lines", small, Frequency.from_range(1, 1000, 1),
                  [f"{n}w" for n in (1, 3, 6, 9, 12, 15, 19)], ["3w", "9w", "15w"]))
    big = build_beam(spec.length, spec.section(), spec.material(), 2000, spec.shear_coefficient)
    cases.append(("(b) 2000 nodes, 4000 DOFs, 7x3, 2000 lines", big, Frequency.from_range(0.5, 1000, 0.5),
                  [f"{n}w" for n in (1, 300, 600, 1000, 1400, 1700, 2000)], ["300w", "1000w", "1700w"]))
    for name, s, f, r, c in cases:
        print(name)
        res = {}
        for method in ("modal", "direct"):
            data, dt, peak = measure(s, f, r, c, method)
            res[method] = data
            print(f"  {method:6s}: {dt:7.3f} s   peak traced memory {peak:8.1f} MiB")
        a, b = res["direct"], res["modal"]
        print(f"  max |modal - direct| / max |direct| = {np.abs(a - b).max() / np.abs(a).max():.2e}; "
              f"median per-line relative difference {np.median(np.abs(a - b) / np.abs(a)):.2e}")


if __name__ == "__main__":
    main()
