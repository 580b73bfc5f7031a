"""Large sparse model: 4 grounded 6-DOF mounts on a >= 1e5-DOF free grillage, 2000 lines.

Run: ``python3 benchmarks/large_model.py [--nodes 4200] [--lines 2000] [--smoothing none|gcv]``.

The free structure is a grillage of steel bars in the x-y plane (3-D
Euler-Bernoulli frame elements, 6 DOFs per node, lumped masses and rotary
inertias), ``nodes x 4`` nodes: 4200 x 4 = 100 800 DOFs, built with
``scipy.sparse`` in under a second. Four grounded mounts on the outer rails,
each a frequency-dependent symmetric 6x6 complex stiffness with
translation-rotation couplings, make 24 joint DOFs. Translations x, y, z are
observed at 16 points (each mount node, 5 cm and 20 cm along its rail, across
on the other rail: 48 DOFs) and excited at 12 points (6 cm and 20 cm along the
rail, across: 36 DOFs).

The layout matters: a plane structure decouples the out-of-plane motion (z, rx,
ry) from the in-plane one (x, y, rz), so the 12 out-of-plane joint DOFs need at
least 12 z measurements and 12 z hits. The first layout had 8 z hits: Y[n,e]
had rank 20 < 24 and the weighted design a condition of 1e12-1e16, whatever
the units (column equilibration already removes the scaling of rotations vs
translations) or the modal truncation (which sets the accuracy floor against
the direct reference, 2e-4, not the conditioning).

Steps, each timed (wall and cpu):

1. **free receptance** on m, n, e at every line from :class:`jointid.physics.sparse_model.SparseModel`
   (modal with residual compensation): the modes (one sparse factorization and
   shift-invert Lanczos), the residual moments of every DOF used (cached per DOF),
   the modal sum over the lines;
2. **constrained FRFs** by Woodbury, ``H = Y[m,e] - Y[m,n] (Y[n,n] + Du^-1)^-1 Y[n,e]``;
3. **identification** with :func:`jointid.methods.receptance.coupling.identify_joint_coupling`
   on all lines at once: 24 joint DOFs take the Kronecker path of
   :func:`jointid.methods.receptance.coupling_lines.coupling_per_line` (the exact per-line
   path would need ~100 GB here); its error against the Du the FRFs were made with;
4. **Kronecker vs exact path** on a few lines with noisy FRFs (0.1 % plus a floor per hit),
   where the exact per-line weighted fit also runs;
5. **accuracy** on a subset of lines against an independent reference: the
   constrained FRFs from a direct sparse solve of the whole constrained model
   (``K (1 + j eta) - w^2 M + Du``) identified with the same (modal) free model,
   compared with the true Du -- so the modal truncation error is in the figure.

Errors are ``|K - Du| / sqrt|Du_ii Du_jj|``, worst per term type: translational
and rotational diagonal terms, the couplings of each mount, the other (zero) terms.
Prints the peak memory (``ru_maxrss``) and the load average.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from jointid.dofs import COMPONENTS, DofArray
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.methods.receptance.coupling_lines import coupling_per_line
from jointid.physics.sparse_model import SparseModel

E, G, RHO, ETA = 210e9, 81e9, 7850.0, 0.002  # steel; structural loss factor


def frame_element(L: float, A: float, Iy: float, Iz: float, J: float) -> np.ndarray:
    """12x12 stiffness of a 3-D Euler-Bernoulli frame element along local x (u, v, w, rx, ry, rz per node)."""
    k = np.zeros((12, 12))
    a = E * A / L
    t = G * J / L
    k[np.ix_([0, 6], [0, 6])] = a * np.array([[1, -1], [-1, 1]])
    k[np.ix_([3, 9], [3, 9])] = t * np.array([[1, -1], [-1, 1]])
    bz = E * Iz / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                                   [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L * L, -6 * L, 4 * L * L]])
    k[np.ix_([1, 5, 7, 11], [1, 5, 7, 11])] = bz  # v, rz (bending in x-y)
    by = E * Iy / L**3 * np.array([[12, -6 * L, -12, -6 * L], [-6 * L, 4 * L * L, 6 * L, 2 * L * L],
                                   [-12, 6 * L, 12, 6 * L], [-6 * L, 2 * L * L, 6 * L, 4 * L * L]])
    k[np.ix_([2, 4, 8, 10], [2, 4, 8, 10])] = by  # w, ry (bending in x-z)
    return k


def grillage(nx: int, ny: int, dx: float, dy: float, rail=(0.02, 0.03), cross=(None, 0.03)):
    """Sparse M, K and DOFs of an ``nx x ny`` grillage in the x-y plane (node ids 1..nx*ny, 6 DOFs each).

    Bars along x (``rail`` = width, depth, m) join neighbouring nodes of a row; bars
    along y (``cross``; width None: ``dx``, a plate strip) join the rows. Lumped
    masses and rotary inertias, so M is diagonal. Returns (M, K, DofArray, ids) with
    ``ids[iy, ix]`` the node number.
    """
    rows, cols, vals = [], [], []
    ids = np.arange(nx * ny).reshape(ny, nx)
    R = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])  # bar along y: local x = global y
    T = np.kron(np.eye(4), R)
    node_mass = np.zeros(nx * ny)
    for (w, d), L, pairs, turn in (
        (rail, dx, (ids[:, :-1], ids[:, 1:]), False),
        ((cross[0] or dx, cross[1]), dy, (ids[:-1, :], ids[1:, :]), True),
    ):
        A, Iy, Iz = w * d, w * d**3 / 12, d * w**3 / 12
        a, b = min(w, d), max(w, d)
        J = a**3 * b * (1 / 3 - 0.21 * a / b * (1 - a**4 / (12 * b**4)))  # rectangular section torsion constant
        k = frame_element(L, A, Iy, Iz, J)
        if turn:
            k = T.T @ k @ T
        a_, b_ = pairs[0].ravel(), pairs[1].ravel()
        np.add.at(node_mass, a_, RHO * A * L / 2)
        np.add.at(node_mass, b_, RHO * A * L / 2)
        dof = np.concatenate([6 * a_[:, None] + np.arange(6), 6 * b_[:, None] + np.arange(6)], axis=1)  # (e, 12)
        rows.append(np.repeat(dof, 12, axis=1).ravel())
        cols.append(np.tile(dof, (1, 12)).ravel())
        vals.append(np.broadcast_to(k.ravel(), (a_.size, 144)).ravel())
    N = 6 * nx * ny
    K = sp.csc_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))
    inertia = node_mass * (dx * dx + dy * dy) / 12  # rotary inertia of each node's tributary patch
    M = sp.diags_array(np.column_stack([node_mass] * 3 + [inertia] * 3).ravel()).tocsc()
    dofs = DofArray(np.repeat(np.arange(1, nx * ny + 1), 6), np.tile(np.arange(1, 7), nx * ny))
    return M, K, dofs, ids + 1


def mount_stiffness(f_hz: np.ndarray, k_diag: np.ndarray) -> np.ndarray:
    """A mount's symmetric 6x6 complex stiffness (x, y, z, rx, ry, rz), growing with frequency, with couplings; (F, 6, 6).

    ``k_diag`` (6,) are the diagonal stiffnesses at 100 Hz (N/m, N*m/rad); couplings x-ry, y-rx and
    x-z of 0.3, -0.25 and 0.1 of ``sqrt(k_i k_j)`` keep the matrix positive definite.
    """
    K0 = np.diag(k_diag)
    for (i, j), c in {(0, 4): 0.3, (1, 3): -0.25, (0, 2): 0.1}.items():
        K0[i, j] = K0[j, i] = c * np.sqrt(k_diag[i] * k_diag[j])
    growth = 1.0 + 0.4 * np.sqrt(f_hz / 100.0)
    eta = 0.1 + 0.05 * np.log1p(f_hz / 100.0)
    return K0[None] * (growth * (1 + 1j * eta))[:, None, None]


def block_diag(blocks: list[np.ndarray]) -> np.ndarray:
    F = blocks[0].shape[0]
    n = sum(b.shape[1] for b in blocks)
    out = np.zeros((F, n, n), dtype=complex)
    i = 0
    for b in blocks:
        out[:, i:i + b.shape[1], i:i + b.shape[1]] = b
        i += b.shape[1]
    return out


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=4200, help="grillage nodes along x (x 4 rails x 6 DOFs: 4200 -> 100 800 DOFs)")
    ap.add_argument("--lines", type=int, default=2000)
    ap.add_argument("--top-hz", type=float, default=300.0)
    ap.add_argument("--check-lines", type=int, default=5, help="lines checked against the direct constrained solve")
    ap.add_argument("--compare-lines", type=int, default=10, help="noisy lines identified by both the Kronecker and the exact per-line path")
    ap.add_argument("--smoothing", choices=("none", "gcv"), default="none", help="smooth each term over frequency (its cost grows with the terms: 300)")
    args = ap.parse_args(argv)
    t_all, c_all = time.perf_counter(), cpu_s()
    M, K, dofs, ids = grillage(args.nodes, 4, 0.002, 0.04, rail=(0.02, 0.06), cross=(None, 0.06))
    nx = args.nodes
    t_build = time.perf_counter() - t_all
    print(f"grillage {nx} x 4 nodes ({nx * 0.002:.1f} m x 0.12 m, bars 60 mm deep): {len(dofs)} DOFs, K nnz {K.nnz}, built in {t_build:.1f} s")

    at = [int(r * nx) for r in (0.12, 0.38, 0.62, 0.88)]
    rails = [0, 3, 0, 3]
    mounts = [ids[r, i] for r, i in zip(rails, at)]
    across = [ids[3 - r, i] for r, i in zip(rails, at)]
    # measured (x, y, z) at each mount, 5 cm and 20 cm along its rail and across (16 points, 48 DOFs); hit
    # (x, y, z) 6 cm and 20 cm along the rail and across (12 points, 36 DOFs). The grillage is plane, so
    # z (out of plane) decouples from x, y: the 12 out-of-plane joint DOFs (z, rx, ry of 4 mounts) need
    # >= 12 z measurements and >= 12 z hits (8 z hits made the design singular, condition 1e13-1e16)
    observed_nodes = mounts + [ids[r, i + 25] for r, i in zip(rails, at)] + across + [ids[r, i - 100] for r, i in zip(rails, at)]
    hit_nodes = [ids[r, i - 30] for r, i in zip(rails, at)] + [ids[r, i + 100] for r, i in zip(rails, at)] + across
    joint = [f"{int(p)}{c}" for p in mounts for c in COMPONENTS]
    observed = [f"{int(p)}{c}" for p in observed_nodes for c in ("x", "y", "z")]
    excited = [f"{int(p)}{c}" for p in hit_nodes for c in ("x", "y", "z")]
    freq = Frequency(np.linspace(10.0, args.top_hz, args.lines))

    t0, c0 = time.perf_counter(), cpu_s()
    model = SparseModel(M, K, dofs, loss_factor=ETA, method="modal")
    basis = model.ensure_modes(freq.hz[-1])
    t_modes, c_modes = time.perf_counter() - t0, cpu_s() - c0
    t0, c0 = time.perf_counter(), cpu_s()
    union = list(dict.fromkeys(observed + joint + excited))
    model.receptance(freq[:1], union, union)  # residual moments of every DOF used (cached per DOF)
    t_res, c_res = time.perf_counter() - t0, cpu_s() - c0
    t0, c0 = time.perf_counter(), cpu_s()
    Y = model.receptance(freq, observed + joint, joint + excited)
    nm, nn = len(observed), len(joint)
    Ymn, Yme, Ynn = Y[:, :nm, :nn], Y[:, :nm, nn:], Y[:, nm:, :nn]
    Yne = np.ascontiguousarray(Y[:, nm:, nn:])
    t_sum, c_sum = time.perf_counter() - t0, cpu_s() - c0
    print(f"free receptance (modal + residual) on {nm} observed, {nn} joint, {len(excited)} excited DOFs, {freq.size} lines: "
          f"modes {t_modes:.1f} s (cpu {c_modes:.1f} s; {basis.eigenvalues.size} modes up to {basis.frequencies_hz[-1]:.0f} Hz, "
          f"{int(np.sum(basis.frequencies_hz <= freq.hz[-1]))} below {freq.hz[-1]:.0f} Hz); residual moments of {len(union)} DOFs "
          f"{t_res:.1f} s (cpu {c_res:.1f} s); modal sum over the lines {t_sum:.1f} s (cpu {c_sum:.1f} s)")
    # each mount's diagonal terms: 0.3 of the structure's own driving-point stiffness 1 / |Y_ii| at its DOF at
    # ~100 Hz (times 1.0, 1.3, 0.8, 1.1 per mount), so every term is identifiable (a mount far softer than the
    # structure at a DOF, e.g. 1e3 N*m/rad on a node whose rotation is held by 2 mm elements, is not)
    ref = int(np.argmin(np.abs(freq.hz - 100.0)))
    k_struct = 1.0 / np.abs(np.diagonal(Ynn[ref]))
    Du = block_diag([mount_stiffness(freq.hz, 0.3 * s * k_struct[6 * i:6 * i + 6]) for i, s in enumerate([1.0, 1.3, 0.8, 1.1])])
    print("mount 1 diagonal at 100 Hz (x, y, z N/m; rx, ry, rz N*m/rad): " + ", ".join(f"{v:.2e}" for v in np.abs(np.diagonal(Du[ref]))[:6]))

    t0 = time.perf_counter()
    H = Yme - Ymn @ np.linalg.solve(Ynn + np.linalg.inv(Du), Yne)
    t_syn = time.perf_counter() - t0
    del Y, Ymn, Yme, Yne
    print(f"constrained FRFs (Woodbury), {nm} x {len(excited)}: {t_syn:.2f} s")

    t0, c0 = time.perf_counter(), cpu_s()
    frf = FRF(freq, H, observed, excited, kind="receptance")
    r = identify_joint_coupling(model, frf, joint, CouplingOptions(smoothing=args.smoothing))  # 24 joint DOFs x 2000 lines: Kronecker path
    t_id, c_id = time.perf_counter() - t0, cpu_s() - c0
    t_main, c_main = time.perf_counter() - t_all, cpu_s() - c_all
    peak = peak_mb()
    scale = np.sqrt(np.abs(np.diagonal(Du, axis1=1, axis2=2)))
    scale = scale[:, :, None] * scale[:, None, :]  # sqrt(|Du_ii Du_jj|)
    err = np.abs(r.stiffness - Du) / scale
    print(f"identification (identify_joint_coupling, smoothing {args.smoothing!r}, Kronecker path), {nn} joint DOFs, {freq.size} lines: "
          f"{t_id:.1f} s (cpu {c_id:.1f} s, free receptance inside included); condition of the weighted design "
          f"{np.nanmin(r.condition):.1e}..{np.nanmax(r.condition):.1e}")
    print("  exact FRFs of the same free model, worst over all lines of |K - Du| / sqrt|Du_ii Du_jj|: " + term_errors(err))
    print(f"TOTAL (model, free receptance, synthesis, identification): {t_main:.1f} s wall, {c_main:.1f} s cpu; "
          f"peak memory {peak:.0f} MB (ru_maxrss); load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")

    # the Kronecker path against the exact per-line weighted fit, on a few noisy lines where both run
    rng = np.random.default_rng(1)
    sel = np.linspace(0, freq.size - 1, args.compare_lines).astype(int)
    sd = 1e-3 * (np.abs(H[sel]) + 0.01 * np.abs(H[sel]).max(axis=1, keepdims=True))  # 0.1 % + a floor per hit at 1e-5 of its largest FRF
    Hn = H[sel] + sd * (rng.standard_normal(sd.shape) + 1j * rng.standard_normal(sd.shape)) / np.sqrt(2)
    Yb = model.receptance(freq[sel], observed + joint, joint + excited)
    args_l = (Yb[:, :nm, :nn], np.ascontiguousarray(Yb[:, nm:, nn:]), Yb[:, nm:, :nn], Yb[:, :nm, nn:] - Hn, sd**2)
    t0 = time.perf_counter()
    ex = coupling_per_line(*args_l, path="exact", pool_lines=1)
    t_ex = time.perf_counter() - t0
    t0 = time.perf_counter()
    kr = coupling_per_line(*args_l, path="kronecker", pool_lines=1)
    t_kr = time.perf_counter() - t0
    D, sc = Du[sel], scale[sel]
    diag = np.arange(nn)
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    print(f"Kronecker vs exact per-line path, {sel.size} lines, FRFs with 0.1 % noise + a floor, true variance: exact {t_ex:.1f} s, "
          f"Kronecker {t_kr:.2f} s; rms |K - Du| / sqrt|Du_ii Du_jj| exact {rms(np.abs(ex.stiffness - D) / sc):.3f}, Kronecker "
          f"{rms(np.abs(kr.stiffness - D) / sc):.3f} (diagonal {rms(np.abs(ex.stiffness - D)[:, diag, diag] / sc[:, diag, diag]):.4f}, "
          f"{rms(np.abs(kr.stiffness - D)[:, diag, diag] / sc[:, diag, diag]):.4f}); rms of error / predicted std: exact "
          f"{rms(np.abs(ex.stiffness - D) / np.sqrt(ex.variance)):.2f}, Kronecker {rms(np.abs(kr.stiffness - D) / np.sqrt(kr.variance)):.2f}")

    # independent reference on a few lines: a direct sparse solve of the whole constrained model
    t0 = time.perf_counter()
    pick = np.linspace(0, freq.size - 1, args.check_lines).astype(int)
    ni, mi, ei = dofs.indices(joint), dofs.indices(observed), dofs.indices(excited)
    rr, cc = np.meshgrid(ni, ni, indexing="ij")
    Kc = (K * (1 + 1j * ETA)).tocsc()
    Eb = np.zeros((K.shape[0], len(excited)), dtype=complex)
    Eb[ei, np.arange(len(excited))] = 1.0
    Hd = np.empty((pick.size, len(observed), len(excited)), dtype=complex)
    for a, i in enumerate(pick):
        Dj = sp.csc_array((Du[i].ravel(), (rr.ravel(), cc.ravel())), shape=K.shape)
        lu = spla.splu((Kc - (2 * np.pi * freq.hz[i]) ** 2 * M + Dj).tocsc(), permc_spec="COLAMD")
        Hd[a] = lu.solve(Eb)[mi]
    t_ref = time.perf_counter() - t0
    h_err = np.max(np.abs(H[pick] - Hd) / np.abs(Hd).max(axis=(1, 2))[:, None, None])
    K_ref = identify_joint_coupling(model, FRF(Frequency(freq.hz[pick]), Hd, observed, excited, kind="receptance"), joint,
                                    CouplingOptions(smoothing="none", calibration="none")).stiffness
    e_ref = np.abs(K_ref - Du[pick]) / scale[pick]
    print(f"reference: direct sparse LU of the constrained model on {pick.size} lines ({t_ref:.1f} s): the modal-model FRFs "
          f"within {h_err:.1e} of max |H| per line; identified from the direct FRFs with the modal free model, worst of "
          f"|K - Du| / sqrt|Du_ii Du_jj|: " + term_errors(e_ref))
    return 0


TRANSLATION, ROTATION = (0, 1, 2), (3, 4, 5)
COUPLED = ((0, 4), (1, 3), (0, 2))  # the couplings mount_stiffness puts in


def term_errors(err: np.ndarray) -> str:
    """Worst error per term type: translational and rotational diagonal, the couplings, the other terms (zero in Du)."""
    n = err.shape[1]
    kind = np.full((n, n), "other", dtype=object)
    for m in range(n // 6):
        o = 6 * m
        for i in range(6):
            kind[o + i, o + i] = "translation" if i in TRANSLATION else "rotation"
        for i, j in COUPLED:
            kind[o + i, o + j] = kind[o + j, o + i] = "coupling"
    parts = []
    for k in ("translation", "rotation", "coupling", "other"):
        sel = kind == k
        parts.append(f"{k} {np.max(err[:, sel]):.1e}")
    diag = np.arange(n)
    per = np.max(err[:, diag, diag].reshape(err.shape[0], n // 6, 6), axis=(0, 1))
    return ", ".join(parts) + " (diagonal x y z rx ry rz: " + " ".join(f"{v:.0e}" for v in per) + ")"


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


if __name__ == "__main__":
    sys.exit(main())
