"""A plain per-line Hong & Lee against ``method = "hong-lee"`` (``identify_joint``) on the same noisy data.

The plain method (:func:`plain_hong_lee`) is the paper's two steps with numpy's pseudo-inverse on
every line, unscaled, written from the equations (not from jointid's solver)::

    H*[mbar, e] = pinv(Do[nbar, mbar]) (I[nbar, e] - Do[nbar, m] H*[m, e])      (estimation)
    Du          = (I[n, e] - Do[n, :] H*[:, e]) pinv(H*[n, e])                  (identification)

Both get the free model the pipeline gives hong-lee (``study.structure.dense_model``: the beam on
its grid nodes, with the accelerometers if ``model_accelerometers``) and the same data: the
study's exact accelerances (``jointid.simulate``, a finer mesh than the model) times
``1 + noise n`` with ``n`` complex circular Gaussian, ``E|n|^2 = 1``.

Cases: the built-in benchmark (``jointid.benchmark_study()``) and a beam of this script's own
(steel, 0.6 m, 13 grid nodes, joint at node 4 off mid-span, Material B, data from 24 elements per
segment). Printed per case and noise level (medians over the study's lines, then over seeds): the
K_ww and K_theta_theta relative errors of both, and the quality of jointid's per-term flag: the
median error of the lines flagged reliable and of the others, and the fraction flagged; with
``std_real``/``std_imag`` given, the coverage of the 90 % intervals ``|dK| <= 1.645 sigma`` on the
flagged lines (real and imaginary part, averaged). Model error (the grid model against data from a
finer mesh) is a bias outside these intervals; ``--matching`` gives hong-lee the data's own mesh
(``jointid.free_model(study)``, refined) to check the propagation alone.

Run: python benchmarks/hong_lee_plain.py [--seeds 20] [--noise 0.005 0.01] [--matching] [--weighting none]
"""

from __future__ import annotations

import argparse
import time

from dataclasses import replace

import numpy as np

import jointid
from jointid.methods.hong_lee.inverse import InverseOptions, identify_joint
from jointid.study.parse import parse_study

OWN_BEAM = {
    "beam": {"length": 0.6, "width": 0.02, "height": 0.01, "elastic_modulus": 205e9, "density": 7850.0,
             "loss_factor": 0.002, "poisson_ratio": 0.29, "shear_coefficient": 0.8333333333333334, "nodes": 13},
    "joint": {"node": 4, "dofs": ["w", "theta"], "model": {"type": "elastomer", "material": "B"}},
    "measurement": {"observed": [1, 3, 5, 7, 10, 13], "excited": [2, 7, 11]},
    "frequency": {"start": 5.0, "stop": 1200.0, "step": 1.0},
    "truth": {"elements_per_segment": 24},
}


def plain_hong_lee(K, M, dofs, H, w, n, m, e):
    """The paper's two steps per line, unscaled ``numpy.linalg.pinv``; returns Du (F, |n|, |n|).

    ``K, M`` (N, N) free model, ``dofs`` its DOF list, ``H`` (F, |m|, |e|) receptance, m/N,
    ``w`` (F,) rad/s, ``n, m, e`` lists of DOFs.
    """
    pos = {d: i for i, d in enumerate(dofs)}
    n, m, e = ([pos[d] for d in g] for g in (n, m, e))
    N = len(dofs)
    nbar = [i for i in range(N) if i not in n]
    mbar = [i for i in range(N) if i not in m]
    I = np.eye(N)[:, e]
    Du = np.empty((len(w), len(n), len(n)), complex)
    for f, wf in enumerate(w):
        Do = K - wf**2 * M
        Hall = np.zeros((N, len(e)), complex)
        Hall[m] = H[f]
        Hall[mbar] = np.linalg.pinv(Do[np.ix_(nbar, mbar)]) @ (I[nbar] - Do[np.ix_(nbar, m)] @ H[f])
        Du[f] = (I[n] - Do[n] @ Hall) @ np.linalg.pinv(Hall[n])
    return Du


