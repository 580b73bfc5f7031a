"""Time the direct method: step-sine processing of 24 blocks and the material fit.

Run: ``python3 benchmarks/direct.py``. Prints seconds (best of 5 repeats).
"""

from __future__ import annotations

import time

import numpy as np

from jointid.physics.elastomer_joint import ElastomerJoint
from jointid.methods.direct.material_fit import complex_modulus_per_line, fit_material
from jointid.measurement.stepsine import process_stepsine
from jointid.measurement.stepsine_synth import synthesize_stepsine


def best(fn, repeats: int = 5) -> float:
    """Smallest wall time of ``repeats`` calls of ``fn``, s."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    f = np.arange(25.0, 601.0, 25.0)  # 24 lines, the benchmark's direct characterization
    joint = ElastomerJoint.from_material("B")
    blocks = synthesize_stepsine(f, joint.blocked_transfer_stiffness, 2.5e-5, displacement_noise=0.01, force_noise=0.01, seed=0)
    samples = sum(b.time_s.size for b in blocks)
    result = process_stepsine(blocks, commanded_amplitude_m=2.5e-5)
    fit = fit_material(result.frequency_hz, result.stiffness)
    print(f"step-sine processing, {len(blocks)} blocks ({samples} samples): {best(lambda: process_stepsine(blocks)):.4f} s")
    print(f"material fit (E, eta, rho), {f.size} lines, {fit.nfev} evaluations: "
          f"{best(lambda: fit_material(result.frequency_hz, result.stiffness)):.4f} s")
    print(f"E*(f) per line (continuation Newton), {f.size} lines: "
          f"{best(lambda: complex_modulus_per_line(result.frequency_hz, result.stiffness, fit.density_kg_m3)):.4f} s")
    ff = np.linspace(0.0, 3000.0, 3001)
    print(f"joint model K21 + 2x2 on {ff.size} lines: "
          f"{best(lambda: (joint.blocked_transfer_stiffness(ff), joint.driving_point_matrix(ff))):.4f} s")


if __name__ == "__main__":
    main()
