"""FRF synthesis from an FE model: batched direct solve or modal superposition.

Receptance ``H(w) = D(w)^-1`` with ``D(w) = K* + sum_j K_j(f) - w^2 M``
(see :mod:`jointid.physics.structure`), restricted to the requested response
rows and reference columns.

Two paths, chosen by ``method="auto"`` and overridable:

``"direct"``
    Solves ``D(w) X = E`` for the reference columns E only. Models up to
    :data:`DENSE_DIRECT_LIMIT` DOFs: one batched LAPACK ``gesv`` over frequency
    (in chunks that bound memory). Larger models: a sparse LU per line
    (``scipy.sparse.linalg.splu``) -- the one place a loop over lines remains,
    because a batched dense factorization of a 4000-DOF model per line would
    need 256 MB a line.
    Exact for any damping and any frequency-dependent joint.
``"modal"``
    ``H = Phi diag(1 / (w_r^2 (1 + j eta) - w^2)) Phi^T`` with real
    mass-normalized modes. Exact (to rounding) when damping is proportional
    (``Im K = eta Re K``) and there are no frequency-dependent joints. With
    every mode present (models up to
    :data:`~jointid.physics.modes.DENSE_EIGEN_LIMIT` DOFs) it equals the direct
    result to round-off (``benchmarks/frf_synthesis.py`` prints the difference).
    Larger models keep the modes below
    ``cutoff_factor * f_max`` and add the truncated modes' residual flexibility
    evaluated at a negative shift ``s0 = -sigma``:
    ``R = [(K* + sigma M)^-1]_rc - sum_kept phi phi^T / (w_r^2 (1 + j eta) + sigma)``;
    its relative error is of order ``(f_max / f_cut)^2`` of the truncated part.

``"coupled"``
    A proportionally damped structure with frequency-dependent joints: the
    joint-free receptance by refined modal superposition, the joints added by
    Sherman-Morrison-Woodbury on their DOFs (:func:`receptance_coupled`); exact,
    and far cheaper than ``"direct"`` (no N x N solve per line).

``"auto"`` picks ``"coupled"`` for such structures (up to
:data:`~jointid.physics.modes.DENSE_EIGEN_LIMIT` DOFs), and ``"modal"`` whenever it is exact (or, for large models,
residual-compensated) and ``"direct"`` otherwise.

At 0 Hz a structure with rigid-body modes (free-free) has a singular ``D``:
its receptance is undefined there and :class:`~jointid.errors.FrequencyError`
is raised.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Iterable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import FrequencyError, ModelError
from ..frequency import Frequency
from ..frf import FRF, kind_factor
from ..parallel import map_chunks
from ..dofs import parse_dofs
from .modes import DENSE_EIGEN_LIMIT, Modes, natural_modes
from .structure import Structure

__all__ = [
    "synthesize_frf", "model_frf", "check_zero_frequency", "receptance_direct", "receptance_modal", "receptance_modal_refined", "receptance_coupled",
    "DENSE_DIRECT_LIMIT", "choose_method",
]

#: Complex values per chunk of the refined modal sum (16 MB a chunk).
_CHUNK_ELEMENTS = 2**20

#: Largest model (DOFs) solved by dense batched LAPACK; larger ones use sparse LU per line.
DENSE_DIRECT_LIMIT = 600
_CHUNK_BYTES = 64 * 2**20


def _as_frequency(frequency) -> Frequency:
    return frequency if isinstance(frequency, Frequency) else Frequency(frequency)


def check_zero_frequency(structure: Structure, frequency: Frequency) -> None:
    if frequency.hz[0] > 0.0:
        return
    D0 = structure.dynamic_stiffness(frequency.hz[:1])[0]
    n = D0.shape[0]
    if n <= 2000:
        s = np.linalg.svd(D0, compute_uv=False)
        singular = s[-1] <= 1e-12 * s[0]
    else:
        Ks = sp.csc_matrix(D0.real)
        Ms = sp.csc_matrix(structure.M)
        lam = spla.eigsh(Ks, k=1, M=Ms, sigma=-1.0, which="LM", return_eigenvectors=False)
        singular = abs(lam[0]) < 1e-6
    if singular:
        raise FrequencyError(
            "the receptance is undefined at 0 Hz: the structure has rigid-body modes "
            "(free-free or under-constrained), so its stiffness matrix is singular; "
            "start the frequency grid above 0 Hz"
        )


def choose_method(structure: Structure) -> str:
    """The synthesis path ``"auto"`` takes for ``structure``: ``"modal"``, ``"coupled"`` or ``"direct"``."""
    if structure.proportional_loss_factor is None or len(structure.dofs) > DENSE_EIGEN_LIMIT:
        return "direct" if structure.joints or structure.proportional_loss_factor is None else "modal"
    return "coupled" if structure.joints else "modal"


#: Modes up to this multiple of the highest line's frequency carry the refinement: the higher
#: modes' share of it is below 1e-12 relative (their ``1 / (w_r^2 - w^2)`` is ~1000x smaller).
REFINE_FACTOR = 30.0
#: The projections need extended precision (x87 long double, eps 1.1e-19); where long double
#: is plain double the refinement takes the residual on every DOF instead (slower, as accurate).
_EXTENDED = bool(np.finfo(np.longdouble).eps < 1e-18)


def _projection_errors(structure: Structure, modes: Modes, count: int, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Phi^T K* Phi - diag(lam)`` and ``Phi^T M Phi - I`` on the first ``count`` modes.

    ``K* Phi`` is the cancelling product (entries ~lam_max, result ~lam_r): it is summed
    in long double over the nonzeros and rounded once; ``Phi^T (K* Phi)`` then errs
    by ~eps lam_r only, far below ``dA`` (~eps lam_max) for the low modes.
    """
    Phi = modes.shapes[:, :count]
    out = []
    for A, diag in ((np.asarray(structure.K, complex), lam[:count]), (structure.M, np.ones(count))):
        dtype = np.clongdouble if np.iscomplexobj(A) else np.longdouble
        i, j = np.nonzero(A)  # row-major: each row's nonzeros together
        rows, start = np.unique(i, return_index=True)
        APhi = np.zeros(Phi.shape, dtype)
        APhi[rows] = np.add.reduceat(A[i, j].astype(dtype)[:, None] * Phi[j].astype(np.longdouble), start, axis=0)
        P = Phi.T @ APhi.astype(A.dtype)
        P[np.arange(count), np.arange(count)] -= diag
        out.append(P)
    return out[0], out[1]


