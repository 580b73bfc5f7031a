"""Assembled structures: beams, lumped masses, springs, frequency-dependent joints, supports.

A :class:`Structure` is immutable: every ``with_*`` method returns a new one, so a
model can be shared between studies without anyone changing it under another.

The dynamic stiffness on the active (unconstrained) DOFs is

    D(w) = K_s (1 + j*eta_g) summed over element groups + sum_j K_j(f) - w^2 M

with structural (hysteretic) damping per group and frequency-dependent complex
stiffness terms ``K_j(f)`` (joints, elastomer mounts) on labelled DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Sequence

import numpy as np

from ..dofs import DIRECTIONS, Dof, dof_indices, parse_dof, parse_dofs
from ..errors import DofError, ModelError
from ..frequency import Frequency
from .elements import Material, Section, timoshenko_element

__all__ = ["ComplexStiffness", "Structure", "build_beam", "constant_stiffness"]


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class ComplexStiffness:
    """A frequency-dependent complex stiffness matrix attached to labelled DOFs.

    The matrix connects the DOFs to each other and to ground: it is added to the
    structure's dynamic stiffness at those DOFs as it stands (a grounded joint
    gives its 2x2 matrix on (w, theta) of one node).

    Parameters
    ----------
    dofs : tuple of Dof, length k
        DOFs the matrix acts on, in matrix order.
    function : callable
        ``function(f_hz)`` with ``f_hz`` an ndarray of shape (F,) in Hz returns
        the complex stiffness, shape (F, k, k), in N/m, N/rad, N*m/m, N*m/rad.
    name : str
        Label for reports.
    """

    dofs: tuple[Dof, ...]
    function: Callable[[np.ndarray], np.ndarray]
    name: str = "joint"

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", parse_dofs(self.dofs))
        if len(set(self.dofs)) != len(self.dofs):
            raise ModelError(f"{self.name}: repeated DOF in {[str(d) for d in self.dofs]}")

    def __call__(self, f_hz) -> np.ndarray:
        """Evaluate the stiffness at ``f_hz`` (Hz, shape (F,)); returns (F, k, k) complex."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        k = np.asarray(self.function(f), dtype=complex)
        n = len(self.dofs)
        if k.shape == (n, n):
            k = np.broadcast_to(k, (f.size, n, n))
        if k.shape != (f.size, n, n):
            raise ModelError(
                f"{self.name}: stiffness function returned shape {k.shape}, expected ({f.size}, {n}, {n})"
            )
        return k


def constant_stiffness(dofs: Sequence, matrix, name: str = "spring") -> ComplexStiffness:
    """A frequency-independent complex stiffness ``matrix`` (k, k) on ``dofs`` as a :class:`ComplexStiffness`."""
    m = np.array(matrix, dtype=complex)
    m.setflags(write=False)
    return ComplexStiffness(parse_dofs(dofs), lambda f: np.broadcast_to(m, (f.size,) + m.shape), name)


