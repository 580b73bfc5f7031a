"""3-D Timoshenko frame factory: statics, convergence, invariance, the planar beam cross-check, files, errors."""

import math
import time

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from jointid.dofs import DofArray
from jointid.errors import DataError, ModelError
from jointid.io.matrix_files import read_free_matrices, write_free_matrices
from jointid.io.output_dir import OutputError, OutputSet
from jointid.physics import FrameSection, Material, Member, PointMass, Section, build_beam, build_frame
from jointid.physics.elements import timoshenko_element
from jointid.physics.frame import frame_element
from jointid.physics.frame_sections import cowper_circle, cowper_rectangle, rectangle_torsion_constant

STEEL = Material(210e9, 7850.0, loss_factor=0.002, poisson_ratio=0.3)


def _rotation(seed=3):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _eig_hz(model, k=None):
    lam = sla.eigh(model.stiffness.toarray(), model.mass.toarray(), eigvals_only=True)
    f = np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)
    return f if k is None else f[:k]


# ------------------------------------------------------------------ sections and element
def test_section_properties_exact_and_series():
    c = FrameSection.circle(0.04, 0.03)
    assert c.area == pytest.approx(math.pi * (0.04**2 - 0.03**2) / 4, rel=1e-15)
    assert c.second_moment_y == c.second_moment_z == pytest.approx(math.pi * (0.04**4 - 0.03**4) / 64, rel=1e-15)
    assert c.torsion_constant == pytest.approx(math.pi * (0.04**4 - 0.03**4) / 32, rel=1e-15)
    r = FrameSection.rectangle(0.02, 0.05)
    assert (r.second_moment_y, r.second_moment_z) == pytest.approx((0.02 * 0.05**3 / 12, 0.05 * 0.02**3 / 12), rel=1e-15)
    # tabulated torsion coefficients beta (J = beta a b^3): square 0.1406, a/b = 2: 0.2287, a/b = 10: 0.3123
    assert rectangle_torsion_constant(1.0, 1.0) == pytest.approx(0.140577, abs=2e-6)
    assert rectangle_torsion_constant(2.0, 1.0) / 2.0 == pytest.approx(0.228682, abs=2e-6)
    assert rectangle_torsion_constant(1.0, 10.0) / 10.0 == pytest.approx(0.312325, abs=2e-6)
    assert r.torsion_constant == rectangle_torsion_constant(0.05, 0.02)
    assert cowper_rectangle(0.3) == pytest.approx(13 / 15.3, rel=1e-15)
    assert cowper_circle(0.3) == pytest.approx(7.8 / 8.8, rel=1e-15)
    assert r.shear_coefficients(STEEL) == pytest.approx((13 / 15.3,) * 2, rel=1e-12)
    assert FrameSection.rectangle(0.02, 0.05, shear_coefficient=5 / 6).shear_coefficients(STEEL) == (5 / 6, 5 / 6)


def test_element_bending_planes_are_the_planar_timoshenko_element():
    L, b, h = 0.07, 0.02, 0.05
    s = FrameSection.rectangle(b, h, shear_coefficient=5 / 6)
    K, M = frame_element(L, STEEL.elastic_modulus, STEEL.G, STEEL.density, s.area, s.second_moment_y,
                         s.second_moment_z, s.torsion_constant, 5 / 6, 5 / 6)
    Kp, Mp = timoshenko_element(L, Section.rectangle(b, h), STEEL, 5 / 6)  # bending along z, I = b h^3 / 12
    xz, sign = [2, 4, 8, 10], np.array([1, -1, 1, -1.0])  # (w, theta) = (z, -ry)
    np.testing.assert_allclose(K[0][np.ix_(xz, xz)], Kp * np.outer(sign, sign), rtol=1e-14, atol=0)
    np.testing.assert_allclose(M[0][np.ix_(xz, xz)], Mp * np.outer(sign, sign), rtol=1e-14, atol=0)
    Kq, Mq = timoshenko_element(L, Section.rectangle(h, b), STEEL, 5 / 6)  # bending along y: I = h b^3 / 12
    xy = [1, 5, 7, 11]
    np.testing.assert_allclose(K[0][np.ix_(xy, xy)], Kq, rtol=1e-14)
    np.testing.assert_allclose(M[0][np.ix_(xy, xy)], Mq, rtol=1e-14)
    assert np.array_equal(K[0], K[0].T) and np.array_equal(M[0], M[0].T)


