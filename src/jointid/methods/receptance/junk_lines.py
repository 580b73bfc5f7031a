"""Junk lines: frequency lines whose coherence or residual says they carry no information, left out with a finding.

A line is junk when

- every FRF value on it is exactly 0 (nothing was measured there: an acquisition's dropout
  or a zeroed block; left out whatever their number, since a floored variance would give
  them nearly full weight on nothing); or
- its median coherence over the FRF values is below :data:`JUNK_COHERENCE` (raw, not
  smoothed: the variance model of :mod:`jointid.methods.receptance.frf_variance` averages
  the coherence over neighbouring lines in log scale, which would spread a few junk lines'
  variance over their neighbours and give the junk lines themselves nearly full weight); or
- its residual in the per-line coupling fit, ``chi2_f`` of
  :func:`~jointid.methods.receptance.model_check.residual_statistics`, is above
  :data:`JUNK_RESIDUAL_RATIO` times the noise measured in its band (the band's median
  ``noise_f``), in a band where the free model fits
  (:func:`~jointid.methods.receptance.model_check.check_model`): a line that far above
  its neighbours' noise is a dropout, a spike or an overload, not noise. Only when the
  free model fits in every band: where it does not, a high residual is the model's error,
  not the line's; nor in a band whose noise is below
  :data:`~jointid.methods.receptance.model_check.MIN_NOISE_LEVEL` (exact data: a model
  error's residual near a resonance would look like junk). The weights of this test are the coherence's ``(1 - g^2) / g^2 |H|^2``
  line by line, or ``|H|^2`` without coherence (not the smoothed variance model, whose
  running mean over lines under-weights a sharp resonance's peak lines and would make
  them look like junk).

Junk lines are left out *before* the variance model, the column calibration and the
smoothing see them, so they pull none of those on the good lines. Nothing is left out
when junk would be more than :data:`JUNK_MAX_FRACTION` of the lines (then the data as a
whole are poor, and the weights and flags must say so).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frf_screening import floor_exact_zeros
from .frf_variance import RELATIVE_FLOOR
from .model_check import MIN_NOISE_LEVEL, ResidualStatistics, check_model, residual_statistics

__all__ = ["JunkLines", "find_junk_lines", "junk_lines", "JUNK_COHERENCE", "JUNK_RESIDUAL_RATIO", "JUNK_MAX_FRACTION"]

#: A line whose median coherence over the FRF values is below this is junk.
JUNK_COHERENCE = 0.5
#: A line whose residual per degree of freedom is above this many times its band's noise is junk.
JUNK_RESIDUAL_RATIO = 25.0
#: Junk on more than this fraction of the lines is not left out (the data as a whole are poor).
JUNK_MAX_FRACTION = 0.2


@dataclass(frozen=True, eq=False)
class JunkLines:
    """Lines to keep and the one finding that names those left out.

    Attributes
    ----------
    keep : ndarray of bool, shape (F,)
    finding : str
        "" when every line is kept.
    """

    keep: np.ndarray
    finding: str


def _spans(hz: np.ndarray, idx: np.ndarray) -> str:
    """Runs of consecutive line indices as "a-b Hz" (at most four, then "...")."""
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    text = [f"{hz[r[0]]:g} Hz" if r.size == 1 else f"{hz[r[0]]:g}-{hz[r[-1]]:g} Hz" for r in runs[:4]]
    return ", ".join(text) + (" ..." if len(runs) > 4 else "")


def find_junk_lines(hz: np.ndarray, coherence: np.ndarray | None, stats: ResidualStatistics | None,
                    empty: np.ndarray | None = None) -> JunkLines:
    """Find junk lines: empty, by coherence and by residual (module docstring).

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    coherence : ndarray, shape (F, m, e), or None
        Ordinary coherence of each FRF value.
    stats : ResidualStatistics or None
        Residuals of the per-line coupling fit on every line (None: no residual test).
    empty : ndarray of bool, shape (F,), optional
        Lines whose every FRF value is exactly 0.

    Returns
    -------
    JunkLines
    """
    hz = np.asarray(hz, float)
    F = hz.size
    keep = np.ones(F, bool)
    reasons = []
    limit = JUNK_MAX_FRACTION * F
    if empty is not None and np.any(empty):
        keep &= ~np.asarray(empty, bool)
        reasons.append(f"every FRF value exactly 0 on {int(np.sum(empty))} of them (nothing measured there)")
        limit += np.sum(empty)
    if coherence is not None:
        g = np.median(np.asarray(coherence, float).reshape(F, -1), axis=1)
        low = (g < JUNK_COHERENCE) & keep
        if 0 < low.sum() and (~keep).sum() + low.sum() <= limit:
            keep &= ~low
            reasons.append(f"coherence {np.median(g[low]):.2g} (median; {np.median(g[keep]):.2g} on the other lines)")
    if stats is not None:
        check = check_model(hz, stats)
        level = np.full(F, np.nan)
        for a, b in check.bands if check.fits else ():  # the noise of each band, when the free model fits everywhere
            noise = stats.noise[a:b][np.isfinite(stats.noise[a:b])]
            if noise.size and np.median(noise) > MIN_NOISE_LEVEL:  # exact data: no noise to be far above
                level[a:b] = np.median(noise)
        with np.errstate(invalid="ignore", divide="ignore"):
            excess = stats.chi2 / level
        high = (excess > JUNK_RESIDUAL_RATIO) & keep
        if 0 < high.sum() and (~keep).sum() + high.sum() <= limit:
            keep &= ~high
            reasons.append(f"residual {np.median(excess[high]):.3g}x the noise")
    if keep.all():
        return JunkLines(keep, "")
    idx = np.flatnonzero(~keep)
    n = idx.size
    return JunkLines(keep, f"{n} line{'s' if n > 1 else ''} at {_spans(hz, idx)} left out as junk: " + "; ".join(reasons)
                     + " (they would pull the calibration and the smoothing on the good lines)")


def junk_lines(hz: np.ndarray, H: np.ndarray, coherence: np.ndarray | None, Ymn: np.ndarray, Yne: np.ndarray, Yme: np.ndarray,
               symmetric: bool = True, residuals: bool = True) -> JunkLines:
    """Junk lines of measured receptances: by coherence first, then by residual on the other lines (module docstring).

    Parameters
    ----------
    hz : ndarray, shape (F,)
        Frequencies, Hz.
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    coherence : ndarray, shape (F, m, e), or None
    Ymn, Yne, Yme : ndarray, shapes (F, m, n), (F, n, e), (F, m, e), complex
        Free receptance blocks, m/N.
    symmetric : bool
    residuals : bool
        Test the residuals too (False: coherence only, e.g. when the full per-line design is too large).

    Returns
    -------
    JunkLines
    """
    empty = ~np.any(np.asarray(H) != 0, axis=(1, 2))
    first = find_junk_lines(hz, coherence, None, empty)
    if not residuals:
        return first
    k = first.keep
    g = None if coherence is None else np.asarray(coherence)[k]
    mag2 = np.maximum(H[k].real ** 2 + H[k].imag ** 2, np.finfo(float).tiny)
    rel = 1.0 if g is None else (1.0 - np.clip(g, 1e-6, 1.0)) / np.clip(g, 1e-6, 1.0)
    variance = floor_exact_zeros((rel + RELATIVE_FLOOR ** 2) * mag2, H[k], RELATIVE_FLOOR)
    stats = residual_statistics(Ymn[k], Yne[k], Yme[k] - H[k], variance, symmetric)
    if stats is None:
        return first
    full = ResidualStatistics(np.full(hz.size, np.nan), np.full(hz.size, np.nan))
    full.chi2[k], full.noise[k] = stats.chi2, stats.noise
    return find_junk_lines(hz, coherence, full, empty)
