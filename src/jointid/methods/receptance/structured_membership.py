"""Does the joint belong to the structured model's class? Residual whiteness over frequency.

``chi^2/dof`` of the structured fit (:mod:`jointid.methods.receptance.structured_fit`)
compares the misfit with the per-line covariance, whose scale is itself estimated from
each line's residuals: the test needs a tolerance (``chi^2/dof <= 1.5``), and a joint
just outside the class (a fractional-Zener modulus, a power law on one term, two
materials in parallel, a free model with a mesh error) leaves a misfit below it. Its
bands are then too narrow and its error is systematic.

What such a misfit has that noise has not is *shape*: it is smooth over frequency, so the
normalized residuals of neighbouring lines are correlated, where the noise of
independent lines is not. The statistic here is the autocorrelation of the whitened
residuals over frequency at lags 1 to :data:`LAGS` (the residual that the fit minimizes,
``(I + G G^H)^(-1/2) C_f^(-1/2) (x_f - x_f(theta))``, common calibration error profiled
out), one real series per whitened component and part::

    rho_s(L) = sum_f z_s(f) z_s(f+L) / sum_f z_s(f)^2,
    Z = sum_L sum_s sqrt(F - L) rho_s(L) / sqrt(LAGS S),

not demeaned (a constant offset counts as shape too). For independent lines each
``sqrt(F - L) rho_s(L)`` is about ``N(0, 1)`` and the lags are asymptotically independent
(Box & Pierce 1970); the components of the whitened residual are independent of each
other, so the pooled ``Z`` over the ``S = 2 p`` series (p terms, real and imaginary) and
the lags is ``N(0, 1)`` too. A missed shape, smooth over many lines, makes every short lag
positive and ``Z`` grows as ``sqrt(LAGS)``; the test is one-sided (:data:`MAX_WHITENESS_Z`).
It is a one-sided Box-Pierce (portmanteau) test, and at lag 1 the Durbin-Watson statistic in
another form (``DW ~ 2 (1 - rho)``). Unlike ``chi^2/dof`` it does not depend on the
covariance's scale: a smooth error in that scale (e.g. from the residual variance
estimated per line) multiplies neighbouring residuals alike and leaves ``rho`` at 0.
The ``P`` fitted parameters bias ``rho`` by ``O(P / F)``, negative for smooth model
functions (least-squares residuals of smooth regressors are anti-correlated); the bias
is removed exactly for the linearized fit (``-sum_f H[f, f+L]`` of its hat matrix), so
``Z`` is centred on 0 also on a few hundred lines.

Caveats
-------
* It needs independent errors from line to line. Noise correlated between neighbouring
  lines (a record windowed so hard that neighbouring lines share leakage, FRFs
  interpolated onto a finer grid, a smoothed H1) makes ``rho`` positive for a joint in the
  class: such data are rejected, and the estimate falls back to per-term smoothing
  (conservative, not wrong).
* A misfit that changes sign from line to line (a narrow resonance missed between two
  lines) is not seen; ``chi^2/dof`` still tests its size.
* The power grows with the number of lines: on a few dozen lines only a misfit well above
  the noise is seen.
* The components follow the whitening's Cholesky order (the upper-triangle terms): the
  second is the second term's residual given the first's, and so on; the per-term values
  name where the shape is missed, the decision uses the pooled ``Z``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Membership", "membership", "whitened_residuals", "lag_correlation", "fitting_bias", "hat_factor", "MAX_WHITENESS_Z", "LAGS"]

#: Lags pooled by the statistic.
LAGS = 4
#: The structured model is rejected when the pooled whiteness statistic exceeds this (one-sided, about 1e-4 under the null).
MAX_WHITENESS_Z = 3.7


@dataclass(frozen=True)
class Membership:
    """The whiteness test of a structured fit's residuals over frequency.

    Attributes
    ----------
    z : float
        Pooled ``sum_L sum_s sqrt(F - L) rho_s(L) / sqrt(LAGS S)``: about N(0, 1) when the joint is in the class.
    rho : ndarray, shape (p, 2)
        Autocorrelation of each whitened component's real and imaginary part, averaged over lags 1 to ``LAGS``.
    lines : int
        Lines tested.
    passed : bool
        ``z <= MAX_WHITENESS_Z``.
    """

    z: float
    rho: np.ndarray
    lines: int
    passed: bool

    def worst_term(self) -> int:
        """Index (upper-triangle order) of the component whose residuals are most correlated."""
        return int(np.argmax(self.rho.mean(axis=1)))


def whitened_residuals(fit, hz, lines, common=None) -> tuple:
    """The fit's whitened real residual and its Jacobian, as the fit's least squares sees them.

    Parameters
    ----------
    fit : StructuredFit
    hz : ndarray, shape (F,)
    lines : LineEstimates
        ``x``, ``x_covariance``, ``Ynn`` on ``hz``.
    common : ndarray, shape (F, p, k), complex, optional
        The common error's factor, profiled out as in the fit.

    Returns
    -------
    z : ndarray, shape (F, p, 2)
        ``sqrt(2)`` times the real and imaginary part of each line's whitened residual (unit variance under the model).
    J : ndarray, shape (F, p, 2, P)
        Its derivative with respect to the parameters (for the fitting's bias of the lag products).
    """
    from .structured_fit import whitened_residual

    r, J = whitened_residual(fit, hz, lines, common)
    F, p = lines.x.shape
    return r.reshape(2, F, p).transpose(1, 2, 0), J.reshape(2, F, p, -1).transpose(1, 2, 0, 3)


def lag_correlation(z: np.ndarray, lag: int = 1) -> np.ndarray:
    """``sum_f z(f) z(f + lag) / sum_f z(f)^2`` over the first axis (not demeaned), shape ``z.shape[1:]``."""
    z = np.asarray(z, float)
    den = np.sum(z * z, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, np.sum(z[lag:] * z[:-lag], axis=0) / den, 0.0)


def fitting_bias(J: np.ndarray, lag: int, JM: np.ndarray | None = None) -> np.ndarray:
    """Expected lag product of least-squares residuals of white noise, per series: ``-sum_f H[f, f + lag]``.

    ``H = J (J^T J)^-1 J^T`` is the fit's hat matrix (linearized); ``J`` shape (F, ..., P), returns shape ``J.shape[1:-1]``.
    ``JM``: ``J (J^T J)^+`` when already formed (the same for every lag: :func:`hat_factor`).
    """
    if JM is None:
        JM = hat_factor(J)
    return -np.einsum("f...j,f...j->...", JM[:-lag], J[lag:])


def hat_factor(J: np.ndarray) -> np.ndarray:
    """``J (J^T J)^+``, shape of ``J``: one product for every lag of :func:`fitting_bias`."""
    P = J.shape[-1]
    flat = J.reshape(-1, P)
    return (flat @ np.linalg.pinv(flat.T @ flat)).reshape(J.shape)


def membership(fit, hz, lines, common=None, max_z: float = MAX_WHITENESS_Z) -> Membership:
    """Test the fit's residuals for whiteness over frequency (module docstring).

    The lag products are corrected for the fit's own bias (:func:`fitting_bias`, about
    ``-P / F`` per lag for smooth model functions), so ``z`` is centred on 0 under the model
    also on a few lines.

    Parameters
    ----------
    fit : StructuredFit
    hz : ndarray, shape (F,)
        Frequencies, Hz, ascending (neighbours in this order are tested).
    lines : LineEstimates
    common : ndarray, optional
        As for the fit.
    max_z : float
        One-sided critical value of the pooled statistic.

    Returns
    -------
    Membership
    """
    z, J = whitened_residuals(fit, hz, lines, common)
    F = z.shape[0]
    lags = [L for L in range(1, LAGS + 1) if L < F - 1]
    if not lags:
        return Membership(0.0, np.zeros(z.shape[1:]), F, True)
    den = np.maximum(np.mean(z * z, axis=0), 1e-300)  # (p, 2): each series' variance (scale-free statistic)
    JM = hat_factor(J)
    rho = np.stack([(np.sum(z[L:] * z[:-L], axis=0) / den - fitting_bias(J, L, JM)) / F for L in lags])  # (lags, p, 2)
    stat = float(np.sum(np.sqrt(F - np.array(lags, float))[:, None, None] * rho) / np.sqrt(rho.size))
    return Membership(stat, rho.mean(axis=0), F, bool(np.isfinite(stat) and stat <= max_z))