# ------------------------------------------------------------------ statics
@pytest.mark.parametrize("rotated", [False, True])
def test_cantilever_tip_deflections_are_exact_timoshenko(rotated):
    L, b, h, P, T = 0.3, 0.02, 0.05, 1000.0, 50.0
    s = FrameSection.rectangle(b, h)
    ky, kz = s.shear_coefficients(STEEL)
    E, G, A = STEEL.elastic_modulus, STEEL.G, s.area
    Rg = _rotation() if rotated else np.eye(3)
    ex, ey, ez = Rg.T  # local axes in global components
    model = build_frame({1: (0, 0, 0), 2: tuple(L * ex)}, [Member(1, 2, s, STEEL, 5, tuple(ey))]).clamped([1])
    idx = model.dofs.indices([(2, c) for c in ("x", "y", "z", "rx", "ry", "rz")])
    K = model.stiffness.tocsc()

    def tip(force6):
        f = np.zeros(model.size)
        f[idx] = force6
        u = spla.spsolve(K, f)[idx]
        return np.r_[Rg.T @ u[:3], Rg.T @ u[3:]]  # tip displacement/rotation in local axes

    zero = np.zeros(3)
    uy = tip(np.r_[P * ey, zero])
    uz = tip(np.r_[P * ez, zero])
    ux = tip(np.r_[P * ex, zero])
    rx = tip(np.r_[zero, T * ex])
    shear_y, shear_z = P * L / (ky * G * A), P * L / (kz * G * A)
    assert shear_z > 0.01 * P * L**3 / (3 * E * s.second_moment_y)  # shear is not negligible here
    assert uy[1] == pytest.approx(P * L**3 / (3 * E * s.second_moment_z) + shear_y, rel=1e-10)
    assert uz[2] == pytest.approx(P * L**3 / (3 * E * s.second_moment_y) + shear_z, rel=1e-10)
    assert uy[5] == pytest.approx(P * L**2 / (2 * E * s.second_moment_z), rel=1e-10)  # rz = +dv/dx
    assert uz[4] == pytest.approx(-P * L**2 / (2 * E * s.second_moment_y), rel=1e-10)  # ry = -dw/dx
    assert ux[0] == pytest.approx(P * L / (E * A), rel=1e-10)
    assert rx[3] == pytest.approx(T * L / (G * s.torsion_constant), rel=1e-10)
    for u, k in ((uy, 1), (uz, 2), (ux, 0)):  # no coupling into the other directions
        assert np.abs(np.delete(u[:3], k)).max() <= 1e-12 * abs(u[k])


# ------------------------------------------------------------------ dynamics
def _plane_xz(model):
    """Only the x-z bending DOFs (z, ry) kept: the others constrained."""
    drop = model.dofs.code != 3
    drop &= model.dofs.code != 5
    return model.constrained(DofArray(model.dofs.node[drop], model.dofs.code[drop]))


def test_free_free_bending_converges_to_euler_bernoulli():
    L, d = 1.0, 0.02
    s = FrameSection.circle(d)
    beta_L = np.array([4.730040744862704, 7.853204624095838, 10.995607838001671])
    exact = beta_L**2 / (2 * np.pi) * np.sqrt(STEEL.elastic_modulus * s.second_moment_y / (STEEL.density * s.area * L**4))
    errors = []
    for n in (8, 16, 32):
        m = _plane_xz(build_frame({1: (0, 0, 0), 2: (L, 0, 0)}, [(1, 2, s, STEEL, n)], euler_bernoulli=True))
        f = _eig_hz(m)
        assert np.all(f[:2] < 1e-4 * exact[0])  # two rigid-body modes (z, ry)
        errors.append((f[2:5] - exact) / exact)
    errors = np.array(errors)
    assert np.all(errors > 0)  # consistent mass: from above
    assert np.all(errors[1:] < errors[:-1] / 12)  # ~h^4
    assert errors[-1].max() < 1.5e-5


