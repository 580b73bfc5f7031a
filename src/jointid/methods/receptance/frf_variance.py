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
mean, per FRF value), which matters most for the weakly seen rotational term
(``benchmarks/robust_identification.py`` prints the default's error per term on the
virtual hammer test).

**Column-common noise** (:func:`column_noise_fraction`). In a roving-hammer test
every response of a column shares that column's force record, so noise in the
force channel lowers the coherence of the whole column alike: with ``a_j`` the
force noise-to-signal power ratio of column ``j`` and ``b_rj`` the response
noise-to-signal ratio of value ``(r, j)``, ``(1 - g^2) / g^2 = (1 + a_j)(1 + b_rj) - 1
~ a_j + b_rj``. The ``a_j`` part is not independent noise per value: it is one
error ``H[:, j] eps_j`` common to the column, which the column calibration
(:mod:`jointid.methods.receptance.column_calibration`) estimates and removes. Once it has,
the variance left in each value is the ``b`` part only; weighting by the total
variance then treats the column error as if it were still there: it costs
K_theta_theta accuracy and leaves its bands too narrow
(``benchmarks/robust_identification.py --hammer-seeds 50 --cases B1`` prints the
default's error and band coverage, with the split, on a hammer test with force noise).
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
(:func:`jointid.methods.receptance.column_calibration.residual_variance`).
"""

from __future__ import annotations

import numpy as np

from ...errors import IdentificationError
from ...parallel import map_chunks, single_threaded_blas, worker_count
from ..moving_average import moving_average

__all__ = ["frf_variance", "column_noise_fraction", "smooth_coherence_variance", "WEIGHTINGS", "RELATIVE_FLOOR", "COHERENCE_SMOOTHING_LINES", "SPLIT_MIN_REDUNDANCY", "SPLIT_MIN_FRACTION"]

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
        var = smooth_coherence_variance(rel, np.maximum(mag2, np.finfo(float).tiny))
        return var, weighting
    rel = rel + 1.0
    return rel * np.maximum(mag2, np.finfo(float).tiny), weighting


#: Spread of ``log q`` over a line's values below which the line carries no split (the coherence is the same
#: for every value: nothing tells column noise from response noise).
FLAT_LOG_Q = 1e-6


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
        :data:`SPLIT_MIN_REDUNDANCY`); one on a line whose coherence is the same for every value
        (:data:`FLAT_LOG_Q`) or where the split does not converge to finite shares.
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
    chunk = min(chunk, -(-F // worker_count(F)))  # and at least one batch per core (lines are independent)
    frac = np.empty((F, m * e))

    def split(lines: np.ndarray) -> None:
        a, b = int(lines[0]), int(lines[-1]) + 1
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # degenerate lines: handled below
            frac[a:b] = _split(logq[a:b], logM[a:b], m, e)

    with single_threaded_blas():  # (F, 21) x (21, 3) products: BLAS threads only contend on such sizes
        map_chunks(split, np.arange(F), chunk)  # numpy releases the GIL: the batches run on the cores
    # a line whose q is the same for every value (a constant coherence: a file that gives one value, or
    # none) cannot tell column noise from response noise: keep the whole variance there (fraction 1),
    # as where the split did not converge to finite shares
    flat = np.ptp(logq, axis=1) < FLAT_LOG_Q
    frac[flat | ~np.isfinite(frac).all(axis=1)] = 1.0
    return np.maximum(frac, SPLIT_MIN_FRACTION).reshape(F, m, e)


def _split(logq: np.ndarray, logM: np.ndarray, m: int, e: int) -> np.ndarray:
    """``b / (a + b)`` of lines (rows of ``logq``, ``logM``: shape (F, m e)) by Levenberg-Marquardt in log scale.

    Parameters per line, in log: ``a_j`` (e), ``s_r`` (m), ``t_j`` (e - 1; ``t_0 = 1`` fixes the
    scale). The model ``lmod = log(exp(la) + exp(lb))`` with ``la[r, j] = a_j`` and
    ``lb[r, j] = s_r + t_j - log M[r, j]`` has the Jacobian columns ``wa`` (a), ``wb`` (s, t) with
    ``wa, wb = exp(la - lmod), exp(lb - lmod)``, each nonzero on one row or one column of the
    (m, e) values, so the normal matrix is formed from sums over rows and columns, its ``s``
    block is diagonal and is eliminated (Schur complement), and the remaining ``2 e - 1``
    unknowns are solved by a Cholesky factorization vectorized over the lines.
    """
    F = logq.shape[0]
    lq = logq.reshape(F, m, e)
    lM = logM.reshape(F, m, e)
    q, M = np.exp(lq), np.exp(lM)
    a = np.log(0.5 * q.min(axis=1))  # (F, e)
    s_ = np.log(np.median(q * M, axis=2))  # (F, m)
    t = np.zeros((F, e - 1))
    lo = np.log(RELATIVE_FLOOR**2)
    rows, cols = np.divmod(np.arange(m * e), e)
    on_col = (cols[:, None] == np.arange(e)).astype(float)  # (m e, e): sum over the rows r of a column j
    on_row = (rows[:, None] == np.arange(m)).astype(float)  # (m e, m): sum over the columns j of a row r

    def col_sum(x):  # (F, m, e) -> (F, e), one BLAS product
        return x.reshape(F, m * e) @ on_col

    def row_sum(x):  # (F, m, e) -> (F, m)
        return x.reshape(F, m * e) @ on_row

    def model(a, s_, t):
        """``lmod`` and the shares ``wa, wb`` (one exp, one log1p per value)."""
        la = a[:, None, :]
        lb = s_[:, :, None] + np.concatenate([np.zeros((F, 1)), t], axis=1)[:, None, :] - lM
        d = la - lb
        ex = np.exp(-np.abs(d))
        lmod = np.maximum(la, lb) + np.log1p(ex)
        inv = 1.0 / (1.0 + ex)
        big_a = d >= 0
        return lmod, np.where(big_a, inv, ex * inv), np.where(big_a, ex * inv, inv)

    def cost(lmod):
        return np.sum(((lq - lmod) ** 2).reshape(F, m * e), axis=1)

    lam = np.full(F, 1e-2)
    lmod, wa, wb = model(a, s_, t)
    c = cost(lmod)
    kt = np.arange(e - 1)
    k = np.arange(e)
    for _ in range(_SPLIT_ITERATIONS):  # Levenberg-Marquardt, every line at once
        r = lq - lmod
        wab = wa * wb
        wb2 = wb * wb
        # J^T J by blocks (the diagonal ones as vectors) and J^T r
        d_a = col_sum(wa * wa)  # (F, e)
        d_s = row_sum(wb2)  # (F, m)
        d_t = col_sum(wb2)[:, 1:]  # (F, e - 1)
        c_at = col_sum(wab)[:, 1:]  # (F, e - 1): a_j with t_j (j >= 1)
        g_a, g_s, g_t = col_sum(wa * r), row_sum(wb * r), col_sum(wb * r)[:, 1:]
        damp = 1.0 + lam[:, None]  # JJ + lam (diag(JJ) + 1e-12)
        tiny = lam[:, None] * 1e-12
        h_a, h_s, h_t = d_a * damp + tiny, d_s * damp + tiny, d_t * damp + tiny
        # Schur complement of the diagonal s block: unknowns u = (a, t), coupling C (F, m, 2e - 1)
        C = np.concatenate([wab, wb2[:, :, 1:]], axis=2)
        Cs = C / h_s[:, :, None]
        S = -(np.swapaxes(C, 1, 2) @ Cs)  # (F, 2e - 1, 2e - 1)
        S[:, k, k] += h_a
        S[:, e + kt, e + kt] += h_t
        S[:, kt + 1, e + kt] += c_at
        S[:, e + kt, kt + 1] += c_at
        g_u = np.concatenate([g_a, g_t], axis=1) - (np.swapaxes(Cs, 1, 2) @ g_s[:, :, None])[:, :, 0]
        u = _cholesky_solve(S, g_u)
        step_s = (g_s - (C @ u[:, :, None])[:, :, 0]) / h_s
        ta, ts, tt = np.maximum(a + u[:, :e], lo), s_ + step_s, t + u[:, e:]
        lmod_t, wa_t, wb_t = model(ta, ts, tt)
        ct = cost(lmod_t)
        better = ct < c
        b1, b3 = better[:, None], better[:, None, None]
        a, s_, t = np.where(b1, ta, a), np.where(b1, ts, s_), np.where(b1, tt, t)
        lmod, wa, wb = np.where(b3, lmod_t, lmod), np.where(b3, wa_t, wa), np.where(b3, wb_t, wb)
        c = np.where(better, ct, c)
        lam = np.where(better, lam / 3.0, lam * 4.0)
    return wb.reshape(F, m * e)


def _cholesky_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for symmetric positive definite ``A`` (F, k, k), ``b`` (F, k): Cholesky vectorized over F.

    A loop over the ``k`` (small) columns, each step an array operation over all lines: no
    per-line LAPACK call (batched ``numpy.linalg.solve`` spends its time calling one per line).
    """
    F, k, _ = A.shape
    L = np.zeros_like(A)
    for j in range(k):
        d = A[:, j, j] - np.sum(L[:, j, :j] ** 2, axis=1)
        L[:, j, j] = np.sqrt(np.maximum(d, np.finfo(float).tiny))
        if j + 1 < k:
            L[:, j + 1:, j] = (A[:, j + 1:, j] - np.einsum("fik,fk->fi", L[:, j + 1:, :j], L[:, j, :j])) / L[:, j, j][:, None]
    y = np.empty_like(b)
    for j in range(k):
        y[:, j] = (b[:, j] - np.sum(L[:, j, :j] * y[:, :j], axis=1)) / L[:, j, j]
    x = np.empty_like(b)
    for j in reversed(range(k)):
        x[:, j] = (y[:, j] - np.sum(L[:, j + 1:, j] * x[:, j + 1:], axis=1)) / L[:, j, j]
    return x


def _coherence(coherence, shape) -> np.ndarray:
    g2 = np.clip(np.asarray(coherence, dtype=float), 1e-6, 1.0)
    if g2.shape != shape:
        raise IdentificationError(f"coherence has shape {g2.shape}, the FRFs {shape}")
    return g2


def smooth_coherence_variance(q: np.ndarray, mag2: np.ndarray) -> np.ndarray:
    """The coherence-based variance ``q |H|^2`` averaged over neighbouring lines without smoothing ``|H|^2``.

    Within a running window of :data:`COHERENCE_SMOOTHING_LINES` lines, per FRF value, ``log q``
    is regressed on ``x = log |H|^2``: ``log q ~ c + beta (x - mean x)``, with the slope
    ``beta`` clipped to ``[-1, 0]`` and evaluated at each line's own ``x``::

        var = exp(mean(log q) + beta (x - mean x)) |H|^2

    ``beta = 0`` is a relative error (force noise, a constant signal-to-noise ratio:
    ``q`` smooth, ``var ~ |H|^2`` through resonances and antiresonances); ``beta = -1`` a noise
    floor over a smooth force spectrum (``var`` smooth); the data choose between them, window
    by window. Averaging ``q |H|^2`` itself (the floor model alone) under-weights nothing but
    makes the variance of a resonance peak the window's mean, many times too small where a
    relative error dominates (bands too narrow at the peaks, spurious column calibrations;
    ``benchmarks/real_world_checks.py --cases junkref`` prints the coverage).

    Parameters
    ----------
    q : ndarray, shape (F, ...)
        ``(1 - g^2) / (n g^2)`` per value, > 0 (relative variance from the coherence).
    mag2 : ndarray, shape (F, ...)
        ``|H|^2`` per value, > 0 (unit^2).

    Returns
    -------
    ndarray, shape (F, ...)
        Smoothed variance (unit^2). Caveat: a window that spans values of both kinds takes the
        slope of their mix; lines fewer than ten per window are not smoothed.
    """
    width = min(COHERENCE_SMOOTHING_LINES, max(1, q.shape[0] // 10)) | 1
    if width == 1:
        return q * mag2
    y, x = np.log(q), np.log(mag2)

    def mean(z):
        return moving_average(z, width, axis=0)

    my, mx = mean(y), mean(x)
    sxx = np.maximum(mean(x * x) - mx * mx, 0.0)
    sxy = mean(x * y) - mx * my
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = np.where(sxx > 0.0, sxy / sxx, 0.0)
    beta = np.clip(np.nan_to_num(beta), -1.0, 0.0)
    return np.exp(my + beta * (x - mx)) * mag2


def _smooth_log(x: np.ndarray) -> np.ndarray:
    """Running mean in log scale over :data:`COHERENCE_SMOOTHING_LINES` lines (at most a tenth of them)."""
    width = min(COHERENCE_SMOOTHING_LINES, max(1, x.shape[0] // 10)) | 1
    return np.exp(moving_average(np.log(x), width, axis=0)) if width > 1 else x
