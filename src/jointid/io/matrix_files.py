"""A free structure's mass and stiffness matrices and DOF list, read from files.

Formats (chosen by the file's extension):

* **Matrix Market** ``.mtx`` (``scipy.io.mmread``): one matrix per file,
  ``coordinate`` (sparse) or ``array`` (dense), ``general`` or ``symmetric``;
* **NumPy** ``.npz``, either a ``scipy.sparse.save_npz`` file (one sparse
  matrix; recognized by its ``format`` array) or an ``np.savez`` file of dense
  2-D arrays, by default ``M`` (mass) and ``K`` (stiffness) -- so one file can
  hold both -- or ``"file.npz:NAME"`` for the array ``NAME``;
* **Nastran OP4** ``.op4`` (binary or ASCII, dense or sparse, read with
  ``pyyeti.nastran.op4``): by default the matrix ``MXX`` (mass) or ``KXX``
  (stiffness), or ``"file.op4:NAME"``; names are case-insensitive.

The DOF list is a CSV with one row per matrix row, ``node,component``, the
component ``x|y|z|rx|ry|rz`` or its code ``1-6`` (UFF direction, Nastran
component), or ``0`` / ``s`` for a scalar point (an SPOINT, a Craig-Bampton
modal coordinate); an optional header row ``node,component``, ``#`` comments and
blank lines are skipped.

Matrices are returned as ``scipy.sparse.csr_array`` (float64) whatever the file
held. Each is checked: real, finite, square, symmetric within a relative
tolerance (``max |A - A^T| <= tol * max |A|``), positive semidefinite within
``sqrt(eps) ||A||`` (:func:`check_semidefinite`: a sparse LDL^T of the shifted
matrix, never a dense eigensolve), and of the DOF list's size; the
DOF list has no repeated DOF. A failed check raises one
:class:`~jointid.errors.DataError` line naming the file and what is wrong.

:func:`write_free_matrices` writes a model (e.g. a
:func:`jointid.physics.frame.build_frame` frame) in these formats, through the
output-directory writer :class:`~jointid.io.output_dir.OutputSet` (atomic; it
never replaces a file jointid did not write).
"""

from __future__ import annotations

import csv
import io
import warnings
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np
import scipy.sparse as sp

from ..dofs import COMPONENT_CODES, DofArray, pack_dof_keys, parse_component
from ..errors import DataError, DofError
from .text import read_utf8

__all__ = [
    "FreeMatrices",
    "MATRIX_SUFFIXES",
    "SYMMETRY_TOLERANCE",
    "read_matrix",
    "read_dof_list",
    "read_free_matrices",
    "check_symmetric",
    "check_semidefinite",
    "write_dof_list",
    "write_free_matrices",
    "FreeMatrixFiles",
    "WRITE_FORMATS",
    "DENSE_NPZ_LIMIT",
]

#: File extensions :func:`read_matrix` reads.
MATRIX_SUFFIXES: tuple[str, ...] = (".mtx", ".npz", ".op4")
#: Default relative symmetry tolerance: ``max |A - A^T| <= tol * max |A|``.
SYMMETRY_TOLERANCE = 1e-8
#: Formats :func:`write_free_matrices` writes.
WRITE_FORMATS: tuple[str, ...] = ("npz", "mtx", "sparse-npz")
#: Largest model (DOFs) written as dense arrays in one ``.npz``; larger ones need ``mtx`` or ``sparse-npz``.
DENSE_NPZ_LIMIT = 5000
_DEFAULT_NAMES = {"mass": {".npz": "M", ".op4": "MXX"}, "stiffness": {".npz": "K", ".op4": "KXX"}}


@dataclass(frozen=True, eq=False)
class FreeMatrices:
    """A free structure's matrices as read from files.

    Attributes
    ----------
    mass, stiffness : scipy.sparse.csr_array, shape (N, N)
        Mass (kg, kg*m, kg*m^2) and stiffness (N/m, N, N*m/rad) matrices, real and symmetric.
    dofs : DofArray
        The DOF of each row/column.
    sources : tuple of str
        Where each came from (mass, stiffness, dofs), as given.
    """

    mass: sp.csr_array
    stiffness: sp.csr_array
    dofs: DofArray
    sources: tuple[str, str, str]


