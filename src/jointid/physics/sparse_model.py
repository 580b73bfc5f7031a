"""A large sparse free structure as a :class:`~jointid.physics.free_model.FreeModel`.

The identification methods need the free receptance ``Y = (K (1 + j eta) - w^2 M)^-1``
only on a few DOFs (observed, joint, excited), on many frequency lines. For a
model of 1e5 DOFs a dense ``N x N`` matrix is out of the question (80 GB);
:class:`SparseModel` keeps M and K sparse and offers two methods:

**modal** (default for many lines): the lowest modes of the free structure,
every mode up to ``cutoff_factor`` times the highest frequency asked for
(default 2.5x; shift-invert Lanczos, ``scipy.sparse.linalg.eigsh`` on one
sparse factorization of ``K + s M``, ``s = (w_top / 3)^2 > 0``, which is
positive definite even with rigid-body modes), superposed with *residual
compensation* for the truncated modes::

    Y(w) = sum_kept phi phi^T / (lambda (1 + j eta) - w^2)  +  sum_k z^k / c^(k+1) R_k

with ``c = 1 + j eta``, ``z = w^2 + s c`` and the moments of the truncated
modes ``R_k = sum_trunc phi phi^T / (lambda + s)^(k+1)``, obtained without
knowing those modes as ``R_k = E^T G (M G)^k E - sum_kept phi phi^T / mu^(k+1)``
from ``G = (K + s M)^-1`` (the same factorization), ``mu = lambda + s``:
``k = 0`` is the classical residual flexibility (static correction), higher
``k`` add the truncated modes' inertia. The series is exact in the loss factor
and converges as ``(|z| / mu_c)^k`` with ``mu_c`` the first truncated
eigenvalue: at the top of the band with ``cutoff_factor = 2.5`` about
``(1.11 / 6.36)^k`` of the truncated modes' contribution is left (far less lower
in the band); the default 6 terms leave ~3e-5 of it. The kept modes are
deflated at every step (no cancellation against the rigid-body terms) and every
solve takes one step of iterative refinement. ``tests/test_sparse_model.py``
bounds the worst relative error per entry against a direct solve over the band
on a 2000-DOF chain with 0, 1, 2 and 6 terms. On an ill-conditioned model (frame
elements far shorter than their depth) the floor is the factorization's
round-off, as for a direct solve (``benchmarks/large_model.py`` prints it against
a direct sparse solve). Cost: one real sparse factorization, ``k`` Lanczos
modes, two block solves per requested DOF set; then every line is a product of
``(r x k)`` and ``(k x c)`` blocks, vectorized over frequency
(``benchmarks/large_model.py`` prints the time of each step and the peak memory
on a 1e5-DOF grillage).

**direct**: one complex sparse LU (``scipy.sparse.linalg.splu``) of
``K (1 + j eta) - w^2 M`` per line, solved for the smaller of the row and
column sets (``Y`` is complex symmetric). Exact to round-off; meant for few
lines, since each line costs a factorization (this loop over lines is the
method, not an implementation shortcut).

``method="auto"`` takes *direct* when ``lines * N <= AUTO_DIRECT_WORK`` or
``lines <= AUTO_DIRECT_LINES``, otherwise *modal*. No ``N x N`` dense matrix
is formed (models up to :data:`DENSE_EIGEN_LIMIT` DOFs take their modes from a
dense eigensolution, all of them, with no truncation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..dofs import Dof, DofArray
from ..errors import ModelError
from ..frequency import Frequency

__all__ = [
    "SparseModel",
    "DENSE_STRUCTURE_MAX_DOFS",
    "ModalBasis",
    "METHODS",
    "AUTO_DIRECT_WORK",
    "AUTO_DIRECT_LINES",
    "DENSE_EIGEN_LIMIT",
    "DEFAULT_CUTOFF_FACTOR",
    "DEFAULT_RESIDUAL_TERMS",
]

METHODS: tuple[str, ...] = ("auto", "modal", "direct")
#: ``method="auto"`` solves directly when lines x DOFs is at most this.
AUTO_DIRECT_WORK = 1_000_000
#: ... or when there are at most this many lines.
AUTO_DIRECT_LINES = 8
#: Models up to this many DOFs take every mode from a dense eigensolution (no truncation).
DENSE_EIGEN_LIMIT = 500
#: Modes are kept up to this multiple of the highest frequency asked for.
DEFAULT_CUTOFF_FACTOR = 2.5
#: Terms of the residual series (0: plain truncation, 1: static residual flexibility).
DEFAULT_RESIDUAL_TERMS = 6
#: Most terms of the residual series.
MAX_RESIDUAL_TERMS = 8
#: Eigenvalues below this fraction of the largest computed one are rigid-body modes, set to 0: their
#: computed values are round-off of ``eps * |K| / m``, far below it; an elastic mode that low would be
#: below ``sqrt(RIGID_TOLERANCE)`` (3e-5) times the highest computed natural frequency.
RIGID_TOLERANCE = 1e-9
_CHUNK_BYTES = 32 * 2**20


@dataclass(frozen=True, eq=False)
class ModalBasis:
    """Modes of the free structure, M-orthonormal.

    Attributes
    ----------
    eigenvalues : ndarray, shape (k,)
        ``lambda_r = w_r^2``, rad^2/s^2 (rigid-body modes ~0), ascending.
    shapes : ndarray, shape (N, k)
        Mode shapes, ``Phi^T M Phi = I``.
    shift : float
        ``s`` of the factorization ``K + s M`` (rad^2/s^2).
    complete : bool
        True when every mode of the model is here (no truncation, no residual).
    covers_hz : float
        Highest frequency this basis serves (``sqrt(lambda_max) / (2 pi) / cutoff_factor``).
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray
    shift: float
    complete: bool
    covers_hz: float

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies, Hz (negative round-off of rigid-body modes clipped to 0)."""
        return np.sqrt(np.clip(self.eigenvalues, 0.0, None)) / (2.0 * np.pi)


#: Largest model :meth:`SparseModel.to_dense` converts (the plain Hong & Lee method: its estimation step holds (250 lines, N, N) complex arrays, 1 GB at 500 DOFs).
DENSE_STRUCTURE_MAX_DOFS = 500


#: Component codes (:data:`jointid.dofs.COMPONENT_CODES`) that carry a lumped mass: x, y, z, w.
_TRANSLATION_CODES = (1, 2, 3, 7)
#: Component codes that carry a lumped rotary inertia: rx, ry, rz, theta.
_ROTATION_CODES = (4, 5, 6, 8)


class SparseModel:
    """A free structure given by sparse M and K, as a :class:`~jointid.physics.free_model.FreeModel`.

    Parameters
    ----------
    mass, stiffness : scipy.sparse matrix or ndarray, shape (N, N)
        Real symmetric mass (kg, kg*m^2) and stiffness (N/m, N*m/rad) matrices.
    dofs : DofArray or sequence of DOF labels, length N
        The DOF of each row.
    loss_factor : float
        Structural damping: the dynamic stiffness is ``K (1 + j eta) - w^2 M``.
    method : {"auto", "modal", "direct"}
        How :meth:`receptance` computes (see the module docstring); overridable per call.
    cutoff_factor : float
        Modal method: keep every mode up to this multiple of the highest frequency asked for (>= 1.5).
    residual_terms : int
        Modal method: terms of the residual series (0-4; 0: plain truncation, 1: static residual).
    n_modes : int, optional
        Modal method: compute exactly this many modes instead (the cutoff is then ignored).

    Notes
    -----
    Modes are computed on the first modal call, for that call's highest
    frequency, and again only if a later call goes higher. The residual moments
    cost two sparse solves per requested DOF and are cached per DOF (about
    ``16 N`` bytes each).
    """

    def __init__(
        self,
        mass,
        stiffness,
        dofs,
        loss_factor: float = 0.0,
        method: str = "auto",
        cutoff_factor: float = DEFAULT_CUTOFF_FACTOR,
        residual_terms: int = DEFAULT_RESIDUAL_TERMS,
        n_modes: int | None = None,
    ) -> None:
        self.dof_array = dofs if isinstance(dofs, DofArray) else DofArray.from_dofs(dofs)
        N = len(self.dof_array)
        self.mass = _real_csc(mass, "mass", N)
        self.stiffness = _real_csc(stiffness, "stiffness", N)
        if not (np.isfinite(loss_factor) and loss_factor >= 0):
            raise ModelError(f"loss_factor must be a finite number >= 0, got {loss_factor!r}")
        if method not in METHODS:
            raise ModelError(f"method must be one of {METHODS}, got {method!r}")
        if not (np.isfinite(cutoff_factor) and cutoff_factor >= 1.5):
            raise ModelError(f"cutoff_factor must be >= 1.5, got {cutoff_factor!r}")
        if residual_terms not in range(MAX_RESIDUAL_TERMS + 1):
            raise ModelError(f"residual_terms must be 0..{MAX_RESIDUAL_TERMS}, got {residual_terms!r}")
        if n_modes is not None and not (isinstance(n_modes, int) and 1 <= n_modes < N):
            raise ModelError(f"n_modes must be an integer in 1..{N - 1}, got {n_modes!r}")
        self.loss_factor = float(loss_factor)
        self.method = method
        self.cutoff_factor = float(cutoff_factor)
        self.residual_terms = int(residual_terms)
        self.n_modes = n_modes
        self._modes: ModalBasis | None = None
        self._factor = None  # splu of K + s M
        self._shifted = None  # K + s M
        self._xs: dict[int, np.ndarray] = {}  # DOF index -> (J + 1, N) deflated Krylov vectors

    @classmethod
    def from_dense(cls, structure, **options) -> "SparseModel":
        """A :class:`~jointid.physics.structure.Structure` (proportional damping, no joints) as a sparse model."""
        if structure.joints:
            raise ModelError("a free model must not contain frequency-dependent joints: Do is the free structure alone")
        eta = structure.proportional_loss_factor
        if eta is None:
            raise ModelError("the structure's damping is not proportional (Im K = eta Re K); a sparse model needs one loss factor")
        return cls(sp.csc_array(structure.M), sp.csc_array(structure.K.real), structure.dofs, eta, **options)

    def with_masses(self, nodes: Iterable[int], mass_kg: float, rotary_inertia_kg_m2: float = 0.0) -> "SparseModel":
        """A copy with the same lumped mass and rotary inertia at each of ``nodes`` (e.g. accelerometers).

        ``mass_kg`` is added to the mass matrix's diagonal at every translational DOF of the
        node (x, y, z, w), ``rotary_inertia_kg_m2`` at every rotational one (rx, ry, rz, theta):
        a point mass with an isotropic rotary inertia. The options and loss factor are kept.

        Raises
        ------
        ModelError
            A negative or non-finite mass or inertia, or a node without DOFs in the model.
        """
        if not (np.isfinite(mass_kg) and mass_kg >= 0 and np.isfinite(rotary_inertia_kg_m2) and rotary_inertia_kg_m2 >= 0):
            raise ModelError(f"lumped masses: mass ({mass_kg!r} kg) and rotary inertia ({rotary_inertia_kg_m2!r} kg*m^2) must be finite and >= 0")
        nodes = np.unique(np.asarray(list(nodes), dtype=np.int64))
        at = np.isin(self.dof_array.node, nodes)
        missing = np.setdiff1d(nodes, self.dof_array.node[at])
        if missing.size:
            raise ModelError(f"lumped masses: node {int(missing[0])} has no DOF in the model")
        code = self.dof_array.code
        add = np.where(at & np.isin(code, _TRANSLATION_CODES), mass_kg, 0.0) + np.where(at & np.isin(code, _ROTATION_CODES), rotary_inertia_kg_m2, 0.0)
        M = (self.mass + sp.diags_array(add, format="csc")).tocsc()
        return SparseModel(M, self.stiffness, self.dof_array, self.loss_factor, self.method, self.cutoff_factor,
                           self.residual_terms, self.n_modes)

    def with_joints(self, joints):
        """The model with frequency-dependent joints attached (:class:`~jointid.physics.jointed_model.JointedModel`)."""
        from .jointed_model import JointedModel

        return JointedModel(self, tuple(joints))

    # ------------------------------------------------------------ FreeModel
    @property
    def dofs(self) -> tuple[Dof, ...]:
        """Every DOF of the model, as :class:`~jointid.dofs.Dof` (built once)."""
        return self.dof_array.to_dofs()

    @property
    def size(self) -> int:
        """Number of DOFs N."""
        return len(self.dof_array)

    @property
    def modes(self) -> ModalBasis | None:
        """The modal basis computed so far (None before the first modal call)."""
        return self._modes

    def choose_method(self, lines: int) -> str:
        """``"direct"`` or ``"modal"`` for ``lines`` frequency lines (see the module docstring)."""
        if self.method != "auto":
            return self.method
        return "direct" if lines <= AUTO_DIRECT_LINES or lines * self.size <= AUTO_DIRECT_WORK else "modal"

    def receptance(self, frequency, rows: Iterable, cols: Iterable, method: str | None = None) -> np.ndarray:
        """Receptance ``Y[rows, cols]`` of the free structure, shape (F, r, c), complex.

        Parameters
        ----------
        frequency : Frequency or array_like, shape (F,)
            Lines, Hz.
        rows, cols : DOF labels, DofArray or (node, code) arrays
            Response and reference DOFs.
        method : {"auto", "modal", "direct"}, optional
            Overrides the model's method for this call.

        Returns
        -------
        ndarray, shape (F, r, c), complex
            m/N, rad/N, m/(N*m), rad/(N*m).

        Raises
        ------
        DofError
            A DOF not in the model.
        ModelError
            A 0 Hz line on a free structure (singular), or a bad method.
        """
        f = frequency.hz if isinstance(frequency, Frequency) else np.atleast_1d(np.asarray(frequency, dtype=float))
        ri = self.dof_array.indices(rows, "sparse model")
        ci = self.dof_array.indices(cols, "sparse model")
        how = self.choose_method(f.size) if method in (None, "auto") else method
        if how not in ("modal", "direct"):
            raise ModelError(f"method must be one of {METHODS}, got {method!r}")
        if f.size == 0 or ri.size == 0 or ci.size == 0:
            return np.zeros((f.size, ri.size, ci.size), dtype=complex)
        if how == "direct":
            return self._direct(f, ri, ci)
        return self._modal(f, ri, ci)

    def to_dense(self, max_dofs: int | None = None):
        """The model as a dense :class:`~jointid.physics.structure.Structure` (``K (1 + j eta)``, ``M``), for small models.

        What the plain Hong & Lee method needs: it solves with ``Do[nbar, mbar]``,
        N - |n| rows, on every line. Node coordinates are not known from matrix
        files: every node is put at x = 0 (the rotation scale then comes from the
        stiffness, :func:`jointid.methods.hong_lee.inverse.rotation_scale`).

        Raises
        ------
        ModelError
            More than ``max_dofs`` DOFs (one line: the dense N x N arrays would be too large).
        """
        from .structure import Structure

        max_dofs = DENSE_STRUCTURE_MAX_DOFS if max_dofs is None else max_dofs
        if self.size > max_dofs:
            raise ModelError(
                f"the model has {self.size} DOFs; the plain Hong & Lee method needs the dense {self.size} x {self.size} "
                f"Do[nbar, mbar] on every line and is limited to {max_dofs} DOFs: use method = \"receptance\""
            )
        dofs = self.dofs
        coordinates = {node: 0.0 for node in sorted({d.node for d in dofs})}
        K = self.stiffness.toarray() * (1.0 + 1j * self.loss_factor)
        return Structure(dofs, coordinates, self.mass.toarray(), K)

    # --------------------------------------------------------------- direct
    def _direct(self, f: np.ndarray, ri: np.ndarray, ci: np.ndarray) -> np.ndarray:
        """One complex sparse LU per line; solves for the smaller DOF set (Y is complex symmetric)."""
        transpose = ri.size < ci.size
        solve_for, take = (ri, ci) if transpose else (ci, ri)
        N = self.size
        E = np.zeros((N, solve_for.size), dtype=complex)
        E[solve_for, np.arange(solve_for.size)] = 1.0
        Kc = (self.stiffness * (1.0 + 1j * self.loss_factor)).tocsc()
        out = np.empty((f.size, ri.size, ci.size), dtype=complex)
        for i, fi in enumerate(f):  # one factorization per line is the method
            A = (Kc - (2.0 * np.pi * fi) ** 2 * self.mass).tocsc()
            try:
                lu = spla.splu(A, permc_spec="COLAMD")
            except RuntimeError as exc:
                raise ModelError(f"the dynamic stiffness is singular at {fi:g} Hz ({exc}); a free structure is singular at 0 Hz") from None
            if fi == 0.0:  # a free structure's K: SuperLU may factor it with a round-off pivot
                u = np.abs(lu.U.diagonal())
                if u.min() <= 1e-12 * u.max():
                    raise ModelError("the dynamic stiffness is singular at 0 Hz (rigid-body modes); drop the 0 Hz line")
            X = lu.solve(E)
            X = (X + lu.solve(E - A @ X))[take]  # one step of iterative refinement: ill-conditioned FE models
            out[i] = X.T if transpose else X
        return out

    # ---------------------------------------------------------------- modal
    def _modal(self, f: np.ndarray, ri: np.ndarray, ci: np.ndarray) -> np.ndarray:
        basis = self.ensure_modes(float(np.max(np.abs(f))))
        lam = basis.eigenvalues
        if np.any(f == 0.0) and np.any(np.abs(lam) <= 1e-9 * max(abs(lam[-1]), 1.0)):
            raise ModelError("the free structure is singular at 0 Hz (rigid-body modes); drop the 0 Hz line")
        c = 1.0 + 1j * self.loss_factor
        w2 = (2.0 * np.pi * f) ** 2
        Pr, Pc = basis.shapes[ri], basis.shapes[ci]
        k = lam.size
        out = np.empty((f.size, ri.size, ci.size), dtype=complex)
        step = max(1, _CHUNK_BYTES // (16 * max(1, ri.size * k)))
        for s in range(0, f.size, step):  # chunks bound memory; each chunk is vectorized
            g = 1.0 / (lam[None, :] * c - w2[s:s + step, None])  # (f, k)
            out[s:s + step] = (Pr[None, :, :] * g[:, None, :]) @ Pc.T
        if not basis.complete and self.residual_terms:
            R = self._residual_moments(ri, ci, basis)  # (terms, r, c)
            z = w2 + basis.shift * c
            coef = np.stack([z**j / c ** (j + 1) for j in range(R.shape[0])], axis=1)  # (F, terms)
            out += np.einsum("ft,trc->frc", coef, R)
        return out

    def ensure_modes(self, top_hz: float) -> ModalBasis:
        """The modal basis serving lines up to ``top_hz`` (computed or extended if needed)."""
        if self._modes is not None and (self._modes.complete or self.n_modes is not None or self._modes.covers_hz >= top_hz):
            return self._modes
        N = self.size
        w_top = 2.0 * np.pi * max(top_hz, 1e-3)
        shift = (w_top / 3.0) ** 2
        if N <= DENSE_EIGEN_LIMIT:
            try:
                lam, phi = sla.eigh(self.stiffness.toarray(), self.mass.toarray())
            except np.linalg.LinAlgError:
                raise ModelError("the mass matrix is not positive definite (massless DOFs?); use method='direct'") from None
            lam = np.where(np.abs(lam) <= RIGID_TOLERANCE * abs(lam[-1]), 0.0, lam)
            self._modes = ModalBasis(lam, phi, shift, True, np.inf)
            return self._modes
        self._set_factor(shift)
        lam_cut = (self.cutoff_factor * w_top) ** 2
        op = spla.LinearOperator((N, N), matvec=self._factor.solve, matmat=self._factor.solve, dtype=float)
        k = self.n_modes or min(N - 2, 40)
        while True:
            lam, phi = spla.eigsh(self.stiffness, k=k, M=self.mass, sigma=-shift, which="LM", OPinv=op)
            if self.n_modes is not None or lam.max() >= lam_cut or k >= N - 2:
                break
            k = _more_modes(np.sort(lam), lam_cut, N)
        # one step of subspace iteration with refined solves, then Rayleigh-Ritz: Lanczos vectors carry the
        # factorization's round-off (1e-5 on ill-conditioned fine meshes), the refined solves do not
        phi = self._solve(np.asarray(self.mass @ phi))
        lam, phi = _rayleigh_ritz(self.stiffness, self.mass, phi)
        lam = np.where(np.abs(lam) <= RIGID_TOLERANCE * abs(lam[-1]), 0.0, lam)
        covers = np.sqrt(max(lam.max(), 0.0)) / (2.0 * np.pi) / self.cutoff_factor
        if self.n_modes is not None:
            covers = np.inf
        self._modes = ModalBasis(lam, phi, shift, False, covers)
        self._xs.clear()
        return self._modes

    def _solve(self, B: np.ndarray) -> np.ndarray:
        """``(K + s M)^-1 B`` with one step of iterative refinement (fine FE meshes are ill-conditioned)."""
        X = self._factor.solve(B)
        return X + self._factor.solve(B - np.asarray(self._shifted @ X))

    def _set_factor(self, shift: float) -> None:
        A = (self.stiffness + shift * self.mass).tocsc()
        self._shifted = A
        try:
            self._factor = spla.splu(A, permc_spec="COLAMD")
        except RuntimeError as exc:
            raise ModelError(f"K + s M is singular ({exc}): check the stiffness and mass matrices") from None

    def _residual_moments(self, ri: np.ndarray, ci: np.ndarray, basis: ModalBasis) -> np.ndarray:
        """Moments of the truncated modes ``R_k[rows, cols] = sum_trunc phi phi^T / mu^(k+1)``, shape (terms, r, c).

        With ``P = I - Phi Phi^T M`` (the projector on the truncated modes) and
        ``X_0 = P G E``, ``X_(j+1) = P G M X_j`` (so ``X_j = sum_trunc phi phi^T E / mu^(j+1)``):
        ``R_0 = E^T X_0`` and ``R_k = X_a^T M X_b`` with ``a + b = k - 1``. Deflating
        the kept modes at every step avoids the cancellation of the rigid-body
        terms ``1 / s^(k+1)`` against the small truncated ones.
        """
        J = (self.residual_terms - 1) // 2
        need = [i for i in dict.fromkeys(np.r_[ri, ci].tolist()) if i not in self._xs]
        if need:
            if self._factor is None:
                self._set_factor(basis.shift)
            Phi = basis.shapes
            E = np.zeros((self.size, len(need)))
            E[need, np.arange(len(need))] = 1.0
            X = self._solve(E)
            stack = []
            for j in range(J + 1):
                X = X - Phi @ (Phi.T @ np.asarray(self.mass @ X))  # P: deflate the kept modes
                stack.append(X)
                if j < J:
                    X = self._solve(np.asarray(self.mass @ X))
            stack = np.stack(stack)  # (J + 1, N, len(need))
            for col, i in enumerate(need):
                self._xs[i] = np.ascontiguousarray(stack[:, :, col])
        Xr = np.stack([self._xs[i] for i in ri.tolist()], axis=2)  # (J + 1, N, r)
        Xc = np.stack([self._xs[i] for i in ci.tolist()], axis=2)
        MXc = np.stack([np.asarray(self.mass @ Xc[j]) for j in range(J + 1)])
        out = [Xr[0][ci].T]  # E_r^T X_0 E_c
        for k in range(1, self.residual_terms):
            a = (k - 1) // 2
            out.append(Xr[a].T @ MXc[k - 1 - a])
        return np.stack(out)


def _real_csc(A, what: str, n: int) -> sp.csc_array:
    """``A`` as a real float64 CSC array of shape (n, n)."""
    A = sp.csc_array(A) if sp.issparse(A) else sp.csc_array(np.asarray(A))
    if A.shape != (n, n):
        raise ModelError(f"the {what} matrix is {A.shape[0]} x {A.shape[1]} but the model has {n} DOFs")
    if np.iscomplexobj(A.data):
        if A.nnz and np.abs(A.data.imag).max() > 0:
            raise ModelError(f"the {what} matrix must be real (damping comes from loss_factor)")
        A = sp.csc_array(A.real)
    return A.astype(np.float64)


def _more_modes(lam: np.ndarray, lam_cut: float, N: int) -> int:
    """Modes to ask for next: the count below ``lam_cut`` extrapolated from the growth ``count ~ lambda^a`` seen so far, +20 %."""
    k = lam.size
    hi, lo = lam[-1], lam[k // 2]
    a = np.log(k / (k // 2 + 1)) / np.log(hi / lo) if lo > 0 and hi > lo * (1 + 1e-9) else 1.5
    a = float(np.clip(a, 0.3, 2.0))
    guess = k * (lam_cut / hi) ** a
    return int(min(N - 2, max(k + 20, np.ceil(1.2 * guess) + 10)))


def _rayleigh_ritz(K, M, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of the projected problem on span(phi): M-orthonormal Ritz vectors, ascending."""
    Kr = phi.T @ np.asarray(K @ phi)
    Mr = phi.T @ np.asarray(M @ phi)
    lam, V = sla.eigh((Kr + Kr.T) / 2.0, (Mr + Mr.T) / 2.0)
    return lam, phi @ V
