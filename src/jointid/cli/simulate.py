"""``jointid simulate``: a virtual test of the study's constrained beam, or of its free beam (``--free``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import StudyError
from ..io.json_files import json_text
from ..io.output_dir import OutputSet
from ..study.parse import load_study
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run", "write_true_joints"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "simulate",
        help="synthesize the constrained beam's FRFs (a virtual test) and the true joint, or a free-free test (--free)",
        description="Synthesize the FRFs of the study's beam attached to ground through its [joint.model] "
        "(with the [accelerometers] on the test article, if given) at the observed x excited coordinates, "
        "and write DIR/frf.uff (UFF58 accelerance, (m/s^2)/N, like a real test) and DIR/true_joint.csv "
        "(the true joint matrix, columns as `jointid identify` writes them). With --free: the free (suspended) "
        "beam with its accelerometers, no joint, at the same coordinates: DIR/free_frf.uff and DIR/true_beam.json "
        "(a virtual free-free test for `jointid update`). The simulated beam is the study's [beam] with its [truth] "
        "overrides, or the [beam] of --truth OTHER.toml. A [structure] study: --free writes DIR/free_frf.uff, the "
        "free structure (its matrices with their stiffness_scale, mass_scale and loss_factor, no joint) on the observed x "
        "excited DOFs; to simulate a true structure that differs from the model, write its own study (e.g. other scales).",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.add_argument("--free", action="store_true", help="a free-free test of the beam with its accelerometers (no joint)")
    p.add_argument("--noise", type=float, default=0.0, metavar="X",
                   help="relative rms of complex Gaussian noise on every FRF value (default 0: exact)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the noise (default 0)")
    p.add_argument("--truth", type=Path, metavar="OTHER.toml",
                   help="study whose [beam] (with its [truth]) is the true beam; default: this study's [beam] + [truth]")
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


def write_true_joints(out, study, frequency, truth) -> list:
    """One ``true_joint[_<name>].csv`` per ``[[joint]]`` of a structure study (its block of ``truth``); returns the paths."""
    from ..terms import stiffness_columns

    written, i = [], 0
    for joint in study.joints:
        k = len(joint.joint_dofs)
        name = "true_joint.csv" if len(study.joints) == 1 else f"true_joint_{joint.name}.csv"
        written.append(out.write_csv(name, stiffness_columns(frequency, joint.joint_dofs, truth[:, i:i + k, i:i + k])))
        i += k
    return written


def _run_structure_free(args: argparse.Namespace, study) -> int:
    """A structure study's free-free test (no joints): DIR/free_frf.uff on the observed x excited DOFs."""
    from ..io.uff import write_uff_frf
    from ..pipeline_structure import simulate_free_structure

    with OutputSet(args.out, command="simulate") as out:
        frf = simulate_free_structure(study, noise=args.noise, seed=args.seed)
        uff = out.write_file("free_frf.uff", lambda p: write_uff_frf(p, frf, kind="accelerance", description="jointid free-free test"))
    f = frf.frequency.hz
    print(f"wrote {uff} (free-free: {len(frf.responses)} x {len(frf.references)} accelerances, "
          f"{f.size} lines {f[0]:g}-{f[-1]:g} Hz, noise {args.noise:g})")
    return 0


def _run_structure(args: argparse.Namespace, study) -> int:
    """A structure study: FRFs of the structure on all its [[joint]] mounts; one true_joint[_<name>].csv per joint."""
    from ..io.uff import write_uff_frf
    from ..pipeline import simulate

    with OutputSet(args.out, command="simulate") as out:
        test = simulate(study)
        frf = _noisy(test.frf, args.noise, args.seed)
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, frf, kind="accelerance", description="jointid structure test"))
        written = write_true_joints(out, study, test.frequency, test.truth)
    f = test.frequency.hz
    print(
        f"wrote {uff} ({len(frf.responses)} x {len(frf.references)} accelerances, {f.size} lines {f[0]:g}-{f[-1]:g} Hz, "
        f"{len(study.joints)} joint(s), noise {args.noise:g}) and {', '.join(map(str, written))}"
    )
    return 0


def run(args: argparse.Namespace) -> int:
    from ..io.uff import write_uff_frf
    from ..terms import stiffness_columns
    from ..pipeline import simulate, simulate_free, true_beam_study

    if not args.noise >= 0 or args.noise != args.noise or args.noise == float("inf"):
        raise StudyError(f"--noise: expected a relative rms >= 0 (e.g. 0.01), got {args.noise}")
    if args.seed < 0:
        raise StudyError(f"--seed: expected an integer >= 0, got {args.seed}")
    study = study_from_args(args)
    if study.is_structure and args.truth:
        raise StudyError(
            f"{study.source}: --truth applies to [beam] studies only; simulate a study of the true structure "
            "(its [structure] stiffness_scale, mass_scale, loss_factor) instead"
        )
    if study.is_structure:
        return _run_structure_free(args, study) if args.free else _run_structure(args, study)
    other = load_study(args.truth) if args.truth else None
    true = true_beam_study(study, other)
    if args.free:
        with OutputSet(args.out, command="simulate") as out:
            frf = simulate_free(study, noise=args.noise, seed=args.seed, truth=other)
            uff = out.write_file("free_frf.uff", lambda p: write_uff_frf(p, frf, kind="accelerance", description="jointid free-free test"))
            b = true.beam
            truth = {
                "elastic_modulus": b.elastic_modulus, "density": b.density, "loss_factor": b.loss_factor,
                "elements_per_segment": b.mesh_refinement(study.frequency.stop), "noise": args.noise, "seed": args.seed,
                "accelerometers": None if study.accelerometers is None else {
                    "mass": study.accelerometers.mass, "rotary_inertia": study.accelerometers.rotary_inertia,
                    "nodes": list(study.accelerometers.nodes)},
            }
            js = out.write_text("true_beam.json", json_text(truth))
        f = frf.frequency.hz
        print(f"wrote {uff} (free-free: {len(frf.responses)} x {len(frf.references)} accelerances, "
              f"{f.size} lines {f[0]:g}-{f[-1]:g} Hz, noise {args.noise:g}) and {js}")
        return 0
    with OutputSet(args.out, command="simulate") as out:
        test = simulate(true)
        if args.noise > 0:
            import numpy as np

            from ..frf import FRF

            rng = np.random.default_rng(args.seed)
            shape = test.frf.data.shape
            n = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)
            noisy = FRF(test.frf.frequency, test.frf.data * (1.0 + args.noise * n), test.frf.responses, test.frf.references, test.frf.kind)
        else:
            noisy = test.frf
        uff = out.write_file("frf.uff", lambda p: write_uff_frf(p, noisy, kind="accelerance"))
        csv = out.write_csv("true_joint.csv", stiffness_columns(test.frequency, test.joint_dofs, test.truth))
    f = test.frequency.hz
    print(
        f"wrote {uff} ({len(test.frf.responses)} x {len(test.frf.references)} accelerances, "
        f"{f.size} lines {f[0]:g}-{f[-1]:g} Hz) and {csv}"
    )
    return 0