def _split_spec(spec: "str | Path", base: "Path | None") -> tuple[Path, str | None]:
    """``("dir/file.op4", "NAME")`` from ``"file.op4:NAME"`` (relative to ``base``)."""
    text = str(spec)
    name = None
    head, sep, tail = text.rpartition(":")
    if sep and Path(head).suffix.lower() in (".npz", ".op4") and tail and "/" not in tail and "\\" not in tail:
        text, name = head, tail.strip()
    path = Path(text)
    if base is not None and not path.is_absolute():
        path = Path(base) / path
    return path, name


def read_matrix(spec: "str | Path", role: str = "stiffness", base: "Path | None" = None) -> sp.csr_array:
    """One real square matrix from a ``.mtx``, ``.npz`` or ``.op4`` file, as a CSR array.

    Parameters
    ----------
    spec : str or Path
        The file, optionally ``"file.npz:NAME"`` / ``"file.op4:NAME"`` to pick a matrix.
    role : {"mass", "stiffness"}
        Chooses the default matrix name in ``.npz`` (``M``/``K``) and ``.op4`` (``MXX``/``KXX``) files.
    base : Path, optional
        Directory that relative paths are relative to (e.g. the study file's).

    Returns
    -------
    scipy.sparse.csr_array, float64

    Raises
    ------
    DataError
        Missing or unreadable file, unknown format or matrix name, a complex,
        non-finite or non-square matrix (one line naming the file).
    """
    if role not in _DEFAULT_NAMES:
        raise DataError(f"role must be 'mass' or 'stiffness', got {role!r}")
    path, name = _split_spec(spec, base)
    suffix = path.suffix.lower()
    if suffix not in MATRIX_SUFFIXES:
        raise DataError(f"{path}: unknown matrix file type {path.suffix!r}; use .mtx (Matrix Market), .npz (NumPy) or .op4 (Nastran)")
    if not path.is_file():
        raise DataError(f"{path}: {role} matrix file not found")
    if name is None:
        name = _DEFAULT_NAMES[role].get(suffix)
    label = f"{path}:{name}" if suffix != ".mtx" else str(path)
    if suffix == ".mtx":
        A = _read_mtx(path)
    elif suffix == ".npz":
        A = _read_npz(path, name, spec_given=":" in str(spec))
    else:
        A = _read_op4(path, name)
    return _check_matrix(A, label)


def _read_mtx(path: Path):
    import scipy.io

    try:
        return scipy.io.mmread(str(path))
    except Exception as exc:  # noqa: BLE001 - any parse failure is a data error
        raise DataError(f"{path}: cannot read as Matrix Market: {_one_line(exc)}") from exc


def _read_npz(path: Path, name: str, spec_given: bool):
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:  # our handle: closed even if np.load fails
            keys = list(z.files)
            sparse_file = "format" in keys and "shape" in keys
            if not sparse_file:
                if name not in keys:
                    raise DataError(f"{path}: no array {name!r} (it has: {', '.join(keys) or 'none'}); write '{path.name}:NAME' to pick one")
                A = np.array(z[name])
    except DataError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: cannot read as a NumPy .npz file: {_one_line(exc)}") from exc
    if sparse_file:
        if spec_given:
            raise DataError(f"{path}: a scipy.sparse .npz file holds one matrix; give the file without ':{name}'")
        try:
            return sp.load_npz(path)
        except Exception as exc:  # noqa: BLE001
            raise DataError(f"{path}: cannot read as a scipy.sparse .npz file: {_one_line(exc)}") from exc
    if A.ndim != 2:
        raise DataError(f"{path}: array {name!r} has {A.ndim} dimension(s); a matrix needs 2")
    return A


def _read_op4(path: Path, name: str):
    try:
        from pyyeti.nastran import op4
    except ImportError as exc:  # pragma: no cover - a declared dependency
        raise DataError(f"{path}: reading Nastran .op4 needs the 'pyyeti' package (pip install pyyeti)") from exc
    try:
        with warnings.catch_warnings():  # pyyeti warns about odd matrix names in a corrupt file before failing on it
            warnings.simplefilter("ignore")
            names, mats, _, _ = op4.load(str(path), into="list", sparse=(None, sp.coo_matrix.tocsr))
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: cannot read as a Nastran OP4 file: {_one_line(exc)}") from exc
    found = [i for i, n in enumerate(names) if n.lower() == name.lower()]
    if not found:
        have = ", ".join(n.upper() for n in names) or "none"
        raise DataError(f"{path}: no matrix {name.upper()} (it has: {have}); write '{path.name}:NAME' to pick one")
    if len(found) > 1:
        raise DataError(f"{path}: {len(found)} matrices are named {name.upper()}; keep one")
    return mats[found[0]]


