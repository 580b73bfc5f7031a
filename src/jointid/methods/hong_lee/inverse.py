"""Inverse identification of a joint's dynamic stiffness (Hong & Lee, 1991).

The constrained structure (free beam + joint to ground) obeys

    (Do + Du) H* = I

with ``Do`` the FE dynamic stiffness of the free beam, ``Du`` the joint's
(non-zero only on the joint coordinates n) and ``H*`` the constrained
receptance. Taking the columns of the excited coordinates e:

Estimation (rows nbar, not touching the joint; generalized left inverse)::

    Do[nbar, mbar] H*[mbar, e] = I[nbar, e] - Do[nbar, m] H*[m, e]

gives the unobserved FRFs ``H*[mbar, e]`` (rotations included) from the
observed ones ``H*[m, e]``. Needs ``|m| >= |n|`` and ``Do[nbar, mbar]`` of full
column rank (the observed points must tell the joint forces apart).

Identification (rows n; generalized right inverse)::

    Du H*[n, e] = I[n, e] - Do[n, :] H*[:, e]

Needs ``|e| >= |n|`` and ``H*[n, e]`` of rank ``|n|``.

Numerics
--------
Neither step uses the normal equations. The estimation step is a Householder
QR least-squares solve per line (LAPACK's ``gels`` algorithm; lines whose
``cond_A`` may exceed 1e6 get the SVD pseudo-inverse instead), the
identification step a small SVD per line; see
:mod:`jointid.methods.hong_lee.estimation`. Everything is batched over frequency in
chunks of lines run on the available cores. Rotational
coordinates are scaled by a length ``l`` (default: the mean element length):
moment rows are divided by ``l`` and rotation unknowns multiplied by it, so
every equation and unknown has force/translation units. This weights the least
squares sensibly and makes the condition numbers ``sigma_max / sigma_min``
meaningful:

* ``cond_A`` of ``Do[nbar, mbar]`` spikes where a combination of joint forces
  gives no response at the observed points (too few or badly placed points).
  ``Do[nbar, mbar] = K - w^2 M`` is linear in ``w^2``, so exact SVDs at a
  subset of lines bracket it everywhere (Weyl's inequality); it is reported
  within a certified relative accuracy (default 1%, ``cond_rtol``; bound per
  line in ``cond_A_bound``), see :mod:`jointid.methods.hong_lee.condition`;
* ``cond_B`` of ``H*[n, e]`` peaks at the constrained structure's resonances
  (one mode dominates; the columns become parallel);
* ``cond_H`` of the measured ``H*[m, e]``.

``identifiability[:, i] = |Du_ii| / |1 / Ho_ii|`` compares the joint's stiffness
with the free beam's driving-point dynamic stiffness at ``n_i`` (``Ho = Do^-1``);
far from 1 in either direction means the term is poorly identifiable with noisy
data (the rotational term of a soft joint is typically ~1e-3).

Options (all off by default, so the plain method stays available):
accelerometer masses on ``Do`` (build the free structure with
:meth:`~jointid.physics.structure.Structure.with_masses`, or pass
``accelerometers``), symmetric identification (``Du = Du^T`` enforced by least
squares on the independent entries), Tikhonov regularization of the
identification step with ``lambda`` chosen per line by GCV or by the corner of
the L-curve (biased: it shrinks ``Du`` where ``H*[n, e]`` is ill-conditioned).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar, Sequence

import numpy as np

from ...dofs import Dof, parse_dofs
from ...errors import IdentificationError
from ...frequency import Frequency
from ...frf import FRF
from ...physics.modes import DENSE_EIGEN_LIMIT, natural_modes
from ...parallel import map_chunks
from ...physics.structure import Structure
from ..estimate import JointEstimate
from .condition import pencil_condition
from .estimation import EstimationLayout, estimate_qr, estimate_svd

__all__ = [
    "Reliability",
    "InverseOptions",
    "InverseResult",
    "identify_joint",
    "rotation_scale",
    "check_layout",
]

_CHUNK_LINES = 250
#: Above this condition number of ``Do[nbar, mbar]`` the QR estimation hands the line to the SVD solver.
_QR_MAX_COND = 1e6


@dataclass(frozen=True)
class Reliability:
    """Thresholds of the per-line ``reliable`` flag.

    A line is reliable when ``cond_A <= max_cond_A``, ``cond_B <= max_cond_B``
    and the translational identifiability ratio (rotational if no translation is
    identified) lies in ``[min_ratio, max_ratio]``.

    Calibration (benchmark beam, joint at mid-span, Materials A and B, layouts
    Models 1-3, 1% complex noise on every FRF value, 1-1000 Hz): lines flagged
    reliable had a median translational-stiffness error of 1.5-7%, the others
    14-30%. The identifiability ratio is what separates them; the condition-number
    limits only catch the worst spikes (a layout whose cond_A exceeds 1e5, or a
    resonance where cond_B exceeds 100).
    """

    max_cond_A: float = 1e5
    max_cond_B: float = 1e2
    min_ratio: float = 0.1
    max_ratio: float = 10.0


@dataclass(frozen=True)
class InverseOptions:
    """Options of :func:`identify_joint` (all off by default: the plain method).

    Parameters
    ----------
    symmetric : bool
        Enforce ``Du = Du^T``.
    regularization : {"none", "gcv", "lcurve"}
        Tikhonov regularization of the identification step, lambda per line by
        generalized cross-validation or by the L-curve corner.
    rotation_scale_m : float, optional
        Length l used to scale rotations (default: :func:`rotation_scale`, the mean element length of a beam).
    reliability : Reliability
        Thresholds of the ``reliable`` flag.
    estimation : {"qr", "svd"}
        Solver of the estimation step (:mod:`jointid.methods.hong_lee.estimation`); both
        return the least-squares solution ``Do[nbar, mbar]^+ b``. ``"qr"``
        (default): Householder QR per line (LAPACK's least-squares algorithm);
        lines whose ``cond_A`` may exceed 1e6 go to the SVD solver, which is
        minimum-norm on rank-deficient lines. ``"svd"``: one SVD per line
        everywhere (3-4x slower on 2 cores, ``benchmarks/identify.py``).
    cond_rtol : float
        With ``estimation="qr"``: certified relative accuracy of ``cond_A``
        (:func:`~jointid.methods.hong_lee.condition.pencil_condition`); 0 computes it by
        an SVD on every line. The SVD solver always gives it exactly.
    """

    symmetric: bool = False
    regularization: str = "none"
    rotation_scale_m: float | None = None
    reliability: Reliability = field(default_factory=Reliability)
    estimation: str = "qr"
    cond_rtol: float = 1e-2

    def __post_init__(self) -> None:
        if self.regularization not in ("none", "gcv", "lcurve"):
            raise IdentificationError(
                f"regularization must be 'none', 'gcv' or 'lcurve', got {self.regularization!r}"
            )
        if self.estimation not in ("qr", "svd"):
            raise IdentificationError(f"estimation must be 'qr' or 'svd', got {self.estimation!r}")
        if not (isinstance(self.cond_rtol, (int, float)) and np.isfinite(self.cond_rtol) and 0 <= self.cond_rtol < 1):
            raise IdentificationError(f"cond_rtol must be a number in [0, 1), got {self.cond_rtol!r}")


@dataclass(frozen=True, eq=False)
class InverseResult(JointEstimate):
    """The Hong & Lee method's :class:`~jointid.methods.estimate.JointEstimate`: K per line, estimated FRFs, condition numbers.

    The method gives no per-term uncertainty (``std_real``/``std_imag`` are NaN); its
    reliability flag is per line (condition numbers and identifiability, :class:`Reliability`)
    and applies to every term of that line.

    Attributes
    ----------
    frequency : Frequency
        F lines, Hz.
    joint_dofs : tuple of Dof
        Joint coordinates n.
    stiffness : ndarray, shape (F, |n|, |n|), complex
        Identified ``Du``: N/m (w,w), N/rad (w,theta), N*m/m (theta,w), N*m/rad (theta,theta).
    estimated : FRF
        Receptance ``H*[:, e]`` of the constrained structure on every free-beam DOF
        (measured rows as measured, the rest estimated).
    cond_A, cond_B, cond_H : ndarray, shape (F,)
        Condition numbers (scaled coordinates) of ``Do[nbar, mbar]``, ``H*[n, e]``, ``H*[m, e]``.
    identifiability : ndarray, shape (F, |n|)
        ``|Du_ii| |Ho_ii|``.
    reliable_lines : ndarray of bool, shape (F,)
        The per-line flag (:class:`Reliability`); ``reliable_terms`` broadcasts it to every term.
    regularization_lambda : ndarray, shape (F,)
        Tikhonov lambda per line (scaled units; 0 without regularization).
    options : InverseOptions
    cond_A_bound : ndarray, shape (F,)
        Certified relative error bound of ``cond_A`` (0 where it came from an SVD of that line).
    """

    estimated: FRF
    cond_A: np.ndarray
    cond_B: np.ndarray
    cond_H: np.ndarray
    identifiability: np.ndarray
    reliable_lines: np.ndarray
    regularization_lambda: np.ndarray
    options: InverseOptions
    cond_A_bound: np.ndarray

    method: ClassVar[str] = "hong-lee"

    @property
    def std_real(self) -> np.ndarray:
        """NaN, shape (F, n, n): the method gives no per-term uncertainty."""
        return np.full(self.stiffness.shape, np.nan)

    std_imag = std_real

    @property
    def reliable_terms(self) -> np.ndarray:
        """The per-line flag on every term, shape (F, n, n)."""
        n = len(self.joint_dofs)
        return np.broadcast_to(self.reliable_lines[:, None, None], (self.reliable_lines.size, n, n))

    def describe_estimator(self) -> str:
        """One line: the paper's two steps per line and what the flag means."""
        return ("Hong & Lee per line (estimation step, then identification step); no per-term uncertainty: a line is "
                "flagged by its condition numbers and the joint's identifiability")

    def findings(self) -> list[str]:
        """The method's one caveat: its flag is per line, not a predicted error per term."""
        return [
            "the Hong & Lee method gives no per-term uncertainty: its flag is per line (cond_A, cond_B, identifiability) "
            "and does not say how far a term may be off; use method = \"receptance\" for per-term bands"
        ]

    def options_summary(self) -> dict:
        """JSON-ready: symmetric, regularization, estimation, cond_rtol."""
        o = self.options
        return {"symmetric": o.symmetric, "regularization": o.regularization, "estimation": o.estimation, "cond_rtol": o.cond_rtol}

    def diagnostics(self) -> dict:
        """JSON-ready: the largest condition numbers (and cond_A's certified error bound) and the flag's thresholds."""
        return {
            "max_cond_A": float(np.max(self.cond_A)),
            "max_cond_A_relative_error_bound": float(np.max(self.cond_A_bound)),
            "max_cond_B": float(np.max(self.cond_B)),
            "max_cond_H": float(np.max(self.cond_H)),
            "reliability_thresholds": vars(self.options.reliability),
        }

    def subset(self, indices) -> "InverseResult":
        """The result on a subset of the joint DOFs (one of several joints identified together).

        ``stiffness`` and ``identifiability`` are cut to the ``indices``; the per-line
        diagnostics (condition numbers, ``reliable_lines``) and the estimated FRFs are those
        of the joint estimate.
        """
        idx = np.asarray(list(indices), dtype=int)
        return replace(
            self, joint_dofs=tuple(self.joint_dofs[i] for i in idx),
            stiffness=self.stiffness[:, idx[:, None], idx[None, :]], identifiability=self.identifiability[:, idx],
        )

    def extra_columns(self) -> dict[str, np.ndarray]:
        """``cond_A``, ``cond_B``, ``cond_H`` per line."""
        return {"cond_A": self.cond_A, "cond_B": self.cond_B, "cond_H": self.cond_H}

    def plot(self, truth: np.ndarray | None = None, axes=None):
        """Magnitude (log), loss factor and condition numbers vs frequency; returns a Figure.

        With ``axes`` (2, n_terms): the joint-stiffness figure of every estimate instead.
        """
        if axes is not None:
            return JointEstimate.plot(self, truth=truth, axes=axes)
        from ...plots.inverse import plot_identification

        return plot_identification(self, truth=truth)


def check_layout(n_joint: int, observed: Sequence, excited: Sequence) -> None:
    """Raise :class:`IdentificationError` unless ``|m| >= |n|`` and ``|e| >= |n|``."""
    if len(observed) < n_joint:
        raise IdentificationError(
            f"{len(observed)} observed coordinate(s) for {n_joint} joint DOFs: the estimation step needs "
            f"at least as many observed coordinates as joint DOFs (|m| >= |n|); observe more points"
        )
    if len(excited) < n_joint:
        raise IdentificationError(
            f"{len(excited)} excited coordinate(s) for {n_joint} joint DOFs: the identification step needs "
            f"at least as many excited coordinates as joint DOFs (|e| >= |n|); excite more points"
        )


def _cond(A: np.ndarray) -> np.ndarray:
    s = np.linalg.svd(A, compute_uv=False)
    with np.errstate(divide="ignore"):
        return s[:, 0] / s[:, -1]


def _tikhonov_lambda(s: np.ndarray, beta: np.ndarray, out_norm2: np.ndarray, m_eq: int, method: str) -> np.ndarray:
    """Lambda per line for ``min ||A x - c||^2 + lambda^2 ||x||^2`` from the SVD of A.

    Parameters
    ----------
    s : (F, k) singular values of A; beta : (F, k) |U^H c|^2 summed over right-hand sides;
    out_norm2 : (F,) squared norm of c outside range(A); m_eq : number of equations.
    """
    grid = s[:, :1] * np.logspace(-4, 0, 41)[None, :]  # (F, G)
    lam2 = grid[:, :, None] ** 2
    s2 = s[:, None, :] ** 2
    f = s2 / (s2 + lam2)  # filter factors (F, G, k)
    res = np.sum(((1 - f) ** 2) * beta[:, None, :], axis=-1) + out_norm2[:, None]
    if method == "gcv":
        dof = m_eq - np.sum(f, axis=-1)
        score = res / np.maximum(dof, 1e-12) ** 2
        return grid[np.arange(s.shape[0]), np.argmin(score, axis=1)]
    # L-curve: corner of maximum curvature of (log ||r||, log ||x||)
    xn = np.sum((f**2) * beta[:, None, :] / s2, axis=-1)
    x = 0.5 * np.log(np.maximum(res, 1e-300))
    y = 0.5 * np.log(np.maximum(xn, 1e-300))
    t = np.log(grid)
    dx, dy = np.gradient(x, axis=1) / np.gradient(t, axis=1), np.gradient(y, axis=1) / np.gradient(t, axis=1)
    ddx, ddy = np.gradient(dx, axis=1) / np.gradient(t, axis=1), np.gradient(dy, axis=1) / np.gradient(t, axis=1)
    kappa = (dx * ddy - ddx * dy) / np.maximum((dx**2 + dy**2) ** 1.5, 1e-300)
    kappa[:, [0, -1]] = -np.inf
    return grid[np.arange(s.shape[0]), np.argmax(kappa, axis=1)]


def identify_joint(
    free: Structure,
    measured: FRF,
    joint_dofs: Sequence,
    options: InverseOptions | None = None,
) -> InverseResult:
    """Identify the joint's dynamic stiffness from constrained-structure FRFs (Hong & Lee).

    Parameters
    ----------
    free : Structure
        FE model of the free (unconstrained) beam, ``Do``; include accelerometer
        masses here (``free.with_masses(nodes, m, J)``) if the test had them.
    measured : FRF
        Measured FRFs of the constrained structure, any kind (converted exactly
        to receptance), responses m (observed, translations) x references e
        (excited, forces). Frequencies > 0 Hz.
    joint_dofs : sequence of Dof or labels
        Joint coordinates n, e.g. ``["10w", "10theta"]``.
    options : InverseOptions, optional

    Returns
    -------
    InverseResult

    Raises
    ------
    IdentificationError
        If ``|m| < |n|`` or ``|e| < |n|``, a DOF is not in the free model, a dead acquisition or
        channel, or joint DOFs the FRFs cannot see (:mod:`jointid.methods.frf_screening`).
    """
    options = options or InverseOptions()
    n_dofs = parse_dofs(joint_dofs)
    m_dofs, e_dofs = measured.responses, measured.references
    check_layout(len(n_dofs), m_dofs, e_dofs)
    dofs = free.dofs
    pos = {d: i for i, d in enumerate(dofs)}
    for what, group in (("joint", n_dofs), ("observed", m_dofs), ("excited", e_dofs)):
        missing = [str(d) for d in group if d not in pos]
        if missing:
            raise IdentificationError(f"{what} DOF(s) {missing} are not DOFs of the free model (nodes {free.nodes[0]}..{free.nodes[-1]})")
    if free.joints:
        raise IdentificationError("the free model must not contain frequency-dependent joints: Do is the free beam alone")
    freq = measured.frequency
    if freq.hz[0] <= 0.0:
        raise IdentificationError(
            "identify_joint needs frequencies > 0 Hz (a free-free beam's dynamic stiffness is singular at 0 Hz); "
            "drop the 0 Hz line"
        )
    H_meas = measured.to("receptance").data
    _screen(free, measured, H_meas, n_dofs)

    N = len(dofs)
    n_idx = np.array([pos[d] for d in n_dofs])
    m_idx = np.array([pos[d] for d in m_dofs])
    e_idx = np.array([pos[d] for d in e_dofs])
    ell = rotation_scale(free) if options.rotation_scale_m is None else float(options.rotation_scale_m)
    # scaled coordinates: rotation unknowns theta' = ell * theta, moment rows / ell
    sc = np.array([1.0 / ell if d.unit == "rad" else 1.0 for d in dofs])  # D_s = S D S with S = diag(sc)
    loads = np.zeros((N, len(e_dofs)))
    loads[e_idx, np.arange(len(e_dofs))] = sc[e_idx]
    layout = EstimationLayout(
        n=n_idx,
        m=m_idx,
        e=e_idx,
        nbar=np.array([i for i in range(N) if i not in set(n_idx)], dtype=int),
        mbar=np.array([i for i in range(N) if i not in set(m_idx)], dtype=int),
        loads=loads,
        stiffness=free.K * np.outer(sc, sc),
        mass=free.M * np.outer(sc, sc),
    )
    ho_nn = _driving_point_receptance(free, n_idx)

    F = freq.size
    w2 = freq.omega**2
    Du = np.empty((F, len(n_dofs), len(n_dofs)), complex)
    H_all = np.empty((F, N, len(e_dofs)), complex)
    condA = np.empty(F)
    condA_bound = np.zeros(F)
    condB = np.empty(F)
    lam_out = np.zeros(F)
    ratio = np.empty((F, len(n_dofs)))
    condH = np.empty(F)
    n_scale = sc[n_idx][:, None] * sc[n_idx][None, :]

    def solve(lines: np.ndarray, method: str) -> None:
        """Both steps on the given lines (chunk); writes the outputs at those lines."""
        Ys_m = H_meas[lines] / sc[m_idx][None, :, None]
        condH[lines] = _cond(H_meas[lines])
        if method == "qr":
            Ys, Cs = estimate_qr(layout, w2[lines], Ys_m)
        else:
            Ys, Cs, condA[lines] = estimate_svd(layout, w2[lines], Ys_m)
        H_all[lines] = Ys * sc[None, :, None]
        # identification: Dus Bs = Cs (scaled), Du = S^-1 Dus S^-1
        Dus, condB[lines], lam_out[lines] = _identify(Ys[:, n_idx], Cs, options)
        Du[lines] = Dus / n_scale[None]
        # identifiability: |Du_ii| |Ho_ii|
        ratio[lines] = np.abs(np.diagonal(Du[lines], axis1=1, axis2=2)) * np.abs(ho_nn(freq.hz[lines]))

    everything = np.arange(F)
    if options.estimation == "svd":
        map_chunks(solve, everything, _CHUNK_LINES, method="svd")
    else:
        cond = pencil_condition(
            *layout.estimation_blocks(),
            w2,
            options.cond_rtol,
            levels=(options.reliability.max_cond_A, _QR_MAX_COND),  # decisions taken on exact values
        )
        condA[:], condA_bound[:] = cond.values, cond.bound
        # (nearly) rank-deficient lines need the pseudo-inverse: the SVD solver, which also gives cond_A exactly
        hard = ~(cond.values <= _QR_MAX_COND)
        map_chunks(solve, everything[~hard], _CHUNK_LINES, method="qr")
        if hard.any():
            map_chunks(solve, everything[hard], _CHUNK_LINES, method="svd")
            condA_bound[hard] = 0.0

    rel = options.reliability
    k = next((i for i, d in enumerate(n_dofs) if d.direction == "w"), 0)
    reliable = (
        (condA <= rel.max_cond_A)
        & (condB <= rel.max_cond_B)
        & (ratio[:, k] >= rel.min_ratio)
        & (ratio[:, k] <= rel.max_ratio)
    )
    estimated = FRF(freq, H_all, dofs, e_dofs, "receptance")
    return InverseResult(freq, n_dofs, Du, estimated, condA, condB, condH, ratio, reliable, lam_out, options, condA_bound)


def _screen(free, measured: FRF, H: np.ndarray, n_dofs) -> None:
    """Refuse dead data and joint DOFs the FRFs cannot see before solving (:mod:`jointid.methods.frf_screening`).

    Hong & Lee uses every measured FRF, so a dead channel is an error here (the receptance
    method leaves it out with a finding).
    """
    from ...physics.free_model import as_free_model
    from ..frf_screening import check_visibility, screen_measured

    m, e = tuple(measured.responses), tuple(measured.references)
    Y = as_free_model(free).receptance(measured.frequency, m + tuple(n_dofs), tuple(n_dofs) + e)
    nm, nn = len(m), len(n_dofs)
    screen = screen_measured(H, getattr(measured, "coherence", None), Y[:, :nm, nn:], m, e)
    if screen.findings:
        raise IdentificationError(
            screen.findings[0].replace(": left out", "") + "; the Hong & Lee method uses every FRF: remove that DOF from "
            "[measurement] or use method = \"receptance\" (which leaves dead channels out)"
        )
    check_visibility(Y[:, :nm, :nn], Y[:, nm:, :nn], Y[:, nm:, nn:], n_dofs)


def rotation_scale(free: Structure) -> float:
    """Default length ``l`` (m) that scales rotations: the mean element length, or a stiffness length.

    A beam (node coordinates spread along x): the mean spacing of its nodes. A
    model without meaningful coordinates (all nodes at one x, e.g. a 3-D model
    read from matrix files): ``l = sqrt(median K_rr / median K_tt)`` over the
    diagonal of ``Re K`` on rotational (r) and translational (t) DOFs, the length
    that gives a moment row and a force row the same size (for a beam of element
    length ``h`` it is about ``h / sqrt(3)``; on a 3-D model the translational median includes the stiffer axial terms). 1 m when the
    model has no rotations or no translations.
    """
    xs = np.array([free.coordinates[k] for k in free.nodes], dtype=float)
    spacing = float(np.mean(np.diff(xs))) if xs.size > 1 else 0.0
    if spacing > 0:
        return spacing
    k = np.abs(np.diagonal(free.K).real)
    rot = np.array([d.unit == "rad" for d in free.dofs])
    tra = np.array([d.unit == "m" for d in free.dofs])
    if rot.any() and tra.any():
        kr, kt = np.median(k[rot]), np.median(k[tra])
        if kr > 0 and kt > 0:
            return float(np.sqrt(kr / kt))
    return 1.0


def _driving_point_receptance(free: Structure, n_idx: np.ndarray):
    """``f_hz -> diag(Do^-1)[n]`` (F, |n|): modal sum over every mode, or a batched solve.

    Only the identifiability ratio uses it, so the modal sum's accuracy (the
    eigensolver's, 1e-8 to 1e-7 relative on the benchmark beam) is ample. A
    mass matrix that is not positive definite (massless DOFs) takes the solve.
    """
    eta = free.proportional_loss_factor
    modes = None
    if eta is not None and len(free.dofs) <= DENSE_EIGEN_LIMIT:
        try:
            modes = natural_modes(free)
        except np.linalg.LinAlgError:
            modes = None
    if modes is not None:
        lam = modes.eigenvalues * (1.0 + 1j * eta)
        phi2 = modes.shapes[n_idx] ** 2  # (|n|, N)

        def modal(f_hz):
            return (1.0 / (lam[None, :] - (2.0 * np.pi * f_hz[:, None]) ** 2)) @ phi2.T

        return modal

    def solved(f_hz):
        E = np.zeros((len(free.dofs), n_idx.size))
        E[n_idx, np.arange(n_idx.size)] = 1.0
        Ho = np.linalg.solve(free.dynamic_stiffness(f_hz), np.broadcast_to(E, (f_hz.size,) + E.shape))
        return Ho[:, n_idx, np.arange(n_idx.size)]

    return solved


def _identify(B: np.ndarray, C: np.ndarray, options: InverseOptions):
    """Solve ``Du B = C`` per line (right inverse); returns (Du, cond_B, lambda)."""
    F, n, e = B.shape
    # Du B = C  <=>  B^T Du^T = C^T : a least-squares problem with n unknowns per row of Du
    At = np.swapaxes(B, -1, -2)  # (F, e, n)
    Ct = np.swapaxes(C, -1, -2)  # (F, e, n): columns are right-hand sides
    U, s, Vh = np.linalg.svd(At, full_matrices=False)  # U (F,e,k), s (F,k), Vh (F,k,n)
    with np.errstate(divide="ignore"):
        cond = s[:, 0] / s[:, -1]
    Uh = np.conj(np.swapaxes(U, -1, -2))
    proj = Uh @ Ct  # (F, k, n)
    lam = np.zeros(F)
    if options.regularization != "none":
        beta = np.sum(np.abs(proj) ** 2, axis=-1)  # (F, k)
        out2 = np.sum(np.abs(Ct) ** 2, axis=(-2, -1)) - np.sum(beta, axis=-1)
        lam = _tikhonov_lambda(s, beta, np.maximum(out2, 0.0), e, options.regularization)
    if options.symmetric and n > 1:
        return _symmetric(B, C, lam), cond, lam  # lambda chosen on B's singular values, as for the plain solve
    filt = s / (s**2 + lam[:, None] ** 2)
    DuT = np.conj(np.swapaxes(Vh, -1, -2)) @ (filt[..., None] * proj)
    return np.swapaxes(DuT, -1, -2), cond, lam


def _symmetric(B: np.ndarray, C: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Least-squares ``Du = Du^T`` with ``Du B = C``: unknowns are the upper triangle of Du."""
    F, n, e = B.shape
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    # vec(Du B)[i, c] = sum_k Du[i, k] B[k, c]; Du[i, k] = x[p(i, k)]
    G = np.zeros((F, n * e, len(pairs)), complex)
    for p, (i, j) in enumerate(pairs):
        G[:, i * e : (i + 1) * e, p] += B[:, j, :]
        if i != j:
            G[:, j * e : (j + 1) * e, p] += B[:, i, :]
    rhs = C.reshape(F, n * e, 1)
    U, s, Vh = np.linalg.svd(G, full_matrices=False)
    filt = s / (s**2 + lam[:, None] ** 2)
    x = (np.conj(np.swapaxes(Vh, -1, -2)) @ (filt[..., None] * (np.conj(np.swapaxes(U, -1, -2)) @ rhs)))[..., 0]
    Du = np.empty((F, n, n), complex)
    for p, (i, j) in enumerate(pairs):
        Du[:, i, j] = x[:, p]
        Du[:, j, i] = x[:, p]
    return Du
