"""A small 3-D test structure for the [structure] study tests: 6-DOF nodes, masses and full SPD springs.

Nodes 1..N, each with x, y, z, rx, ry, rz; a chain of springs between consecutive
nodes (each spring a random symmetric positive definite 6x6 block ``k`` acting as
``[[k, -k], [-k, k]]``), with ``breaks`` listing nodes after which the chain is cut
(separate parts). Masses 0.5-1.5 kg, rotary inertias 2e-3-6e-3 kg*m^2.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from jointid.dofs import DofArray
from jointid.io.matrix_files import write_dof_list

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")

#: A 6-DOF mount stiffening over frequency, as a study's ``[joint.model]`` (``.format(n=node)``):
#: ``K0 (1 + 0.3 (f / 100)^0.8) (1 + 0.12 j)`` with three couplings.
MOUNT_A = """
[joint.model]
type = "mount"
stiffness = [3e6, 2e6, 4e6, 3e3, 2.5e3, 1.5e3]
couplings = [["{n}x", "{n}ry", 2e4], ["{n}y", "{n}rx", -1.5e4], ["{n}x", "{n}y", 4e5]]
loss_factor = 0.12
growth = 0.3
reference_frequency = 100.0
exponent = 0.8
"""
#: A second 6-DOF mount (``.format(n=node)``).
MOUNT_B = """
[joint.model]
type = "mount"
stiffness = [1.5e6, 2.5e6, 3e6, 2e3, 3e3, 2e3]
couplings = [["{n}z", "{n}rz", 1e4], ["{n}rx", "{n}ry", 300.0]]
loss_factor = 0.08
growth = 0.5
"""


def toml_list(xs) -> str:
    """``["a", "b"]``: a TOML array of strings."""
    return "[" + ", ".join(f'"{x}"' for x in xs) + "]"


def structure_table(mass: str, dofs: str) -> str:
    """The ``[structure]`` table of the chain's files (``mass`` holds M and K), loss factor 0.003."""
    return f'\n[structure]\nmass = "{mass}"\nstiffness = "{mass}"\ndofs = "{dofs}"\nloss_factor = 0.003\n'


def write_grounded_study(directory: Path, observed, excited, joints=("front", "rear"), step: float = 20.0,
                         smoothing: str | None = "none", extra: str = "") -> Path:
    """The 10-node chain with grounded mounts (``"front"``: MOUNT_A at node 1, ``"rear"``: MOUNT_B at node 10), 10-400 Hz
    every ``step`` Hz, written with its model files to ``directory/study.toml``; ``smoothing`` None: the default."""
    text = structure_table(*write_model(directory, 10))
    for name, node, model in (("front", 1, MOUNT_A), ("rear", 10, MOUNT_B)):
        if name in joints:
            text += textwrap.dedent(f"""
                [[joint]]
                name = "{name}"
                dofs = {toml_list(labels(node))}
                """) + model.format(n=node)
    text += textwrap.dedent(f"""
        [measurement]
        observed = {toml_list(observed)}
        excited = {toml_list(excited)}
        """)
    if smoothing is not None:
        text += f'\n[identification]\nsmoothing = "{smoothing}"\n'
    text += f"\n[frequency]\nstart = 10.0\nstop = 400.0\nstep = {step}\n" + extra
    path = Path(directory) / "study.toml"
    path.write_text(text)
    return path


def chain_matrices(n_nodes: int = 10, breaks: tuple[int, ...] = (), seed: int = 3):
    """(M, K, DofArray) of the spring chain, sparse."""
    rng = np.random.default_rng(seed)
    N = 6 * n_nodes
    M = np.zeros(N)
    K = np.zeros((N, N))
    for a in range(n_nodes):
        M[6 * a:6 * a + 3] = rng.uniform(0.5, 1.5)
        M[6 * a + 3:6 * a + 6] = rng.uniform(2e-3, 6e-3, 3)
    scale = np.array([1e6, 1e6, 1e6, 2e3, 2e3, 2e3])
    for a in range(n_nodes - 1):
        if a + 1 in breaks:
            continue
        B = rng.standard_normal((6, 6)) * 0.3
        k = np.sqrt(scale)[:, None] * (B @ B.T + np.eye(6)) * np.sqrt(scale)[None, :]
        i, j = slice(6 * a, 6 * a + 6), slice(6 * a + 6, 6 * a + 12)
        K[i, i] += k
        K[j, j] += k
        K[i, j] -= k
        K[j, i] -= k
    node = np.repeat(np.arange(1, n_nodes + 1), 6)
    code = np.tile(np.arange(1, 7), n_nodes)
    return sp.csr_array(sp.diags(M)), sp.csr_array(K), DofArray(node, code)


def write_model(directory: Path, n_nodes: int = 10, breaks: tuple[int, ...] = (), seed: int = 3) -> tuple[str, str]:
    """Save the chain as ``model.npz`` (arrays M, K) and ``model_dofs.csv`` in ``directory``; returns their names."""
    M, K, dofs = chain_matrices(n_nodes, breaks, seed)
    np.savez(directory / "model.npz", M=M.toarray(), K=K.toarray())
    write_dof_list(directory / "model_dofs.csv", dofs)
    return "model.npz", "model_dofs.csv"


def labels(node: int, comps=COMPONENTS) -> list[str]:
    """``["<node>x", ..., "<node>rz"]``."""
    return [f"{node}{c}" for c in comps]