def receptance_modal_refined(structure: Structure, frequency: Frequency, responses, references, modes: Modes) -> np.ndarray:
    """Modal receptance over every mode plus one step of iterative refinement, shape (F, r, c).

    ``Y0 = Phi g Phi^T`` with ``g = diag(1 / (w_r^2 (1 + j eta) - w^2))`` over every mode:
    exact in exact arithmetic, but the computed modes diagonalize ``K*`` only to
    ``eps lam_max`` (``Phi^T K* Phi = Lam* + dA``, ``Phi^T M Phi = I + dB``), which the
    plain sum turns into a relative error of up to about ``eps lam_max / (eta lam_r)``
    (at resonances, where ``g`` is ~1/eta; large on fine meshes). One step of
    refinement removes it to first order::

        Y = Y0 - Phi[r] g (dA - w^2 dB) g Phi[c]^T

    with ``dA``, ``dB`` computed once (:func:`_projection_errors`) on the modes below
    ``REFINE_FACTOR * f_max`` (the others' share is < 1e-12 relative; their plain sum
    is evaluated as a power series in ``w^2``). It agrees with a direct solve refined
    with long-double residuals to round-off, more closely than the refinement
    against the assembled matrices on every DOF (``tests/test_synthesis.py``
    bounds both). Cost: a modal sum over the modes below ``REFINE_FACTOR * f_max``
    on ``r, c`` plus a product of that size squared per line, no N x N work per line.
    Needs complete modes of a proportionally damped structure without joints.
    """
    ri, ci = np.array(structure.index(responses)), np.array(structure.index(references))
    if not _EXTENDED:
        return _refined_on_every_dof(structure, frequency, ri, ci, modes)
    Phi = modes.shapes
    eta = modes.loss_factor if modes.loss_factor is not None else structure.proportional_loss_factor
    lam = modes.eigenvalues * (1.0 + 1j * eta)
    w2_all = frequency.omega**2
    w2_max = float(w2_all.max())
    count = int(np.clip(np.searchsorted(modes.eigenvalues, REFINE_FACTOR**2 * w2_max, "right"), min(12, lam.size), lam.size))
    dA, dB = _projection_errors(structure, modes, count, lam)
    # modes above REFINE_FACTOR f_max: 1 / (lam - w^2) = sum_p w^(2p) / lam^(p+1), with w^2 / lam < 1 / REFINE_FACTOR^2
    ratio = w2_max / float(modes.eigenvalues[count]) if count < lam.size else 0.0
    terms = 0 if count == lam.size else max(1, int(np.ceil(np.log(1e-17) / np.log(max(ratio, 1e-300)))))
    Hr, Hc = Phi[ri, count:], Phi[ci, count:]
    series = np.array([((Hr / lam[count:] ** (p + 1)) @ Hc.T).ravel() for p in range(terms)])  # (terms, r c)
    Pr, Pc = Phi[ri, :count], Phi[ci, :count]
    dAB = np.hstack([dA.T, dB.T]).astype(complex)
    nr, nc = ri.size, ci.size
    out = np.empty((frequency.size, nr, nc), complex)

    def chunk(lines: np.ndarray) -> None:
        w2 = w2_all[lines]
        g = 1.0 / (lam[None, :count] - w2[:, None])  # (f, count)
        Y0 = ((g.real[:, None, :] * Pr[None]).reshape(-1, count) @ Pc.T
              + 1j * ((g.imag[:, None, :] * Pr[None]).reshape(-1, count) @ Pc.T)).reshape(w2.size, nr, nc)
        if terms:
            Y0 += ((w2[:, None] ** np.arange(terms)[None, :]) @ series).reshape(w2.size, nr, nc)
        V = (g[:, None, :] * Pc[None]).reshape(-1, count)  # rows (f, c): g Phi[c]^T, transposed
        VdA, VdB = np.split((V @ dAB).reshape(w2.size, nc, 2 * count), 2, axis=2)
        W = (VdA - w2[:, None, None] * VdB) * g[:, None, :]  # g (dA - w^2 dB) g Phi[c]^T, transposed
        out[lines] = Y0 - np.swapaxes((W.reshape(-1, count) @ Pr.T).reshape(w2.size, nc, nr), 1, 2)

    map_chunks(chunk, np.arange(frequency.size), max(1, _CHUNK_ELEMENTS // (4 * count * max(nr, nc) + nr * nc)))
    return out


def _refined_on_every_dof(structure: Structure, frequency: Frequency, ri: np.ndarray, ci: np.ndarray, modes: Modes) -> np.ndarray:
    """The refinement with the residual ``E - D Y0`` on every DOF (sparse products in double), shape (F, r, c).

    ``Y = Y0 + Phi g Phi^T (E - D Y0)``: O(N^2 c) per line; used where long double is plain double.
    """
    Phi = modes.shapes
    lam = modes.eigenvalues * (1.0 + 1j * structure.proportional_loss_factor)
    K, M = sp.csr_matrix(structure.K), sp.csr_matrix(structure.M)
    N = Phi.shape[0]
    out = np.empty((frequency.size, ri.size, ci.size), complex)
    chunk = max(1, _CHUNK_ELEMENTS // (N * max(ci.size, 1)))
    w2_all = frequency.omega**2
    for a in range(0, frequency.size, chunk):  # chunks bound memory (F x N x c); vectorized within
        w2 = w2_all[a : a + chunk]
        g = 1.0 / (lam[None, :] - w2[:, None])  # (f, modes)
        Y0 = np.einsum("nk,fk,ck->fnc", Phi, g, Phi[ci], optimize=True)  # (f, N, c): every row
        flat = Y0.transpose(1, 0, 2).reshape(N, -1)
        KY = (K @ flat).reshape(N, w2.size, ci.size).transpose(1, 0, 2)
        MY = (M @ flat).reshape(N, w2.size, ci.size).transpose(1, 0, 2)
        R = w2[:, None, None] * MY - KY
        R[:, ci, np.arange(ci.size)] += 1.0  # E - D Y0
        corr = np.einsum("rk,fk,fkc->frc", Phi[ri], g, np.einsum("nk,fnc->fkc", Phi, R, optimize=True), optimize=True)
        out[a : a + chunk] = Y0[:, ri, :] + corr
    return out


def receptance_coupled(structure: Structure, frequency: Frequency, responses, references) -> np.ndarray:
    """Receptance of a structure with frequency-dependent joints by coupling them to its joint-free part.

    With ``Y`` the receptance of the structure without its joints
    (:func:`receptance_modal_refined`) and ``Kj(f)`` the joints' stiffness on their
    DOFs J (Sherman-Morrison-Woodbury)::

        H[r, c] = Y[r, c] - Y[r, J] (I + Kj Y[J, J])^-1 Kj Y[J, c]

    Exact for any joint model; the cost is that of the modal sum on ``r, J, c``
    plus a |J| x |J| solve per line (no N x N solve per line).
    """
    base = replace(structure, joints=())
    modes = natural_modes(base)
    J = tuple(dict.fromkeys(d for joint in structure.joints for d in joint.dofs if d in set(base.dofs)))
    rows, cols = tuple(responses), tuple(references)
    Y = receptance_modal_refined(base, frequency, rows + J, cols + J, modes)
    nr, nc = len(rows), len(cols)
    Yrc, YrJ, YJc, YJJ = Y[:, :nr, :nc], Y[:, :nr, nc:], Y[:, nr:, :nc], Y[:, nr:, nc:]
    pos = {d: i for i, d in enumerate(J)}
    Kj = np.zeros((frequency.size, len(J), len(J)), complex)
    for joint in structure.joints:
        keep = [a for a, d in enumerate(joint.dofs) if d in pos]
        idx = np.array([pos[joint.dofs[a]] for a in keep])
        Kj[:, idx[:, None], idx[None, :]] += joint(frequency.hz)[:, keep][:, :, keep]
    S = np.linalg.solve(np.eye(len(J))[None] + Kj @ YJJ, Kj @ YJc)
    return Yrc - YrJ @ S


def receptance_direct(structure: Structure, frequency: Frequency, responses, references) -> np.ndarray:
    """Receptance by direct solution of ``D(w) X = E``, shape (F, r, c), complex (m/N, rad/N, ...).

    Parameters
    ----------
    structure : Structure
    frequency : Frequency
    responses, references : sequence of Dof
        Active DOFs of the structure.
    """
    frequency = _as_frequency(frequency)
    ri = structure.index(responses)
    ci = structure.index(references)
    n = len(structure.dofs)
    F = frequency.size
    out = np.empty((F, len(ri), len(ci)), dtype=complex)
    E = np.zeros((n, len(ci)))
    E[ci, np.arange(len(ci))] = 1.0
    # symmetric diagonal scaling (translations vs rotations differ by ~L^2) keeps the
    # solve accurate on fine meshes: D_s = S D S, X = S D_s^-1 S E
    scale = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(structure.K)), 1e-300))
    Es = E * scale[:, None]
    if n <= DENSE_DIRECT_LIMIT:
        chunk = max(1, _CHUNK_BYTES // (16 * n * n))
        S2 = scale[:, None] * scale[None, :]
        for a in range(0, F, chunk):  # chunks bound memory; each chunk is one batched LAPACK call
            D = structure.dynamic_stiffness(frequency.hz[a : a + chunk]) * S2[None]
            X = np.linalg.solve(D, np.broadcast_to(Es, (D.shape[0], n, len(ci))))
            out[a : a + chunk] = X[:, ri, :] * scale[ri][None, :, None]
        return out
    Sd = sp.diags(scale)
    K = sp.csc_matrix(structure.K)
    M = sp.csc_matrix(structure.M)
    joint_terms = structure.joint_terms(frequency.hz)
    w2 = frequency.omega**2
    for i in range(F):  # large sparse models: one sparse LU per line
        D = K - w2[i] * M
        for kj, idx in joint_terms:
            r, c = np.meshgrid(idx, idx, indexing="ij")
            D = D + sp.csc_matrix((kj[i].ravel(), (r.ravel(), c.ravel())), shape=(n, n))
        X = spla.splu(sp.csc_matrix(Sd @ D @ Sd)).solve(Es.astype(complex))
        out[i] = X[ri, :] * scale[ri][:, None]
    return out


def receptance_modal(
    structure: Structure,
    frequency: Frequency,
    responses,
    references,
    modes: Modes | None = None,
    cutoff_factor: float = 4.0,
) -> np.ndarray:
    """Receptance by modal superposition (proportional structural damping), shape (F, r, c).

    Parameters
    ----------
    structure : Structure
        No frequency-dependent joints; ``Im K = eta Re K``.
    frequency : Frequency
    responses, references : sequence of Dof
    modes : Modes, optional
        Precomputed modes of ``structure`` (reused across calls).
    cutoff_factor : float
        Large models: keep modes below ``cutoff_factor * f_max`` plus residual flexibility.
    """
    frequency = _as_frequency(frequency)
    eta = structure.proportional_loss_factor
    if structure.joints or eta is None:
        raise ModelError(
            "modal superposition needs proportional structural damping and no frequency-dependent joints; "
            "use method='direct'"
        )
    fmax = float(frequency.hz[-1])
    if modes is None:
        modes = natural_modes(structure, max_frequency_hz=cutoff_factor * max(fmax, 1.0))
    ri = structure.index(responses)
    ci = structure.index(references)
    lam = modes.eigenvalues * (1.0 + 1j * eta)
    w2 = frequency.omega**2
    pr = modes.shapes[ri, :]
    pc = modes.shapes[ci, :]
    g = 1.0 / (lam[None, :] - w2[:, None])  # (F, modes)
    H = np.einsum("rk,fk,ck->frc", pr, g, pc, optimize=True)
    if not modes.complete:
        # shift to the first elastic eigenvalue: far enough from the rigid-body modes that
        # G - kept does not cancel catastrophically, low enough that the truncated modes'
        # flexibility 1 / (w_r^2 + sigma) is close to their 1 / (w_r^2 - w^2) in the band
        elastic = modes.eigenvalues[modes.eigenvalues > 0]
        sigma = float(elastic[0]) if elastic.size else (2.0 * np.pi * max(fmax, 1.0)) ** 2
        n = len(structure.dofs)
        scale = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(structure.K)), 1e-300))
        Sd = sp.diags(scale)
        E = np.zeros((n, len(ci)), dtype=complex)
        E[ci, np.arange(len(ci))] = scale[ci]
        Ks = sp.csc_matrix(Sd @ sp.csc_matrix(structure.K + sigma * structure.M) @ Sd)
        G = spla.splu(Ks).solve(E)[ri, :] * scale[ri][:, None]
        kept = np.einsum("rk,k,ck->rc", pr, 1.0 / (lam + sigma), pc)
        H = H + (G - kept)[None, :, :]
    return H


