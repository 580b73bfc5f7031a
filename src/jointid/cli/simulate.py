"""``jointid simulate``: a virtual test of the study's constrained beam, or of its free beam (``--free``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import StudyError
from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from ..study import load_study
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run", "write_true_joints"]


#: Largest relative rms noise ``--noise`` takes (1000 %: beyond it the FRFs are noise and overflow soon follows).
MAX_NOISE = 10.0


def add_parser(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help="synthesize the test article's FRFs (a virtual test) and the true joints, or a free-free test (--free)",
        description="Synthesize the FRFs of the study's free structure (a [beam] or a [structure] of matrix files) "
        "attached through every joint's [joint.model] (with the [accelerometers] on the test article, if given) at the "
        "observed x excited coordinates, and write DIR/frf.uff (UFF58 accelerance, (m/s^2)/N, like a real test) and "
        "DIR/true_joint.csv (one DIR/true_joint_<name>.csv per joint when there are several; columns as `jointid "
        "identify` writes them). With --free: the free (suspended) structure with its accelerometers, no joint, at the "
        "same coordinates: DIR/free_frf.uff and DIR/true_structure.json (a virtual free-free test for `jointid update`). "
        "The simulated structure is the study's with its [truth] overrides ([beam]: elastic_modulus, density, "
        "loss_factor, elements_per_segment; [structure]: stiffness_scale, mass_scale, loss_factor), or the structure "
        "of --truth OTHER.toml.",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.add_argument("--free", action="store_true", help="a free-free test of the structure with its accelerometers (no joint)")
    p.add_argument("--noise", type=float, default=0.0, metavar="X",
                   help="relative rms of complex Gaussian noise on every FRF value (default 0: exact)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the noise (default 0)")
    p.add_argument("--truth", type=Path, metavar="OTHER.toml",
                   help="study whose free structure (with its [truth]) is the true one; default: this study's + its [truth]")
    p.set_defaults(func=run)


def _noisy(frf, noise: float, seed: int):
    """``frf`` with relative complex Gaussian noise ``H (1 + noise n)`` (unchanged for noise 0)."""
    if noise <= 0:
        return frf
    import numpy as np

    from ..frf import FRF

    rng = np.random.default_rng(seed)
    n = (rng.standard_normal(frf.data.shape) + 1j * rng.standard_normal(frf.data.shape)) / np.sqrt(2.0)
    return FRF(frf.frequency, frf.data * (1.0 + noise * n), frf.responses, frf.references, frf.kind)


#: What ``simulate --free`` writes beside the FRFs: the true free structure's values (JSON).
TRUTH_FILE = "true_structure.json"


def write_true_joints(out, study, frequency, truth) -> list:
    """One ``true_joint[_<name>].csv`` per joint of the study (its block of ``truth``); returns the paths."""
    from ..terms import stiffness_columns

    written, i = [], 0
    for joint in study.joints:
        k = len(joint.joint_dofs)
        name = "true_joint.csv" if len(study.joints) == 1 else f"true_joint_{joint.name}.csv"
        written.append(out.write_csv(name, stiffness_columns(frequency, joint.joint_dofs, truth[:, i:i + k, i:i + k])))
        i += k
    return written


def run(args: argparse.Namespace) -> int:
    from ..io.uff import write_uff_frf
    from ..pipeline import simulate, simulate_free, true_study

    if not 0 <= args.noise <= MAX_NOISE:
        raise StudyError(f"--noise: expected a relative rms >= 0 (e.g. 0.01 for 1 %) and at most {MAX_NOISE:g}, got {args.noise}")
    if args.seed < 0:
        raise StudyError(f"--seed: expected an integer >= 0, got {args.seed}")
    study = study_from_args(args)
    lines = study.frequency.frequency().hz.size
    if lines < 2:  # a UFF58 record holds at least 2 lines
        fq = study.frequency
        raise StudyError(f"{study.source}: [frequency] gives {lines} line ({fq.start:g}..{fq.stop:g} Hz, step {fq.step:g}); "
                         "a simulated FRF file needs at least 2: lower step or widen start..stop")
    other = load_study(args.truth) if args.truth else None
    true = true_study(study, other)
    if args.free:
        with OutputSet(args.out, command="simulate --free") as out:  # its own set: a jointed test's files stay
            frf = simulate_free(study, noise=args.noise, seed=args.seed, truth=other)
            uff = out.write_file("free_frf.uff", lambda p: write_uff_frf(p, frf, kind="accelerance", description="jointid free-free test"))
            spec = true.structure
            truth = {k: getattr(spec, k) for k in spec.truth_keys}
            if "elements_per_segment" in truth:
                truth["elements_per_segment"] = spec.mesh_refinement(study.frequency.stop)
            truth.update({
                "structure": spec.describe(), "noise": args.noise, "seed": args.seed,
                "accelerometers": None if study.accelerometers is None else {
                    "mass": study.accelerometers.mass, "rotary_inertia": study.accelerometers.rotary_inertia,
                    "nodes": list(study.accelerometers.nodes)},
            })
            js = out.write_text(TRUTH_FILE, json_text(truth))
        f = frf.frequency.hz
        print(f"wrote {uff} (free-free: {len(frf.responses)} x {len(frf.references)} accelerances, "
              f"{f.size} lines {f[0]:g}-{f[-1]:g} Hz, noise {args.noise:g}) and {js}")
        return 0
    with OutputSet(args.out, command="simulate") as out:
        test = simulate(true)
        frf = _noisy(test.frf, args.noise, args.seed)
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, frf, kind="accelerance"))
        written = write_true_joints(out, study, test.frequency, test.truth)
    f = test.frequency.hz
    print(
        f"wrote {uff} ({len(frf.responses)} x {len(frf.references)} accelerances, {f.size} lines {f[0]:g}-{f[-1]:g} Hz, "
        f"{len(study.joints)} joint(s), noise {args.noise:g}) and {', '.join(map(str, written))}"
    )
    return 0