@dataclass(frozen=True, eq=False)
class Structure:
    """An assembled linear structure in planar bending.

    Parameters
    ----------
    all_dofs : tuple of Dof, length N
        Every DOF of the model, including fixed ones, in matrix order.
    coordinates : dict
        Node number -> x coordinate, m.
    mass : ndarray, shape (N, N)
        Mass matrix (kg, kg*m, kg*m^2).
    stiffness : ndarray, shape (N, N), complex
        Frequency-independent complex stiffness ``sum_g K_g (1 + j eta_g)``.
    joints : tuple of ComplexStiffness
        Frequency-dependent complex stiffness terms.
    fixed : frozenset of Dof
        Constrained (zero-displacement) DOFs, removed from every matrix this
        structure hands out.
    """

    all_dofs: tuple[Dof, ...]
    coordinates: dict
    mass: np.ndarray
    stiffness: np.ndarray
    joints: tuple[ComplexStiffness, ...] = ()
    fixed: frozenset = field(default_factory=frozenset)

    def __post_init__(self) -> None:
        n = len(self.all_dofs)
        if self.mass.shape != (n, n) or self.stiffness.shape != (n, n):
            raise ModelError("mass and stiffness must be square with one row per DOF")
        object.__setattr__(self, "mass", _frozen(np.asarray(self.mass, dtype=float)))
        object.__setattr__(self, "stiffness", _frozen(np.asarray(self.stiffness, dtype=complex)))
        object.__setattr__(self, "_index", {d: i for i, d in enumerate(self.all_dofs)})

    # ------------------------------------------------------------------ DOFs
    @property
    def dofs(self) -> tuple[Dof, ...]:
        """Active (unconstrained) DOFs, in matrix order of every matrix handed out."""
        return tuple(d for d in self.all_dofs if d not in self.fixed)

    @property
    def nodes(self) -> tuple[int, ...]:
        """Node numbers in ascending order."""
        return tuple(sorted(self.coordinates))

    def _active_index(self) -> np.ndarray:
        return np.array([self._index[d] for d in self.dofs], dtype=int)

    def index(self, dofs: Iterable) -> list[int]:
        """Positions of ``dofs`` among the active DOFs (raises DofError if fixed or absent)."""
        return dof_indices(self.dofs, dofs, what="structure's active DOFs")

    def _check_dofs(self, dofs: Iterable[Dof], what: str) -> None:
        for d in dofs:
            if d not in self._index:
                raise DofError(f"{what}: DOF {d} is not in the structure (nodes {self.nodes[0]}..{self.nodes[-1]})")

    # ------------------------------------------------------------ matrices
    @property
    def M(self) -> np.ndarray:
        """Mass matrix on the active DOFs, shape (n, n)."""
        i = self._active_index()
        return self.mass[np.ix_(i, i)]

    @property
    def K(self) -> np.ndarray:
        """Frequency-independent complex stiffness on the active DOFs, shape (n, n)."""
        i = self._active_index()
        return self.stiffness[np.ix_(i, i)]

    @property
    def proportional_loss_factor(self) -> float | None:
        """The single loss factor eta with ``Im K = eta Re K``, or None if damping is not proportional.

        Modal superposition with real modes is exact only when this is not None
        and the structure has no frequency-dependent joints.
        """
        K = self.K
        kr, ki = K.real, K.imag
        denom = float(np.vdot(kr, kr))
        if denom == 0.0:
            return None
        eta = float(np.vdot(kr, ki)) / denom
        if np.linalg.norm(ki - eta * kr) <= 1e-10 * max(np.linalg.norm(ki), 1e-300 + np.linalg.norm(kr) * 1e-16):
            return eta
        if np.linalg.norm(ki) == 0.0:
            return 0.0
        return None

    def dynamic_stiffness(self, frequency: Frequency | np.ndarray) -> np.ndarray:
        """Dynamic stiffness ``D(w) = K* + sum K_j(f) - w^2 M`` on the active DOFs.

        Parameters
        ----------
        frequency : Frequency or array_like, shape (F,)
            Frequency lines, Hz.

        Returns
        -------
        ndarray, shape (F, n, n), complex
            N/m, N/rad, N*m/m, N*m/rad.
        """
        f = frequency.hz if isinstance(frequency, Frequency) else np.atleast_1d(np.asarray(frequency, float))
        w2 = (2.0 * np.pi * f) ** 2
        D = self.K[None, :, :] - w2[:, None, None] * self.M[None, :, :]
        D = D.astype(complex)
        self.add_joints(D, f)
        return D

    def joint_terms(self, f_hz: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each joint's stiffness on its active DOFs: ``(K_j (F, k, k), active indices (k,))`` pairs."""
        pos = {d: i for i, d in enumerate(self.dofs)}
        out = []
        for joint in self.joints:
            keep = [a for a, d in enumerate(joint.dofs) if d in pos]
            if keep:
                idx = np.array([pos[joint.dofs[a]] for a in keep], dtype=int)
                out.append((joint(f_hz)[:, keep][:, :, keep], idx))
        return out

    def add_joints(self, D: np.ndarray, f_hz: np.ndarray) -> None:
        """Add every frequency-dependent joint term to ``D`` (F, n, n) in place (active DOFs)."""
        for kj, idx in self.joint_terms(f_hz):
            D[:, idx[:, None], idx[None, :]] += kj

    # ------------------------------------------------------------ builders
    def with_mass(self, node: int, mass_kg: float, rotary_inertia_kg_m2: float = 0.0) -> "Structure":
        """Return a copy with a lumped mass (kg) and rotary inertia (kg*m^2) at ``node``."""
        if not (np.isfinite(mass_kg) and mass_kg >= 0 and np.isfinite(rotary_inertia_kg_m2) and rotary_inertia_kg_m2 >= 0):
            raise ModelError(
                f"lumped mass at node {node}: mass ({mass_kg!r} kg) and rotary inertia "
                f"({rotary_inertia_kg_m2!r} kg*m^2) must be finite and >= 0"
            )
        w, t = Dof(node, "w"), Dof(node, "theta")
        self._check_dofs([w, t], f"lumped mass at node {node}")
        M = np.array(self.mass)
        M[self._index[w], self._index[w]] += mass_kg
        M[self._index[t], self._index[t]] += rotary_inertia_kg_m2
        return replace(self, mass=M)

    def with_masses(self, nodes: Iterable[int], mass_kg: float, rotary_inertia_kg_m2: float = 0.0) -> "Structure":
        """Return a copy with the same lumped mass and rotary inertia at each of ``nodes`` (e.g. accelerometers)."""
        s = self
        for n in nodes:
            s = s.with_mass(int(n), mass_kg, rotary_inertia_kg_m2)
        return s

    def with_spring(self, dof_a, dof_b=None, stiffness: complex = 0.0) -> "Structure":
        """Return a copy with a frequency-independent complex spring.

        Parameters
        ----------
        dof_a, dof_b : Dof or label
            Connected DOFs; ``dof_b=None`` grounds the spring at ``dof_a``.
        stiffness : complex
            ``k (1 + j eta)`` in N/m (translation) or N*m/rad (rotation).
        """
        a = parse_dof(dof_a)
        dofs = [a] if dof_b is None else [a, parse_dof(dof_b)]
        self._check_dofs(dofs, "spring")
        K = np.array(self.stiffness)
        ia = self._index[a]
        K[ia, ia] += stiffness
        if dof_b is not None:
            ib = self._index[dofs[1]]
            K[ib, ib] += stiffness
            K[ia, ib] -= stiffness
            K[ib, ia] -= stiffness
        return replace(self, stiffness=K)

    def with_joint(self, joint: ComplexStiffness) -> "Structure":
        """Return a copy with a frequency-dependent complex stiffness term (e.g. the joint to ground)."""
        if not isinstance(joint, ComplexStiffness):
            raise ModelError("with_joint expects a ComplexStiffness (dofs + function of frequency in Hz)")
        self._check_dofs(joint.dofs, joint.name)
        return replace(self, joints=self.joints + (joint,))

    def with_joints(self, joints: Iterable[ComplexStiffness]) -> "Structure":
        """Return a copy with every joint of ``joints`` attached (:meth:`with_joint`)."""
        s = self
        for joint in joints:
            s = s.with_joint(joint)
        return s

    def with_fixed(self, dofs: Iterable) -> "Structure":
        """Return a copy with ``dofs`` constrained to zero displacement."""
        new = parse_dofs(dofs)
        self._check_dofs(new, "support")
        return replace(self, fixed=frozenset(self.fixed) | frozenset(new))

    def clamped(self, node: int) -> "Structure":
        """Return a copy clamped at ``node`` (w = theta = 0)."""
        return self.with_fixed([Dof(node, "w"), Dof(node, "theta")])

    def pinned(self, node: int) -> "Structure":
        """Return a copy simply supported at ``node`` (w = 0)."""
        return self.with_fixed([Dof(node, "w")])

    def translational_mass(self) -> float:
        """Total mass in rigid translation ``u^T M u`` (u = 1 at every w DOF, all DOFs), kg."""
        u = np.array([1.0 if d.direction == "w" else 0.0 for d in self.all_dofs])
        return float(u @ self.mass @ u)


def build_beam(
    length: float,
    section: Section,
    material: Material,
    nodes: int,
    shear_coefficient: float = 5.0 / 6.0,
    euler_bernoulli: bool = False,
    first_node: int = 1,
    elements_per_segment: int = 1,
) -> Structure:
    """A free-free uniform beam of ``nodes`` equally spaced nodes numbered from ``first_node`` at x = 0.

    With ``elements_per_segment = r > 1`` every segment between two of these
    nodes is meshed with ``r`` elements: the ``nodes`` keep their numbers
    (``first_node .. first_node + nodes - 1``, the measurement grid) and the
    ``(nodes - 1)(r - 1)`` internal nodes are numbered after them, in x order
    (``first_node + nodes, ...``). They are ordinary (unobserved) DOFs.

    Parameters
    ----------
    length : float
        Beam length, m.
    section : Section
        Cross-section.
    material : Material
        E (Pa), rho (kg/m^3), loss factor (structural damping ``K (1 + j eta)``), G or nu.
    nodes : int
        Number of nodes (>= 2); ``nodes - 1`` elements.
    shear_coefficient : float
        Timoshenko shear coefficient kappa.
    euler_bernoulli : bool
        Use Euler-Bernoulli elements (no shear deformation, no rotary inertia).
    first_node : int
        Number of the node at x = 0.
    elements_per_segment : int
        Elements between two consecutive grid nodes (>= 1); see
        :func:`jointid.physics.beam_mesh.elements_per_segment` for the convergence criterion.

    Returns
    -------
    Structure
        DOFs ordered (node1 w, node1 theta, node2 w, ...).
    """
    if not isinstance(nodes, (int, np.integer)) or isinstance(nodes, bool) or nodes < 2:
        raise ModelError(f"a beam needs an integer number of nodes >= 2, got {nodes!r}")
    r = elements_per_segment
    if not isinstance(r, (int, np.integer)) or isinstance(r, bool) or r < 1:
        raise ModelError(f"elements_per_segment must be an integer >= 1, got {r!r}")
    nodes, r = int(nodes), int(r)
    ne = (nodes - 1) * r
    Ke, Me = timoshenko_element(length / ne, section, material, shear_coefficient, euler_bernoulli)
    n = 2 * (ne + 1)
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    # element e spans global DOFs 2e .. 2e+3: add all blocks with one fancy-index scatter
    rows = (2 * np.arange(ne))[:, None] + np.arange(4)[None, :]
    np.add.at(K, (rows[:, :, None], rows[:, None, :]), Ke)
    np.add.at(M, (rows[:, :, None], rows[:, None, :]), Me)
    # mesh point p (x = length p / ne): grid node if p % r == 0, else an internal node numbered after the grid
    p = np.arange(ne + 1)
    internal = p % r != 0
    ids = np.where(internal, 0, first_node + p // r)
    ids[internal] = first_node + nodes + np.arange(int(internal.sum()))
    dofs = tuple(Dof(int(i), d) for i in ids for d in DIRECTIONS)
    coords = {int(i): length * int(k) / ne for k, i in enumerate(ids)}
    return Structure(dofs, coords, M, K * (1.0 + 1j * material.loss_factor))
