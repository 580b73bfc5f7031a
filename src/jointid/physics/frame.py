"""3-D frames of Timoshenko beam elements, 6 DOFs per node, assembled sparse.

A frame is built from nodes at arbitrary coordinates and straight members
between them, each meshed into equal elements (:func:`build_frame`)::

    from jointid.physics import FrameSection, Material, build_frame
    steel = Material(210e9, 7850, loss_factor=0.001)
    tube = FrameSection.circle(0.04, 0.034)
    model = build_frame({1: (0, 0, 0), 2: (1, 0, 0), 3: (1, 0.5, 0.2)},
                        [(1, 2, tube, steel, 20), (2, 3, tube, steel, 10)])
    free = model.free_model()          # a SparseModel: receptance(frequency, rows, cols)

DOFs are ``x, y, z`` (m) and ``rx, ry, rz`` (rad, right-handed rotations about
the global axes) of every node (:data:`jointid.dofs.COMPONENTS`), node by node:
the given nodes in ascending number, then each member's internal nodes,
numbered consecutively from ``internal_node_start`` (default: one above the
highest given node) member after member, from the member's start to its end.

Element
-------
Local axes: x from the start node to the end node; y along the member's
``orientation`` vector (its component across the member); ``z = x cross y``.
Default orientation: y horizontal, ``y ~ Z cross x`` (so a member along X has
local axes = global axes, and a section's ``height`` is vertical, as for the
planar beam); a vertical member (along +-Z) takes y = global Y.

On local DOFs ``(u, v, w, tx, ty, tz)`` of both nodes the element is the
superposition of

* axial bar: ``K = E A / L [[1, -1], [-1, 1]]``, ``M = rho A L / 6 [[2, 1], [1, 2]]``;
* torsion: ``K = G J / L [[1, -1], [-1, 1]]``, ``M = rho (Iy + Iz) L / 6 [[2, 1], [1, 2]]``;
* bending in the x-y plane on ``(v1, tz1, v2, tz2)`` (``tz = dv/dx`` in the
  Euler-Bernoulli limit) with ``Iz`` and ``kappa_y``, and in the x-z plane on
  ``(w1, -ty1, w2, -ty2)`` (``-ty = dw/dx``) with ``Iy`` and ``kappa_z``: each the
  exact two-node Timoshenko element of
  :func:`jointid.physics.elements.timoshenko_element` (stiffness with shear
  parameter ``phi = 12 E I / (kappa G A L^2)``, consistent mass with
  translational and rotary inertia, Friedman & Kosmatka 1993).

Global matrices are ``T^T K T`` with ``T`` four copies of the direction-cosine
matrix. The element is exact in statics for end loads (tip deflection
``P L^3 / (3 E I) + P L / (kappa G A)``); dynamics converge with the mesh
(consistent mass: frequencies from above), as ``h^4`` while elements are long
compared with the section depth but only as ``h^2`` once they are short
(``phi >> 1``: the shape functions tend to linear ones; ``tests/test_frame.py``
checks the first three modes of a simply supported deep beam against the
analytic ones as the mesh is refined), so keep ~10 elements per half
wavelength and check convergence with the mesh. Caveats: straight prismatic members
with doubly symmetric sections (shear centre = centroid, no warping: open thin
sections are stiffer in torsion here than in reality), small displacements,
no geometric stiffness (axial load does not change bending stiffness),
members are rigidly connected at shared nodes. Damping is structural, one loss
factor for the whole frame (``K (1 + j eta)``).

Lumped masses (:class:`PointMass`: accelerometers, rigid bodies with an
offset centre of mass and an inertia tensor) are added to M at nodes.

Assembly is vectorized over elements (one batch of ``(n, 12, 12)`` arrays and
one ``scipy.sparse`` COO -> CSR conversion), with no Python loop over elements.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

import numpy as np
import scipy.sparse as sp

from ..dofs import COMPONENTS, COMPONENT_CODES, DofArray
from ..errors import ModelError
from .elements import Material, timoshenko_bending
from .frame_sections import FrameSection

__all__ = ["Member", "PointMass", "FrameModel", "build_frame", "frame_element", "element_axes"]

_CODES = np.array([COMPONENT_CODES[c] for c in COMPONENTS], dtype=np.int64)  # x..rz -> 1..6
#: |sin| of the angle between an orientation vector and the member below which they are parallel.
PARALLEL_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Member:
    """A straight prismatic member between two nodes, meshed into equal elements.

    Parameters
    ----------
    start, end : int
        Node numbers (keys of :func:`build_frame`'s ``nodes``).
    section : FrameSection
        Cross-section in local axes.
    material : Material
        E (Pa), density (kg/m^3), G or nu; its loss factor is the frame's unless overridden.
    elements : int
        Number of equal elements (>= 1); ``elements - 1`` internal nodes.
    orientation : (3,) array_like, optional
        A vector (global axes, any length) giving the local y axis (its part
        across the member); default: see the module docstring.
    """

    start: int
    end: int
    section: FrameSection
    material: Material
    elements: int = 1
    orientation: tuple | None = None


@dataclass(frozen=True)
class PointMass:
    """A rigid body attached to a node: mass, inertia tensor, offset centre of mass.

    Parameters
    ----------
    mass : float
        kg (>= 0).
    inertia : float, (3,) or (3, 3) array_like
        Inertia tensor about the body's centre of mass in global axes, kg*m^2:
        a scalar (isotropic), the diagonal, or the full symmetric tensor.
    offset : (3,) array_like
        Centre of mass minus node position, m (global axes).

    Notes
    -----
    With ``S(r)`` the cross-product matrix of the offset ``r``, the body's
    6 x 6 mass matrix on the node's ``(x, y, z, rx, ry, rz)`` is
    ``[[m I, -m S], [m S, J - m S S]]`` (the centre of mass moves ``u + theta x r``).
    """

    mass: float = 0.0
    inertia: object = 0.0
    offset: tuple = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        """The 6 x 6 mass matrix on the node's DOFs (kg, kg*m, kg*m^2)."""
        m = float(self.mass)
        J = np.asarray(self.inertia, dtype=float)
        J = np.eye(3) * J if J.ndim == 0 else (np.diag(J) if J.shape == (3,) else J)
        r = np.asarray(self.offset, dtype=float)
        if not (np.isfinite(m) and m >= 0):
            raise ModelError(f"point mass must be a finite number >= 0 kg, got {self.mass!r}")
        if J.shape != (3, 3) or r.shape != (3,) or not (np.isfinite(J).all() and np.isfinite(r).all()):
            raise ModelError("point mass: inertia must be a number, 3 diagonal values or a 3 x 3 tensor (kg*m^2), offset 3 coordinates (m)")
        if np.abs(J - J.T).max() > 1e-12 * max(np.abs(J).max(), 1e-300) or np.linalg.eigvalsh(0.5 * (J + J.T)).min() < -1e-12 * np.abs(J).max():
            raise ModelError("point mass: the inertia tensor must be symmetric positive semi-definite (kg*m^2)")
        S = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        out = np.zeros((6, 6))
        out[:3, :3] = m * np.eye(3)
        out[:3, 3:] = -m * S
        out[3:, :3] = m * S
        out[3:, 3:] = J - m * S @ S
        return 0.5 * (out + out.T)  # exactly symmetric


@dataclass(frozen=True, eq=False)
class FrameModel:
    """An assembled free 3-D frame.

    Attributes
    ----------
    mass, stiffness : scipy.sparse.csr_array, shape (N, N)
        Real symmetric mass (kg, kg*m, kg*m^2) and storage stiffness (N/m, N/rad, N*m/rad).
    dofs : DofArray
        DOF of each row: 6 per node, ``x, y, z, rx, ry, rz``.
    loss_factor : float
        Structural loss factor eta (dynamic stiffness ``K (1 + j eta) - w^2 M``).
    node_ids : ndarray of int64, shape (n,)
        Node numbers in DOF order.
    node_coordinates : ndarray, shape (n, 3)
        Their coordinates, m.
    member_nodes : tuple of ndarray
        For each member, its node chain from start to end (internal nodes included).
    """

    mass: sp.csr_array
    stiffness: sp.csr_array
    dofs: DofArray
    loss_factor: float
    node_ids: np.ndarray
    node_coordinates: np.ndarray
    member_nodes: tuple = ()

    @property
    def size(self) -> int:
        """Number of DOFs N."""
        return len(self.dofs)

    def coordinates(self, nodes: Iterable[int]) -> np.ndarray:
        """Coordinates of ``nodes`` (m), shape (k, 3); ModelError for a node not in the frame."""
        nodes = np.atleast_1d(np.asarray(list(nodes) if not np.isscalar(nodes) else [nodes], dtype=np.int64))
        order = np.argsort(self.node_ids)
        pos = np.minimum(np.searchsorted(self.node_ids, nodes, sorter=order), len(order) - 1)
        found = self.node_ids[order[pos]] == nodes
        if not found.all():
            raise ModelError(f"node {int(nodes[~found][0])} is not in the frame")
        return self.node_coordinates[order[pos]]

    def free_model(self, **options):
        """The frame as a :class:`~jointid.physics.sparse_model.SparseModel` (options: ``method``, ``cutoff_factor``, ...)."""
        from .sparse_model import SparseModel

        return SparseModel(self.mass, self.stiffness, self.dofs, self.loss_factor, **options)

    def rigid_body_modes(self, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The six rigid-body displacement fields, shape (N, 6): translations x, y, z, rotations about x, y, z through ``origin`` (m)."""
        d = self.node_coordinates - np.asarray(origin, dtype=float)
        n = len(self.node_ids)
        R = np.zeros((n, 6, 6))
        R[:, 0:3, 0:3] = np.eye(3)
        R[:, 3:6, 3:6] = np.eye(3)
        # u = theta x d: columns e_k x d
        for k in range(3):
            R[:, 0:3, 3 + k] = np.cross(np.eye(3)[k], d)
        return R.reshape(6 * n, 6)

    def constrained(self, dofs) -> "FrameModel":
        """A copy with ``dofs`` (labels, DofArray) removed: fixed to zero displacement."""
        drop = np.zeros(self.size, dtype=bool)
        drop[self.dofs.indices(dofs, "frame")] = True
        keep = np.flatnonzero(~drop)
        sub = DofArray(self.dofs.node[keep], self.dofs.code[keep])
        return FrameModel(
            sp.csr_array(self.mass[keep][:, keep]), sp.csr_array(self.stiffness[keep][:, keep]), sub,
            self.loss_factor, self.node_ids, self.node_coordinates, self.member_nodes,
        )

    def clamped(self, nodes: Iterable[int]) -> "FrameModel":
        """A copy with every DOF of ``nodes`` fixed (a clamped support)."""
        nodes = np.asarray(list(nodes), dtype=np.int64)
        return self.constrained((np.repeat(nodes, 6), np.tile(_CODES, nodes.size)))


def element_axes(start: np.ndarray, end: np.ndarray, orientation: np.ndarray | None = None) -> np.ndarray:
    """Direction cosines of elements: rows ``(x, y, z)`` local axes in global components, shape (n, 3, 3).

    Parameters
    ----------
    start, end : ndarray, shape (n, 3)
        End coordinates, m (distinct: the caller checks lengths).
    orientation : ndarray, shape (n, 3), optional
        Vectors giving local y (rows of NaN: the default, see the module docstring).
        They must not be parallel to the element (the caller checks).
    """
    ex = end - start
    ex = ex / np.linalg.norm(ex, axis=1)[:, None]
    n = ex.shape[0]
    ref = np.full((n, 3), np.nan) if orientation is None else np.array(orientation, dtype=float)
    default = np.isnan(ref).any(axis=1)
    if default.any():
        zx = np.cross(np.array([0.0, 0.0, 1.0]), ex[default])
        vertical = np.linalg.norm(zx, axis=1) < PARALLEL_TOLERANCE
        zx[vertical] = (0.0, 1.0, 0.0)
        ref[default] = zx
    ey = ref - np.sum(ref * ex, axis=1)[:, None] * ex
    ey = ey / np.linalg.norm(ey, axis=1)[:, None]
    ez = np.cross(ex, ey)
    return np.stack([ex, ey, ez], axis=1)


#: Local DOFs and signs of the two bending planes: x-y on (v, tz), x-z on (w, -ty).
_PLANE_XY = (np.array([1, 5, 7, 11]), np.array([1.0, 1.0, 1.0, 1.0]))
_PLANE_XZ = (np.array([2, 4, 8, 10]), np.array([1.0, -1.0, 1.0, -1.0]))


def frame_element(
    length, E, G, density, area, Iy, Iz, J, kappa_y, kappa_z, euler_bernoulli: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Local stiffness and consistent mass of 3-D Timoshenko frame elements, vectorized.

    Parameters
    ----------
    length : array_like, shape (n,)
        Element lengths L, m.
    E, G : array_like, shape (n,) or scalar
        Young's and shear moduli, Pa.
    density : array_like
        rho, kg/m^3.
    area, Iy, Iz, J : array_like
        A (m^2), second moments ``Iy = int z^2 dA``, ``Iz = int y^2 dA`` and torsion constant (m^4).
    kappa_y, kappa_z : array_like
        Shear coefficients for shear along local y and z.
    euler_bernoulli : bool
        No shear deformation and no rotary inertia in bending (torsional inertia is kept).

    Returns
    -------
    K, M : ndarray, shape (n, 12, 12)
        On local ``(u, v, w, tx, ty, tz)`` of the start then the end node (see the module docstring).
    """
    L = np.atleast_1d(np.asarray(length, dtype=float))
    b = [np.broadcast_to(np.asarray(a, dtype=float), L.shape) for a in (E, G, density, area, Iy, Iz, J, kappa_y, kappa_z)]
    E, G, rho, A, Iy, Iz, J, ky, kz = b
    n = L.size
    K = np.zeros((n, 12, 12))
    M = np.zeros((n, 12, 12))
    bar = np.array([[1.0, -1.0], [-1.0, 1.0]])
    cons = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
    for (i, j), k, m in (((0, 6), E * A / L, rho * A * L), ((3, 9), G * J / L, rho * (Iy + Iz) * L)):
        K[:, [[i], [j]], [i, j]] = k[:, None, None] * bar
        M[:, [[i], [j]], [i, j]] = m[:, None, None] * cons
    for (idx, sign), I, kappa in ((_PLANE_XY, Iz, ky), (_PLANE_XZ, Iy, kz)):
        Kb, Mb = timoshenko_bending(L, E, G, rho, A, I, kappa, euler_bernoulli)
        s = sign[:, None] * sign[None, :]
        K[:, idx[:, None], idx[None, :]] = Kb * s
        M[:, idx[:, None], idx[None, :]] = Mb * s
    return K, M


def _vector(value, what: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        v = np.full(1, np.nan)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ModelError(f"{what} must be 3 finite numbers (x, y, z), got {value!r}")
    return v


def _as_member(k: int, m) -> Member:
    if isinstance(m, Member):
        member = m
    elif isinstance(m, (tuple, list)) and 4 <= len(m) <= 6:
        member = Member(*m)
    else:
        raise ModelError(f"member {k}: give a Member or a tuple (start, end, section, material[, elements[, orientation]]), got {m!r}")
    if not isinstance(member.section, FrameSection):
        raise ModelError(f"member {k} ({member.start}-{member.end}): section must be a FrameSection (FrameSection.circle or .rectangle), got {type(member.section).__name__}")
    if not isinstance(member.material, Material):
        raise ModelError(f"member {k} ({member.start}-{member.end}): material must be a jointid Material, got {type(member.material).__name__}")
    e = member.elements
    if not isinstance(e, (int, np.integer)) or isinstance(e, bool) or e < 1:
        raise ModelError(f"member {k} ({member.start}-{member.end}): elements must be an integer >= 1, got {e!r}")
    return member


def _assemble_blocks(Ae: np.ndarray, pos_a: np.ndarray, pos_b: np.ndarray, nn: int,
                     extra_pos: np.ndarray | None = None, extra: np.ndarray | None = None) -> sp.csr_array:
    """Global CSR matrix from element matrices ``Ae`` (n, 12, 12) on node positions ``pos_a``, ``pos_b``.

    Assembled by 6 x 6 node blocks: the blocks are sorted stably by (row, column)
    node and summed in element order (``np.add.reduceat``), so block (b, a) is
    exactly the transpose of block (a, b) and the matrix is exactly symmetric
    when every element matrix is. ``extra`` (k, 6, 6) are added on the diagonal
    blocks of node positions ``extra_pos`` (point masses).
    """
    blocks = [Ae[:, :6, :6], Ae[:, :6, 6:], Ae[:, 6:, :6], Ae[:, 6:, 6:]]
    keys = [pos_a * nn + pos_a, pos_a * nn + pos_b, pos_b * nn + pos_a, pos_b * nn + pos_b]
    if extra_pos is not None and extra_pos.size:
        blocks.append(extra)
        keys.append(extra_pos * nn + extra_pos)
    data = np.concatenate(blocks).reshape(-1, 36)
    key = np.concatenate(keys)
    srt = np.argsort(key, kind="stable")
    sk = key[srt]
    first = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1]])
    summed = np.add.reduceat(data[srt], first, axis=0).reshape(-1, 6, 6)
    brow, bcol = np.divmod(sk[first], nn)
    indptr = np.searchsorted(brow, np.arange(nn + 1))
    A = sp.bsr_array((summed, bcol, indptr), shape=(6 * nn, 6 * nn)).tocsr()
    A.eliminate_zeros()
    A.sort_indices()
    return sp.csr_array(A)


