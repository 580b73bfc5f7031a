"""A grounded 6-DOF mount on a Craig-Bampton model: the joint spline fit against the per-line and P-spline estimates.

The case (issue 26's must-show): a 3-D steel frame (a 0.8 x 0.5 m rectangle of tubes
and boxes, a 0.3 m post; :func:`jointid.physics.build_frame`) reduced by
:func:`jointid.physics.reduction.craig_bampton` to the mount grid's 6 DOFs and the
measured grids' translations (fixed-interface modes to 2 kHz). A grounded 6-DOF mount
at grid 1: ``K(f) = (f / f_ref)^alpha (K0 o (1 + j eta))`` with ``K0`` positive definite
(three couplings), ``alpha = 0.15``, ``f_ref = 50 Hz``, loss factor 0.08 on the
translational, 0.2 on the rotational and 0.14 on the mixed terms. Data: the jointed
receptance (:class:`jointid.physics.jointed_model.JointedModel`) on the x, y, z of
three grids away from the mount (9 x 9: responses = excitations), 2-150 Hz every
``--step`` Hz, 1 % complex relative noise on every value (``add_noise``).

Per realization (``--seeds``, default 50) it runs

* the joint spline fit (:func:`jointid.methods.receptance.spline_fit.fit_joint_spline`,
  variance ``|H|^2``, its scale from the residuals, started from the per-line estimate);
* the per-line estimate (``identify_joint_coupling(..., CouplingOptions(smoothing="none"))``);
* the per-term P-spline (``smoothing="gcv"``);

and prints per diagonal term the median relative error ``|K - K_true| / |K_true|`` over
lines and seeds and the coverage of the 90 % bands (fraction of lines, real and imaginary
parts pooled, with the truth within +-1.645 sigma). The Cramer-Rao bound of the spline
class (4 functions per term) is the same Jacobian at the truth with the true noise
variance; printed as the median over lines of ``0.83 sqrt(E|dK|^2) / |K|`` (the median
of a circular Gaussian error's modulus), comparable to the median errors.

Then the spline fit's diagonal coverage split by the band's branch (:mod:`jointid.methods.receptance.spline_bands`):
seeds where per-term orders were chosen (the bias of each term left short measured against it given the missing
coefficients, one term at a time) and seeds with one uniform order (each term in turn given the order above it).

Also per off-diagonal term of the spline fit: the median error relative to ``sqrt(|K_aa K_bb|)``
and the coverage of its bands.

Not a test: ``python benchmarks/mount_6dof.py [--seeds 50] [--step 0.5] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from jointid.frf import FRF
from jointid.frequency import Frequency
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.methods.receptance.spline_fit import fit_joint_spline, log_frequency_basis, spline_covariance, term_variance
from jointid.physics import FrameSection, Material, build_frame
from jointid.physics.jointed_model import JointedModel
from jointid.physics.reduction import craig_bampton
from jointid.physics.structure import ComplexStiffness
from jointid.reproduce.common import add_noise

Z90 = 1.6448536269514722
#: median of |z| / sqrt(E|z|^2) for a circular complex Gaussian z
MEDIAN_MODULUS = np.sqrt(np.log(2.0))
STEEL = Material(210e9, 7850.0, loss_factor=0.002, poisson_ratio=0.3)
COMP = ("x", "y", "z", "rx", "ry", "rz")
MOUNT_GRID = 1
MEASURED_GRIDS = (3, 5, 10)  # opposite corner, top of the post, middle of side 2-3
K0_DIAGONAL = (3e6, 2e6, 4e6, 8e3, 6e3, 5e3)  # N/m, N*m/rad
K0_COUPLINGS = (("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5))
ALPHA, F_REF = 0.15, 50.0
ETA_TRANSLATION, ETA_ROTATION = 0.08, 0.2
NOISE = 0.01


def frame():
    """The free frame: corners 1-4, post top 5; 4 elements per side (internal nodes from 6: side 2-3 is 9, 10, 11)."""
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.8, 0.0, 0.0), 3: (0.8, 0.5, 0.0), 4: (0.0, 0.5, 0.0), 5: (0.8, 0.0, 0.3)}
    tube, box = FrameSection.circle(0.04, 0.032), FrameSection.rectangle(0.03, 0.05)
    members = [(1, 2, tube, STEEL, 4), (2, 3, box, STEEL, 4), (3, 4, tube, STEEL, 4), (4, 1, box, STEEL, 4), (2, 5, tube, STEEL, 2)]
    return build_frame(nodes, members)


def mount_stiffness(f_hz: np.ndarray) -> np.ndarray:
    """The mount's true K(f), shape (F, 6, 6): power-law modulus, loss factor per direction."""
    K0 = np.diag(np.asarray(K0_DIAGONAL, float))
    for a, b, v in K0_COUPLINGS:
        K0[COMP.index(a), COMP.index(b)] = K0[COMP.index(b), COMP.index(a)] = v
    eta = np.where(np.arange(6) < 3, ETA_TRANSLATION, ETA_ROTATION)
    loss = 1j * 0.5 * (eta[:, None] + eta[None, :])
    f = np.atleast_1d(np.asarray(f_hz, float))
    return (f / F_REF)[:, None, None] ** ALPHA * (K0 * (1.0 + loss))


