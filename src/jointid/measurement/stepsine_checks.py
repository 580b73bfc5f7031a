"""Clipping and harmonic distortion of a step-sine block: when F1 / X1 no longer describes the test.

A saturated load cell (amplifier, actuator) clips its channel: the record holds
its limit for as long as the true signal exceeds it. The fundamental of a
clipped sine is smaller than the true one (clipped at ``c`` times its peak:
``(2 / pi) (asin c + c sqrt(1 - c^2))`` of it, so the identified modulus reads
far low), so such a block must not be identified from. :func:`distortion_problems`
names what is wrong with one block, used by
:func:`jointid.measurement.stepsine.process_block`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_THD", "MAX_FLAT_SHARE", "MAX_DRIFT", "MAX_PEAK_SLOPE", "PEAK_WINDOW", "flat_top_share", "peak_slope",
           "distortion_problems", "drift_problem"]

#: Total harmonic distortion (harmonics 2..H over the fundamental) of either channel above which a block
#: is flagged distorted. Smooth distortion does not bias the fundamental (the harmonics are fitted with it:
#: a 20 % third harmonic leaves K21 exact), clipping does; far beyond an elastomer's own nonlinearity (a few
#: per cent), a THD above 25 % means clipping that noise hides from the flat-top test (a sine clipped at
#: 30 % of its peak has a THD of ~0.32) or a test too nonlinear for one K21.
MAX_THD = 0.25
#: Share of a channel's samples on flat tops (runs of >= 3 equal samples at its maximum or minimum) above
#: which the channel is flagged clipped (a saturated load cell, amplifier or actuator).
MAX_FLAT_SHARE = 0.01

#: A channel is flagged clipped when the slope of its samples against its fundamental near either extreme (where
#: ``|cos(w t + phi)| >`` :data:`PEAK_WINDOW`) is, by four standard errors, below this share of a sine's (1):
#: a clipped peak is flat (slope 0) whatever noise is added after the clip, which hides it from the flat-top
#: test. A smooth third harmonic ``a_3`` changes the slope to about ``1 + 9 a_3 cos(phi_3)`` (2 %: 0.82 to 1.18);
#: only a harmonic of over 5.5 % that flattens the peaks comes near 0.5.
MAX_PEAK_SLOPE = 0.5
#: ``|cos|`` of the fundamental's phase above which a sample is near an extreme (within 26 degrees; 14 % of the
#: samples at each extreme; a sine clipped at 90 % of its peak or lower is flat over all of it).
PEAK_WINDOW = 0.9

#: Change of ``|F1 / X1|`` over a block's settled cycles (a straight line through the per-cycle values, relative)
#: above which the block is flagged not stationary (a specimen heating, the machine drifting): its K21 is a time
#: average that the bands of the fits do not know of (0.5 %/s over a 12-cycle block at 1 Hz: 4 % off).
MAX_DRIFT = 0.01


def flat_top_share(y: np.ndarray) -> float:
    """Share of the samples of ``y`` on flat tops: runs of >= 3 consecutive samples equal (to 1e-9 of the range) to its max or min.

    A sampled sinusoid has at most two equal samples around a peak (symmetric
    sampling); a clipped one holds its limit for as long as the signal exceeds it.

    Parameters
    ----------
    y : ndarray, shape (n,)
        One channel's samples (any unit).

    Returns
    -------
    float
        In [0, 1].
    """
    y = np.asarray(y, dtype=float)
    rng = float(y.max() - y.min()) if y.size else 0.0
    if rng <= 0:
        return 0.0
    tol = 1e-9 * rng
    total = 0
    for at in (y >= y.max() - tol, y <= y.min() + tol):
        edges = np.diff(np.concatenate(([0], at.astype(np.int8), [0])))
        runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
        total += int(runs[runs >= 3].sum())
    return total / y.size


def peak_slope(y: np.ndarray, fundamental: np.ndarray, envelope: np.ndarray) -> tuple[float, float]:
    """Slope of a channel against its fundamental near its extremes, and its standard error (the flatter extreme).

    At each extreme (samples where ``c = u / e`` is above :data:`PEAK_WINDOW`, or below its negative; ``u`` the
    fitted fundamental, ``e`` its amplitude) the samples are fitted by a straight line ``y = a + b u`` (least squares);
    ``se_b = s / sqrt(sum (u - mean u)^2)`` from the line's residual ``s``. A sine gives ``b = 1``, a clipped peak
    ``b = 0`` (its samples sit at the clip level plus noise).

    Parameters
    ----------
    y : ndarray, shape (n,)
        The channel's samples less its fitted offset (channel units).
    fundamental : ndarray, shape (n,)
        ``u``: the fitted fundamental at the samples (same units).
    envelope : ndarray, shape (n,)
        ``e > 0``: the fundamental's amplitude at the samples (same units).

    Returns
    -------
    (float, float)
        ``(b, se_b)`` of the extreme with the smallest ``b + 4 se_b``; ``(nan, nan)`` with fewer than 6 samples at
        an extreme.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.asarray(fundamental, float) / np.asarray(envelope, float)
    best = (float("nan"), float("nan"))
    for at in (c > PEAK_WINDOW, c < -PEAK_WINDOW):
        n = int(at.sum())
        if n < 6:
            return float("nan"), float("nan")
        u, v = fundamental[at], y[at]
        uc = u - u.mean()
        sxx = float(np.dot(uc, uc))
        if sxx <= 0:
            return float("nan"), float("nan")
        b = float(np.dot(uc, v - v.mean()) / sxx)
        r = v - v.mean() - b * uc
        se = float(np.sqrt(np.dot(r, r) / (n - 2) / sxx))
        if not np.isfinite(best[0]) or b + 4.0 * se < best[0] + 4.0 * best[1]:
            best = (b, se)
    return best