def test_simply_supported_timoshenko_frequencies_converge_to_exact():
    L, b, h = 0.25, 0.02, 0.05  # stubby (L/h = 5): shear and rotary inertia matter
    s = FrameSection.rectangle(b, h)
    kz = s.shear_coefficients(STEEL)[1]
    E, G, rho, A, I = STEEL.elastic_modulus, STEEL.G, STEEL.density, s.area, s.second_moment_y
    exact, euler = [], []
    for n in (1, 2, 3):
        k = n * np.pi / L
        Kt = np.array([[kz * G * A * k**2, -kz * G * A * k], [-kz * G * A * k, E * I * k**2 + kz * G * A]])
        exact.append(np.sqrt(sla.eigh(Kt, np.diag([rho * A, rho * I]), eigvals_only=True)[0]) / (2 * np.pi))
        euler.append(k**2 * np.sqrt(E * I / (rho * A)) / (2 * np.pi))
    exact = np.array(exact)
    assert exact[0] < 0.95 * euler[0] and exact[2] < 0.75 * euler[2]  # the Timoshenko correction is large here
    errors = []
    for ne in (8, 16, 32):
        m = _plane_xz(build_frame({1: (0, 0, 0), 2: (L, 0, 0)}, [(1, 2, s, STEEL, ne)])).constrained(["1z", "2z"])
        errors.append((_eig_hz(m, 3) - exact) / exact)
    errors = np.array(errors)
    # short elements (phi >> 1): the interdependent-interpolation element converges as h^2
    assert np.all(errors > 0) and np.all(errors[1:] < errors[:-1] / 3.8)
    assert errors[-1] == pytest.approx([3.5e-5, 4.1e-4, 1.5e-3], rel=0.05)


def _portal(R=np.eye(3), shift=np.zeros(3)):
    """A 3-D frame of rectangles and a tube with point masses; every vector rotated by R."""
    xyz = {1: (0, 0, 0), 2: (0, 0, 0.6), 3: (0.8, 0.1, 0.6), 4: (0.8, 0.1, 0.0), 5: (0.4, 0.7, 0.9)}
    nodes = {k: tuple(R @ np.array(v, float) + shift) for k, v in xyz.items()}
    rect, tube = FrameSection.rectangle(0.03, 0.05), FrameSection.circle(0.04, 0.032)
    alu = Material(70e9, 2700.0, loss_factor=0.002, shear_modulus=26e9)
    members = [
        Member(1, 2, rect, STEEL, 4, tuple(R @ [1.0, 0.2, 0.0])),
        Member(2, 3, rect, STEEL, 5, tuple(R @ [0.0, 0.3, 1.0])),
        Member(3, 4, rect, STEEL, 4, tuple(R @ [0.0, 1.0, 0.0])),
        Member(2, 5, tube, alu, 3, tuple(R @ [1.0, 0.0, 0.0])),
        Member(5, 3, tube, alu, 3, tuple(R @ [0.0, 0.0, 1.0])),
    ]
    J = np.array([[2e-3, 1e-4, 0], [1e-4, 3e-3, 2e-4], [0, 2e-4, 1e-3]])
    masses = {5: PointMass(1.5, R @ J @ R.T, tuple(R @ [0.02, -0.01, 0.03])), 7: 0.03}
    return build_frame(nodes, members, point_masses=masses)