def build_case(step: float = 0.5):
    """(free model, frequency, joint DOFs, measured DOFs, exact FRF, true K)."""
    fm = frame()
    joint = [f"{MOUNT_GRID}{c}" for c in COMP]
    measured = [f"{g}{c}" for g in MEASURED_GRIDS for c in ("x", "y", "z")]
    cb = craig_bampton(fm.mass, fm.stiffness, fm.dofs, joint + measured, cutoff_hz=2000.0, loss_factor=0.002)
    free = cb.free_model()
    freq = Frequency.from_range(2.0, 150.0, step)
    mount = ComplexStiffness(tuple(joint), mount_stiffness, "mount")
    H = JointedModel(free, [mount]).receptance(freq, measured, measured)
    frf = FRF(freq, H, tuple(measured), tuple(measured), "receptance")
    return free, freq, tuple(joint), tuple(measured), frf, mount_stiffness(freq.hz)


def blocks(free, freq, joint, measured):
    """Free receptance blocks Ymn, Ynn, Yne, Yme."""
    m, n = len(measured), len(joint)
    Y = free.receptance(freq, tuple(measured) + tuple(joint), tuple(joint) + tuple(measured))
    return Y[:, :m, :n], Y[:, m:, :n], Y[:, m:, n:], Y[:, :m, n:]


def term_figures(K, std_re, std_im, truth):
    """Per upper-triangle term (a <= b): error (F, 21) relative to ``sqrt(|K_aa K_bb|)`` (``|K_aa|`` on the diagonal)
    and within-band (F, 21, 2) of the 90 % bands of the real and imaginary part."""
    ia, ib = np.triu_indices(6)
    d = np.arange(6)
    scale = np.sqrt(np.abs(truth[:, d, d][:, ia] * truth[:, d, d][:, ib]))
    dK = K[:, ia, ib] - truth[:, ia, ib]
    inside = np.stack([np.abs(dK.real) <= Z90 * std_re[:, ia, ib], np.abs(dK.imag) <= Z90 * std_im[:, ia, ib]], axis=-1)
    return np.abs(dK) / scale, inside


_CASE = {}


