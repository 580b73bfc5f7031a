"""Craig-Bampton reduction of a sparse model: physical boundary DOFs plus modal scalar points.

The DOFs are split into boundary ``b`` (kept: joint, measured and excited DOFs)
and interior ``i``. The interior motion is the static response to the boundary
(constraint modes) plus a few fixed-interface normal modes::

    u_i = Psi u_b + Phi q,    Psi = -K_ii^-1 K_ib,    (K_ii - w_r^2 M_ii) phi_r = 0

so with ``T = [[I, 0], [Psi, Phi]]`` the reduced matrices are ``T^T M T`` and
``T^T K T`` on ``(u_b, q)``. ``Phi`` is mass-normalized, so ``K_qq = diag(w_r^2)``
and ``M_qq = I``. The modal coordinates ``q`` are scalar points (component
``"s"``, unit 1) numbered ``first_mode_id, first_mode_id + 1, ...`` -- the
form a Nastran superelement (physical boundary grids + SPOINTs) comes in.

Caveats: the reduced receptance at boundary DOFs converges to the full model's
below the highest kept fixed-interface frequency (a usual rule: keep modes up
to 1.5-2x the top of the band); ``K_ii`` must be nonsingular (the boundary
must hold the structure's rigid-body motion, or the interior must be
supported). Structural damping ``K (1 + j eta)`` reduces exactly with the same
``eta``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..dofs import COMPONENT_CODES, DofArray
from ..errors import ModelError

__all__ = ["CraigBamptonModel", "craig_bampton"]

#: ``K_ii`` counts as singular when its smallest LU pivot is below this fraction of the largest.
SINGULAR_PIVOT = 1e-12


@dataclass(frozen=True, eq=False)
class CraigBamptonModel:
    """A Craig-Bampton reduced model.

    Attributes
    ----------
    mass, stiffness : ndarray, shape (b + r, b + r)
        Reduced mass and stiffness on the boundary DOFs then the modal coordinates.
    dofs : DofArray
        The boundary DOFs (as given) then ``r`` scalar points ``first_mode_id + k`` (component ``s``).
    fixed_interface_hz : ndarray, shape (r,)
        Frequencies of the kept fixed-interface modes, Hz.
    loss_factor : float
        Structural loss factor of the full model (unchanged by the reduction).
    """

    mass: np.ndarray
    stiffness: np.ndarray
    dofs: DofArray
    fixed_interface_hz: np.ndarray
    loss_factor: float = 0.0

    def free_model(self, **options):
        """The reduced model as a :class:`~jointid.physics.sparse_model.SparseModel` (``method="direct"`` by default)."""
        from .sparse_model import SparseModel

        options.setdefault("method", "direct")
        return SparseModel(sp.csc_array(self.mass), sp.csc_array(self.stiffness), self.dofs, self.loss_factor, **options)


def craig_bampton(
    mass,
    stiffness,
    dofs,
    boundary,
    n_modes: int | None = None,
    cutoff_hz: float | None = None,
    first_mode_id: int = 1995001,
    loss_factor: float = 0.0,
) -> CraigBamptonModel:
    """Reduce ``(M, K)`` to the ``boundary`` DOFs plus fixed-interface modes (Craig & Bampton 1968).

    Parameters
    ----------
    mass, stiffness : scipy.sparse matrix or ndarray, shape (N, N)
        Real symmetric mass (kg, kg*m^2) and stiffness (N/m, N*m/rad) of the full model.
    dofs : DofArray or sequence of labels, length N
    boundary : sequence of DOF labels
        DOFs kept as physical coordinates, in the order wanted (joint, observed, excited DOFs).
    n_modes : int, optional
        Number of fixed-interface modes kept.
    cutoff_hz : float, optional
        Keep every fixed-interface mode below this frequency instead (Hz).
    first_mode_id : int
        Scalar-point number of the first modal coordinate.
    loss_factor : float
        Structural loss factor carried to the reduced model.

    Returns
    -------
    CraigBamptonModel

    Raises
    ------
    ModelError
        Neither or both of ``n_modes``/``cutoff_hz``, a boundary DOF not in the model,
        scalar-point numbers that collide with the boundary's nodes, a singular ``K_ii``.
    """
    if (n_modes is None) == (cutoff_hz is None):
        raise ModelError("craig_bampton: give exactly one of n_modes (a count) or cutoff_hz (keep modes below it)")
    dof_array = dofs if isinstance(dofs, DofArray) else DofArray.from_dofs(dofs)
    N = len(dof_array)
    M = sp.csc_array(mass, dtype=float)
    K = sp.csc_array(stiffness, dtype=float)
    if M.shape != (N, N) or K.shape != (N, N):
        raise ModelError(f"craig_bampton: mass {M.shape} and stiffness {K.shape} must both be {N} x {N} (one row per DOF)")
    b = dof_array.indices(boundary, "model")
    if np.unique(b).size != b.size:
        raise ModelError("craig_bampton: the boundary lists a DOF twice")
    interior = np.setdiff1d(np.arange(N), b)
    Kii, Kib = K[interior][:, interior], K[interior][:, b]
    Mii, Mib = M[interior][:, interior], M[interior][:, b]
    try:
        lu = spla.splu(sp.csc_array(Kii))
    except RuntimeError:
        raise ModelError("craig_bampton: K_ii is singular; the boundary must restrain every rigid-body motion of the interior") from None
    pivots = np.abs(lu.U.diagonal())
    Psi = -lu.solve(Kib.toarray())
    if not np.all(np.isfinite(Psi)) or pivots.min() <= SINGULAR_PIVOT * pivots.max():
        raise ModelError("craig_bampton: K_ii is singular; the boundary must restrain every rigid-body motion of the interior")
    n_int = interior.size
    if cutoff_hz is not None:
        n_try = min(max(8, int(n_modes or 0)), n_int - 2)
        while True:
            lam, Phi = _fixed_modes(Kii, Mii, n_try)
            if np.sqrt(lam[-1]) / (2 * np.pi) > cutoff_hz or n_try >= n_int - 2:
                break
            n_try = min(2 * n_try, n_int - 2)
        keep = np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi) < cutoff_hz
        lam, Phi = lam[keep], Phi[:, keep]
    else:
        if not (isinstance(n_modes, (int, np.integer)) and 0 <= n_modes <= n_int - 2):
            raise ModelError(f"craig_bampton: n_modes must be an integer in 0..{n_int - 2}, got {n_modes!r}")
        lam, Phi = _fixed_modes(Kii, Mii, int(n_modes)) if n_modes else (np.zeros(0), np.zeros((n_int, 0)))
    r = lam.size
    # T = [[I, 0], [Psi, Phi]]: reduced blocks without forming T
    Kbb = K[b][:, b].toarray() + Kib.T @ Psi  # K_bb + K_bi Psi (K_ii Psi = -K_ib)
    MPsi = Mii @ Psi
    Mbb = M[b][:, b].toarray() + Mib.T @ Psi + Psi.T @ Mib + Psi.T @ MPsi
    Mbq = (Mib.T @ Phi) + Psi.T @ (Mii @ Phi)
    nb = b.size
    Kr = np.zeros((nb + r, nb + r))
    Mr = np.zeros((nb + r, nb + r))
    Kr[:nb, :nb] = 0.5 * (Kbb + Kbb.T)
    Kr[nb:, nb:] = np.diag(lam)
    Mr[:nb, :nb] = 0.5 * (Mbb + Mbb.T)
    Mr[:nb, nb:] = Mbq
    Mr[nb:, :nb] = Mbq.T
    Mr[nb:, nb:] = np.eye(r)
    ids = first_mode_id + np.arange(r)
    if np.intersect1d(ids, dof_array.node[b]).size:
        raise ModelError(f"craig_bampton: scalar-point numbers {first_mode_id}..{first_mode_id + r - 1} collide with boundary nodes; choose another first_mode_id")
    out = DofArray(np.concatenate([dof_array.node[b], ids]), np.concatenate([dof_array.code[b], np.full(r, COMPONENT_CODES["s"])]))
    return CraigBamptonModel(Mr, Kr, out, np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi), float(loss_factor))


def _fixed_modes(Kii, Mii, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest ``k`` mass-normalized modes of ``(K_ii, M_ii)`` (shift-invert at 0).

    The Lanczos start vector is fixed (all ones): ARPACK's default is random, which made the basis, and so the
    reduced model, differ from one process to the next at round-off level.
    """
    v0 = np.ones(Kii.shape[0])
    lam, Phi = spla.eigsh(sp.csc_array(Kii), k=k, M=sp.csc_array(Mii), sigma=0.0, which="LM", v0=v0)
    order = np.argsort(lam)
    lam, Phi = lam[order], Phi[:, order]
    Phi = Phi / np.sqrt(np.einsum("ir,ir->r", Phi, Mii @ Phi))
    return lam, Phi
