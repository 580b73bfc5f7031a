"""``jointid modes``: free-free natural frequencies of a study's beam, and its FRFs."""

from __future__ import annotations

import argparse

from ..io.output_dir import OutputSet
from ..errors import StudyError
from .common import add_out_argument, add_study_argument, study_from_args

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    p = sub.add_parser(
        "modes",
        help="free-free natural frequencies of the study's beam",
        description="Write DIR/modes.csv (mode, frequency_hz) with the free-free natural frequencies "
        "of the study's beam (rigid-body modes at ~0 Hz included), print them, and plot the free-free "
        "driving-point accelerances at the excited nodes (DIR/modes_frf.png).",
    )
    add_study_argument(p, required=False)
    add_out_argument(p)
    p.add_argument("--no-plots", action="store_true", help="skip the FRF figure")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..physics.modes import natural_modes
    from ..physics.synthesis import synthesize_frf
    from ..plots.frf import plot_frf

    study = study_from_args(args)
    with OutputSet(args.out, command="modes") as out:
        if study.beam is None:  # the dense modes of the beam factory; a large matrix model has its own eigensolver
            raise StudyError(f"{study.source}: `jointid modes` needs a [beam] study; the modes of a [{study.structure.study_table}] "
                             "come with its FRFs (`jointid simulate --free`)")
        beam = study.beam.structure()
        modes = natural_modes(beam)
        f = modes.frequencies_hz
        out.write_csv("modes.csv", {"mode": range(1, f.size + 1), "frequency_hz": f})
        if not args.no_plots:
            dofs = study.measurement.excited_dofs
            frf = synthesize_frf(beam, study.grid, dofs, dofs, kind="accelerance", modes=modes)
            fig = plot_frf(frf, pairs=[(d, d) for d in dofs], markers_hz=f[f > 1e-3],
                           title="free-free driving-point accelerance (dotted: natural frequencies)")
            out.write_figure("modes_frf.png", fig)
    print(f"free-free modes of {study.source} ({study.beam.nodes} nodes, {study.beam.theory}):")
    for i, x in enumerate(f[:12], 1):
        print(f"  mode {i:2d}: {x:10.2f} Hz" + ("  (rigid body)" if x < 1e-3 else ""))
    if f.size > 12:
        print(f"  ... {f.size} modes in all, written to {out.path('modes.csv')}")
    return 0