def _one_seed(seed):
    """Spline, per-line and GCV estimates of one noise realization: (seed, time, n_basis, orders, chi2, figures)."""
    free, freq, joint, exact, truth, blk = (_CASE[k] for k in ("free", "freq", "joint", "exact", "truth", "blocks"))
    Ymn, Ynn, Yne, Yme = blk
    frf = add_noise(exact, NOISE, np.random.default_rng(seed))
    H = frf.data
    lines = identify_joint_coupling(free, frf, joint, CouplingOptions(smoothing="none"))
    t1 = time.perf_counter()
    fit = fit_joint_spline(freq.hz, Ymn, Ynn, Yne, Yme, H, np.abs(H) ** 2, max_basis=_CASE["max_basis"], initial=lines.per_line)
    t2 = time.perf_counter()
    gcv = identify_joint_coupling(free, frf, joint, CouplingOptions(smoothing="gcv"))
    figs = {key: term_figures(K, sr, si, truth) for key, (K, sr, si) in (
        ("spline", (fit.stiffness, fit.std_real, fit.std_imag)),
        ("per-line", (lines.stiffness, lines.std_real, lines.std_imag)),
        ("gcv", (gcv.stiffness, gcv.std_real, gcv.std_imag)))}
    ia, ib = np.triu_indices(6)
    return seed, t2 - t1, fit.n_basis, fit.term_basis[ia == ib], fit.chi2_per_dof, figs, "per-term" in fit.criterion


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--step", type=float, default=0.5, help="line spacing, Hz")
    ap.add_argument("--max-basis", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=1, help="processes (seeds in parallel)")
    args = ap.parse_args(argv)
    free, freq, joint, measured, exact, truth = build_case(args.step)
    blk = blocks(free, freq, joint, measured)
    Ymn, Ynn, Yne, Yme = blk
    _CASE.update(free=free, freq=freq, joint=joint, exact=exact, truth=truth, blocks=blk, max_basis=args.max_basis)
    F = freq.size
    basis = log_frequency_basis(freq.hz, args.max_basis)
    var_true = (NOISE * np.abs(exact.data)) ** 2
    crb = term_variance(spline_covariance((Ymn, Ynn, Yne, var_true, True), truth, basis), basis, 6)
    d = np.arange(6)
    crb_med = MEDIAN_MODULUS * np.median(np.sqrt(crb[:, d, d]) / np.abs(truth[:, d, d]), axis=0)
    print(f"6-DOF mount on grid {MOUNT_GRID} of a Craig-Bampton frame model ({free.dofs.__len__()} DOFs), "
          f"9 x 9 translational FRFs at grids {MEASURED_GRIDS}, {F} lines 2-150 Hz, {100 * NOISE:g} % noise, {args.seeds} seeds")
    ia, ib = np.triu_indices(6)
    names = [f"K_{COMP[a]}_{COMP[b]}" for a, b in zip(ia, ib)]
    diag = np.flatnonzero(ia == ib)
    out = {k: ([], []) for k in ("spline", "per-line", "gcv")}
    nbs, times, chi2, orders, per_term = [], [], [], [], []
    if args.jobs > 1:
        import multiprocessing

        pool = multiprocessing.get_context("fork").Pool(args.jobs)
        results = pool.imap(_one_seed, range(args.seeds))
    else:
        pool, results = None, map(_one_seed, range(args.seeds))
    for seed, dt, nb, order, c2, figs, branch in results:
        per_term.append(branch)
        times.append(dt)
        nbs.append(nb)
        orders.append(order)
        chi2.append(c2)
        for key, (e, c) in figs.items():
            out[key][0].append(e)
            out[key][1].append(c)
        if seed < 3 or seed % 10 == 9:
            e = np.median(figs["spline"][0][:, diag], axis=0)
            print(f"  seed {seed}: spline n_basis {nb}, noise level from residuals {100 * np.sqrt(c2):.3f} %, {dt:.1f} s; median error "
                  + " ".join(f"{100 * v:.3g}" for v in e) + " %", flush=True)
    if pool is not None:
        pool.close()
    print(f"\nspline fit: {np.mean(times):.1f} s per fit (median {np.median(times):.1f}, {args.jobs} process(es)); n_basis chosen "
          + ", ".join(f"{k}: {nbs.count(k)}" for k in sorted(set(nbs))) + f"; noise level from residuals {100 * np.sqrt(np.median(chi2)):.3f} % (median)")
    print("coefficients per diagonal term (median over seeds): " + " ".join(f"{names[t]}: {v:g}" for t, v in zip(diag, np.median(orders, axis=0))))
    print(f"{'term':10s} " + " ".join(f"{k:>22s}" for k in out) + f" {'CRB (4 per term)':>18s}")
    print(f"{'':10s} " + " ".join(f"{'median err / cover':>22s}" for _ in out))
    for i, t in enumerate(diag):
        cells = []
        for key in out:
            e = np.concatenate([x[:, t] for x in out[key][0]])
            c = np.concatenate([x[:, t].ravel() for x in out[key][1]])
            cells.append(f"{100 * np.median(e):12.3g} % / {c.mean():5.2f}")
        print(f"{names[t]:10s} " + " ".join(f"{s:>22s}" for s in cells) + f" {100 * crb_med[i]:16.3g} %")
    per_term = np.array(per_term)
    print("\nspline fit, coverage of the diagonal terms' 90 % bands by the band's branch (spline_bands): per-term orders"
          f" (bias: each short term in turn given {args.max_basis} coefficients) / one uniform order, any (bias: each term in"
          " turn given the order above it; n_basis per seed above)")
    for label, group in (("per-term", per_term), ("uniform", ~per_term)):
        if group.any():
            c = [np.mean([out["spline"][1][s][:, t] for s in np.flatnonzero(group)]) for t in diag]
            print(f"  {label:9s} {int(group.sum()):3d} seeds: " + " ".join(f"{names[t]} {v:.2f}" for t, v in zip(diag, c)))
    print("\noff-diagonal terms, spline fit: median error relative to sqrt(|K_aa K_bb|) / coverage of the 90 % bands"
          " (* a coupling of the true mount; the others are zero)")
    nonzero = {(COMP.index(a), COMP.index(b)) for a, b, _ in K0_COUPLINGS}
    cells = []
    for t in np.flatnonzero(ia != ib):
        e = np.concatenate([x[:, t] for x in out["spline"][0]])
        c = np.concatenate([x[:, t].ravel() for x in out["spline"][1]])
        star = "*" if (ia[t], ib[t]) in nonzero or (ib[t], ia[t]) in nonzero else " "
        cells.append(f"{names[t] + star:11s} {100 * np.median(e):7.3g} % / {c.mean():4.2f}")
    for k in range(0, len(cells), 3):
        print("  ".join(cells[k:k + 3]))


if __name__ == "__main__":
    main()
