"""The variance of each measured FRF value: the weights of the statistical estimators.

An FRF estimated by H1 from ``n`` averages with ordinary coherence ``g^2`` has a
complex random error of variance (Bendat & Piersol, *Random Data*, 9.2; both the
magnitude and the phase have normalized random error
``eps = sqrt(1 - g^2) / (|g| sqrt(2 n))``)::

    E|dH|^2 / |H|^2 = 2 eps^2 = (1 - g^2) / (n g^2)

Antiresonances and lines near the noise floor have low coherence and get
little weight. Without coherence the error is taken as relative
(``E|dH|^2 ~ |H|^2``: a constant signal-to-noise ratio per FRF value). Only the
*shape* of the variance matters to the estimators here: its scale is
re-estimated from the least-squares residuals, so a wrong ``n`` or an unknown
noise level does not bias the uncertainty. A floor of relative standard
deviation :data:`RELATIVE_FLOOR` keeps lines with coherence 1 (noise-free
simulations) finitely weighted.

The coherence of a few averages is itself a noisy estimate (``1 - g^2`` of a
line with true coherence 0.99 from 5 averages scatters by a factor of ~3), and
weights taken from it line by line over-weight lines whose coherence came out
high by chance. The expected variance of an FRF value is smooth over frequency
(a flat noise floor divided by a smooth force spectrum, or a relative force
error times ``|H|^2``), so the coherence-based variance is averaged in log
scale over :data:`COHERENCE_SMOOTHING_LINES` neighbouring lines (running
mean, per FRF value); on the benchmark's virtual hammer test this lowers the
median K_theta_theta error at mid-span from 3.9 % to 1.6 %.

**Column-common noise** (:func:`column_noise_fraction`). In a roving-hammer test
every response of a column shares that column's force record, so noise in the
force channel lowers the coherence of the whole column alike: with ``a_j`` the
force noise-to-signal power ratio of column ``j`` and ``b_rj`` the response
noise-to-signal ratio of value ``(r, j)``, ``(1 - g^2) / g^2 = (1 + a_j)(1 + b_rj) - 1
~ a_j + b_rj``. The ``a_j`` part is not independent noise per value: it is one
error ``H[:, j] eps_j`` common to the column, which the column calibration
(:mod:`jointid.methods.column_calibration`) estimates and removes. Once it has,
the variance left in each value is the ``b`` part only; weighting by the total
variance then treats the column error as if it were still there, and on the
benchmark's virtual hammer test with 1 % force noise gave K_theta_theta 11 %
median error with bands that held the truth on 0.65-0.75 of the lines
(material B at the beam end, 50 tests; 5.8 % and 0.85-0.93 with the split).
The split uses that response noise is a floor per channel over a force spectrum
per column: ``b_rj = s_r t_j / |H_rj|^2``, so per line::

    q_rj = (1 - g_rj^2) / g_rj^2 = a_j + s_r t_j / |H_rj|^2

(``e`` + ``m`` + ``e`` - 1 unknowns; fitted in log scale to the smoothed ``q`` and
``|H|^2``, all lines at once by Levenberg-Marquardt; fractions below :data:`SPLIT_MIN_FRACTION`
are raised to it). Caveats: it needs ``m >= 3`` responses and ``e >= 2`` columns with
:data:`SPLIT_MIN_REDUNDANCY` more values than unknowns per line, else nothing
is split; response noise that is not a floor per channel (e.g. a mass-loading
or cable error proportional to ``|H|``) is taken as column-common. The split
gives the column calibration its first weights; the final ones are measured from
the residuals once the column error is removed
(:func:`jointid.methods.column_calibration.residual_variance`).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..errors import IdentificationError

__all__ = ["frf_variance", "column_noise_fraction", "WEIGHTINGS", "RELATIVE_FLOOR", "COHERENCE_SMOOTHING_LINES", "SPLIT_MIN_REDUNDANCY", "SPLIT_MIN_FRACTION"]

WEIGHTINGS = ("auto", "coherence", "relative", "none")
#: Smallest relative standard deviation assigned to an FRF value (calibration, round-off).
RELATIVE_FLOOR = 1e-6
#: Lines over which the coherence-based variance is averaged (log scale); at most a tenth of the lines.
COHERENCE_SMOOTHING_LINES = 41
#: Values per line beyond the split's unknowns (``m e - (m + 2 e - 1)``) below which nothing is split.
SPLIT_MIN_REDUNDANCY = 3
#: Smallest fraction kept (weights at most 1 / this times those of the total variance): a channel whose
#: noisy coherence happens to match its column's force noise would otherwise get no response noise at all.
SPLIT_MIN_FRACTION = 0.05
#: Levenberg-Marquardt iterations of the split (log-scale least squares, all lines at once).
_SPLIT_ITERATIONS = 30
#: Jacobian entries per batch of lines (~8 bytes each).
_SPLIT_CHUNK_VALUES = 4_000_000


def frf_variance(
    data: np.ndarray,
    coherence: np.ndarray | None = None,
    weighting: str = "auto",
    averages: int | None = None,
) -> tuple[np.ndarray, str]:
    """Variance shape of each FRF value, ``E|dH|^2`` up to a common scale, shape (F, m, e).

    Parameters
    ----------
    data : ndarray, shape (F, m, e), complex
        FRF values (any kind: the variance is in the square of its unit).
    coherence : ndarray, shape (F, m, e), optional
        Ordinary coherence of each value (0..1).
    weighting : {"auto", "coherence", "relative", "none"}
        "auto": coherence if given, else relative.
    averages : int, optional
        Number of averages behind the coherence (default 1; it only scales).

    Returns
    -------
    variance : ndarray, shape (F, m, e)
    source : str
        The weighting used.
    """
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    mag2 = np.abs(data) ** 2
    if weighting == "auto":
        weighting = "coherence" if coherence is not None else "relative"
    if weighting == "none":
        return np.full(data.shape, float(np.median(mag2)) or 1.0), "none"
    rel = np.full(data.shape, RELATIVE_FLOOR**2)
    if weighting == "coherence":
        if coherence is None:
            raise IdentificationError("weighting = 'coherence' needs coherence records in the FRF file; use 'relative'")
        g2 = _coherence(coherence, data.shape)
        rel = rel + (1.0 - g2) / (g2 * (averages or 1))
        var = _smooth_log(rel * np.maximum(mag2, np.finfo(float).tiny))
        return var, weighting
    rel = rel + 1.0
    return rel * np.maximum(mag2, np.finfo(float).tiny), weighting


def column_noise_fraction(data: np.ndarray, coherence: np.ndarray) -> np.ndarray:
    """Fraction of each FRF value's coherence-based variance that is *not* common to its column.

    Splits ``q = (1 - g^2) / g^2`` into a column-common part ``a_j`` (force-channel
    noise) and a per-value part ``s_r t_j / |H_rj|^2`` (response noise over the force
    spectrum), line by line, as in the module docstring.

    Parameters
    ----------
    data : ndarray, shape (F, m, e), complex
        FRF values (any kind; only ratios across a line's values matter).
    coherence : ndarray, shape (F, m, e)
        Ordinary coherence of each value (0..1).

    Returns
    -------
    ndarray, shape (F, m, e)
        ``b_rj / (a_j + b_rj)``, at least :data:`SPLIT_MIN_FRACTION`: multiply the variance of
        :func:`frf_variance` by it once the column errors have been removed.
        All ones when the layout cannot separate the parts (see
        :data:`SPLIT_MIN_REDUNDANCY`).
    """
    F, m, e = data.shape
    if m < 3 or e < 2 or m * e - (m + 2 * e - 1) < SPLIT_MIN_REDUNDANCY:
        return np.ones(data.shape)
    g2 = _coherence(coherence, data.shape)
    tiny = np.finfo(float).tiny
    q = _smooth_log(np.maximum((1.0 - g2) / g2, RELATIVE_FLOOR**2))
    M = _smooth_log(np.maximum(np.abs(data) ** 2, tiny))
    logq, logM = np.log(q).reshape(F, m * e), np.log(M).reshape(F, m * e)
    chunk = max(1, _SPLIT_CHUNK_VALUES // (m * e * (m + 2 * e)))  # lines per batch: bounded memory
    frac = np.concatenate([_split(logq[i:i + chunk], logM[i:i + chunk], m, e) for i in range(0, F, chunk)])
    return np.maximum(frac, SPLIT_MIN_FRACTION).reshape(F, m, e)


def _split(logq: np.ndarray, logM: np.ndarray, m: int, e: int) -> np.ndarray:
    """``b / (a + b)`` of lines (rows of ``logq``, ``logM``: shape (F, m e)) by Levenberg-Marquardt in log scale."""
    F = logq.shape[0]
    q, M = np.exp(logq).reshape(F, m, e), np.exp(logM).reshape(F, m, e)
    # parameters per line, in log: a_j (e), s_r (m), t_j (e - 1; t_0 = 1 fixes the scale)
    rows, cols = np.divmod(np.arange(m * e), e)
    Sa = np.zeros((m * e, e)); Sa[np.arange(m * e), cols] = 1
    Ss = np.zeros((m * e, m)); Ss[np.arange(m * e), rows] = 1
    St = Sa[:, 1:]
    theta = np.concatenate([np.log(0.5 * q.min(axis=1)), np.log(np.median(q * M, axis=2)), np.zeros((F, e - 1))], axis=1)
    lo = np.log(RELATIVE_FLOOR**2)

    def parts(th):
        la = th[:, :e] @ Sa.T
        lb = th[:, e:e + m] @ Ss.T + th[:, e + m:] @ St.T - logM
        top = np.maximum(la, lb)
        lmod = top + np.log(np.exp(la - top) + np.exp(lb - top))
        return la, lb, lmod

    def cost(th):
        return np.sum((logq - parts(th)[2]) ** 2, axis=1)

    lam = np.full(F, 1e-2)
    c = cost(theta)
    for _ in range(_SPLIT_ITERATIONS):  # Levenberg-Marquardt, every line at once
        la, lb, lmod = parts(theta)
        wa, wb = np.exp(la - lmod), np.exp(lb - lmod)  # shares of the model
        J = np.concatenate([wa[:, :, None] * Sa, wb[:, :, None] * Ss, wb[:, :, None] * St], axis=2)  # d lmod / d theta
        r = logq - lmod
        Jt = np.swapaxes(J, 1, 2)
        JJ = Jt @ J  # batched BLAS (einsum's loop took 10 s on a 196-line frame test)
        g = (Jt @ r[..., None])[..., 0]
        D = np.einsum("fkk->fk", JJ) + 1e-12
        step = np.linalg.solve(JJ + lam[:, None, None] * D[:, :, None] * np.eye(JJ.shape[1]), g[..., None])[..., 0]
        trial = theta + step
        trial[:, :e] = np.maximum(trial[:, :e], lo)
        ct = cost(trial)
        better = ct < c
        theta = np.where(better[:, None], trial, theta)
        c = np.where(better, ct, c)
        lam = np.where(better, lam / 3.0, lam * 4.0)
    la, lb, lmod = parts(theta)
    return np.exp(lb - lmod)


def _coherence(coherence, shape) -> np.ndarray:
    g2 = np.clip(np.asarray(coherence, dtype=float), 1e-6, 1.0)
    if g2.shape != shape:
        raise IdentificationError(f"coherence has shape {g2.shape}, the FRFs {shape}")
    return g2


def _smooth_log(x: np.ndarray) -> np.ndarray:
    """Running mean in log scale over :data:`COHERENCE_SMOOTHING_LINES` lines (at most a tenth of them)."""
    width = min(COHERENCE_SMOOTHING_LINES, max(1, x.shape[0] // 10)) | 1
    return np.exp(uniform_filter1d(np.log(x), width, axis=0, mode="nearest")) if width > 1 else x
