"""The joint spline fit on a joint whose shape in log f the 4-coefficient cap cannot follow: orders and bands.

The frame and mount directions of ``mount_6dof.py`` (Craig-Bampton model, 9 x 9 translational
FRFs at grids 3, 5, 10), with a stiffening joint ``K(f) = (1 + 0.3 (f / 100)^0.8) K0 o (1 + j eta)``
(eta 0.08 translations, 0.2 rotations) over 10-400 Hz every 10 Hz (40 lines, 1.6 decades). Per noise
level (``--noise``, complex relative) and seed, :func:`~jointid.methods.receptance.spline_fit.fit_joint_spline`
(variance ``|H|^2``, default options) is run, and per diagonal term it prints

* the median relative error over lines and seeds;
* the coverage of the fit's 90 % bands (lines, real and imaginary parts pooled);
* the coverage of the chosen order's own linearized band (``fit.covariance``, no bias term): what the
  bands were before the bias against the next order was added;

and the orders the AIC chose.

``--chain``: the case an adversarial sweep found (issue 26) through the whole estimator (``jointid.pipeline.identify``,
default options, smoothing "auto"): one grounded 6-DOF mount (``K0 (1 + 0.3 (f / 100)^0.8) (1 + 0.12 j)``, three
couplings) on the tests' 10-node spring chain (``tests/structure_model.py``), x, y, z observed at 6 nodes and excited
at 4, 40 lines 10-400 Hz, 1 % noise; per diagonal term the median error, the coverage of the 90 % bands and the
fraction of lines flagged reliable with the truth more than 3 sigma off.

Not a test: ``python benchmarks/spline_wide_band.py [--seeds 20] [--noise 0.01 0.001] [--chain]``.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jointid.frequency import Frequency
from jointid.methods.receptance.spline_fit import fit_joint_spline, legendre_log_basis, log_frequency_basis, term_variance
from jointid.physics.jointed_model import JointedModel
from jointid.physics.structure import ComplexStiffness

import mount_6dof as m6

TERMS = [f"K_{c}_{c}" for c in m6.COMP]


def stiffening(f_hz):
    """The joint's true K(f), shape (F, 6, 6)."""
    s = 1.0 + 0.3 * (np.atleast_1d(np.asarray(f_hz, float)) / 100.0) ** 0.8
    return s[:, None, None] * m6.mount_stiffness(np.full(np.size(f_hz), m6.F_REF))


def chain(seeds: int) -> None:
    """The chain case through ``pipeline.identify`` (module docstring)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from structure_model import labels, write_grounded_study

    from jointid import pipeline
    from jointid.reproduce.common import add_noise
    from jointid.study import load_study

    observed = [x for n in (1, 2, 4, 5, 7, 9) for x in labels(n, ("x", "y", "z"))]
    excited = [x for n in (2, 4, 5, 7) for x in labels(n, ("x", "y", "z"))]
    with tempfile.TemporaryDirectory() as d:  # the study and its model files (read by each identification)
        study = load_study(write_grounded_study(Path(d), observed, excited, joints=("front",), step=10.0, smoothing=None))
        test = pipeline.simulate(study)
        T = test.truth
        err, cover, wrong, orders = [], [], [], collections.Counter()
        for seed in range(seeds):
            est = pipeline.identify(study, add_noise(test.frf, 0.01, np.random.default_rng(seed)))
            orders[est.spline.n_basis if est.spline is not None else est.estimator] += 1
            i = np.arange(6)
            dK = est.stiffness[:, i, i] - T[:, i, i]
            zr, zi = np.abs(dK.real) / est.std_real[:, i, i], np.abs(dK.imag) / est.std_imag[:, i, i]
            err.append(np.abs(dK) / np.abs(T[:, i, i]))
            cover.append(np.r_[zr <= m6.Z90, zi <= m6.Z90])
            reliable = est.reliable_terms[:, i, i]
            wrong.append((reliable & (np.maximum(zr, zi) > 3)).sum(0) / np.maximum(reliable.sum(0), 1))
        err, cover, wrong = np.concatenate(err), np.concatenate(cover), np.array(wrong)
        print(f"chain: one grounded 6-DOF mount, 40 lines 10-400 Hz, 18 x 12 FRFs, 1 % noise, {seeds} seeds; "
              f"orders chosen {dict(orders)}")
        print(f"{'term':10s} {'median err':>11s} {'coverage':>9s} {'reliable z>3':>13s}")
        for t, name in enumerate(TERMS):
            print(f"{name:10s} {100 * np.median(err[:, t]):9.3g} % {cover[:, t].mean():9.2f} {wrong[:, t].mean():13.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.01, 0.001])
    ap.add_argument("--chain", action="store_true", help="the chain case through the whole estimator instead")
    a = ap.parse_args(argv)
    if a.chain:
        chain(a.seeds)
        return
    free, _, joint, measured, _, _ = m6.build_case()
    freq = Frequency.from_range(10.0, 400.0, 10.0)
    Ymn, Ynn, Yne, Yme = m6.blocks(free, freq, joint, measured)
    H0 = JointedModel(free, [ComplexStiffness(tuple(joint), stiffening, "mount")]).receptance(freq, measured, measured)
    truth = stiffening(freq.hz)
    d = np.arange(6)
    print(f"stiffening 6-DOF mount, {freq.size} lines 10-400 Hz, 9 x 9 FRFs, {a.seeds} seeds per noise level")
    for level in a.noise:
        err, cover, own_cover, orders, secs = [], [], [], collections.Counter(), []
        for seed in range(a.seeds):
            rng = np.random.default_rng(seed)
            H = H0 * (1 + level * (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / np.sqrt(2))
            t0 = time.perf_counter()
            fit = fit_joint_spline(freq.hz, Ymn, Ynn, Yne, Yme, H, np.abs(H) ** 2)
            secs.append(time.perf_counter() - t0)
            per_term = "per-term" in fit.criterion
            orders[f"{fit.term_basis.min()}-{fit.term_basis.max()} per term" if per_term else f"{fit.n_basis}"] += 1
            basis = (legendre_log_basis if per_term else log_frequency_basis)(freq.hz, fit.n_basis)
            own = np.sqrt(term_variance(fit.covariance, basis, 6) / 2)[:, d, d]
            dK = fit.stiffness[:, d, d] - truth[:, d, d]
            err.append(np.abs(dK) / np.abs(truth[:, d, d]))
            cover.append(np.r_[np.abs(dK.real) <= m6.Z90 * fit.std_real[:, d, d], np.abs(dK.imag) <= m6.Z90 * fit.std_imag[:, d, d]])
            own_cover.append(np.r_[np.abs(dK.real) <= m6.Z90 * own, np.abs(dK.imag) <= m6.Z90 * own])
        err, cover, own_cover = (np.concatenate(x) for x in (err, cover, own_cover))
        print(f"\nnoise {100 * level:g} %: orders chosen {dict(orders)}; {np.median(secs):.1f} s per fit (median)")
        print(f"{'term':10s} {'median err':>11s} {'coverage':>9s} {'own band':>9s}")
        for t, name in enumerate(TERMS):
            print(f"{name:10s} {100 * np.median(err[:, t]):9.3g} % {cover[:, t].mean():9.2f} {own_cover[:, t].mean():9.2f}")


if __name__ == "__main__":
    main()
