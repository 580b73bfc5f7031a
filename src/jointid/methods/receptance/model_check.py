"""Does the free model explain the measured FRFs? The coupling equations' residuals per band against the noise.

Per line the coupling equations ``Y[m,e] - H[m,e] = Y[m,n] X Y[n,e]``
(:mod:`jointid.methods.receptance.coupling_lines`) are ``|m||e|`` complex equations in
``p`` joint parameters (``p = n(n+1)/2`` when symmetric). With weights ``1 / var(H)``
the whitened residual ``r = (I - Q Q^H) W^(1/2) (Y[m,e] - H)`` of the per-line fit has
``E|r_k|^2 = (1 - h_k) sigma^2`` when the free model ``Y`` is right (``h``: leverage,
``sigma^2``: the weights' unknown scale), so per line::

    chi2_f = sum_k |r_fk|^2 / (|m||e| - p)  ~  sigma^2

A free model that is wrong (E or density off by 1-2 %: its resonances shift by
~0.5-1 %) adds a residual the joint cannot absorb (``Y[m,e]`` is not of the form
``Y[m,n] X Y[n,e]``); it grows near the resonances and is far above the noise there.

**The noise without a model of it.** The weights carry the noise's *shape* only
(relative weighting has no scale at all, and coherence from ``n`` averages is read
with ``n`` unknown), so ``sigma^2`` is measured from the residuals themselves: FRF
noise is independent from line to line while a model error's residual is smooth in
frequency, so the second difference over lines ``d2_f = r_(f+1) - 2 r_f + r_(f-1)``
has ``E|d2|^2 = 6 (1 - h) sigma^2`` from the noise and almost nothing from the model
error. Per line (medians over the ``|m||e|`` values; for a complex Gaussian ``|z|^2``,
median = ``ln 2`` times the mean)::

    noise_f = median_k |d2_fk|^2 / (6 ln 2 (1 - p / (|m||e|)))

and per band ``b`` (octaves from the first line, merged until each has at least
:data:`BAND_MIN_LINES` lines) the ratio ``R_b = median_(f in b) chi2_f / median_(f in b)
noise_f`` is ~1 when the free model fits (medians: a few junk lines do not move it).
``R_b >`` :data:`MODEL_RESIDUAL_RATIO` fails the band (the median noise is taken at least
:data:`MIN_NOISE_LEVEL`, so exact data's round-off fails nothing): the free model does not explain the
FRFs there.

**Once the free model is proven wrong**, no band of it is trusted. A free model's error (a modulus, a
density, a beam theory) is global; the bands only say where it shows. Where the residual is near the
noise, the joint terms absorb the error: an Euler-Bernoulli model of a Timoshenko beam (0.5 % noise,
5-400 Hz) has ``R_b`` 0.9-1.0 at 5-39 Hz and 46-50 at 320-400 Hz, and at 5-39 Hz the 90 % bands of
K_w_w hold the truth on 66-78 % of the lines. So when some band is above
:data:`MODEL_ERROR_PROVEN_RATIO` (twice the limit: a window's correlated noise alone raises ``R`` to
3-4, never that far), every band fails.

**A smooth residual.** A free model a little off leaves a residual below the ratio's limit but
smooth over frequency: E 0.2 % high (benchmark beam, 0.5 % noise) gives ``R_b`` 1.2-2.5 while
K_w_w's bands hold the truth on 54 % of its lines. FRF errors are correlated over neighbouring lines
too (an exponential window: ``1 / (1 + (pi k df tau)^2)`` at lag ``k``, a Lorentzian; the virtual
hammer test's residuals: 0.61 at lag 1, 0.07 at lag 5, 0.04 at 8), but only over a few lines, while a
model error's residual stays correlated over many. So the residuals' pooled correlation at lags
:data:`SMOOTH_LAGS` minus the Lorentzian through their lag-1 correlation (``smooth_excess``) is ~0
for FRF errors alone (-0.007 to 0.019 on the benchmarks' right models, hammer tests with coherence
included; 0.041 on a virtual hammer test without its coherence, weighted by a floor, whose joint
estimate is right within its bands) and 0.043 (E 0.05 % off), 0.087 (0.1 %), 0.16 (0.2 %), 0.42 (an
Euler-Bernoulli beam) with a model error. Above :data:`SMOOTH_EXCESS_LIMIT` and five standard errors
(``1 / sqrt(2 dof F)``), or above :data:`SMOOTH_EXCESS_WITH_FAILED_BAND` when a band's ratio fails too
(a 3-D frame on a 6-DOF mount with E 2 % off: 0.039 and 5.8x at 2-15.5 Hz, while the other bands'
1.1-1.4x let rotational terms 3-10 times off through as reliable), the free model is proven wrong as
above: every band fails. A smooth processing error (leakage, a window's correction) or a column error
the calibration does not follow looks the same, and biases the joint as much. Caveat: E 0.05 % off is
below the limit (K_w_w's bands then hold the truth on 84 % of its lines).

Caveats: noise correlated over neighbouring lines (a strong time window smooths the
spectrum) lowers ``noise_f`` and raises ``R``; a frequency step much coarser than the
resonances' half-power bandwidth makes a model error's residual rough over lines
(it then also raises ``noise_f``, and ``R`` understates the misfit).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ...parallel import map_lines, single_threaded_blas
from .coupling_lines import DESIGN_VARIANCE_RTOL, same_inputs, symmetric_parametrization, whitened_line_design

__all__ = ["ResidualStatistics", "residual_statistics", "line_residuals", "design_residual", "whitened_residuals", "ModelCheck", "check_model", "octave_bands", "MODEL_RESIDUAL_RATIO", "MODEL_ERROR_PROVEN_RATIO",
           "SMOOTH_LAGS", "SMOOTH_EXCESS_LIMIT", "SMOOTH_EXCESS_WITH_FAILED_BAND",
           "BAND_MIN_LINES", "MIN_NOISE_LEVEL",
           "CORRELATED_RESIDUAL_Z"]

#: A band whose median residual is above this many times the noise (both per degree of freedom) fails.
MODEL_RESIDUAL_RATIO = 4.0
#: A band this many times above the noise proves the free model wrong: then every band fails (module docstring).
MODEL_ERROR_PROVEN_RATIO = 2.0 * MODEL_RESIDUAL_RATIO
#: Lags (lines) at which a smooth residual is told from the FRF errors' own correlation (``smooth_excess``).
SMOOTH_LAGS = (5, 6, 7, 8)
#: A ``smooth_excess`` above this (and five of its standard errors) proves the free model wrong (module docstring).
SMOOTH_EXCESS_LIMIT = 0.05
#: ... and above this when some band also fails (its ratio above :data:`MODEL_RESIDUAL_RATIO`).
SMOOTH_EXCESS_WITH_FAILED_BAND = 0.03
#: Fewest lines of a band (octaves are merged with the next until they have as many).
BAND_MIN_LINES = 16
#: Smallest noise level per degree of freedom a ratio is taken against (in the weights' units: with relative
#: weights ``|H|^2`` a relative standard deviation of 1e-4): exact data's round-off says nothing about the model.
MIN_NOISE_LEVEL = 1e-8
#: ``correlation_z`` above this: the residuals are correlated from line to line (one-sided, about 1e-4 for independent
#: lines, as the structured model's whiteness test).
CORRELATED_RESIDUAL_Z = 3.7
#: Fewest residual degrees of freedom per line (complex) for the check.
MIN_REDUNDANCY = 3


@dataclass(frozen=True, eq=False)
class ResidualStatistics:
    """Per-line residual level of the coupling fit and the noise measured from its second differences.

    Attributes
    ----------
    chi2 : ndarray, shape (F,)
        ``sum_k |r_fk|^2 / (|m||e| - p)`` of the whitened residual (units of the weights' scale).
    noise : ndarray, shape (F,)
        ``noise_f`` of the module docstring (NaN on the first and last line).
    correlation : float
        Lag-1 correlation of the whitened residuals over frequency, pooled over the values: the mean over the
        ``2 |m||e|`` real series ``s`` (real and imaginary parts) of ``sum_f s_f s_(f+1) / sum_f s_f^2``. About 0
        (standard deviation ``1 / sqrt(2 (|m||e| - p) F)``) when the FRFs' errors are independent from line to line; positive
        when they are not (an impact test's window or leakage bias, FRFs smoothed or interpolated onto a finer grid) or
        when the free model is off (its residual is smooth over frequency). NaN when not measured.
    correlation_z : float
        ``correlation`` in standard deviations of its value for independent lines.
    lag_correlation : ndarray, shape (SMOOTH_LAGS[-1],)
        The pooled correlation (as ``correlation``) at lags 1, 2, ... lines (empty: not measured).
    lag_correlation_se : float
        Its standard error for independent lines, ``1 / sqrt(2 dof F)``.
    """

    chi2: np.ndarray
    noise: np.ndarray
    correlation: float = float("nan")
    correlation_z: float = float("nan")
    lag_correlation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lag_correlation_se: float = float("nan")

    @property
    def smooth_excess(self) -> float:
        """The residuals' correlation at lags :data:`SMOOTH_LAGS` above what their lag-1 correlation explains
        (module docstring, "A smooth residual"); NaN when not measured."""
        a = self.lag_correlation
        if a.size < SMOOTH_LAGS[-1] or not np.all(np.isfinite(a)):
            return float("nan")
        rho1 = min(max(float(a[0]), 1e-9), 1.0 - 1e-9)
        k = np.asarray(SMOOTH_LAGS, float)
        window = 1.0 / (1.0 + (1.0 / rho1 - 1.0) * k ** 2)  # an exponential window's (Lorentzian) correlation
        return float(np.mean(a[k.astype(int) - 1] - window))


def residual_statistics(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, variance: np.ndarray,
                        symmetric: bool = True) -> ResidualStatistics | None:
    """Residuals of the per-line weighted coupling fit and their line-to-line noise (module docstring).

    Parameters
    ----------
    Ymn, Yne : ndarray, shapes (F, m, n), (F, n, e), complex
        Free receptance blocks, m/N.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]``, m/N.
    variance : ndarray, shape (F, m, e)
        Variance shape of each measured value (the weights), (m/N)^2.
    symmetric : bool

    Returns
    -------
    ResidualStatistics, or None with fewer than 3 lines or :data:`MIN_REDUNDANCY` residual
    degrees of freedom per line.

    Notes
    -----
    The junk-line test and the model check of one identification ask for the same statistics when no
    line was left out and no column correction applied (measured on the 19 901-line benchmark: the
    check's own computation gave the junk test's numbers bit for bit): the last one computed in this
    thread is kept with a copy of its inputs and returned again (read-only arrays) for the same
    ``Ymn``, ``Yne``, ``change`` and ``symmetric`` and a variance within
    :data:`~jointid.methods.receptance.coupling_lines.DESIGN_VARIANCE_RTOL` of its own (the rule of
    the per-line design they are computed from, :func:`~.coupling_lines.whitened_line_design`).
    """
    inputs = (np.asarray(Ymn), np.asarray(Yne), np.asarray(change), np.asarray(variance))
    last = getattr(_LAST_STATISTICS, "entry", None)
    if last is not None and last[1] == bool(symmetric) and same_inputs(inputs, last[0], DESIGN_VARIANCE_RTOL):
        return last[2]
    out = _statistics(*inputs, bool(symmetric))
    if out is not None:
        for a in (out.chi2, out.noise, out.lag_correlation):
            a.flags.writeable = False
    _LAST_STATISTICS.entry = (tuple(a.copy() for a in inputs), bool(symmetric), out)
    return out


#: The last statistics of :func:`residual_statistics` in each thread: (inputs, symmetric, outputs).
_LAST_STATISTICS = threading.local()


def line_residuals(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, variance: np.ndarray, symmetric: bool = True,
                   keep: bool = True) -> tuple[np.ndarray, int] | None:
    """The whitened residual of the weighted per-line coupling fit and its degrees of freedom per line.

    ``r_f = (I - Q Q^H) W^(1/2) (Y[m,e] - H)`` (module docstring); ``sum_k |r_fk|^2 / dof`` is ``chi2_f``.

    Parameters
    ----------
    Ymn, Yne, change, variance, symmetric
        As :func:`residual_statistics`.
    keep : bool
        Keep the per-line design for the next caller (:func:`~.coupling_lines.whitened_line_design`); False for a
        design asked for once (a hypothesis tried on a subset of the lines).

    Returns
    -------
    (r, dof) : ndarray, shape (F, m e), complex, and int; or None below :data:`MIN_REDUNDANCY` degrees of freedom.
    """
    _, m, n = Ymn.shape
    dof = m * Yne.shape[2] - symmetric_parametrization(n, symmetric).shape[1]
    if dof < MIN_REDUNDANCY:
        return None
    with single_threaded_blas():
        sw, _, Q, _ = whitened_line_design(Ymn, Yne, variance, symmetric, keep=keep)
    return map_lines(design_residual, change, sw, Q), dof


def _statistics(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, variance: np.ndarray, symmetric: bool):
    """:func:`residual_statistics`' computation."""
    F, m, _ = Ymn.shape
    e = Yne.shape[2]
    fit = line_residuals(Ymn, Yne, change, variance, symmetric) if F >= 3 else None
    if fit is None:
        return None
    r, dof = fit
    chi2 = np.sum(r.real ** 2 + r.imag ** 2, axis=1) / dof
    d2 = r[2:] - 2.0 * r[1:-1] + r[:-2]
    noise = np.full(F, np.nan)
    noise[1:-1] = np.median(d2.real ** 2 + d2.imag ** 2, axis=1) / (6.0 * np.log(2.0) * dof / (m * e))
    rho, z = _lag_correlation(r, dof)
    lags = (np.array([rho] + [_lag_correlation(r, dof, k)[0] for k in range(2, SMOOTH_LAGS[-1] + 1)])
            if F > 4 * SMOOTH_LAGS[-1] else np.zeros(0))
    return ResidualStatistics(chi2, noise, rho, z, lags, 1.0 / float(np.sqrt(2.0 * dof * F)))


def design_residual(change, sw, Q):
    """The weighted per-line fit's residual ``(I - Q Q^H) d_w``, ``d_w = sw vec(change)``, shape (F, m e), complex.

    ``sw``, ``Q``: the design of :func:`~.coupling_lines.whitened_line_design` (shapes (F, m e), (F, m e, p));
    ``change``: ``Y[m,e] - H``, shape (F, m, e)."""
    F, m, e = change.shape
    return whitened_residuals((change.reshape(F, m * e) * sw)[:, :, None], Q)[:, :, 0]


def whitened_residuals(dw, Q):
    """``(I - Q Q^H) d_w`` for ``h`` whitened data vectors per line at once: ``dw`` (F, m e, h) -> (F, m e, h), complex.

    One product per line for all ``h`` (the hypotheses of :mod:`.gross_errors` share one design);
    ``Q^H d_w`` is formed as ``conj(d_w^H Q)``: no conjugated copy of ``Q``."""
    c = np.conj(np.conj(np.swapaxes(dw, 1, 2)) @ Q)  # (Q^H d_w)^T, (F, h, p)
    return dw - Q @ np.swapaxes(c, 1, 2)


def _lag_correlation(r: np.ndarray, dof: int, lag: int = 1) -> tuple[float, float]:
    """Pooled correlation at ``lag`` lines over the first axis of the real series of ``r`` (F, k) complex, and its z-score.

    For lines with independent errors the mean of ``sum_f s_f s_(f+lag)`` over the series has variance ``(F - lag) * 2 dof``
    times that of one product (the ``k`` values of a line span ``dof`` complex dimensions of residual), so
    ``z = rho sqrt(2 dof (F - lag))`` is about N(0, 1).
    """
    re, im = r.real, r.imag
    den = np.concatenate([np.einsum("fk,fk->k", re, re), np.einsum("fk,fk->k", im, im)])
    lagged = np.concatenate([np.einsum("fk,fk->k", re[lag:], re[:-lag]), np.einsum("fk,fk->k", im[lag:], im[:-lag])])
    use = den > 0
    if not use.any():
        return float("nan"), float("nan")
    rho = float(np.mean(lagged[use] / den[use]))
    return rho, rho * float(np.sqrt(2.0 * dof * (r.shape[0] - lag)))


def octave_bands(hz: np.ndarray, min_lines: int = BAND_MIN_LINES) -> list[tuple[int, int]]:
    """Octaves ``[f0 2^k, f0 2^(k+1))`` from the first line, as index ranges ``(start, stop)``,
    each merged with the next until it has at least ``min_lines`` lines (the last with the one before)."""
    hz = np.asarray(hz, float)
    f0 = max(hz[0], np.finfo(float).tiny)
    k = np.floor(np.log2(np.maximum(hz, f0) / f0) + 1e-12).astype(int)
    edges = np.r_[0, np.flatnonzero(np.diff(k)) + 1, hz.size]
    bands: list[list[int]] = []
    for a, b in zip(edges[:-1], edges[1:]):
        if bands and bands[-1][1] - bands[-1][0] < min_lines:
            bands[-1][1] = int(b)
        else:
            bands.append([int(a), int(b)])
    if len(bands) > 1 and bands[-1][1] - bands[-1][0] < min_lines:
        last = bands.pop()
        bands[-1][1] = last[1]
    return [(a, b) for a, b in bands]


@dataclass(frozen=True, eq=False)
class ModelCheck:
    """The free model's fit per band.

    Attributes
    ----------
    bands : list of (int, int)
        Index ranges of the bands (:func:`octave_bands`).
    ratio : ndarray, shape (bands,)
        ``R_b``: median residual over median noise per degree of freedom (~1 when the model fits).
    failed_lines : ndarray of bool, shape (F,)
        Lines in a failed band: every line when the free model is proven wrong (:attr:`proven_wrong`).
    smooth_excess : float
        :attr:`ResidualStatistics.smooth_excess` when it proves the free model wrong, else NaN.
    """

    bands: list
    ratio: np.ndarray
    failed_lines: np.ndarray
    smooth_excess: float = float("nan")

    @property
    def fits(self) -> bool:
        """Every band passes."""
        return not bool(self.failed_lines.any())

    @property
    def proven_wrong(self) -> bool:
        """Some band is above :data:`MODEL_ERROR_PROVEN_RATIO`, or the residual is smooth (``smooth_excess``): every
        band fails (module docstring)."""
        return bool(np.any(self.ratio > MODEL_ERROR_PROVEN_RATIO)) or np.isfinite(self.smooth_excess)

    def finding(self, hz: np.ndarray, leaking: Sequence[str] = ()) -> str:
        """One line naming the failing bands, the residual and the fix ("" when every band passes).

        ``leaking``: the records the FRF file marks as leaking (``"response/reference"``, :attr:`jointid.frf.FRF.marks`):
        a response still ringing at the record's end biases the FRFs near the lightly damped modes as a model error
        does, so the fix named first is to process those hits again.
        """
        if self.fits:
            return ""
        bad = self.ratio > MODEL_RESIDUAL_RATIO
        fix = ": update it from a free-free test (`jointid update`) or correct the structure's model"
        if leaking:
            names = ", ".join(leaking[:6]) + (", ..." if len(leaking) > 6 else "")
            fix = (f", or {len(leaking)} record(s) marked leaking by jointid frf ({names}) are biased near the lightly damped "
                   "modes: process those hits again (longer records or an exponential window) before you update the free "
                   "model from a free-free test (`jointid update`) or correct the structure's model")
        if not bad.any():  # proven by the smooth residual alone
            return (f"the free model does not explain these FRFs: its residual is near the noise ({self._size(~bad)}) but "
                    f"smooth over frequency (correlation {self.smooth_excess:.2f} at {SMOOTH_LAGS[0]}-{SMOOTH_LAGS[-1]} lines "
                    "beyond what the FRFs' own errors give): a free-model error the joint terms absorb (or a smooth "
                    f"processing error: leakage, a window's correction){fix}; every term flagged unreliable on every line")
        text = f"the free model does not explain these FRFs in {self._where(hz, bad)} (residual {self._size(bad)} the noise)"
        if not self.proven_wrong or bad.all():
            return text + fix + "; every term flagged unreliable there"
        return (text + f"; an error that large is in the whole model, and in {self._where(hz, ~bad)} (residual "
                f"{self._size(~bad)} the noise) the joint terms absorb it{fix}; every term flagged unreliable on every line")

    def _where(self, hz, which) -> str:
        spans: list[list[int]] = []
        for i in np.flatnonzero(which):
            a, b = self.bands[i]
            if spans and spans[-1][1] == a:
                spans[-1][1] = b
            else:
                spans.append([a, b])
        return ", ".join(f"{hz[a]:g}-{hz[b - 1]:g} Hz" for a, b in spans)

    def _size(self, which) -> str:
        lo, hi = (_ratio_text(float(f(self.ratio[which]))) for f in (np.min, np.max))
        return f"{lo}x" if lo == hi else f"{lo}-{hi}x"


def _ratio_text(v: float) -> str:
    """A ratio to two significant figures below 10, as an integer above."""
    return f"{v:.1f}" if v < 9.95 else f"{v:.0f}"


def check_model(hz: np.ndarray, stats: ResidualStatistics, ratio_limit: float = MODEL_RESIDUAL_RATIO,
                smooth_limit: float = SMOOTH_EXCESS_LIMIT) -> ModelCheck:
    """Test the free model band by band: ``R_b = median chi2 / median noise`` against ``ratio_limit``.

    A band fails above ``ratio_limit``; every band fails when some band is above
    :data:`MODEL_ERROR_PROVEN_RATIO` or the residual is smooth over frequency (``smooth_excess`` above
    :data:`SMOOTH_EXCESS_LIMIT`, or :data:`SMOOTH_EXCESS_WITH_FAILED_BAND` with a band failed, and five
    standard errors): the free model proven wrong (module docstring).

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies of the lines, Hz.
    stats : ResidualStatistics
    ratio_limit : float
    smooth_limit : float
        The ``smooth_excess`` that proves the free model wrong when no band fails (with a failed band:
        :data:`SMOOTH_EXCESS_WITH_FAILED_BAND`, or ``smooth_limit`` if lower).

    Returns
    -------
    ModelCheck
    """
    bands = octave_bands(hz)
    ratio = np.ones(len(bands))
    failed = np.zeros(hz.size, bool)
    for i, (a, b) in enumerate(bands):
        noise = stats.noise[a:b]
        noise = noise[np.isfinite(noise) & (noise > 0)]
        chi2 = stats.chi2[a:b][np.isfinite(stats.chi2[a:b])]
        if noise.size == 0 or chi2.size == 0:
            continue
        ratio[i] = float(np.median(chi2) / max(float(np.median(noise)), MIN_NOISE_LEVEL))
        failed[a:b] = ratio[i] > ratio_limit
    excess = stats.smooth_excess
    limit = min(SMOOTH_EXCESS_WITH_FAILED_BAND, smooth_limit) if failed.any() else smooth_limit
    smooth = bool(np.isfinite(excess) and excess > max(limit, 5.0 * stats.lag_correlation_se))
    if np.any(ratio > MODEL_ERROR_PROVEN_RATIO) or smooth:
        failed[:] = True
    return ModelCheck(bands, ratio, failed, excess if smooth else float("nan"))