def _one_line(exc: Exception) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def _check_matrix(A, label: str) -> sp.csr_array:
    """Real, finite, square: as a float64 CSR array."""
    A = sp.csr_array(A) if sp.issparse(A) else sp.csr_array(np.asarray(A))
    if A.ndim != 2:
        raise DataError(f"{label}: not a 2-D matrix")
    if np.iscomplexobj(A.data):
        if A.nnz and np.abs(A.data.imag).max() > 0:
            raise DataError(f"{label}: the matrix is complex; give real mass and stiffness (damping comes from loss_factor)")
        A = sp.csr_array(A.real)
    if not np.issubdtype(A.dtype, np.number) or A.dtype == bool:
        raise DataError(f"{label}: the matrix is not numeric ({A.dtype})")
    A = A.astype(np.float64)
    r, c = A.shape
    if r != c:
        raise DataError(f"{label}: the matrix is {r} x {c}, not square")
    if A.nnz and not np.isfinite(A.data).all():
        raise DataError(f"{label}: the matrix has non-finite entries (NaN or inf)")
    A.sum_duplicates()
    A.eliminate_zeros()
    return A


def check_symmetric(A: sp.csr_array, label: str, tol: float = SYMMETRY_TOLERANCE) -> None:
    """Raise :class:`DataError` unless ``max |A - A^T| <= tol * max |A|``."""
    if A.nnz == 0:
        return
    scale = np.abs(A.data).max()
    D = (A - A.T).tocsr()
    asym = np.abs(D.data).max() if D.nnz else 0.0
    if asym > tol * scale:
        raise DataError(f"{label}: the matrix is not symmetric: max |A - A^T| = {asym / scale:.3g} of max |A| (tolerance {tol:g})")


def check_semidefinite(A: sp.csr_array, label: str, role: str = "stiffness") -> None:
    """Raise :class:`DataError` unless the symmetric ``A`` is positive semidefinite within a tolerance.

    A free structure's mass and stiffness matrices are positive semidefinite
    (kinetic and strain energy are never negative; zero for rigid-body motion or a
    massless DOF). The test is Sylvester's law of inertia on a sparse
    :math:`LDL^T` factorization of the shifted matrix

    .. math:: A + \\sigma I = P^T L D L^T P, \\qquad \\sigma = \\sqrt{\\epsilon}\\,\\|A\\|_\\infty,

    (SuperLU with diagonal pivoting and a symmetric fill-reducing ordering, so that
    ``U = D L^T``): ``A`` has an eigenvalue below ``-sigma`` exactly when ``D`` has a
    negative entry (the number of negative entries is the number of eigenvalues below
    ``-sigma``). The shift is far above the factorization's rounding (a backward
    error ``~ n eps ||A||``), so a semidefinite matrix with rigid-body modes passes,
    and far below any physical eigenvalue that matters: an eigenvalue between
    ``-sigma`` and 0 is taken as a rounding zero. A negative diagonal entry (a negative
    mass, a negated stiffness) is refused before any factorization. If SuperLU has to
    leave the diagonal (an exactly zero pivot), the smallest eigenvalue is found by a
    few Lanczos steps (``eigsh(which="SA")``) instead. Matrices of at most 200 DOFs
    are checked by their eigenvalues directly (``eigvalsh``, as cheap as a factorization there);
    never a dense eigensolve on a large model.

    Parameters
    ----------
    A : scipy.sparse array, shape (N, N)
        Real and symmetric (see :func:`check_symmetric`).
    label : str
        The file, for the message.
    role : {"mass", "stiffness"}
        Named in the message.

    Raises
    ------
    DataError
        ``"<file>: the mass matrix is not positive semidefinite: ..."``.
    """
    if A.nnz == 0:
        return
    what = f"{label}: the {role} matrix is not positive semidefinite"
    energy = "kinetic" if role == "mass" else "strain"
    diag = A.diagonal()
    norm = float(abs(A).sum(axis=1).max())  # ||A||_inf >= spectral radius
    sigma = np.sqrt(np.finfo(float).eps) * norm
    if diag.min() < -sigma:
        i = int(np.argmin(diag))
        raise DataError(
            f"{what}: diagonal entry {i + 1} is {diag[i]:.3g} (a negative {role}); its {energy} energy would be "
            "negative: check the sign and the matrix file"
        )
    negative = _negative_eigenvalues(A, sigma)
    if negative:
        raise DataError(
            f"{what}: {negative} eigenvalue(s) below -{sigma:.3g} (the tolerance sqrt(eps) ||A||); "
            f"some motion would have negative {energy} energy: check the matrix file"
        )


