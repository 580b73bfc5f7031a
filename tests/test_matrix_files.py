"""Free-structure matrices from Matrix Market, NumPy .npz and Nastran .op4 files, and DOF lists."""

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

from jointid.dofs import Dof, DofArray
from jointid.errors import DataError
from jointid.io.matrix_files import read_dof_list, read_free_matrices, read_matrix, write_dof_list


def _chain(n=12, seed=0):
    """A free spring-mass chain with random masses and springs: sparse symmetric M, K."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(1e5, 2e5, n - 1)
    m = rng.uniform(0.5, 1.5, n)
    K = sp.diags([np.r_[k, 0] + np.r_[0, k], -k, -k], [0, 1, -1], format="csr")
    M = sp.diags(m, format="csr") + sp.diags([0.01 * m[1:]] * 2, [1, -1])
    return sp.csr_array(M), sp.csr_array(K)


def _dofs(n):
    return DofArray(np.repeat(np.arange(1, n // 2 + 1) * 10, 2)[:n], np.tile([1, 3], n)[:n])


def _same(A, B):
    return A.shape == B.shape and abs(A - B).max() == 0.0


def test_matrix_market_npz_and_op4_read_back_equal(tmp_path):
    from pyyeti.nastran import op4

    M, K = _chain()
    dofs = _dofs(12)
    write_dof_list(tmp_path / "dofs.csv", dofs)
    scipy.io.mmwrite(tmp_path / "M.mtx", M)
    scipy.io.mmwrite(tmp_path / "K.mtx", K, symmetry="symmetric")
    np.savez(tmp_path / "model.npz", M=M.toarray(), K=K.toarray(), other=2 * K.toarray())
    sp.save_npz(tmp_path / "K_sparse.npz", sp.csr_matrix(K))
    op4.write(str(tmp_path / "model.op4"), {"MXX": M.toarray(), "KXX": sp.csr_matrix(K), "KAA": 3 * K.toarray()})
    op4.write(str(tmp_path / "ascii.op4"), {"MXX": M.toarray(), "KXX": K.toarray()}, binary=False)
    got = [
        read_free_matrices("M.mtx", "K.mtx", "dofs.csv", base=tmp_path),
        read_free_matrices("model.npz", "model.npz", "dofs.csv", base=tmp_path),
        read_free_matrices(tmp_path / "model.op4", tmp_path / "model.op4", tmp_path / "dofs.csv"),
        read_free_matrices("ascii.op4", "ascii.op4", "dofs.csv", base=tmp_path),
    ]
    for g in got:
        assert isinstance(g.mass, sp.csr_array) and isinstance(g.stiffness, sp.csr_array)
        assert _same(g.mass, M) and _same(g.stiffness, K)
        assert np.array_equal(g.dofs.keys, dofs.keys)
    assert _same(read_matrix(tmp_path / "K_sparse.npz"), K)
    assert _same(read_matrix(f"{tmp_path}/model.npz:other"), 2 * K)
    assert _same(read_matrix(f"{tmp_path}/model.op4:kaa"), 3 * K)


def test_dof_list_reads_names_codes_scalar_points_and_a_header(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("# exported\nnode,component\n101,x\n101, 3\n101,RZ\n1995001,0\n\n1995002,s\n")
    d = read_dof_list(p)
    assert d.to_dofs() == (Dof(101, "x"), Dof(101, "z"), Dof(101, "rz"), Dof(1995001, "s"), Dof(1995002, "s"))


@pytest.mark.parametrize(
    "text, message",
    [
        ("1,x\n2,q\n", r"^row 2 of .*d\.csv: unknown component 'q'; use x, y, z, rx, ry, rz, 1-6, or 0 for a scalar point$"),
        ("1,x\n0,y\n", r"^row 2 of .*d\.csv: node must be an integer from 1 to 576460752303423487, got '0'$"),
        ("1,x\n2,y,3\n", r"^row 2 of .*d\.csv: expected 'node,component', got '2,y,3'$"),
        ("1,x\n2,y\n1,1\n", r"^.*d\.csv: DOF 1x is listed twice \(rows 1 and 3\); each matrix row needs its own DOF$"),
        ("node,component\n", r"^.*d\.csv: the DOF list has no rows$"),
    ],
)
def test_bad_dof_lists_name_the_row(tmp_path, text, message):
    p = tmp_path / "d.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=message):
        read_dof_list(p)


def test_bad_matrices_name_the_file_and_the_problem(tmp_path):
    from pyyeti.nastran import op4

    M, K = _chain(4)
    write_dof_list(tmp_path / "d.csv", _dofs(4))
    write_dof_list(tmp_path / "d6.csv", _dofs(6))
    A = K.toarray()
    A[0, 1] *= 1.001
    scipy.io.mmwrite(tmp_path / "asym.mtx", sp.csr_matrix(A))
    scipy.io.mmwrite(tmp_path / "rect.mtx", sp.csr_matrix(np.ones((4, 3))))
    scipy.io.mmwrite(tmp_path / "cplx.mtx", sp.csr_matrix(K.toarray() * (1 + 0.1j)))
    scipy.io.mmwrite(tmp_path / "M.mtx", M)
    B = K.toarray()
    B[2, 2] = np.nan
    np.savez(tmp_path / "nan.npz", M=M.toarray(), K=B)
    op4.write(str(tmp_path / "m.op4"), {"MAA": M.toarray()})
    (tmp_path / "junk.mtx").write_text("not a matrix\n")
    rel = 0.001 * abs(K[0, 1]) / abs(K).max()  # the one asymmetric pair, relative to the largest term
    cases = [
        (("M.mtx", "asym.mtx", "d.csv"), rf"^.*asym\.mtx: the matrix is not symmetric: max \|A - A\^T\| = {rel:.3g} of max \|A\| \(tolerance 1e-08\)$"),
        (("M.mtx", "rect.mtx", "d.csv"), r"^.*rect\.mtx: the matrix is 4 x 3, not square$"),
        (("M.mtx", "cplx.mtx", "d.csv"), r"^.*cplx\.mtx: the matrix is complex; give real mass and stiffness \(damping comes from loss_factor\)$"),
        (("M.mtx", "M.mtx", "d6.csv"), r"^.*M\.mtx: the mass matrix is 4 x 4 but the DOF list d6\.csv has 6 DOFs$"),
        (("nan.npz", "nan.npz", "d.csv"), r"^.*nan\.npz:K: the matrix has non-finite entries \(NaN or inf\)$"),
        (("m.op4", "m.op4", "d.csv"), r"^.*m\.op4: no matrix MXX \(it has: MAA\); write 'm\.op4:NAME' to pick one$"),
        (("M.mtx", "nan.npz:KK", "d.csv"), r"^.*nan\.npz: no array 'KK' \(it has: M, K\); write 'nan\.npz:NAME' to pick one$"),
        (("M.mtx", "none.mtx", "d.csv"), r"^.*none\.mtx: stiffness matrix file not found$"),
        (("M.mtx", "K.mat", "d.csv"), r"^.*K\.mat: unknown matrix file type '\.mat'; use \.mtx \(Matrix Market\), \.npz \(NumPy\) or \.op4 \(Nastran\)$"),
        (("M.mtx", "junk.mtx", "d.csv"), r"^.*junk\.mtx: cannot read as Matrix Market: "),
    ]
    for args, message in cases:
        with pytest.raises(DataError, match=message):
            read_free_matrices(*args, base=tmp_path)
    assert read_free_matrices("m.op4:MAA", "M.mtx", "d.csv", base=tmp_path).mass.shape == (4, 4)


def _free_chain(n: int, k: float = 1e6) -> sp.csr_array:
    """Stiffness of n unit masses in a free-free chain of springs k: eigenvalues 2k (1 - cos(j pi / n)), j = 0..n-1."""
    main = np.full(n, 2 * k)
    main[[0, -1]] = k
    return sp.csr_array(sp.diags([np.full(n - 1, -k), main, np.full(n - 1, -k)], [-1, 0, 1]))


@pytest.mark.parametrize("n", [100, 3000])  # the dense path (<= 200 DOFs) and the sparse LDL^T inertia
def test_semidefinite_check_counts_the_negative_eigenvalues_of_a_shifted_chain(n):
    from jointid.io.matrix_files import check_semidefinite

    k = 1e6
    lam = 2 * k * (1 - np.cos(np.arange(n) * np.pi / n))  # analytic spectrum, one rigid-body mode
    K = _free_chain(n, k)
    check_semidefinite(K, "chain")  # semidefinite: the rigid-body mode (0) passes
    sigma = np.sqrt(np.finfo(float).eps) * 4 * k  # ||K||_inf = 4k
    check_semidefinite(sp.csr_array(K - 0.5 * sigma * sp.eye_array(n)), "chain")  # -sigma/2: a rounding zero
    c = 0.5 * (lam[5] + lam[6])  # six eigenvalues below -0 after the shift, with a wide gap either side
    with pytest.raises(DataError) as e:
        check_semidefinite(sp.csr_array(K - c * sp.eye_array(n)), "shifted.mtx")
    assert str(e.value).startswith("shifted.mtx: the stiffness matrix is not positive semidefinite: 6 eigenvalue(s) below -")


def test_negative_mass_and_negated_stiffness_are_refused_before_any_factorization(tmp_path):
    from jointid.io.matrix_files import check_semidefinite

    M = sp.csr_array(sp.diags(np.linspace(1.0, 2.0, 12)))
    M[3, 3] = -0.5
    with pytest.raises(DataError, match=r"^m\.npz: the mass matrix is not positive semidefinite: diagonal entry 4 is -0\.5 "
                                        r"\(a negative mass\); its kinetic energy would be negative"):
        check_semidefinite(M, "m.npz", "mass")
    with pytest.raises(DataError, match=r"diagonal entry 2 is -2e\+06 \(a negative stiffness\); its strain energy"):
        check_semidefinite(-_free_chain(12), "k.npz")
    K = _free_chain(12).toarray()
    np.savez(tmp_path / "model.npz", M=np.eye(12), K=-K)
    write_dof_list(tmp_path / "d.csv", DofArray(np.arange(1, 13), np.full(12, 3)))
    with pytest.raises(DataError, match=r"model\.npz: the stiffness matrix is not positive semidefinite"):
        read_free_matrices("model.npz", "model.npz", "d.csv", base=tmp_path)


def test_corrupt_npz_files_and_a_latin1_dof_list_are_one_line_data_errors(tmp_path):
    np.savez(tmp_path / "m.npz", M=np.eye(3), K=np.eye(3))
    raw = (tmp_path / "m.npz").read_bytes()
    (tmp_path / "half.npz").write_bytes(raw[: len(raw) // 2])
    (tmp_path / "zero.npz").write_bytes(b"")
    for name in ("half.npz", "zero.npz"):
        with pytest.raises(DataError, match=rf"^{tmp_path}/{name}: cannot read as a NumPy \.npz file: "):
            read_matrix(tmp_path / name, "mass")
    p = tmp_path / "d.csv"
    p.write_bytes("node,component\n# unités\n1,x\n".encode("latin-1"))
    with pytest.raises(DataError) as e:
        read_dof_list(p)
    assert str(e.value) == f"{p} line 2: not UTF-8 text (byte 0xe9); save the DOF list as UTF-8 (e.g. 'CSV UTF-8' in a spreadsheet)"