def case(study, matching=False):
    """(free model, exact receptance FRF, truth (F, n, n)) of a study, as the pipeline gives hong-lee."""
    free = jointid.free_model(study) if matching else study.structure.dense_model(study.frequency.stop)
    acc = study.accelerometers
    if study.identification.model_accelerometers and acc is not None and not matching:
        free = free.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
    test = jointid.simulate(study)
    keep = test.frf.frequency.hz > 0
    frf = test.frf.band(test.frf.frequency.hz[keep][0]).to("receptance")
    return free, frf, test.truth[keep]


def noisy(frf, level, seed):
    """``H (1 + level n)``, n complex circular Gaussian with E|n|^2 = 1."""
    rng = np.random.default_rng(seed)
    z = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2)
    return replace(frf, data=frf.data * (1 + level * z))


def rel_err(K, truth, i, j):
    return np.abs(K[:, i, j] - truth[:, i, j]) / np.abs(truth[:, i, j])


def run(name, study, levels, seeds, matching=False, weighting="relative"):
    free, frf, truth = case(study, matching)
    n = study.joint_dofs
    w = frf.frequency.omega
    print(f"\n{name}: {len(free.dofs)}-DOF free model, {frf.frequency.size} lines, |m| = {len(frf.responses)}, "
          f"|e| = {len(frf.references)}, joint {[str(d) for d in n]}")
    print("noise | K_ww plain / jointid | K_thth plain / jointid | flag K_ww: rel / unrel median (frac) | "
          "flag K_thth: rel / unrel (frac) | coverage ww thth (flagged)")
    for level in levels:
        rows = []
        t_plain = t_jid = 0.0
        for seed in range(seeds):
            data = noisy(frf, level, seed)
            t0 = time.perf_counter()
            Kp = plain_hong_lee(free.K, free.M, free.dofs, data.data, w, n, data.responses, data.references)
            t1 = time.perf_counter()
            r = identify_joint(free, data, n, InverseOptions(weighting=weighting))
            t2 = time.perf_counter()
            t_plain += t1 - t0
            t_jid += t2 - t1
            row = []
            rel = r.reliable_terms
            std_r, std_i = r.std_real, r.std_imag
            for i, j in ((0, 0), (1, 1)):
                ep, ej = rel_err(Kp, truth, i, j), rel_err(r.stiffness, truth, i, j)
                flag = rel[:, i, j]
                d = r.stiffness[:, i, j] - truth[:, i, j]
                inside = 0.5 * ((np.abs(d.real) <= 1.645 * std_r[:, i, j]) + 1.0 * (np.abs(d.imag) <= 1.645 * std_i[:, i, j]))
                row += [np.median(ep), np.median(ej),
                        np.median(ej[flag]) if flag.any() else np.nan,
                        np.median(ej[~flag]) if (~flag).any() else np.nan, flag.mean(),
                        inside[flag].mean() if flag.any() else np.nan]
            rows.append(row)
        a = np.nanmedian(np.array(rows), axis=0)
        print(f"{level:5.3f} | {a[0]:.3%} / {a[1]:.3%} ({a[1] / a[0]:.2f}x) | {a[6]:.3%} / {a[7]:.3%} "
              f"({a[7] / a[6]:.2f}x) | {a[2]:.2%} / {a[3]:.2%} ({a[4]:.0%}) | {a[8]:.2%} / {a[9]:.2%} ({a[10]:.0%})"
              f" | {a[5]:.2f} {a[11]:.2f}   [{t_plain / seeds:.2f} s plain, {t_jid / seeds:.2f} s jointid per run]")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--noise", type=float, nargs="+", default=[0.005, 0.01])
    p.add_argument("--matching", action="store_true", help="free model = the data's mesh (no model error)")
    p.add_argument("--weighting", default="relative", choices=("relative", "none"),
                   help="InverseOptions.weighting (none: the unweighted estimation step of earlier versions)")
    a = p.parse_args(argv)
    run("benchmark (Model 3, joint at mid-span, Material A)", jointid.benchmark_study(), a.noise, a.seeds, a.matching,
        a.weighting)
    run("own beam (steel 0.6 m, 13 nodes, joint at node 4, Material B, data 24 el/segment)",
        parse_study(OWN_BEAM, "<own beam>"), a.noise, a.seeds, a.matching, a.weighting)


if __name__ == "__main__":
    main()