def synthesize_frf(
    structure: Structure,
    frequency,
    responses: Iterable,
    references: Iterable,
    kind: str = "receptance",
    method: str = "auto",
    modes: Modes | None = None,
) -> FRF:
    """FRFs of ``structure`` between labelled DOFs over a frequency grid.

    Parameters
    ----------
    structure : Structure
    frequency : Frequency or array_like (Hz), shape (F,)
    responses, references : iterable of Dof or labels (``"3w"``)
        Active DOFs; references are unit forces (N) or moments (N*m).
    kind : {"receptance", "mobility", "accelerance"}
    method : {"auto", "direct", "modal", "coupled"}
        See the module docstring.
    modes : Modes, optional
        Precomputed modes for the modal path.

    Returns
    -------
    FRF
        Data shaped (F, r, c).

    Raises
    ------
    FrequencyError
        At 0 Hz for a structure with rigid-body modes.
    """
    frequency = _as_frequency(frequency)
    responses = parse_dofs(responses)
    references = parse_dofs(references)
    if method not in ("auto", "direct", "modal", "coupled"):
        raise ModelError(f"unknown synthesis method {method!r}; expected 'auto', 'direct', 'modal' or 'coupled'")
    kind_factor(frequency.omega[-1:], "receptance", kind)  # validates the kind
    check_zero_frequency(structure, frequency)
    auto = method == "auto"
    if auto:
        method = choose_method(structure)
        if method == "coupled" and np.any(frequency.hz == 0.0):  # the joint-free part is singular at 0 Hz
            method = "direct"
    if method == "coupled":
        try:
            H = receptance_coupled(structure, frequency, responses, references)
        except np.linalg.LinAlgError:  # M not positive definite (massless DOFs): no modes
            if not auto:
                raise
            H = receptance_direct(structure, frequency, responses, references)
    elif method == "modal":
        H = receptance_modal(structure, frequency, responses, references, modes)
    else:
        H = receptance_direct(structure, frequency, responses, references)
    frf = FRF(frequency, H, responses, references, "receptance")
    return frf.to(kind)


def model_frf(model, frequency, responses: Iterable, references: Iterable, kind: str = "receptance") -> FRF:
    """FRFs of any model with the free-model seam: a :class:`Structure` by :func:`synthesize_frf` (every
    line, 0 Hz included where the structure is grounded), anything else by its ``receptance(frequency,
    rows, cols)`` (a free or Woodbury-coupled model: lines above 0 Hz only, where its free part is regular).

    Parameters
    ----------
    model : Structure, SparseModel, JointedModel or any FreeModel
    frequency : Frequency
    responses, references : iterable of Dof or labels
    kind : {"receptance", "mobility", "accelerance"}

    Returns
    -------
    FRF
        Shape (F, r, c) on the lines computed.
    """
    if isinstance(model, Structure):
        return synthesize_frf(model, frequency, responses, references, kind=kind)
    frequency = _as_frequency(frequency)
    if frequency.hz[0] <= 0:
        frequency = frequency[frequency.hz > 0]
    rows, cols = parse_dofs(responses), parse_dofs(references)
    return FRF(frequency, model.receptance(frequency, rows, cols), rows, cols, "receptance").to(kind)
