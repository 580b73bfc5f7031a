"""Calibration of the inverse method's ``reliable`` flag (see ``jointid.methods.hong_lee.inverse.Reliability``).

Benchmark beam with the cap on the beam, joint at node 10 (Materials A and B), layouts
Models 1-3, 1% complex noise on every FRF value, 1-1000 Hz. Prints, per case, the
fraction of lines flagged reliable and the median translational-stiffness error on
the reliable and on the other lines.
Run: python benchmarks/reliability.py
"""

from __future__ import annotations

import numpy as np

from jointid.methods.hong_lee.inverse import identify_joint
from jointid.physics.synthesis import synthesize_frf
from jointid.reproduce.common import add_noise, material_joint, study_beam
from jointid.reproduce.config import load_config


def main() -> None:
    config = load_config()
    f = config.grid
    beam = study_beam(config)
    rng = np.random.default_rng(0)
    print("case                 reliable  median error: reliable / other lines")
    for material in ("A", "B"):
        joint = material_joint(config, material)
        truth = joint(f.hz)[:, 0, 0]
        for layout in config.layouts.values():
            frf = synthesize_frf(beam.with_joint(joint), f, [f"{n}w" for n in layout.observed],
                                 [f"{n}w" for n in layout.excited], kind="accelerance")
            r = identify_joint(beam, add_noise(frf, 0.01, rng), config.joint_dofs)
            err = np.abs(r.term("w", "w") - truth) / np.abs(truth)
            ok = r.reliable
            print(f"Material {material}, {layout.name}:  {ok.mean():6.0%}   {np.median(err[ok]):6.1%} / {np.median(err[~ok]):6.1%}")


if __name__ == "__main__":
    main()