def test_rotated_frame_has_same_frequencies_rigid_body_modes_and_definite_matrices():
    a = _portal()
    b = _portal(_rotation(7), np.array([1.0, -2.0, 0.5]))
    fa, fb = _eig_hz(a, 40), _eig_hz(b, 40)
    assert np.all(fa[:6] < 1e-2) and fa[6] > 10.0  # six rigid-body modes, then elastic ones
    np.testing.assert_allclose(fb[6:], fa[6:], rtol=1e-9)
    for m in (a, b):
        K, M = m.stiffness, m.mass
        assert abs(K - K.T).max() == 0 and abs(M - M.T).max() == 0
        assert np.linalg.eigvalsh(M.toarray()).min() > 0
        assert np.linalg.eigvalsh(K.toarray()).min() > -1e-12 * abs(K).max()
        Rb = m.rigid_body_modes(origin=m.node_coordinates[0])
        assert np.abs(K @ Rb).max() < 1e-9 * abs(K).max()
    # total mass: members rho A L plus the point masses
    c = np.array([[0, 0, 0], [0, 0, 0.6], [0.8, 0.1, 0.6], [0.8, 0.1, 0.0], [0.4, 0.7, 0.9]])
    length = lambda i, j: np.linalg.norm(c[i - 1] - c[j - 1])  # noqa: E731
    rect, tube = FrameSection.rectangle(0.03, 0.05), FrameSection.circle(0.04, 0.032)
    total = 7850 * rect.area * (length(1, 2) + length(2, 3) + length(3, 4)) + 2700 * tube.area * (length(2, 5) + length(5, 3)) + 1.53
    Rt = b.rigid_body_modes()[:, :3]
    np.testing.assert_allclose(Rt.T @ (b.mass @ Rt), total * np.eye(3), rtol=1e-12, atol=1e-12 * total)


@pytest.mark.parametrize("meshed_member", [False, True])
def test_frame_in_xz_plane_reproduces_planar_beam_receptance(meshed_member):
    L, b, h, n = 0.9, 0.0127, 0.0254, 7
    eta = 0.01
    mat = Material(70e9, 2700.0, loss_factor=eta, poisson_ratio=0.33)
    planar = build_beam(L, Section.rectangle(b, h), mat, n, shear_coefficient=5 / 6)
    s = FrameSection.rectangle(b, h, shear_coefficient=5 / 6)
    x = {k: (L * (k - 1) / (n - 1), 0.0, 0.0) for k in range(1, n + 1)}
    if meshed_member:
        frame = build_frame({1: x[1], n: x[n]}, [(1, n, s, mat, n - 1)], internal_node_start=100)
        grid = frame.member_nodes[0]  # 1, 100, ..., 104, 7
        np.testing.assert_allclose(frame.coordinates(grid)[:, 0], np.linspace(0, L, n), rtol=1e-15, atol=1e-16)
    else:
        frame = build_frame(x, [(k, k + 1, s, mat) for k in range(1, n)])
        grid = np.arange(1, n + 1)
    assert frame.loss_factor == eta
    pick = [0, 3, 6]
    rows3 = [(int(grid[i]), "z") for i in pick] + [(int(grid[i]), "ry") for i in (0, 6)]
    rows2 = [f"{i + 1}w" for i in pick] + ["1theta", f"{n}theta"]
    sign = np.array([1, 1, 1, -1, -1.0])  # theta = dw/dx = -ry
    f = np.array([3.0, 37.0, 480.0, 2100.0, 7300.0])
    Yp_all = np.linalg.inv(planar.dynamic_stiffness(f))
    ip = planar.index(rows2)
    Yp = Yp_all[:, ip][:, :, ip] * np.outer(sign, sign)
    Y3 = frame.free_model(method="direct").receptance(f, rows3, rows3)
    # two backward-stable solves of the same N x N pencil differ norm-wise by at most ~N eps cond(D) per line
    # (cond 1.2e4 - 6e6, 3 Hz the largest: near the rigid-body modes; measured 1e-15 - 2.5e-11 relative)
    D = planar.dynamic_stiffness(f)
    tol = D.shape[-1] * np.finfo(float).eps * np.linalg.cond(D)
    assert np.all(np.abs(Y3 - Yp).max(axis=(1, 2)) <= tol * np.abs(Yp).max(axis=(1, 2)))


