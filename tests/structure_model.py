"""A small 3-D test structure for the [structure] study tests: 6-DOF nodes, masses and full SPD springs.

Nodes 1..N, each with x, y, z, rx, ry, rz; a chain of springs between consecutive
nodes (each spring a random symmetric positive definite 6x6 block ``k`` acting as
``[[k, -k], [-k, k]]``), with ``breaks`` listing nodes after which the chain is cut
(separate parts). Masses 0.5-1.5 kg, rotary inertias 2e-3-6e-3 kg*m^2.
"""

from __future__ import annotations

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
