"""Benchmark the inverse identification: batched paths vs a per-line numpy.linalg.pinv loop.

Benchmark beam, joint at node 10, 7 observed x 3 excited, 1000 and 20 000 lines.
Prints seconds (best of a few runs, after a warm-up), the speed-up of the
default method (receptance coupling on the 290-DOF refined free model, 1 % noise,
smoothed, with uncertainty; model building and modes included) and of the
Hong & Lee paths (QR estimation, cond_A certified to 1%; SVD estimation) over
the loop, and the accuracy of each on exact data. Best-of-N times, because other
processes on a shared machine only ever add time.
Run: python benchmarks/identify.py
"""

from __future__ import annotations

import time

import numpy as np

from jointid.benchmark import benchmark_beam
from jointid.frequency import Frequency
from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.methods.coupling import identify_joint_coupling
from jointid.methods.inverse import InverseOptions, identify_joint
from jointid.physics.joints import parametric_joint
from jointid.physics.synthesis import synthesize_frf

OBSERVED = [1, 3, 6, 9, 12, 15, 19]
EXCITED = [3, 9, 15]


def pinv_loop(beam, frf, joint_dofs, diagnostics=False):
    """Straightforward reference: one pinv per line for both steps (no scaling).

    With ``diagnostics``, also the per-line outputs the batched path returns:
    cond of A, B and the measured H (``numpy.linalg.cond``) and |Du_ii| |Ho_ii|.
    """
    dofs = beam.dofs
    pos = {d: i for i, d in enumerate(dofs)}
    n = [pos[d] for d in joint_dofs]
    m = [pos[d] for d in frf.responses]
    e = [pos[d] for d in frf.references]
    N = len(dofs)
    nbar = [i for i in range(N) if i not in n]
    mbar = [i for i in range(N) if i not in m]
    H = frf.to("receptance").data
    I = np.eye(N)
    out = np.empty((frf.frequency.size, len(n), len(n)), complex)
    for k, f in enumerate(frf.frequency.hz):
        Do = beam.dynamic_stiffness(np.array([f]))[0]
        Hfull = np.zeros((N, len(e)), complex)
        Hfull[m] = H[k]
        rhs = I[np.ix_(nbar, e)] - Do[np.ix_(nbar, m)] @ H[k]
        Hfull[mbar] = np.linalg.pinv(Do[np.ix_(nbar, mbar)]) @ rhs
        C = I[np.ix_(n, e)] - Do[n, :] @ Hfull
        out[k] = C @ np.linalg.pinv(Hfull[n])
        if diagnostics:
            np.linalg.cond(Do[np.ix_(nbar, mbar)]), np.linalg.cond(Hfull[n]), np.linalg.cond(H[k])
            np.abs(np.diag(out[k])) * np.abs(np.diag(np.linalg.inv(Do)[np.ix_(n, n)]))
    return out


def _best(fn, repeats):
    """Smallest wall time of ``repeats`` calls (s) and the last result."""
    best, out = float("inf"), None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


_LOOP = {}


def t_loop_first(lines, beam, frf, jd):
    """The pinv loop's time at this size (measured once)."""
    if lines not in _LOOP:
        _LOOP[lines] = _best(lambda: pinv_loop(beam, frf, jd), 2)[0]
    return _LOOP[lines]


def main() -> None:
    beam = benchmark_beam()
    joint = parametric_joint(10, 2e5, 60.0, 1.5e3, 0.12, growth=0.5, reference_frequency=100, exponent=0.5)
    jd = joint.dofs
    warm = Frequency(np.linspace(5, 1000, 1000))  # first-call costs (imports, thread pool) out of the timings
    identify_joint(beam, synthesize_frf(beam.with_joint(joint), warm, [f"{n}w" for n in OBSERVED], [f"{n}w" for n in EXCITED]), jd)
    for lines in (1000, 20000):
        freq = Frequency(np.linspace(5, 1000, lines))
        frf = synthesize_frf(beam.with_joint(joint), freq, [f"{n}w" for n in OBSERVED], [f"{n}w" for n in EXCITED], kind="accelerance")
        K = joint(freq.hz)
        t_qr, r = _best(lambda: identify_joint(beam, frf, jd), 3)
        t_svd, r_svd = _best(lambda: identify_joint(beam, frf, jd, InverseOptions(estimation="svd")), 2)
        t_loop, ref = _best(lambda: pinv_loop(beam, frf, jd), 1)
        _LOOP[lines] = min(_LOOP.get(lines, np.inf), t_loop)
        t_diag, _ = _best(lambda: pinv_loop(beam, frf, jd, diagnostics=True), 1)
        e_qr = (np.abs(r.stiffness - K) / np.abs(K)).max()
        e_svd = (np.abs(r_svd.stiffness - K) / np.abs(K)).max()
        e_loop = (np.abs(ref - K) / np.abs(K)).max()
        refined = benchmark_study().beam.structure(1000.0)  # the default method's converged free model (8x mesh)
        rng = np.random.default_rng(0)
        noisy = FRF(freq, frf.data * (1 + 0.01 * (rng.standard_normal(frf.shape) + 1j * rng.standard_normal(frf.shape)) / np.sqrt(2)),
                    frf.responses, frf.references, frf.kind)
        t_rc, r_rc = _best(lambda: identify_joint_coupling(refined, noisy, jd), 5)
        print(f"{lines:6d} lines (best of 5/3/2/1/1 runs):")
        print(f"    receptance method (jointid default: weighted, smoothed, with uncertainty, 290-DOF free model) "
              f"{t_rc:6.3f} s   {t_loop_first(lines, beam, frf, jd) / t_rc:5.1f}x vs pinv loop (19-node model)")
        print(f"    batched, QR estimation (default), with diagnostics {t_qr:6.3f} s   "
              f"{t_loop / t_qr:5.1f}x vs pinv loop   max rel. error {e_qr:.1e}")
        print(f"        cond_A from {int(np.sum(r.cond_A_bound == 0))} SVD lines, certified within "
              f"{r.cond_A_bound.max():.1e} (relative) on the others")
        print(f"    batched, SVD estimation, with diagnostics          {t_svd:6.3f} s   "
              f"{t_loop / t_svd:5.1f}x vs pinv loop   max rel. error {e_svd:.1e}")
        print(f"    pinv loop                                          {t_loop:6.3f} s                       max rel. error {e_loop:.1e}")
        print(f"    pinv loop with the same diagnostics                {t_diag:6.3f} s   (QR path {t_diag / t_qr:4.1f}x faster)")


if __name__ == "__main__":
    main()