def test_many_elements_assemble_fast():
    s = FrameSection.circle(0.03, 0.02)
    build_frame({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, s, STEEL, 10)])
    t = time.perf_counter()
    m = build_frame({1: (0, 0, 0), 2: (3.0, 1.0, 0.5), 3: (0, 2, 0)}, [(1, 2, s, STEEL, 5000), (2, 3, s, STEEL, 5000)])
    dt = time.perf_counter() - t
    assert m.size == 6 * 10_001 and m.stiffness.shape == (6 * 10_001,) * 2
    assert dt < 3.0, f"1e4 elements took {dt:.2f} s"


# ------------------------------------------------------------------ files
@pytest.mark.parametrize("fmt", ["npz", "mtx", "sparse-npz"])
def test_write_read_round_trip_is_identical(tmp_path, fmt):
    m = _portal(_rotation(2))
    files = write_free_matrices(tmp_path / "out" / "frame", m.mass, m.stiffness, m.dofs, format=fmt)
    got = read_free_matrices(files.mass, files.stiffness, files.dofs)
    assert abs(got.mass - m.mass).max() == 0 and abs(got.stiffness - m.stiffness).max() == 0
    assert np.array_equal(got.dofs.keys, m.dofs.keys)
    table = files.structure_table(tmp_path / "out")
    assert table["dofs"] == "frame_dofs.csv"
    assert table["mass"] == {"npz": "frame.npz", "mtx": "frame_M.mtx", "sparse-npz": "frame_M.npz"}[fmt]


def test_writer_never_replaces_a_foreign_file_and_rewrites_its_own(tmp_path):
    m = build_frame({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, FrameSection.circle(0.02), STEEL, 2)])
    (tmp_path / "model.npz").write_bytes(b"mine")
    with pytest.raises(OutputError, match="model.npz exists and was not written by jointid"):
        write_free_matrices(tmp_path / "model.npz", m.mass, m.stiffness, m.dofs)
    assert (tmp_path / "model.npz").read_bytes() == b"mine" and not (tmp_path / "model_dofs.csv").exists()
    write_free_matrices(tmp_path / "beam", m.mass, m.stiffness, m.dofs)
    write_free_matrices(tmp_path / "beam", 2 * m.mass, m.stiffness, m.dofs, format="mtx")  # same stem: replaces its own
    assert not (tmp_path / "beam.npz").exists()
    got = read_free_matrices(tmp_path / "beam_M.mtx", tmp_path / "beam_K.mtx", tmp_path / "beam_dofs.csv")
    assert abs(got.mass - 2 * m.mass).max() == 0
    with OutputSet(tmp_path / "run", "simulate") as out:  # staged with a command's other outputs
        files = write_free_matrices("model/frame", m.mass, m.stiffness, m.dofs, output=out)
    assert files.mass == tmp_path / "run" / "model" / "frame.npz" and files.mass.is_file()