def distortion_problems(force: np.ndarray, force_thd: float, displacement: np.ndarray, displacement_thd: float,
                        force_peak: tuple[float, float] | None = None,
                        displacement_peak: tuple[float, float] | None = None) -> list[str]:
    """What is wrong with a block's channels: ``["force clipped (flat tops on 33% of the samples)"]``, or ``[]``.

    Parameters
    ----------
    force, displacement : ndarray, shape (n,)
        The samples the fit used (N, m).
    force_thd, displacement_thd : float
        Their total harmonic distortion ``sqrt(sum_{h>=2} |P_h|^2) / |P_1|``.
    force_peak, displacement_peak : (float, float), optional
        :func:`peak_slope` of each channel: flagged ``"force clipped (flat peaks under the noise: slope 2 % of a
        sine's near them)"`` when ``b + 4 se_b <`` :data:`MAX_PEAK_SLOPE`.
    """
    problems = []
    for name, y, d, pk in (("force", force, force_thd, force_peak),
                           ("displacement", displacement, displacement_thd, displacement_peak)):
        flat = flat_top_share(y)
        b, se = pk if pk is not None else (float("nan"), float("nan"))
        if flat > MAX_FLAT_SHARE:
            problems.append(f"{name} clipped (flat tops on {flat:.0%} of the samples)")
        elif np.isfinite(b) and b + 4.0 * se < MAX_PEAK_SLOPE:
            problems.append(f"{name} clipped (flat peaks under the noise: slope {b:.0%} of a sine's near them)")
        elif d > MAX_THD:
            problems.append(f"{name} distorted (harmonic distortion {d:.0%})")
    return problems


def drift_problem(ratio: np.ndarray, frequency_hz: float) -> str:
    """``"stiffness drifting 3.2 % over the 10 settled cycles (...)"`` when ``|F1 / X1|`` changes along the block, else "".

    The per-cycle ratios ``r_c`` (one per settled cycle, at ``t_c = (c + 1/2) / f``) are fitted by a straight line
    ``|r_c| / mean|r| = a + b t_c``; the change over the block is ``b n / f``, its standard error ``s n / (f sqrt(Sxx))``
    from the line's residual ``s``. Flagged when the change exceeds :data:`MAX_DRIFT` and four standard errors
    (noise alone does not flag it). Fewer than 4 cycles: no test.

    Parameters
    ----------
    ratio : ndarray, shape (n,), complex
        ``F1 / X1`` of each settled cycle, N/m.
    frequency_hz : float
        The block's test frequency, Hz.
    """
    q = np.abs(np.asarray(ratio, complex))
    n = q.size
    if n < 4 or not np.all(np.isfinite(q)) or q.mean() <= 0:
        return ""
    t = (np.arange(n) + 0.5) / frequency_hz
    y = q / q.mean()
    tc = t - t.mean()
    sxx = float(np.dot(tc, tc))
    b = float(np.dot(tc, y - y.mean()) / sxx)
    resid = y - y.mean() - b * tc
    s = float(np.sqrt(np.dot(resid, resid) / (n - 2)))
    change, se = b * n / frequency_hz, s * n / (frequency_hz * np.sqrt(sxx))
    if abs(change) > MAX_DRIFT and abs(change) > 4.0 * se:
        return (f"stiffness drifting {100 * change:+.2g} % over the {n} settled cycles (the specimen heating or the machine "
                "drifting: not stationary)")
    return ""
