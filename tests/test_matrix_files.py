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
        ("1,x\n0,y\n", r"^row 2 of .*d\.csv: node must be an integer >= 1, got '0'$"),
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
