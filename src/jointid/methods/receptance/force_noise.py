"""Force noise without coherence: a random error common to each excitation column, line by line.

In a roving-hammer test every response of a column ``j`` is divided by the same force
spectrum, so a random error ``n_F[j]`` of the force at one line is common to every response
of that column at that line::

    H_meas[f, r, j] = H[f, r, j] (1 + n_R[f, r, j]) / (1 + n_F[f, j])
                   ~ H[f, r, j] (1 + n_R[f, r, j] - n_F[f, j])

With coherence in the file, the force noise lowers the coherence of the whole column and
:func:`~jointid.methods.receptance.frf_variance.column_noise_fraction` splits it off; a smooth
force error is the column calibration's
(:mod:`jointid.methods.receptance.column_calibration`). Without coherence, the relative-noise
model (``var H = a |H|^2``, independent values) has no term for a per-line random error
shared by a column. It is not independent noise: within a column its covariance is of rank
one, ``b_j H[:, j] H[:, j]^H``, and the per-line fit absorbs most of it into the joint (the
rotational term is nearly a column factor), so the residual scale underrates the joint's
error and the bands are too narrow; the structured joint model's chi^2 test then fails
("not one viscoelastic material") although the cause is the force.

**Model** (per line ``f``; ``v`` the variance shape in use, e.g. ``|H|^2``)::

    cov(H[:, j], H[:, k]) = delta_jk (a_f diag(v[:, j]) + b_fj H[:, j] H[:, j]^H)

**Statistic.** With the per-line weighted fit (weights ``1 / v``, whitened design
``Q R``: :func:`~jointid.methods.receptance.coupling_lines.whitened_line_design`) the residual
is ``r = (I - Q Q^H) W^(1/2) d``. The whitened column directions ``g_j = W^(1/2) H[:, j]``
(zero outside column ``j``) projected off the design, ``Z = (I - Q Q^H) G = U_z R_z`` (thin
QR, ``e`` columns), span the only residual directions the column-common error reaches. With
``c = U_z^H r`` (``e`` values) and ``r_perp = r - U_z c`` (``|m||e| - p - e`` complex degrees
of freedom)::

    E[c c^H] = a I + R_z diag(b) R_z^H,    E|r_perp|^2 = a (|m||e| - p - e)

so without column-common noise ``c`` and ``r_perp`` have the same variance per degree of
freedom, independently. Pooled over the band (each line normalized by its own smoothed
``a``)::

    F = (sum_f |c_f|^2 / a_f / (e F)) / (sum_f |r_perp,f|^2 / a_f / ((|m||e| - p - e) F))

is ``F(2 e F, 2 (|m||e| - p - e) F)`` distributed without column-common noise. The force
noise is significant when its p-value is below :data:`FORCE_NOISE_P_VALUE`, ``F`` above
:data:`FORCE_NOISE_MIN_F` and its level above :data:`FORCE_NOISE_MIN_LEVEL` (round-off). ``F``
needs the effect size: over a thousand lines the p-value alone rejects for any departure, and
weights of the wrong shape put some excess into the column directions too (a hammer test's
response noise floor weighted as relative noise: ``F`` 1.0-1.3), while 1 % force noise with 1 %
response noise gives ``F`` ~5.5 on the benchmark beam (``benchmarks/force_noise.py`` prints
both rates). ``a`` and ``b`` are estimated per line by moments over
:data:`FORCE_NOISE_LINES` neighbouring lines (running sums): ``a`` from ``r_perp``, ``b`` by
least squares of ``c c^H - a I`` on ``R_z diag(b) R_z^H`` (clipped at 0).

**Downstream** (:meth:`ForceNoise.line_estimates`): the per-line fit by generalized least
squares with that covariance (each column whitened by
``(I - kappa u u^H / |u|^2) D^-1``, ``D = sqrt(a v)``, ``u = D^-1 H[:, j]``,
``kappa = 1 - (1 + b |u|^2)^(-1/2)``), so its covariance, the smoothers' and the structured
model's bands include the force noise; same output as
:func:`~jointid.methods.receptance.coupling_lines.coupling_per_line`.

The column directions are those of the per-line fit's ``H`` (the measured values less the
residual), not of the measured ``H``: its noise is the residual's own (errors in variables),
and where a column direction has little signal of its own (below a free structure's first
flexible modes, where the joint's DOFs take up any column scale) the measured direction is
mostly that noise. On a 3-D frame with a 6-DOF mount (9 x 9 FRFs, 1 % response noise) the
measured directions gave F 5.7-6.0 and "force noise" of 0.1-0.2 %; the fitted ones F 1.00-1.02,
and with 1 % force noise added F 6.8-9.6 and levels of 0.8-1.1 % (the benchmark beam: F
0.99-1.01 without, 5.1-5.8 with).

Caveats: the force noise is taken independent from line to line (a force noise smooth over
frequency is the column calibration's, which should run first); response noise of
another shape than ``v`` leaks into ``b`` in proportion to its projection on the column
directions; it needs ``|m||e| - p - e >= 1`` and at least 2 responses per column.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.special import fdtrc

from ...parallel import map_lines, single_threaded_blas
from ..moving_average import moving_average
from .coupling_lines import LineEstimates, symmetric_parametrization, whitened_line_design

__all__ = ["ForceNoise", "detect_force_noise", "column_split", "FORCE_NOISE_P_VALUE", "FORCE_NOISE_MIN_F", "FORCE_NOISE_MIN_LEVEL", "FORCE_NOISE_LINES"]

#: Force noise is significant when the F test's p-value is below this ...
FORCE_NOISE_P_VALUE = 1e-3
#: ... and F above this: the column directions carry at least this many times the residual variance per
#: degree of freedom (weights of a wrong shape: up to ~1.3; 1 % force and 1 % response noise: ~5.5).
FORCE_NOISE_MIN_F = 1.5
#: ... and the largest column's median level above this (relative): below it, on exact or nearly exact data,
#: the test only measures round-off.
FORCE_NOISE_MIN_LEVEL = 1e-5
#: Lines of the running sums of the per-line estimates of ``a`` and ``b`` (odd; at most a quarter of the lines).
FORCE_NOISE_LINES = 101
#: A column-common error above this (relative rms) is more than a hammer's force noise: the finding names units and sensitivity.
FORCE_NOISE_GROSS_LEVEL = 0.1


@dataclass(frozen=True, eq=False)
class ForceNoise:
    """Column-common random error of the excitation columns, tested and estimated.

    Attributes
    ----------
    response_scale : ndarray, shape (F,)
        ``a_f``: the response (independent) variance is ``a_f * variance``.
    column_variance : ndarray, shape (F, e)
        ``b_fj``: variance of the relative error common to column ``j`` (force noise).
    f_statistic, p_value : float
        The F test against "no column-common error" (module docstring).
    dof : tuple of int
        Its real degrees of freedom (numerator, denominator).
    """

    response_scale: np.ndarray
    column_variance: np.ndarray
    f_statistic: float
    p_value: float
    dof: tuple

    @property
    def significant(self) -> bool:
        """p-value below :data:`FORCE_NOISE_P_VALUE`, F above :data:`FORCE_NOISE_MIN_F` and a level above
        :data:`FORCE_NOISE_MIN_LEVEL`."""
        big = float(np.max(self.level)) > FORCE_NOISE_MIN_LEVEL
        return bool(self.p_value < FORCE_NOISE_P_VALUE and self.f_statistic > FORCE_NOISE_MIN_F and big)

    @property
    def level(self) -> np.ndarray:
        """Median relative standard deviation of the force noise of each column, shape (e,)."""
        return np.sqrt(np.median(self.column_variance, axis=0))

    @property
    def response_level(self) -> float:
        """Median relative standard deviation of the response noise (with relative weights ``|H|^2``)."""
        return float(np.sqrt(np.median(self.response_scale)))

    @property
    def finding(self) -> str:
        """One line naming the force noise as the cause (whether significant or not: check :attr:`significant`)."""
        return self.finding_text()

    def finding_text(self, model_fits: bool = True) -> str:
        """:attr:`finding`; ``model_fits`` False (the model check found the free model off): the residual it was measured
        from holds the model's error too, and the finding says so instead of ruling a model error out."""
        lv = ", ".join(f"{100 * v:.2g}" for v in self.level)
        gross = ("; more than force noise makes: check the units and the hammer's sensitivity per column"
                 if float(np.max(self.level)) > FORCE_NOISE_GROSS_LEVEL else "")
        cause = ("not a joint or model error" if model_fits else
                 "the free model does not explain these FRFs (see that finding), so part or all of it may be the model's error")
        return (f"the excitation columns share a random error line by line (force noise, ~{lv} % per column; "
                f"F test F = {self.f_statistic:.3g}, p = {self.p_value:.2g}), measured from the residuals: {cause}; it is in "
                "the variance model, so the per-line covariance and the bands include it" + gross)

    def variance(self, variance: np.ndarray) -> np.ndarray:
        """Response (independent) variance of each value, ``a_f * variance``, shape (F, m, e)."""
        return variance * self.response_scale[:, None, None]

    def line_estimates(self, Ymn: np.ndarray, Yne: np.ndarray, Ynn: np.ndarray, change: np.ndarray, H: np.ndarray,
                       variance: np.ndarray, symmetric: bool = True, pool_lines: int | None = None,
                       common_x_covariance: np.ndarray | None = None) -> LineEstimates:
        """Per-line generalized least squares with the force noise in the covariance (module docstring).

        Parameters
        ----------
        Ymn, Yne, Ynn : ndarray, shapes (F, m, n), (F, n, e), (F, n, n), complex
            Free receptance blocks.
        change : ndarray, shape (F, m, e), complex
            ``Y[m,e] - H[m,e]``.
        H : ndarray, shape (F, m, e), complex
            The measured receptance (the column directions).
        variance : ndarray, shape (F, m, e)
            The variance shape this was estimated with (:func:`detect_force_noise`).
        symmetric : bool
        pool_lines : int, optional
            Lines pooled for the residual scale (as :func:`~jointid.methods.receptance.coupling_lines.coupling_per_line`).
        common_x_covariance : ndarray, shape (F, p, p), optional
            Covariance of x common to all lines (a column calibration), propagated to ``common_variance``.

        Returns
        -------
        LineEstimates
            As :func:`~jointid.methods.receptance.coupling_lines.coupling_per_line` returns (exact path).
        """
        with single_threaded_blas():
            return _gls_lines(Ymn, Yne, Ynn, change, H, self.variance(variance), self.column_variance, symmetric,
                              pool_lines, common_x_covariance)