def _negative_eigenvalues(A: sp.csr_array, sigma: float) -> int:
    """How many eigenvalues of the symmetric ``A`` lie below ``-sigma`` (at least 1 if any, by the fallback)."""
    import scipy.sparse.linalg as spla

    n = A.shape[0]
    if n <= 200:
        return int(np.count_nonzero(np.linalg.eigvalsh(A.toarray()) < -sigma))
    S = sp.csc_matrix(A + sigma * sp.eye_array(n, format="csr"))
    try:
        lu = spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # an exactly zero pivot: A + sigma I is singular (A has the eigenvalue -sigma)
        lu = None
    if lu is not None and np.array_equal(lu.perm_r, lu.perm_c):
        return int(np.count_nonzero(lu.U.diagonal() < 0))  # Sylvester: inertia of D = inertia of A + sigma I
    try:  # SuperLU left the diagonal: a few Lanczos steps for the smallest eigenvalue
        lam = float(spla.eigsh(A, k=1, which="SA", tol=1e-6, maxiter=20 * n, return_eigenvectors=False)[0])
    except spla.ArpackNoConvergence as exc:
        vals = np.asarray(exc.eigenvalues)
        lam = float(vals.min()) if vals.size else 0.0
    return int(lam < -sigma)


#: Largest node id of a DOF list (ids are packed with the component into one int64 key: 2^59 - 1; a Nastran grid id
#: is at most 10^8).
MAX_NODE_ID = (1 << 59) - 1


def read_dof_list(path: "str | Path", base: "Path | None" = None) -> DofArray:
    """The DOF of each matrix row from a CSV of ``node,component`` rows.

    Parameters
    ----------
    path : str or Path
        The CSV (see the module docstring for the layout).
    base : Path, optional
        Directory relative paths are relative to.

    Returns
    -------
    DofArray

    Raises
    ------
    DataError
        Missing file, a row that is not ``node,component``, a node < 1, an
        unknown component, or a DOF listed twice (naming both rows).
    """
    path = Path(path)
    if base is not None and not path.is_absolute():
        path = Path(base) / path
    if not path.is_file():
        raise DataError(f"{path}: DOF list not found")
    nodes: list[int] = []
    codes: list[int] = []
    rows: list[int] = []
    text = read_utf8(path, "DOF list")
    for lineno, row in enumerate(csv.reader(io.StringIO(text, newline="")), start=1):
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if not nodes and not rows and [c.lower() for c in cells[:2]] == ["node", "component"]:
            continue
        if len(cells) != 2:
            raise DataError(f"row {lineno} of {path}: expected 'node,component', got {','.join(row)!r}")
        try:
            node = int(cells[0])
        except ValueError:
            node = 0
        if not 1 <= node <= MAX_NODE_ID:
            raise DataError(f"row {lineno} of {path}: node must be an integer from 1 to {MAX_NODE_ID}, got {cells[0]!r}")
        try:
            comp = parse_component(cells[1])
        except DofError:
            raise DataError(f"row {lineno} of {path}: unknown component {cells[1]!r}; use x, y, z, rx, ry, rz, 1-6, or 0 for a scalar point") from None
        nodes.append(node)
        codes.append(COMPONENT_CODES[comp])
        rows.append(lineno)
    if not nodes:
        raise DataError(f"{path}: the DOF list has no rows")
    dofs = DofArray(nodes, codes)
    dup = dofs.duplicates()
    if dup:
        where = np.flatnonzero(dofs.keys == pack_dof_keys(dup[0].node, dup[0].code))
        lines = " and ".join(str(rows[i]) for i in where[:2])
        more = f" ({len(dup)} DOFs are repeated)" if len(dup) > 1 else ""
        raise DataError(f"{path}: DOF {dup[0]} is listed twice (rows {lines}){more}; each matrix row needs its own DOF")
    return dofs


