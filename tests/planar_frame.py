"""A planar frame for the dead/invisible-DOF tests: a rectangle of steel tubes in the xy plane, 6 DOFs per node.

In-plane (x, y, rz) and out-of-plane (z, rx, ry) motions are exactly uncoupled, so every FRF between an
in-plane and an out-of-plane DOF is exactly zero, and in-plane measurements cannot see a joint's
out-of-plane DOFs at all.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import scipy.io

from jointid.io.matrix_files import write_dof_list
from jointid.physics.frame import build_frame
from jointid.physics.frame_sections import FrameSection
from jointid.physics.elements import Material


def write_planar_frame(directory: Path, elements: int = 4) -> tuple[str, str, str]:
    """Write ``frame_M.mtx``, ``frame_K.mtx`` and ``frame_dofs.csv``; returns (mass, stiffness, dofs) names."""
    steel = Material(210e9, 7850.0, loss_factor=0.002)
    tube = FrameSection.circle(0.03, 0.026)
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.8, 0.0, 0.0), 3: (0.8, 0.5, 0.0), 4: (0.0, 0.5, 0.0)}
    frame = build_frame(nodes, [(1, 2, tube, steel, elements), (2, 3, tube, steel, elements),
                                (3, 4, tube, steel, elements), (4, 1, tube, steel, elements)])
    scipy.io.mmwrite(directory / "frame_M.mtx", frame.mass)
    scipy.io.mmwrite(directory / "frame_K.mtx", frame.stiffness)
    write_dof_list(directory / "frame_dofs.csv", frame.dofs)
    return "frame_M.mtx", "frame_K.mtx", "frame_dofs.csv"


def planar_study(directory: Path, observed: list[str], excited: list[str], joint_dofs: list[str], extra: str = "") -> Path:
    """A [structure] study: the frame on one grounded mount at node 1 (its ``joint_dofs``)."""
    mass, stiffness, dofs = write_planar_frame(directory)
    lst = lambda xs: "[" + ", ".join(f'"{x}"' for x in xs) + "]"  # noqa: E731
    comps = [d.lstrip("0123456789") for d in joint_dofs]
    values = {"x": 3e6, "y": 2e6, "z": 4e6, "rx": 3e3, "ry": 2.5e3, "rz": 1.5e3}
    text = textwrap.dedent(f"""
        [structure]
        mass = "{mass}"
        stiffness = "{stiffness}"
        dofs = "{dofs}"

        [[joint]]
        name = "mount"
        dofs = {lst(joint_dofs)}

        [joint.model]
        type = "mount"
        stiffness = {[values[c] for c in comps]}
        loss_factor = 0.1

        [measurement]
        observed = {lst(observed)}
        excited = {lst(excited)}

        [frequency]
        start = 20.0
        stop = 400.0
        step = 10.0
        """) + extra
    p = directory / "study.toml"
    p.write_text(text)
    return p