def build_frame(
    nodes: Mapping[int, Sequence[float]],
    members: Sequence,
    point_masses: Mapping[int, "PointMass | float"] | None = None,
    loss_factor: float | None = None,
    internal_node_start: int | None = None,
    euler_bernoulli: bool = False,
) -> FrameModel:
    """Assemble a free 3-D frame of Timoshenko beam elements (see the module docstring).

    Parameters
    ----------
    nodes : mapping int -> (x, y, z)
        Node numbers (>= 1) and coordinates, m. Every node must belong to a member.
    members : sequence of Member or tuple
        ``(start, end, section, material[, elements[, orientation]])``; members
        are numbered from 1 in error messages.
    point_masses : mapping int -> PointMass or float, optional
        Lumped masses at nodes (a float: a point mass in kg without inertia).
    loss_factor : float, optional
        The frame's structural loss factor; default: the members' materials'
        (which must then agree: one loss factor per frame).
    internal_node_start : int, optional
        Number of the first internal node (default: highest node + 1).
    euler_bernoulli : bool
        Euler-Bernoulli bending elements (no shear deformation, no bending rotary inertia).

    Returns
    -------
    FrameModel

    Raises
    ------
    ModelError
        One line: an unknown node, a zero-length member, an orientation
        vector parallel to its member, a node on no member, bad numbers.
    """
    ids = sorted(nodes)
    for n in ids:
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise ModelError(f"node numbers must be integers >= 1, got {n!r}")
    if not members:
        raise ModelError("a frame needs at least one member")
    coords = {int(n): _vector(nodes[n], f"coordinates of node {n}") for n in ids}
    mlist = [_as_member(k, m) for k, m in enumerate(members, start=1)]
    next_id = (max(ids) + 1 if ids else 1) if internal_node_start is None else int(internal_node_start)
    if next_id < 1:
        raise ModelError(f"internal_node_start must be >= 1, got {internal_node_start!r}")
    used = set()
    chains, starts, ends, orient, props = [], [], [], [], []
    internal_ids, internal_xyz = [], []
    for k, m in enumerate(mlist, start=1):
        a, b = int(m.start), int(m.end)
        for n in (a, b):
            if n not in coords:
                raise ModelError(f"member {k} ({m.start}-{m.end}): node {n} is not in nodes; give its coordinates")
        pa, pb = coords[a], coords[b]
        length = float(np.linalg.norm(pb - pa))
        if length <= 1e-12 * max(1.0, float(np.abs(pa).max()), float(np.abs(pb).max())):
            raise ModelError(f"member {k} ({a}-{b}) has zero length: nodes {a} and {b} are at the same point")
        ex = (pb - pa) / length
        if m.orientation is None:
            o = np.full(3, np.nan)
        else:
            o = _vector(m.orientation, f"member {k} ({a}-{b}): orientation")
            if np.linalg.norm(np.cross(o, ex)) <= PARALLEL_TOLERANCE * np.linalg.norm(o):
                raise ModelError(f"member {k} ({a}-{b}): orientation vector {tuple(float(x) for x in o)} is parallel to the member; give a vector across it (it sets local y)")
        ne = int(m.elements)
        inner = np.arange(next_id, next_id + ne - 1, dtype=np.int64)
        next_id += ne - 1
        t = np.arange(1, ne)[:, None] / ne
        internal_ids.append(inner)
        internal_xyz.append(pa + t * (pb - pa))
        chain = np.concatenate([[a], inner, [b]]).astype(np.int64)
        chains.append(chain)
        used.update((a, b))
        xyz = np.vstack([pa, pa + t * (pb - pa), pb])
        starts.append(xyz[:-1])
        ends.append(xyz[1:])
        orient.append(np.broadcast_to(o, (ne, 3)))
        ky, kz = m.section.shear_coefficients(m.material)
        s, mat = m.section, m.material
        props.append(np.broadcast_to(
            [mat.elastic_modulus, mat.G, mat.density, s.area, s.second_moment_y, s.second_moment_z, s.torsion_constant, ky, kz],
            (ne, 9)))
    unused = [n for n in ids if n not in used]
    if unused:
        raise ModelError(f"node {unused[0]} is not on any member; connect it or remove it")
    all_ids = np.concatenate([np.asarray(ids, dtype=np.int64)] + internal_ids)
    if np.unique(all_ids).size != all_ids.size:
        raise ModelError(f"internal_node_start {internal_node_start} would reuse given node numbers; start above {max(ids)}")
    xyz_all = np.vstack([np.array([coords[n] for n in ids]).reshape(-1, 3)] + internal_xyz)
    order = np.argsort(all_ids)
    chain_all = np.concatenate([c[:-1] for c in chains]), np.concatenate([c[1:] for c in chains])
    pos_a = order[np.searchsorted(all_ids, chain_all[0], sorter=order)]
    pos_b = order[np.searchsorted(all_ids, chain_all[1], sorter=order)]

    start_xyz, end_xyz = np.vstack(starts), np.vstack(ends)
    P = np.vstack(props)
    L = np.linalg.norm(end_xyz - start_xyz, axis=1)
    Kl, Ml = frame_element(L, *P.T, euler_bernoulli=euler_bernoulli)
    R = element_axes(start_xyz, end_xyz, np.vstack(orient))
    ne = L.size
    T = np.zeros((ne, 12, 12))
    for blk in range(4):
        T[:, 3 * blk:3 * blk + 3, 3 * blk:3 * blk + 3] = R
    Kg = np.matmul(T.transpose(0, 2, 1), np.matmul(Kl, T))
    Mg = np.matmul(T.transpose(0, 2, 1), np.matmul(Ml, T))
    Kg = 0.5 * (Kg + Kg.transpose(0, 2, 1))
    Mg = 0.5 * (Mg + Mg.transpose(0, 2, 1))
    nn = all_ids.size
    pm_pos, pm_blocks = [], []
    for node, pm in (point_masses or {}).items():
        if not np.isin(int(node), all_ids):
            raise ModelError(f"point mass at node {node}: the node is not in the frame")
        pm = pm if isinstance(pm, PointMass) else PointMass(float(pm))
        pm_pos.append(int(order[np.searchsorted(all_ids, int(node), sorter=order)]))
        pm_blocks.append(pm.matrix())
    K = _assemble_blocks(Kg, pos_a, pos_b, nn)
    M = _assemble_blocks(Mg, pos_a, pos_b, nn, np.asarray(pm_pos, dtype=np.int64), np.asarray(pm_blocks).reshape(-1, 6, 6))

    if loss_factor is None:
        etas = sorted({float(m.material.loss_factor) for m in mlist})
        if len(etas) > 1:
            raise ModelError(f"the members' materials have different loss factors {etas}; give build_frame(loss_factor=...) (one loss factor per frame)")
        loss_factor = etas[0]
    if not (np.isfinite(loss_factor) and loss_factor >= 0):
        raise ModelError(f"loss_factor must be a finite number >= 0, got {loss_factor!r}")
    dofs = DofArray(np.repeat(all_ids, 6), np.tile(_CODES, all_ids.size))
    xyz_all.setflags(write=False)
    all_ids.setflags(write=False)
    return FrameModel(M, K, dofs, float(loss_factor), all_ids, xyz_all, tuple(chains))