def write_dof_list(path: "str | Path", dofs: DofArray) -> None:
    """Write a DOF list CSV (header ``node,component``, components by name) that :func:`read_dof_list` reads."""
    names = np.array(["s", "x", "y", "z", "rx", "ry", "rz", "w", "theta"], dtype=object)[dofs.code]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.write("node,component\n")
        fh.writelines(f"{n},{c}\n" for n, c in zip(dofs.node.tolist(), names.tolist()))


def read_free_matrices(
    mass: "str | Path",
    stiffness: "str | Path",
    dofs: "str | Path",
    base: "Path | None" = None,
    symmetry_tolerance: float = SYMMETRY_TOLERANCE,
) -> FreeMatrices:
    """Mass, stiffness and DOF list of a free structure, read and checked (the study's ``[structure]``).

    Parameters
    ----------
    mass, stiffness : str or Path
        Matrix files (``.mtx``, ``.npz``, ``.op4``, optionally ``":NAME"``; see :func:`read_matrix`).
    dofs : str or Path
        DOF list CSV (:func:`read_dof_list`).
    base : Path, optional
        Directory relative paths are relative to (the study file's).
    symmetry_tolerance : float
        Relative tolerance of the symmetry check.

    Returns
    -------
    FreeMatrices

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    dof_array = read_dof_list(dofs, base)
    out = []
    for role, spec in (("mass", mass), ("stiffness", stiffness)):
        A = read_matrix(spec, role, base)
        path, name = _split_spec(spec, base)
        label = str(path) if name is None else f"{path}:{name}"
        check_symmetric(A, label, symmetry_tolerance)
        check_semidefinite(A, label, role)
        if A.shape[0] != len(dof_array):
            raise DataError(f"{label}: the {role} matrix is {A.shape[0]} x {A.shape[1]} but the DOF list {dofs} has {len(dof_array)} DOFs")
        out.append(A)
    return FreeMatrices(out[0], out[1], dof_array, (str(mass), str(stiffness), str(dofs)))


@dataclass(frozen=True)
class FreeMatrixFiles:
    """Where :func:`write_free_matrices` wrote a model (final paths).

    Attributes
    ----------
    mass, stiffness, dofs : Path
        The mass and stiffness matrix files (the same ``.npz`` for format ``npz``)
        and the DOF list CSV: the ``[structure]`` table's ``mass``, ``stiffness`` and ``dofs``.
    """

    mass: Path
    stiffness: Path
    dofs: Path

    def structure_table(self, base: "str | Path | None" = None) -> dict[str, str]:
        """``{"mass": ..., "stiffness": ..., "dofs": ...}`` for a study's ``[structure]``, relative to ``base`` if given."""
        def rel(p: Path) -> str:
            if base is None:
                return str(p)
            try:
                return p.resolve().relative_to(Path(base).resolve()).as_posix()
            except ValueError:
                return str(p.resolve())

        return {"mass": rel(self.mass), "stiffness": rel(self.stiffness), "dofs": rel(self.dofs)}


def _matrix_to_write(A, role: str, n: int) -> sp.csr_array:
    """``A`` checked as :func:`read_free_matrices` would check it (real, finite, square, symmetric, n x n)."""
    A = _check_matrix(A, f"{role} matrix to write")
    check_symmetric(A, f"{role} matrix to write")
    if A.shape[0] != n:
        raise DataError(f"{role} matrix to write is {A.shape[0]} x {A.shape[1]} but the DOF list has {n} DOFs")
    return A