def detect_force_noise(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, H: np.ndarray, variance: np.ndarray,
                       symmetric: bool = True, lines: int = FORCE_NOISE_LINES) -> ForceNoise | None:
    """Test for and estimate a per-line random error common to each excitation column (force noise).

    Parameters
    ----------
    Ymn, Yne : ndarray, shapes (F, m, n), (F, n, e), complex
        Free receptance blocks, m/N.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]``, m/N (free of a smooth column error: correct it first).
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    variance : ndarray, shape (F, m, e)
        Variance shape of each value under the independent-noise model (e.g. ``|H|^2``: relative weighting).
    symmetric : bool
        ``X = X^T`` (as in the per-line fit).
    lines : int
        Lines of the running sums of the per-line estimates (odd; at most a quarter of the lines).

    Returns
    -------
    ForceNoise, or None when the layout cannot tell the column directions from the rest of the
    residual (``|m||e| - p - e < 1`` or fewer than 2 responses).
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    p = symmetric_parametrization(n, symmetric).shape[1]
    rest = m * e - p - e
    if m < 2 or rest < 1 or F < 1:
        return None
    with single_threaded_blas():
        c, perp, Rz = _column_residuals(Ymn, Yne, change, H, variance, symmetric)
    width = min(int(lines), max(1, F // 4)) | 1
    tiny = np.finfo(float).tiny

    def run(x):
        return moving_average(x, width, axis=0)

    a = np.maximum(run(perp) / rest, tiny)  # (F,)
    # the F test, each line normalized by its own smoothed a
    num = float(np.sum(np.sum(np.abs(c) ** 2, axis=1) / a)) / (e * F)
    den = float(np.sum(perp / a)) / (rest * F)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        f_stat = num / den if den > 0 else (np.inf if num > 0 else 1.0)
    d1, d2 = 2 * e * F, 2 * rest * F
    p_value = float(fdtrc(d1, d2, max(f_stat, 0.0))) if np.isfinite(f_stat) else 0.0
    # b per line: least squares of c c^H - a I on R_z diag(b) R_z^H over the window
    M = np.abs(np.conj(np.swapaxes(Rz, 1, 2)) @ Rz) ** 2  # (F, e, e): |z_k^H z_l|^2
    proj = np.abs(np.einsum("fik,fi->fk", np.conj(Rz), c)) ** 2  # |z_k^H c|^2 (z_k in the U_z basis)
    norm2 = np.sum(np.abs(Rz) ** 2, axis=1)  # |z_k|^2
    rhs = proj - a[:, None] * norm2
    N = run(M) + np.eye(e) * 1e-12 * np.maximum(run(M).trace(axis1=1, axis2=2), tiny)[:, None, None]
    b = np.linalg.solve(N, run(rhs)[:, :, None])[:, :, 0]
    b = np.maximum(b, 0.0)
    return ForceNoise(a, b, float(f_stat), p_value, (d1, d2))


def column_split(Ymn, Yne, change, H, variance, symmetric, keep: bool = True, fitted: bool = False):
    """The per-line weighted fit's residual and the excitation columns' directions outside the fit's range.

    Returns ``(sw, Q, r, Uz, Rz)``: the weights ``sw`` (F, m e) and the orthonormal design ``Q`` (F, m e, p) of
    :func:`~.coupling_lines.whitened_line_design`, the weighted residual ``r = (I - Q Q^H) d_w`` (F, m e), and
    ``Uz R_z = (I - Q Q^H) G_w`` (QR; ``G_w[:, :, j]``: column j of the weighted ``H``, what a scale error of that
    column changes), shapes (F, m e, e) and (F, e, e). ``keep``: passed to ``whitened_line_design`` (False: a
    design of a subset of the lines, not kept for the calls that follow). ``fitted``: the columns of the per-line
    fit's ``H`` (``H + r / sw``, the measured values less the residual) instead of the measured ones: the
    residual's own noise is then not in the directions it is projected on (errors in variables; where a column
    direction has little signal of its own, as below a free structure's first flexible modes, the measured one is
    mostly that noise and ``c = U_z^H r`` came out 6x the noise variance with no force noise).
    """
    sw, _, Q, _ = whitened_line_design(Ymn, Yne, variance, symmetric, keep=keep)
    return (sw, Q) + map_lines(partial(_split_lines, fitted=fitted), change, H, sw, Q)


def _split_lines(change, H, sw, Q, fitted=False):
    """``(r, Uz, Rz)`` of :func:`column_split` on some lines."""
    F, m, e = change.shape
    Qh = np.conj(np.swapaxes(Q, 1, 2))
    dw = (change.reshape(F, m * e) * sw)[:, :, None]
    r = (dw - Q @ (Qh @ dw))[:, :, 0]
    if fitted:  # the fitted change is d - r / sw, so the fitted H = Yme - fitted change = H + r / sw
        with np.errstate(divide="ignore", invalid="ignore"):
            H = H + np.where(sw > 0, r / sw, 0.0).reshape(F, m, e)
    G = np.zeros((F, m, e, e), complex)
    idx = np.arange(e)
    G[:, :, idx, idx] = H
    G = G.reshape(F, m * e, e) * sw[:, :, None]
    Uz, Rz = np.linalg.qr(G - Q @ (Qh @ G))
    return r, Uz, Rz


def _column_residuals(Ymn, Yne, change, H, variance, symmetric):
    """``c = U_z^H r`` (F, e), ``|r_perp|^2`` (F,) and ``R_z`` (F, e, e) of the per-line weighted fit (module docstring)."""
    _, _, r, Uz, Rz = column_split(Ymn, Yne, change, H, variance, symmetric, fitted=True)
    c = np.einsum("fkc,fk->fc", np.conj(Uz), r)
    perp = np.maximum(np.sum(np.abs(r) ** 2, axis=1) - np.sum(np.abs(c) ** 2, axis=1), 0.0)
    return c, perp, Rz


def _gls_lines(Ymn, Yne, Ynn, change, H, resp_var, col_var, symmetric, pool_lines, common_x_covariance) -> LineEstimates:
    """Per-line generalized least squares, covariance ``diag(resp_var) + b_j H_j H_j^H`` per column (module docstring)."""
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    P = symmetric_parametrization(n, symmetric)
    p = P.shape[1]
    A = (np.einsum("fkc,fri->frcik", Yne, Ymn).reshape(F, m * e, n * n) @ P).reshape(F, m, e, p)
    d = change
    tiny = np.finfo(float).tiny
    Dinv = 1.0 / np.sqrt(np.maximum(resp_var, tiny))  # (F, m, e)
    u = H * Dinv
    u2 = np.sum(np.abs(u) ** 2, axis=1)  # (F, e)
    uh = u / np.sqrt(np.maximum(u2, tiny))[:, None, :]
    kappa = 1.0 - 1.0 / np.sqrt(1.0 + col_var * u2)  # (F, e)

    def whiten(x):  # x (F, m, e, ...) -> (I - kappa uh uh^H) D^-1 x, per column
        xd = x * Dinv.reshape(Dinv.shape + (1,) * (x.ndim - 3))
        proj = np.einsum("fre,fre...->fe...", np.conj(uh), xd)
        k = (kappa[..., None] * proj) if x.ndim > 3 else kappa * proj
        return xd - uh.reshape(uh.shape + (1,) * (x.ndim - 3)) * k[:, None]

    Aw = whiten(A).reshape(F, m * e, p)
    dw = whiten(d).reshape(F, m * e)
    cs = np.linalg.norm(Aw, axis=1)
    cs = np.where(cs > 0, cs, 1.0)
    Q, R = np.linalg.qr(Aw / cs[:, None, :])
    qd = np.einsum("fji,fj->fi", Q.conj(), dw)
    Ri = np.linalg.solve(R, np.broadcast_to(np.eye(p), (F, p, p)))
    x = np.einsum("fij,fj->fi", Ri, qd) / cs
    resid = dw - np.einsum("fij,fj->fi", Q, qd)
    dof = m * e - p
    sv = np.linalg.svd(R, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = sv[:, 0] / sv[:, -1]
    w = pool_lines or (max(1, F // 40) | 1)
    scale = moving_average(np.sum(np.abs(resid) ** 2, axis=1) / dof, min(w, F)) if dof > 0 else np.full(F, np.nan)
    C = (Ri @ np.conj(np.swapaxes(Ri, 1, 2))) / (cs[:, :, None] * cs[:, None, :])
    X = (x @ P.T).reshape(F, n, n)
    I = np.eye(n)
    Du = np.linalg.solve(I[None] - X @ Ynn, X)
    J = np.einsum("fik,flj->fijkl", I[None] + Du @ Ynn, I[None] + Ynn @ Du).reshape(F, n * n, n * n) @ P
    V = np.real(np.einsum("fab,fbc,fac->fa", J, C, J.conj())).reshape(F, n, n) * scale[:, None, None]
    common = np.zeros_like(V)
    if common_x_covariance is not None:
        common = np.real(np.einsum("fab,fbc,fac->fa", J, common_x_covariance, J.conj())).reshape(F, n, n)
    return LineEstimates(Du, V, scale, cond, dof, common, x, C * scale[:, None, None], common_x_covariance, Ynn, symmetric)
