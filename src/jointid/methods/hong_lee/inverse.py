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
Neither step uses the normal equations. The estimation step (default
``weighting="relative"``) is the generalized least squares of the measured FRFs' noise:
the rows ``nbar`` hold exactly, so every admissible ``H*[:, e]`` is ``H0 + Z g`` with ``Z`` the
null space of ``Do[nbar, :]`` (a complete Householder QR per line; the SVD where that matrix is
rank deficient), and ``g`` is fitted to the measured values weighted by ``1 / |H*[m, e]|`` (relative
noise) by a small SVD per line and column; see :func:`~jointid.methods.hong_lee.estimation.estimate_weighted`.
On data consistent with ``Do`` it is the paper's estimate; on noisy data it does not weight the
rows by their units, so the rotation scale ``l`` does not change ``Du``. ``weighting="none"``
solves the paper's ``Do[nbar, mbar] x = b`` unweighted instead (Householder QR per line, LAPACK's
``gels`` algorithm; lines whose ``cond_A`` may exceed 1e6 by the SVD pseudo-inverse). The
identification step is a small SVD per line (:mod:`jointid.methods.hong_lee.identification`).
Everything is batched over frequency in chunks of lines run on the available cores.

Rotational coordinates are scaled by a length ``l`` (default: the mean element length):
moment rows are divided by ``l`` and rotation unknowns multiplied by it, so
every equation and unknown has force/translation units; this makes the condition numbers
``sigma_max / sigma_min`` meaningful:

* ``cond_A`` of ``Do[nbar, mbar]`` spikes where a combination of joint forces
  gives no response at the observed points (too few or badly placed points).
  ``Do[nbar, mbar] = K - w^2 M`` is linear in ``w^2``, so exact SVDs at a
  subset of lines bracket it everywhere (Weyl's inequality); it is reported
  within a certified relative accuracy (default 1%, ``cond_rtol``; bound per
  line in ``cond_A_bound``), see :mod:`jointid.methods.hong_lee.condition`;
* ``cond_W`` of the weighted fit ``W Z[m]`` (the same loss of information, seen by the weights);
* ``cond_B`` of ``H*[n, e]`` peaks at the constrained structure's resonances
  (one mode dominates; the columns become parallel);
* ``cond_H`` of the measured ``H*[m, e]``.

Per-term predicted error: the relative FRF noise is estimated from the weighted residuals
(``|m| - |n|`` redundant values per excited column) and propagated to first order through both
steps (:mod:`jointid.methods.hong_lee.reliability`); a term is flagged reliable where its
predicted relative standard deviation is small. Model error in ``Do`` is a bias outside it.

``identifiability[:, i] = |Du_ii| / |1 / Ho_ii|`` compares the joint's stiffness
with the free beam's driving-point dynamic stiffness at ``n_i`` (``Ho = Do^-1``);
far from 1 in either direction means the term is poorly identifiable with noisy
data (the rotational term of a soft joint is typically ~1e-3).

Options (off by default): accelerometer masses on ``Do`` (build the free structure with
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
from ..estimate import JointEstimate, check_layout, term_scale
from .condition import pencil_condition
from .estimation import EstimationLayout, estimate_qr, estimate_svd, estimate_weighted
from .identification import identify_step
from .reliability import Reliability, pooled_noise, propagate_std

__all__ = [
    "Reliability",
    "InverseOptions",
    "InverseResult",
    "identify_joint",
    "rotation_scale",
]

_CHUNK_LINES = 250
#: Above this condition number of ``Do[nbar, mbar]`` the QR estimation hands the line to the SVD solver.
_QR_MAX_COND = 1e6


@dataclass(frozen=True)
class InverseOptions:
    """Options of :func:`identify_joint` (the defaults are the paper's two steps, noise-weighted).

    Parameters
    ----------
    symmetric : bool
        Enforce ``Du = Du^T``.
    regularization : {"none", "gcv", "lcurve"}
        Tikhonov regularization of the identification step, lambda per line by
        generalized cross-validation or by the L-curve corner.
    rotation_scale_m : float, optional
        Length l used to scale rotations (default: :func:`rotation_scale`, the mean element
        length of a beam). With ``weighting="relative"`` it changes only the condition numbers.
    reliability : Reliability
        Thresholds of the per-term ``reliable`` flag.
    weighting : {"relative", "none"}
        Least-squares weights of the estimation step. ``"relative"`` (default): each measured
        value by its relative noise, ``1 / |H*[m, e]|`` (the generalized least squares of
        :func:`~jointid.methods.hong_lee.estimation.estimate_weighted`; independent of the
        rotation scale; gives the per-term predicted error). ``"none"``: the rows of
        ``Do[nbar, mbar] H*[mbar, e] = b`` unweighted in scaled units (the least squares of the
        paper taken literally; no predicted error, so no term is flagged reliable).
    estimation : {"qr", "svd"}
        Solver of the estimation step (:mod:`jointid.methods.hong_lee.estimation`); both
        give the same solution. ``"qr"`` (default): Householder QR per line; with
        ``weighting="none"`` lines whose ``cond_A`` may exceed 1e6 go to the SVD solver
        (minimum-norm on rank-deficient lines), with ``"relative"`` lines where
        ``Do[nbar, :]`` is rank deficient do. ``"svd"``: one SVD per line everywhere.
    cond_rtol : float
        With ``estimation="qr"``: certified relative accuracy of ``cond_A``
        (:func:`~jointid.methods.hong_lee.condition.pencil_condition`); 0 computes it by
        an SVD on every line.
    """

    symmetric: bool = False
    regularization: str = "none"
    rotation_scale_m: float | None = None
    reliability: Reliability = field(default_factory=Reliability)
    estimation: str = "qr"
    cond_rtol: float = 1e-2
    weighting: str = "relative"

    def __post_init__(self) -> None:
        if self.regularization not in ("none", "gcv", "lcurve"):
            raise IdentificationError(
                f"regularization must be 'none', 'gcv' or 'lcurve', got {self.regularization!r}"
            )
        if self.estimation not in ("qr", "svd"):
            raise IdentificationError(f"estimation must be 'qr' or 'svd', got {self.estimation!r}")
        if self.weighting not in ("relative", "none"):
            raise IdentificationError(f"weighting must be 'relative' or 'none', got {self.weighting!r}")
        if not (isinstance(self.cond_rtol, (int, float)) and np.isfinite(self.cond_rtol) and 0 <= self.cond_rtol < 1):
            raise IdentificationError(f"cond_rtol must be a number in [0, 1), got {self.cond_rtol!r}")


@dataclass(frozen=True, eq=False)
class InverseResult(JointEstimate):
    """The Hong & Lee method's :class:`~jointid.methods.estimate.JointEstimate`: K per line, estimated FRFs, condition numbers.

    With ``weighting="relative"`` every term has a predicted 1-sigma (the FRF noise, estimated from
    the estimation step's residuals, propagated through both steps:
    :mod:`jointid.methods.hong_lee.reliability`) and is flagged reliable by it
    (:class:`~jointid.methods.hong_lee.reliability.Reliability`). Without redundant observed
    points (``|m| = |n|``) or with ``weighting="none"`` the method gives no predicted error:
    ``std_real``/``std_imag`` are NaN and no term is flagged reliable.

    Attributes
    ----------
    frequency : Frequency
        F lines, Hz.
    joint_dofs : tuple of Dof
        Joint coordinates n.
    stiffness : ndarray, shape (F, |n|, |n|), complex
        Identified ``Du``: N/m (w,w), N/rad (w,theta), N*m/m (theta,w), N*m/rad (theta,theta).
    estimated : FRF
        Receptance ``H*[:, e]`` of the constrained structure on every free-model DOF
        (measured rows as fitted by the weighted estimation step, as measured without weighting).
    cond_A, cond_B, cond_H : ndarray, shape (F,)
        Condition numbers (scaled coordinates) of ``Do[nbar, mbar]``, ``H*[n, e]``, ``H*[m, e]``.
    cond_W : ndarray, shape (F,)
        Largest condition number over the excited columns of the weighted fit ``W Z[m]`` of the
        estimation step (:func:`~jointid.methods.hong_lee.estimation.estimate_weighted`; NaN
        without weighting): with ``cond_A`` it bounds the amplification of FRF errors.
    identifiability : ndarray, shape (F, |n|)
        ``|Du_ii| |Ho_ii|``.
    std_real, std_imag : ndarray, shape (F, |n|, |n|)
        Predicted 1-sigma of ``Re Du`` and ``Im Du`` (units of ``stiffness``; NaN: none).
    reliable_terms : ndarray of bool, shape (F, |n|, |n|)
        The per-term flag (:class:`~jointid.methods.hong_lee.reliability.Reliability`).
    noise_std : ndarray, shape (F,)
        Relative FRF noise ``sigma`` estimated from the estimation step's residuals (pooled over
        ``Reliability.window`` lines; NaN without redundancy). Model error in ``Do`` raises it.
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
    cond_W: np.ndarray
    identifiability: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    reliable_terms: np.ndarray
    noise_std: np.ndarray
    regularization_lambda: np.ndarray
    options: InverseOptions
    cond_A_bound: np.ndarray

    method: ClassVar[str] = "hong-lee"

    @property
    def reliable_lines(self) -> np.ndarray:
        """Lines on which every term is reliable, shape (F,) (:attr:`reliable`)."""
        return self.reliable

    def describe_estimator(self) -> str:
        """One line: the paper's two steps per line and what the flag means."""
        if self.has_uncertainty:
            return ("Hong & Lee per line (estimation step weighted by the FRF noise, then identification step); "
                    "per-term predicted error: the FRF noise from the residuals propagated through both steps")
        return "Hong & Lee per line (estimation step, then identification step); no per-term predicted error"

    def findings(self) -> list[str]:
        """What the flag rests on: the predicted error (and its limits), or that there is none."""
        if not self.has_uncertainty:
            why = ("weighting = \"none\"" if self.options.weighting == "none" else
                   "no observed point beyond the joint DOFs (|m| = |n|) to estimate the noise from")
            return [f"the Hong & Lee method gives no per-term predicted error here ({why}): no term is flagged "
                    "reliable; use method = \"receptance\" for per-term bands"]
        sigma = float(np.nanmedian(self.noise_std))
        return [f"Hong & Lee: predicted errors are first order in the FRF noise estimated from the estimation "
                f"step's residuals (median {sigma:.2g} relative); they contain no bias from model error in the free "
                "model, which shows as a larger residual noise"]

    def options_summary(self) -> dict:
        """JSON-ready: symmetric, regularization, weighting, estimation, cond_rtol."""
        o = self.options
        return {"symmetric": o.symmetric, "regularization": o.regularization, "weighting": o.weighting,
                "estimation": o.estimation, "cond_rtol": o.cond_rtol}

    def diagnostics(self) -> dict:
        """JSON-ready: the largest condition numbers (and cond_A's certified error bound), the noise estimate, the flag's thresholds."""
        finite = np.isfinite(self.noise_std)
        return {
            "max_cond_A": float(np.max(self.cond_A)),
            "max_cond_A_relative_error_bound": float(np.max(self.cond_A_bound)),
            "max_cond_B": float(np.max(self.cond_B)),
            "max_cond_H": float(np.max(self.cond_H)),
            "max_cond_W": float(np.nanmax(self.cond_W)) if np.isfinite(self.cond_W).any() else None,
            "median_relative_noise": float(np.median(self.noise_std[finite])) if finite.any() else None,
            "reliability_thresholds": vars(self.options.reliability),
        }

    def subset(self, indices) -> "InverseResult":
        """The result on a subset of the joint DOFs (one of several joints identified together).

        ``stiffness``, its standard deviations, flags and ``identifiability`` are cut to the
        ``indices``; the per-line diagnostics (condition numbers, noise) and the estimated FRFs
        are those of the joint estimate.
        """
        idx = np.asarray(list(indices), dtype=int)
        cut = np.ix_(np.arange(self.stiffness.shape[0]), idx, idx)
        return replace(
            self, joint_dofs=tuple(self.joint_dofs[i] for i in idx), stiffness=self.stiffness[cut],
            std_real=self.std_real[cut], std_imag=self.std_imag[cut], reliable_terms=self.reliable_terms[cut],
            identifiability=self.identifiability[:, idx],
        )

    def extra_columns(self) -> dict[str, np.ndarray]:
        """``cond_A``, ``cond_B``, ``cond_H`` and the relative FRF noise estimate per line."""
        return {"cond_A": self.cond_A, "cond_B": self.cond_B, "cond_H": self.cond_H, "noise_std": self.noise_std}

    def plot(self, truth: np.ndarray | None = None, axes=None):
        """Magnitude (log), loss factor and condition numbers vs frequency; returns a Figure.

        With ``axes`` (2, n_terms): the joint-stiffness figure of every estimate instead.
        """
        if axes is not None:
            return JointEstimate.plot(self, truth=truth, axes=axes)
        from ...plots.inverse import plot_identification

        return plot_identification(self, truth=truth)


def _cond(A: np.ndarray) -> np.ndarray:
    s = np.linalg.svd(A, compute_uv=False)
    with np.errstate(divide="ignore"):
        return s[:, 0] / s[:, -1]


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

    F, n = freq.size, len(n_dofs)
    w2 = freq.omega**2
    Du = np.empty((F, n, n), complex)
    H_all = np.empty((F, N, len(e_dofs)), complex)
    condA = np.empty(F)
    condA_bound = np.zeros(F)
    condB = np.empty(F)
    lam_out = np.zeros(F)
    ratio = np.empty((F, n))
    condH = np.empty(F)
    condW = np.full(F, np.nan)
    rss = np.zeros(F)
    unit_std = np.full((2, F, n, n), np.nan)  # std of Re, Im Du per unit relative noise variance
    n_scale = sc[n_idx][:, None] * sc[n_idx][None, :]
    weighted = options.weighting == "relative"

    def solve(lines: np.ndarray, method: str) -> None:
        """Both steps on the given lines (chunk); writes the outputs at those lines."""
        Ys_m = H_meas[lines] / sc[m_idx][None, :, None]
        condH[lines] = _cond(H_meas[lines])
        if weighted:
            mag = np.abs(Ys_m)
            wts = 1.0 / np.maximum(mag, 1e-12 * mag.max(axis=1, keepdims=True) + 1e-300)
            est = estimate_weighted(layout, w2[lines], Ys_m, wts, method)
            Ys, Cs, rss[lines], condW[lines] = est.Ys, est.Cs, est.rss, est.cond_w
        elif method == "qr":
            Ys, Cs = estimate_qr(layout, w2[lines], Ys_m)
        else:
            Ys, Cs, condA[lines] = estimate_svd(layout, w2[lines], Ys_m)
        H_all[lines] = Ys * sc[None, :, None]
        # identification: Dus Bs = Cs (scaled), Du = S^-1 Dus S^-1
        Dus, condB[lines], lam_out[lines] = identify_step(Ys[:, n_idx], Cs, options.symmetric, options.regularization)
        Du[lines] = Dus / n_scale[None]
        if weighted and len(m_dofs) > n:
            P = layout.dynamic_stiffness_times(n_idx, np.arange(N), w2[lines], est.null)
            std = propagate_std(Ys[:, n_idx], Cs, est.null[:, n_idx], P, est.cov, np.ones(lines.size),
                                lam_out[lines], options.symmetric)
            unit_std[:, lines] = np.stack(std) / n_scale[None, None]
        # identifiability: |Du_ii| |Ho_ii|
        ratio[lines] = np.abs(np.diagonal(Du[lines], axis1=1, axis2=2)) * np.abs(ho_nn(freq.hz[lines]))

    everything = np.arange(F)
    rel = options.reliability
    if options.estimation == "svd" and not weighted:
        map_chunks(solve, everything, _CHUNK_LINES, method="svd")
    else:
        exact = options.estimation == "svd"
        cond = pencil_condition(
            *layout.estimation_blocks(),
            w2,
            0.0 if exact else options.cond_rtol,
            levels=(rel.max_cond_A, _QR_MAX_COND),  # decisions taken on exact values
        )
        condA[:], condA_bound[:] = cond.values, cond.bound
        if weighted:  # rank deficiency is in the small weighted fit, solved by SVD on every line
            map_chunks(solve, everything, _CHUNK_LINES, method=options.estimation)
        else:  # (nearly) rank-deficient lines need the pseudo-inverse: the SVD solver, which also gives cond_A exactly
            hard = ~(cond.values <= _QR_MAX_COND)
            map_chunks(solve, everything[~hard], _CHUNK_LINES, method="qr")
            if hard.any():
                map_chunks(solve, everything[hard], _CHUNK_LINES, method="svd")
                condA_bound[hard] = 0.0

    sigma2 = pooled_noise(rss, (len(m_dofs) - n) * len(e_dofs), rel.window) if weighted else np.full(F, np.nan)
    std_real, std_imag = unit_std * np.sqrt(sigma2)[None, :, None, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_std = np.hypot(std_real, std_imag) / term_scale(Du)
    reliable = (rel_std <= rel.max_relative_std) & (condA <= rel.max_cond_A)[:, None, None]
    estimated = FRF(freq, H_all, dofs, e_dofs, "receptance")
    return InverseResult(freq, n_dofs, Du, estimated, condA, condB, condH, condW, ratio, std_real, std_imag, reliable,
                         np.sqrt(sigma2), lam_out, options, condA_bound)


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