def test_writer_refuses_bad_matrices():
    m = build_frame({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, FrameSection.circle(0.02), STEEL, 2)])
    K = m.stiffness.toarray()
    K[0, 1] += 1e-3 * abs(K).max()
    with pytest.raises(DataError, match=r"^stiffness matrix to write: the matrix is not symmetric"):
        write_free_matrices("never/x", m.mass, K, m.dofs)
    with pytest.raises(DataError, match=r"^mass matrix to write is 18 x 18 but the DOF list has 12 DOFs$"):
        write_free_matrices("never/x", m.mass, m.stiffness, DofArray(m.dofs.node[:12], m.dofs.code[:12]))
    with pytest.raises(DataError, match=r"^unknown matrix file format 'op4'; use one of npz, mtx, sparse-npz$"):
        write_free_matrices("never/x", m.mass, m.stiffness, m.dofs, format="op4")


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "nodes, members, message",
    [
        ({1: (0, 0, 0), 2: (0, 0, 0)}, [(1, 2, "S", "M", 2)], "member 1 (1-2) has zero length: nodes 1 and 2 are at the same point"),
        ({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, "S", "M"), (2, 3, "S", "M")], "member 2 (2-3): node 3 is not in nodes; give its coordinates"),
        ({1: (0, 0, 0), 2: (1, 1, 0)}, [Member(1, 2, "S", "M", 1, (-2, -2, 0))],
         "member 1 (1-2): orientation vector (-2.0, -2.0, 0.0) is parallel to the member; give a vector across it (it sets local y)"),
        ({1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0)}, [(1, 2, "S", "M")], "node 3 is not on any member; connect it or remove it"),
        ({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, "S", "M", 0)], "member 1 (1-2): elements must be an integer >= 1, got 0"),
        ({1: (0, 0, 0), 2: (1, 0)}, [(1, 2, "S", "M")], "coordinates of node 2 must be 3 finite numbers (x, y, z), got (1, 0)"),
        ({1: (0, 0, 0), 2: (1, 0, 0)}, [], "a frame needs at least one member"),
    ],
)
def test_bad_frames_raise_one_line(nodes, members, message):
    sec, mat = FrameSection.circle(0.02), STEEL
    members = [Member(m.start, m.end, sec, mat, m.elements, m.orientation) if isinstance(m, Member)
               else (m[0], m[1], sec, mat, *m[4:]) for m in members]
    with pytest.raises(ModelError) as err:
        build_frame(nodes, members)
    assert str(err.value) == message


def test_other_bad_inputs():
    s = FrameSection.circle(0.02)
    with pytest.raises(ModelError, match=r"^member 1 \(1-2\): section must be a FrameSection \(FrameSection.circle or .rectangle\), got Section$"):
        build_frame({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, Section.circle(0.02), STEEL)])
    soft = Material(1e6, 1000.0, loss_factor=0.1)
    with pytest.raises(ModelError, match=r"^the members' materials have different loss factors \[0.002, 0.1\]; give build_frame\(loss_factor=...\)"):
        build_frame({1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0)}, [(1, 2, s, STEEL), (2, 3, s, soft)])
    assert build_frame({1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0)}, [(1, 2, s, STEEL), (2, 3, s, soft)], loss_factor=0.01).loss_factor == 0.01
    with pytest.raises(ModelError, match=r"^section inner diameter must be >= 0 and smaller than the outer diameter 0.02 m, got 0.03$"):
        FrameSection.circle(0.02, 0.03)
    with pytest.raises(ModelError, match=r"^point mass at node 9: the node is not in the frame$"):
        build_frame({1: (0, 0, 0), 2: (1, 0, 0)}, [(1, 2, s, STEEL)], point_masses={9: 1.0})
    with pytest.raises(ModelError, match=r"^internal_node_start 2 would reuse given node numbers; start above 3$"):
        build_frame({1: (0, 0, 0), 3: (1, 0, 0)}, [(1, 3, s, STEEL, 3)], internal_node_start=2)


def test_point_mass_is_a_rigid_body_with_offset_centre_of_mass():
    rng = np.random.default_rng(5)
    m, r = 2.5, np.array([0.03, -0.02, 0.05])
    A = rng.normal(size=(3, 3))
    J = A @ A.T * 1e-3
    Mb = PointMass(m, J, tuple(r)).matrix()
    assert np.array_equal(Mb, Mb.T)
    for _ in range(3):
        t, th = rng.normal(size=3), rng.normal(size=3)
        v = t + np.cross(th, r)  # velocity of the centre of mass
        assert np.r_[t, th] @ Mb @ np.r_[t, th] == pytest.approx(m * v @ v + th @ J @ th, rel=1e-13)
    np.testing.assert_allclose(Mb[3:, 3:], J + m * (r @ r * np.eye(3) - np.outer(r, r)), rtol=1e-14)
    assert np.array_equal(PointMass(0.1).matrix(), np.diag([0.1, 0.1, 0.1, 0, 0, 0]))