def write_free_matrices(
    path: "str | Path",
    mass,
    stiffness,
    dofs: DofArray,
    format: str | None = None,
    output=None,
) -> FreeMatrixFiles:
    """Write a free model's M, K and DOF list in files :func:`read_free_matrices` reads back exactly.

    Parameters
    ----------
    path : str or Path
        Stem ``"dir/model"`` or a file ``"dir/model.npz"`` / ``"dir/model.mtx"``
        (the suffix sets ``format``). Files written, for stem ``model``:

        * ``npz``: ``model.npz`` with dense arrays ``M`` and ``K`` (models up to
          :data:`DENSE_NPZ_LIMIT` DOFs);
        * ``mtx``: ``model_M.mtx`` and ``model_K.mtx`` (Matrix Market,
          coordinate, ``symmetric`` when exactly so, else ``general``; 17 digits);
        * ``sparse-npz``: ``model_M.npz`` and ``model_K.npz`` (``scipy.sparse.save_npz``);

        and always ``model_dofs.csv`` (:func:`write_dof_list`). With ``output``,
        ``path`` is a name relative to that output directory.
    mass, stiffness : scipy.sparse matrix or ndarray, shape (N, N)
        Real symmetric mass (kg, kg*m, kg*m^2) and stiffness (N/m, N, N*m/rad).
    dofs : DofArray
        The DOF of each row (no repeats).
    format : {"npz", "mtx", "sparse-npz"}, optional
        Default: from the suffix of ``path``, else ``npz`` up to
        :data:`DENSE_NPZ_LIMIT` DOFs and ``mtx`` above.
    output : jointid.io.output_dir.OutputSet, optional
        An open output set to stage the files in (committed with the rest of
        its files). Without it the files go through their own
        ``OutputSet(dir, "matrices:<stem>")``: written atomically, all or none;
        a file of the same name that jointid did not write is never replaced
        (:class:`~jointid.io.output_dir.OutputError`), and rewriting the same
        stem removes that stem's previous files (e.g. of another format).

    Returns
    -------
    FreeMatrixFiles

    Raises
    ------
    DataError
        Matrices that are not real, finite, square, symmetric, of the DOF list's
        size; a repeated DOF; an unknown format; a dense ``npz`` too large.
    """
    from .output_dir import OutputSet

    if not isinstance(dofs, DofArray):
        dofs = DofArray.from_dofs(dofs)
    dup = dofs.duplicates()
    if dup:
        raise DataError(f"DOF {dup[0]} is listed twice in the DOF list to write; each matrix row needs its own DOF")
    n = len(dofs)
    M = _matrix_to_write(mass, "mass", n)
    K = _matrix_to_write(stiffness, "stiffness", n)
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".npz", ".mtx"):
        p = p.with_suffix("")
        if format is None:
            format = suffix[1:]
        elif (format == "mtx") != (suffix == ".mtx"):
            raise DataError(f"{path}: the suffix {suffix!r} contradicts format {format!r}; give the stem without a suffix")
    if format is None:
        format = "npz" if n <= DENSE_NPZ_LIMIT else "mtx"
    if format not in WRITE_FORMATS:
        raise DataError(f"unknown matrix file format {format!r}; use one of {', '.join(WRITE_FORMATS)}")
    if format == "npz" and n > DENSE_NPZ_LIMIT:
        raise DataError(
            f"{p}.npz: a model of {n} DOFs is too large for dense arrays in one .npz (limit {DENSE_NPZ_LIMIT}); use format 'mtx' or 'sparse-npz'"
        )
    stem = p.name
    if not stem:
        raise DataError(f"{path}: give a file stem such as 'dir/model'")
    writers = {f"{stem}_dofs.csv": lambda q: write_dof_list(q, dofs)}
    if format == "npz":
        writers = {f"{stem}.npz": lambda q: _savez(q, M, K), **writers}
        names = (f"{stem}.npz", f"{stem}.npz")
    else:
        ext = "mtx" if format == "mtx" else "npz"
        save = _mmwrite if format == "mtx" else _save_sparse_npz
        names = (f"{stem}_M.{ext}", f"{stem}_K.{ext}")
        writers = {names[0]: lambda q: save(q, M), names[1]: lambda q: save(q, K), **writers}
    if output is not None:
        parent = PurePosixPath(p.parent.as_posix()) if str(p.parent) not in ("", ".") else None
        keys = {name: (str(parent / name) if parent else name) for name in writers}
        final = {name: output.write_file(keys[name], w) for name, w in writers.items()}
    else:
        with OutputSet(p.parent, f"matrices:{stem}") as out:
            final = {name: out.write_file(name, w) for name, w in writers.items()}
    return FreeMatrixFiles(final[names[0]], final[names[1]], final[f"{stem}_dofs.csv"])


def _savez(path: Path, M: sp.csr_array, K: sp.csr_array) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, M=M.toarray(), K=K.toarray())


def _save_sparse_npz(path: Path, A: sp.csr_array) -> None:
    with open(path, "wb") as fh:
        sp.save_npz(fh, sp.csr_matrix(A))


def _mmwrite(path: Path, A: sp.csr_array) -> None:
    import scipy.io

    exact = (A != A.T).nnz == 0  # "symmetric" keeps one triangle: only for exactly symmetric matrices
    with open(path, "wb") as fh:
        scipy.io.mmwrite(fh, sp.coo_matrix(A), symmetry="symmetric" if exact else "general", precision=17)
