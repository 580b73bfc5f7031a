"""CPU time of the default (structured) identification and what it identifies, on the scenarios of tests/test_structured.py.

For each scenario (Material B at mid-span with 1 % noise; FRFs of a finer mesh at the
beam end; the virtual hammer test at the beam end, seeds 0 and 1; Material A at
mid-span with force noise) prints the CPU seconds of one ``identify`` call (one BLAS
thread), the median relative error per term (K_ww / K_wtheta / K_thetatheta, %), the
fraction of lines whose truth lies within the 90 % band (real, imaginary; per term),
the membership test's whiteness statistic (:mod:`jointid.methods.receptance.structured_membership`)
and the model orders averaged. Joints outside the class: ``benchmarks/out_of_class.py``. Compare two versions by running it under each.

Not a test: ``python benchmarks/structured_fit.py``.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from jointid.dofs import Dof
from threadpoolctl import threadpool_limits

from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.pipeline import experiment, identify, simulate
from jointid.reproduce.noise_robustness import TERMS, term_errors, within_band


def study(material: str, node: int, **beam):
    st = benchmark_study()
    joint = dataclasses.replace(st.joint, dofs=tuple(Dof(node, d.direction) for d in st.joint.dofs), model=dataclasses.replace(st.joint.model, parameters={"material": material}))
    st = dataclasses.replace(st, joints=(joint,), frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))
    return dataclasses.replace(st, structure=dataclasses.replace(st.beam, **beam)) if beam else st


def noisy(frf, level, seed):
    """As tests/test_structured.py: relative complex noise of rms ``level``."""
    rng = np.random.default_rng(seed)
    d = frf.data
    noise = level * np.abs(d) * (rng.standard_normal(d.shape) + 1j * rng.standard_normal(d.shape)) / np.sqrt(2)
    return FRF(frf.frequency, d + noise, frf.responses, frf.references, frf.kind)


def scenarios():
    st = study("B", 10)
    test = simulate(st)
    yield "Material B, node 10, 1 % noise (seed 3)", st, noisy(test.frf, 0.01, 3), test.truth
    fine = study("B", 1, elements_per_segment=16)
    tf = simulate(fine)
    coarse = dataclasses.replace(fine, structure=dataclasses.replace(fine.beam, elements_per_segment=None))
    yield "finer-mesh FRFs, Material B, node 1, 1 % noise (seed 5)", coarse, noisy(tf.frf, 0.01, 5), tf.truth
    for seed in (0, 1):
        sb = study("B", 1)
        ex = experiment(sb, seed=seed, periodic=True)
        yield f"hammer test, Material B, node 1 (seed {seed})", sb, ex.frf.band(100, 1000), ex.truth[ex.frf.frequency.mask(100, 1000)]
    sa = study("A", 10)
    ex = experiment(sa, seed=1, periodic=True)
    yield "hammer test, Material A, node 10 (seed 1)", sa, ex.frf.band(100, 1000), ex.truth[ex.frf.frequency.mask(100, 1000)]


def main() -> None:
    total = 0.0
    with threadpool_limits(1, user_api="blas"):
        for label, st, frf, truth in scenarios():
            t = time.process_time()
            r = identify(st, frf)
            cpu = time.process_time() - t
            total += cpu
            err = 100 * np.median(term_errors(r.stiffness, truth), axis=0)
            cov = within_band(r.stiffness, r.std_real, r.std_imag, truth).mean(axis=1)  # (2, 3)
            orders = sorted(r.structured.weights) if r.structured is not None else []
            white = f" (whiteness Z {r.structured.membership.z:.1f})" if r.structured is not None and r.structured.membership is not None else ""
            print(f"{label}: {cpu:.2f} s CPU, {r.estimator}{white}; error % {' / '.join(f'{e:.3g}' for e in err)}; "
                  f"coverage (re, im) {', '.join(f'{cov[0, t]:.2f}/{cov[1, t]:.2f}' for t in range(len(TERMS)))}; orders {orders}")
    print(f"total {total:.1f} s CPU")


if __name__ == "__main__":
    main()
