"""Force-calibration error of each excitation column: detect it, estimate it, carry its uncertainty.

A roving-hammer FRF column shares its hits: noise in the force channel inside
the force window, a hammer calibration or a hit-angle error multiplies the whole
column ``H[:, j]`` by ``1 + eps_j(f)``, a factor common to every response and
smooth over frequency (the force window is short, so its noise spectrum varies
on a scale of ``1 / window``). Such an error does not average out over the
responses, and the joint's rotational term is nearly indistinguishable from
it: a column error far below the noise of a single value moves ``K_theta_theta`` by
many times its own size.

Model, with ``delta_j = eps_j / (1 + eps_j)`` so that the true FRF is
``H (1 - delta)`` exactly::

    Y[m,e] - H[m,e] + H[m,j] delta_j(f) = Y[m,n] X(f) Y[n,e]     for each column j

is linear in ``X`` (per line) and in ``delta`` (cubic B-splines over the band,
``n_basis`` per column, complex coefficients ``c``). ``X`` is projected out
line by line (variable projection: the residual of the per-line weighted least
squares), which leaves a small linear least-squares problem for ``c`` over all
lines at once::

    (sum_f (Z_f (x) B_f)^H (Z_f (x) B_f)) c = -sum_f (Z_f (x) B_f)^H r0_f,
    Z_f = (I - Q_f Q_f^H) W_f G_f,   r0_f = (I - Q_f Q_f^H) W_f d_f

It is tested by an F test of the residual reduction (``2 e n_basis`` real
parameters, with a minimum effect size :data:`CALIBRATION_MIN_F`); only a
significant error is corrected (``calibration = "auto"``),
since estimating it costs the rotational term most of its information. The
uncertainty of ``c`` (``s^2 N^-1``) is mapped to each line's ``X``
(``dX = A^+ W G B dc``): it is common to all lines, so frequency smoothing does
not reduce it, and it is added to the bands after smoothing.

**Errors in variables.** ``H`` is both in the data ``d = Y - H`` and in the
regressor ``G``, so its noise enters the normal equations twice: with ``h`` the
leverage of value ``(r, j)`` in its line's fit and ``s^2`` the residual variance,
``E[Z^H r0]`` carries ``-s^2 sum_r (1 - h_rj)`` per line and column, and
``E[Z^H Z]`` ``+s^2`` the same. Second order per line, it does not average out over
the lines as the noise does: uncorrected it biases the column error by about the
relative noise variance, and the joint's terms by a few of their standard deviations.
Both are subtracted (bias-compensated least squares), and the F test is of the compensated score
``rhs_c = rhs - s^2 b`` against its covariance ``s^2 N`` (Wald: ``rhs_c^H N^-1 rhs_c``), not of the
uncompensated residual reduction, which holds the bias: on a 6-DOF mount's 9 x 9 FRFs with no column
error it gave F 12-22 (the compensated test 1.0-1.1, below). The estimate's covariance is the sandwich
``Nc^-1 (s^2 N) Nc^-1`` (``Nc = N - s^2 D``). Where the regressor's own noise is most of the information
on a direction of the column error (:func:`noise_shares` above :data:`EIV_MAX_NOISE_SHARE`; e.g. functions
below a free structure's first flexible mode, where the joint's DOFs span its rigid-body motion and take
up any column scale), ``Nc`` is near singular there: that direction is not determined and is left at 0
(not estimated, not tested); the others are estimated and tested (a 6-DOF mount's 9 x 9 FRFs over
2-150 Hz: 3 of 144 directions left out with 16 functions, F 1.00-1.13 with no column error, a 3 %
error of one column found as 3.0-3.2 %).
With the true noise variance as weights the coefficients' errors match ``s^2 N^-1`` where the noise
share is small (mean Mahalanobis distance ~1 per coefficient); with weights that are only roughly
right (the coherence split below) they are larger.

**Weights after the correction** (:func:`residual_variance`). The coherence of a
test with force noise mixes the column error with the response noise; the split of
:func:`~jointid.methods.receptance.frf_variance.column_noise_fraction` separates them only as well
as its noise model holds (a floor per channel over a force spectrum per column),
which is only roughly. Once the column error is removed, the residuals of the
per-line fit measure the noise left in each value directly, and the calibration
and the joint are estimated again with those weights
(:func:`jointid.methods.receptance.coupling.identify_joint_coupling`).

**How fine a basis.** The identification tries :data:`CALIBRATION_BASES` (16, 32 and 64
functions), coarse to fine, and takes a finer one while its extra functions explain more than
:data:`CALIBRATION_FINER_MIN_F` times the residual variance per parameter (than the coarser
fit, or than no calibration where the coarser fit explains less than none). The force noise inside a
force window of ``T`` seconds varies on a ``1 / T`` scale (100 Hz for 10 ms), finer than 16
functions over 5-1000 Hz follow: on a virtual hammer test of the benchmark beam (2 % force noise,
10 ms force window, 20 hits) the 16-function calibration left K_w_w 3.7 % off, flagged reliable
with a predicted 0.76 %; 32 functions explained 235 times the residual variance per parameter more,
and K_w_w came out 0.007 % off. Not AIC: it assumes errors independent from line to line, and
errors shared by neighbouring lines (a window, smoothed FRFs) look like a finer column error to it
(F 4-6 per extra parameter: AIC took 64 functions on FRFs with 5-line moving-average errors, and
the joint came out 30 times worse).

Caveats: a column error that varies faster than the knot spacing (band / n_basis)
is only partly removed; the bias compensation is first order in ``delta``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import fdtrc

from ...parallel import map_lines, single_threaded_blas
from ..moving_average import moving_average
from .coupling_lines import symmetric_parametrization, whitened_line_design
from .smoothing import bspline_basis

__all__ = ["ColumnCalibration", "estimate_column_calibration", "residual_variance", "RESIDUAL_VARIANCE_LINES", "CALIBRATION_BASIS", "CALIBRATION_BASES", "CALIBRATION_FINER_MIN_F", "CALIBRATION_P_VALUE", "CALIBRATION_MIN_F", "CALIBRATION_MIN_ERROR", "EIV_MAX_NOISE_SHARE", "noise_shares", "usable_bases"]

#: B-spline basis functions per column over the band (knot spacing band / (n - 3)).
CALIBRATION_BASIS = 16
#: The candidate bases of the identification (``calibration_basis``; module docstring, "How fine a basis").
CALIBRATION_BASES = (CALIBRATION_BASIS, 2 * CALIBRATION_BASIS, 4 * CALIBRATION_BASIS)
#: A finer candidate basis is taken when its extra functions explain more than this many times the residual variance
#: per parameter (an F statistic of the reduction; noise correlated over neighbouring lines alone raises it to its
#: long-run variance factor, 4-6 for a 5-line moving average or a virtual hammer test's exponential window).
CALIBRATION_FINER_MIN_F = 10.0
#: An estimated column calibration error is corrected (``"auto"``) when its F-test p-value is below this.
CALIBRATION_P_VALUE = 1e-3
#: ... and its F statistic above this: the column error explains at least this many times the
#: residual variance per parameter. The F test alone assumes exactly right weights; weights from
#: coherence are right only to a factor (~1.5), which moves F by as much; a real column error
#: (force noise) moves it by orders of magnitude.
CALIBRATION_MIN_F = 4.0
#: ... and a median column error above this (relative): below it, on exact or nearly exact
#: data, the F test only measures round-off.
CALIBRATION_MIN_ERROR = 1e-5
#: A direction of the column error is not estimated (left at 0) where the regressor's own noise is more than this share
#: of the information on it (:func:`noise_shares`): its compensated estimate would be mostly amplified noise (by
#: ``1 / (1 - share)``, at most 2 here). Measured, largest share: a 6-DOF mount's 9 x 9 FRFs 0.84-1.03 (16 functions
#: over 2-150 Hz), the benchmark beam's 7 x 3 0.004 (16 functions over 5-1000 Hz).
EIV_MAX_NOISE_SHARE = 0.5
#: Lines of the running sums of :func:`residual_variance` (as the coherence smoothing of :mod:`.frf_variance`).
RESIDUAL_VARIANCE_LINES = 41


class ColumnCalibration:
    """Estimated relative force-calibration error of each excitation column.

    Attributes
    ----------
    delta : ndarray, shape (F, e), complex
        ``delta_j(f)``: the corrected FRF is ``H[:, j] (1 - delta_j)``.
    x_covariance : ndarray, shape (F, p, p), complex
        Covariance its uncertainty adds to the per-line coupling parameters x (upper triangle of X).
    x_factor : ndarray, shape (F, p, e n_basis), complex
        ``G`` with ``x_f`` error ``G_f u``, ``u ~ CN(0, I)`` common to all lines: ``G_f G_f^H`` is
        ``x_covariance[f]`` and ``G_f G_g^H`` the covariance between lines f and g (what a fit over
        all lines at once needs, :mod:`jointid.methods.receptance.structured_fit`).
    f_statistic, p_value : float
        F test of the residual reduction against "no calibration error".
    n_basis : int

    ``x_covariance`` and ``x_factor`` are either given or, from :func:`estimate_column_calibration`,
    formed on first use from their factors (``_factors``): an error that is not corrected needs
    neither, and the (F, p, e n_basis) factor is the largest array of the estimate.
    """

    def __init__(self, delta: np.ndarray, x_covariance: np.ndarray | None, f_statistic: float, p_value: float,
                 n_basis: int, x_factor: np.ndarray | None = None, *, _factors: "_XFactors | None" = None):
        self.delta = delta
        self.f_statistic = f_statistic
        self.p_value = p_value
        self.n_basis = n_basis
        self._x_covariance = x_covariance
        self._x_factor = x_factor
        self._factors = _factors

    def __repr__(self) -> str:
        return (f"ColumnCalibration(F={self.delta.shape[0]}, e={self.delta.shape[1]}, n_basis={self.n_basis}, "
                f"f_statistic={self.f_statistic:.4g}, p_value={self.p_value:.3g})")

    @property
    def x_covariance(self) -> np.ndarray | None:
        """Covariance added to the per-line coupling parameters x, shape (F, p, p), complex."""
        if self._x_covariance is None and self._factors is not None:
            self._x_covariance = self._factors.covariance()
        return self._x_covariance

    @property
    def x_factor(self) -> np.ndarray | None:
        """``G`` (F, p, e n_basis), complex, with ``G_f G_g^H`` the covariance of ``x_f`` and ``x_g`` (class docstring)."""
        if self._x_factor is None and self._factors is not None:
            self._x_factor = self._factors.factor()
        return self._x_factor

    @property
    def error(self) -> np.ndarray:
        """Relative column error ``eps = delta / (1 - delta)`` (measured = true (1 + eps)), shape (F, e)."""
        return self.delta / (1.0 - self.delta)

    @property
    def common_shape_ratio(self) -> float:
        """How much more the columns' errors share a part varying over frequency than they differ from each other.

        ``e mean_f |m(f) - mean_f m|^2 / (sum_j mean_f |delta_j - m|^2 / (e - 1))`` with ``m(f) = mean_j delta_j(f)``:
        about 1 (or less) for errors of separate hits or force records (independent per column: the common mean of
        ``e`` of them has ``1 / e`` of their variance), large where every column is corrected alike over frequency, as
        a free-model error makes it (a constant common factor, e.g. one hammer's sensitivity, does not count). NaN
        with one column.
        """
        d = np.asarray(self.delta)
        e = d.shape[1]
        if e < 2:
            return float("nan")
        m = d.mean(axis=1)
        spread = float(np.sum(np.mean(np.abs(d - m[:, None]) ** 2, axis=0))) / (e - 1)
        varying = float(np.mean(np.abs(m - m.mean()) ** 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            return e * varying / spread if spread > 0 else (float("inf") if varying > 0 else float("nan"))

    @property
    def common_shape_rms(self) -> float:
        """RMS over the lines of the columns' mean error less its mean over frequency (relative, :attr:`common_shape_ratio`)."""
        m = np.asarray(self.delta).mean(axis=1)
        return float(np.sqrt(np.mean(np.abs(m - m.mean()) ** 2)))

    @property
    def significant(self) -> bool:
        """The F test rejects "no column error" at :data:`CALIBRATION_P_VALUE` with ``F >`` :data:`CALIBRATION_MIN_F`
        and a median error above :data:`CALIBRATION_MIN_ERROR`."""
        big = float(np.max(np.median(np.abs(self.delta), axis=0))) > CALIBRATION_MIN_ERROR
        return bool(self.p_value < CALIBRATION_P_VALUE and self.f_statistic > CALIBRATION_MIN_F and big)

    def apply(self, H: np.ndarray, variance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Corrected receptance ``H (1 - delta)`` and its variance, shapes (F, m, e)."""
        g = 1.0 - self.delta[:, None, :]
        return H * g, variance * np.abs(g) ** 2


@dataclass(frozen=True, eq=False)
class _XFactors:
    """What ``x_covariance`` and ``x_factor`` are formed from: ``G_f = U_f (I_e (x) b_f^T) L``.

    Attributes
    ----------
    R : ndarray, shape (F, p, p), complex
        R of the per-line QR of the weighted, column-equilibrated design.
    QhG : ndarray, shape (F, p, e), complex
        ``Q^H G_w`` per line.
    cs : ndarray, shape (F, p)
        Column equilibration.
    basis : scipy.sparse CSR, shape (F, nb)
        The B-spline basis ``b_f`` of the column errors.
    pairs : scipy.sparse CSR, shape (F, nb nb)
        ``b_f (x) b_f`` (:func:`_pair_products`).
    L : ndarray, shape (e nb, e nb), complex
        ``L L^H`` the coefficients' covariance (the sandwich on the determined directions, :func:`_fit_basis`).
    """

    R: np.ndarray
    QhG: np.ndarray
    cs: np.ndarray
    basis: object
    pairs: object
    L: np.ndarray

    def _u(self) -> np.ndarray:
        """``U = R^-1 Q^H G_w / cs``: d x / d delta per line, shape (F, p, e)."""
        return np.linalg.solve(self.R, self.QhG) / self.cs[:, :, None]

    def covariance(self) -> np.ndarray:
        """``G_f G_f^H = U_f M_f U_f^H`` with ``M_f[j, l] = sum_bc b_f[b] b_f[c] (L L^H)[(j, b), (l, c)]``, (F, p, p).

        The same matrix as ``x_factor @ x_factor^H`` (summed in another order: they differ by
        round-off, ``~ (e nb) eps |G_f|^2``) without forming the (F, p, e nb) factor.
        """
        U = self._u()
        F, p, e = U.shape
        nb = self.basis.shape[1]
        C = self.L @ np.conj(self.L.T)
        C4 = C.reshape(e, nb, e, nb).transpose(1, 3, 0, 2).reshape(nb * nb, e * e)
        M = np.asarray(self.pairs @ C4).reshape(F, e, e)
        return (U @ M) @ np.conj(np.swapaxes(U, 1, 2))

    def factor(self) -> np.ndarray:
        """``G_f = U_f Lb_f`` with ``Lb_f[j] = sum_b b_f[b] L[(j, b)]``, shape (F, p, e nb)."""
        U = self._u()
        F, p, e = U.shape
        nb = self.basis.shape[1]
        K = self.L.shape[1]
        Lr = self.L.reshape(e, nb, K).transpose(1, 0, 2).reshape(nb, e * K)
        return U @ np.asarray(self.basis @ Lr).reshape(F, e, K)


def estimate_column_calibration(
    hz: np.ndarray,
    Ymn: np.ndarray,
    Yne: np.ndarray,
    change: np.ndarray,
    H: np.ndarray,
    variance: np.ndarray,
    symmetric: bool = True,
    n_basis: int | Sequence[int] = CALIBRATION_BASIS,
) -> ColumnCalibration | None:
    """Estimate each excitation column's smooth calibration error jointly with the per-line joint.

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies, Hz (increasing).
    Ymn, Yne : ndarray, shapes (F, m, n), (F, n, e), complex
        Free receptance blocks, m/N.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]``, m/N.
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    variance : ndarray, shape (F, m, e)
        Variance shape of each measured value, (m/N)^2.
    symmetric : bool
        ``X = X^T`` (as in :func:`~jointid.methods.receptance.coupling_lines.coupling_per_line`).
    n_basis : int or sequence of int
        B-spline functions per column (at least 4); several: from the fewest, each finer one is taken while its extra
        functions explain more than :data:`CALIBRATION_FINER_MIN_F` times the residual variance per parameter (the
        per-line parts are shared).

    Returns
    -------
    ColumnCalibration, or None when the data have no redundancy for it (too few lines or residual degrees of freedom,
    :func:`usable_bases`) or determine no direction of it (:func:`noise_shares`: every direction mostly the
    regressor's own noise).
    """
    with single_threaded_blas():  # per-line products of a few rows: BLAS threads only contend on such sizes
        return _estimate(hz, Ymn, Yne, change, H, variance, symmetric, n_basis)


def _estimate(hz, Ymn, Yne, change, H, variance, symmetric, n_basis) -> ColumnCalibration | None:
    """:func:`estimate_column_calibration`'s computation (its docstring): the per-line parts once, then each
    candidate basis (:func:`_fit_basis`), coarse to fine while a finer one earns its functions."""
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    p = symmetric_parametrization(n, symmetric).shape[1]
    usable = usable_bases(F, m, e, p, n_basis)
    if not usable:
        return None
    sw, cs, Q, R = whitened_line_design(Ymn, Yne, variance, symmetric)
    parts = map_lines(_calibration_lines, change, H, sw, Q)
    best = None
    ref_rss, ref_k = float(np.sum(parts[3])), 0  # the reference a finer basis must beat: no calibration at first
    for nb in usable:  # coarse to fine: a finer basis must earn its functions (module docstring)
        dof = F * (m * e - p) - e * nb
        fit = _fit_basis(np.asarray(hz, float), parts, R, cs, dof, nb, 2 * F * m * e)
        if fit is None:  # singular, or not determined by these FRFs (noise_shares): a finer basis is not either
            break
        cal, rss = fit
        k = 2 * e * nb  # real parameters
        if best is not None:
            f_more = ((ref_rss - rss) / (k - ref_k)) / (rss / (2 * dof))
            if f_more <= CALIBRATION_FINER_MIN_F:
                break
        best = cal
        if rss < ref_rss:  # a coarser fit that explains less than none (the bias compensation) is no reference
            ref_rss, ref_k = rss, k
    return best


def usable_bases(lines: int, m: int, e: int, p: int, n_basis: int | Sequence[int]) -> list[int]:
    """The candidate bases (functions per column, increasing) that ``lines`` lines of ``m x e`` FRFs with ``p`` joint
    parameters per line have the redundancy for: at least 4 functions, 2 lines per function, residual degrees of
    freedom left. (A basis may still be undetermined by the data: :func:`noise_shares`.)"""
    return [nb for nb in sorted({int(b) for b in np.atleast_1d(n_basis)})
            if nb >= 4 and lines >= 2 * nb and lines * (m * e - p) - e * nb > 0]


def _resolved_rss(rss0: float, reduction: float, n_terms: int) -> float:
    """The residual sum of squares ``rss0 - reduction`` a fit leaves, floored at the round-off of that difference.

    ``rss0`` sums ``n_terms`` real squares; the computed difference is exact only to about ``n_terms eps rss0`` (the
    bound for a sum of ``n_terms`` positive terms). An exact fit (the FRFs' column error and nothing else, noise-free)
    leaves a difference of that size whose bits depend on the BLAS kernel (seen: 1.08e17 of an ``rss0`` 3.07e32 on
    one kernel, 0 on another). Below the floor the residual is not resolved: the floor is returned, so F statistics
    stay finite and a finer basis cannot beat a coarser one by round-off alone.
    """
    return max(rss0 - reduction, n_terms * np.finfo(float).eps * rss0, np.finfo(float).tiny)


def _fit_basis(hz, parts, R, cs, dof, nb, n_terms) -> tuple | None:
    """``(ColumnCalibration, rss)`` with ``nb`` B-splines per column from the per-line parts, or None (singular).

    ``n_terms``: the real squares the per-line residuals ``|r0|^2`` sum (``2 F m e``), for the round-off floor of the
    residual (:func:`_resolved_rss`).

    ``G_w`` (column j of the weighted ``H`` in the rows ``(r, j)``) is diagonal in the column:
    only its nonzeros ``h_w`` (F, m, e) are held. The sums over the lines use the banded basis
    (:func:`_pair_products`): each line adds to the 4 x 4 block of its knot interval.
    """
    QhG, ZZ, v, rr0, d = parts
    F, e = v.shape
    idx = np.arange(e)
    Bs = bspline_basis(hz, nb)  # (F, nb) CSR, uniform knots over the band
    pairs = _pair_products(Bs)
    # N[(i,b),(j,c)] = sum_f ZZ[f,i,j] B[f,b] B[f,c]
    N = _gram(pairs, ZZ.reshape(F, e * e), nb).reshape(nb, e, e, nb).transpose(1, 0, 2, 3).reshape(e * nb, e * nb)
    rhs = -np.asarray(Bs.T @ v).T.reshape(e * nb)
    try:
        Ninv = np.linalg.inv(N)
    except np.linalg.LinAlgError:
        return None
    rss0 = float(np.sum(rr0))
    c = Ninv @ rhs
    s2 = _resolved_rss(rss0, float(np.real(np.vdot(c, N @ c))), n_terms) / dof
    # errors in variables: H is in the regressor G and in the data d, so E[G^H P d] carries -s^2 sum_r (1 - h_rj)
    # per line and column (h: leverage of the per-line fit, summed in d), E[G^H P G] +s^2 the same; removed
    # (bias-compensated LS)
    Dm = np.zeros((e, nb, e, nb))
    Dm[idx, :, idx, :] = _gram(pairs, d, nb).transpose(1, 0, 2)  # sum_f d[f,j] B[f,b] B[f,c]
    noise = s2 * Dm.reshape(e * nb, e * nb)
    try:
        shares, V = noise_shares(N, noise)  # V^H N V = I, V^H noise V = diag(shares)
    except np.linalg.LinAlgError:
        return None
    keep = shares <= EIV_MAX_NOISE_SHARE  # the directions these FRFs determine (module docstring)
    if not keep.any():
        return None
    # the compensated normal equations (N - noise) c = rhs_c in N's whitened directions: (1 - share) y = u, c = V y,
    # with u = V^H rhs_c ~ CN(., s^2 I); a direction mostly the regressor's own noise is left at 0 (not determined)
    u = np.conj(V.T) @ (rhs - s2 * np.asarray(Bs.T @ d).T.reshape(e * nb))
    gain = np.where(keep, 1.0 / np.where(keep, 1.0 - shares, 1.0), 0.0)
    c = V @ (gain * u)
    # the test is of the compensated score (Wald: sum |u|^2 over the determined directions, s^2 / 2 chi^2 of k real
    # degrees of freedom with no column error); the uncompensated residual reduction carries the errors-in-variables
    # bias (F 12-22 with no column error on a 6-DOF mount's 9 x 9 FRFs, where it is as large as the information)
    reduction = float(np.sum(np.abs(u[keep]) ** 2))
    rss1 = _resolved_rss(rss0, reduction, n_terms)
    s2 = rss1 / dof
    k = 2 * int(keep.sum())
    with np.errstate(over="ignore"):  # rss0 = 0 (no residual at all): rss1 is the smallest float, F may be inf, p = 0
        f_stat = (reduction / k) / (rss1 / (2 * dof))
    # F(k, 2 dof) survival function (scipy.stats.f.sf, which is 1 for F <= 0, without importing scipy.stats)
    p_value = float(fdtrc(k, 2 * dof, max(f_stat, 0.0)))
    delta = np.asarray(Bs @ c.reshape(e, nb).T)
    # d x / d c per line: x = (R^-1 Q^H (dw + Gw delta)) / cs; its covariance and factor are formed on first use.
    # Covariance of c: V diag(gain) (s^2 I) diag(gain) V^H (the sandwich (N - noise)^-1 s^2 N (N - noise)^-1 on the
    # determined directions), so L = s V diag(gain)
    factors = _XFactors(R, QhG, cs, Bs, pairs, np.sqrt(s2) * V * gain[None, :])
    return ColumnCalibration(delta, None, float(f_stat), p_value, nb, _factors=factors), rss1


def _calibration_lines(change, H, sw, Q):
    """The per-line parts of :func:`_estimate` on some lines: ``(Q^H G_w, Z^H Z, Z^H r0, |r0|^2, sum_r (1 - h))``,
    shapes (F, p, e), (F, e, e), (F, e), (F,), (F, e), with ``Z = (I - Q Q^H) G_w``, ``r0 = (I - Q Q^H) d_w`` and
    ``h`` the leverage of each value in the per-line fit."""
    F, m, e = change.shape
    p = Q.shape[2]
    Q4 = Q.reshape(F, m, e, p)
    hw = H * sw.reshape(F, m, e)  # the nonzeros of G_w: column j of H enters the rows (r, j) with delta_j
    dw = change.reshape(F, m * e) * sw
    QhG = np.conj(np.einsum("frjp,frj->fpj", Q4, np.conj(hw)))  # Q^H G_w, (F, p, e)
    Z = -(Q @ QhG).reshape(F, m, e, e)  # (I - Q Q^H) G_w, (F, m e, e)
    idx = np.arange(e)
    Z[:, :, idx, idx] += hw
    Z = Z.reshape(F, m * e, e)
    r0 = dw - (Q @ np.conj(np.einsum("frp,fr->fp", Q, np.conj(dw)))[:, :, None])[:, :, 0]  # (I - Q Q^H) d_w, (F, m e)
    Zt = np.swapaxes(Z, 1, 2)
    ZZ = np.conj(Zt @ np.conj(Z))  # Z^H Z, (F, e, e)
    v = np.conj((Zt @ np.conj(r0)[:, :, None])[:, :, 0])  # Z^H r0 per line, (F, e)
    Qf = Q.view(float)  # (F, m e, 2 p): real and imaginary parts
    lev = np.einsum("fij,fij->fi", Qf, Qf).reshape(F, m, e)
    return QhG, ZZ, v, np.sum(r0.real ** 2 + r0.imag ** 2, axis=1), np.sum(1.0 - lev, axis=1)


def residual_variance(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, variance: np.ndarray, symmetric: bool = True,
                      lines: int = RESIDUAL_VARIANCE_LINES) -> np.ndarray | None:
    """Variance of each measured value from the residuals of the per-line joint fit, shape (F, m, e), (m/N)^2.

    With ``r`` the residual of the per-line least squares (``X`` free on each line,
    weights ``1 / variance``) and ``h`` the leverage of the value in it,
    ``E|r|^2 = (1 - h) var`` when the weights are right; so::

        var[f, r, j] = sum_g |r[g, r, j]|^2 / sum_g (1 - h[g, r, j])

    over the ``lines`` lines around ``f`` (running sums). It needs no model of the
    noise: what is left once the column calibration has removed the column-common
    error is measured directly. The coherence split's variance
    (:func:`~jointid.methods.receptance.frf_variance.column_noise_fraction`) is only as
    right as its noise model; with force noise, bands from these weights hold the truth
    on more of the lines than bands from the split's (``benchmarks/robust_identification.py
    --hammer-seeds N`` prints the default's band coverage per term).

    Caveats: the ``change`` must be free of column errors (corrected); the running sums
    smear a variance that changes within ``lines`` lines (a relative error ``~|H|^2``
    across a sharp resonance), and weights far from right leak variance between the
    values of a line.

    Parameters
    ----------
    Ymn, Yne : ndarray, shapes (F, m, n), (F, n, e), complex
        Free receptance blocks, m/N.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]`` of the corrected measured receptance, m/N.
    variance : ndarray, shape (F, m, e)
        The weights of the per-line fit (variance shape), (m/N)^2.
    symmetric : bool
    lines : int
        Lines of the running sums (odd; at most a tenth of the lines).

    Returns
    -------
    ndarray, or None when a line has fewer than 3 residual degrees of freedom.
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    p = symmetric_parametrization(n, symmetric).shape[1]
    if m * e - p < 3:
        return None
    with single_threaded_blas():
        sw, _, Q, _ = whitened_line_design(Ymn, Yne, variance, symmetric)
    dw = change.reshape(F, m * e) * sw
    rw = dw - (Q @ (np.conj(np.swapaxes(Q, 1, 2)) @ dw[:, :, None]))[:, :, 0]
    r2 = (np.abs(rw) / sw) ** 2  # |residual|^2, (m/N)^2
    free = np.clip(1.0 - np.sum(np.abs(Q) ** 2, axis=2), 0.0, None)
    width = min(int(lines), max(1, F // 10)) | 1
    num = moving_average(r2, width, axis=0)
    den = moving_average(free, width, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = num / den
    return np.where(np.isfinite(v) & (v > 0), v, variance.reshape(F, m * e)).reshape(F, m, e)


def _pair_products(Bs):
    """``b_f (x) b_f`` of every line as CSR, shape (F, nb nb): row f holds ``B[f, b] B[f, c]`` at column ``b nb + c``.

    A cubic B-spline basis has 4 functions per line, so 16 entries per row: the sums over the
    lines of :func:`_gram` and of ``x_covariance`` are sparse products of F 16 terms each.
    """
    from scipy.sparse import csr_matrix

    Bs = Bs.tocsr()
    F, nb = Bs.shape
    counts = np.diff(Bs.indptr)
    k = max(int(counts.max()), 1) if F else 1
    row = np.repeat(np.arange(F), counts)
    slot = np.arange(Bs.indices.size) - np.repeat(Bs.indptr[:-1], counts)
    idx = np.zeros((F, k), np.int64)
    val = np.zeros((F, k))
    idx[row, slot] = Bs.indices
    val[row, slot] = Bs.data
    cols = (idx[:, :, None] * nb + idx[:, None, :]).reshape(F, k * k)
    data = (val[:, :, None] * val[:, None, :]).reshape(F, k * k)
    return csr_matrix((data.ravel(), cols.ravel(), np.arange(0, F * k * k + 1, k * k)), shape=(F, nb * nb))


def _gram(pairs, values: np.ndarray, nb: int) -> np.ndarray:
    """``out[b, k, c] = sum_f values[f, k] B[f, b] B[f, c]`` for a banded ``B``; ``pairs``: :func:`_pair_products` of B.

    One sparse product over the lines, ``(B (x) B)^T values``: (F, K) values -> (nb, K, nb).
    """
    K = values.shape[1]
    return np.asarray(pairs.T @ values).reshape(nb, nb, K).transpose(0, 2, 1)


def noise_shares(N: np.ndarray, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How much of the information on each direction of the column error is the regressor's own noise.

    ``N = Z^H Z`` holds the columns' noise: ``E[Z^H Z] = Z0^H Z0 + noise`` (errors in variables, module docstring).
    The generalized eigenproblem ``noise v = share N v`` gives directions ``V`` with ``V^H N V = I`` and
    ``V^H noise V = diag(share)``: a share of 1 leaves a direction no information of its own; above
    :data:`EIV_MAX_NOISE_SHARE` the compensated estimate ``(N - noise)^-1`` would amplify its noise by
    ``1 / (1 - share)`` or more, and it is not estimated.

    Parameters
    ----------
    N, noise : ndarray, shape (k, k), complex
        Hermitian, ``N`` positive definite, ``noise`` positive semi-definite (same units).

    Returns
    -------
    shares : ndarray, shape (k,)
        Increasing.
    V : ndarray, shape (k, k), complex

    Raises
    ------
    numpy.linalg.LinAlgError
        ``N`` is not positive definite.
    """
    from scipy.linalg import eigh

    return eigh(0.5 * (noise + np.conj(noise.T)), 0.5 * (N + np.conj(N.T)))
