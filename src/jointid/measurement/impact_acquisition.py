"""Acquisition checks of impact tests: slips of the analyser's set-up that the hit checks do not see.

Run by :func:`jointid.measurement.impact.estimate_frfs` on each excited node's accepted hits; each
finding is one line (naming the excited node or the response channel, and what to do) in
``ImpactFRF.notes``, except a force window that cuts the pulse, which is refused. Every threshold
follows from the noise statistics stated with it:

* :func:`force_window_error` -- the force window's flat part ends before the main pulse does
  (it must hold the whole pulse): :class:`~jointid.errors.DataError`.
* :func:`remove_force_offset` -- a DC offset on the force, measured as the mean of the pre-trigger
  samples: removed (each hit's pre-trigger mean subtracted) when it exceeds
  :data:`OFFSET_STANDARD_ERRORS` standard errors of that mean.
* :func:`pretrigger_note` -- the pulse starts within its own length of the record's first sample:
  no pre-trigger, the pulse's start is cut.
* :func:`force_noise_note` -- no force window, and the force channel's noise outside the pulse
  scatters H1 by more than :data:`FORCE_NOISE_SCATTER` per line.
* :func:`leaking_responses` -- a response whose last samples still hold signal above its noise and
  above :data:`LEAKAGE_FRACTION` of its peak (as processed, exponential window included).
* :func:`noise_channel_notes` -- a response whose coherence is no higher than that of noise
  uncorrelated with the force.
"""

from __future__ import annotations

import dataclasses
import math
from typing import AbstractSet, Sequence

import numpy as np

from ..dofs import Dof
from ..errors import DataError
from .impact_checks import main_pulse
from .impact_records import ImpactOptions, ImpactRecord

__all__ = [
    "OFFSET_STANDARD_ERRORS",
    "FORCE_NOISE_SCATTER",
    "LEAKAGE_FRACTION",
    "LEAKAGE_TAIL",
    "NOISE_COHERENCE_QUANTILE",
    "NOISE_CHANNEL_FRACTION",
    "force_window_error",
    "remove_force_offset",
    "pretrigger_note",
    "force_noise_note",
    "leaking_responses",
    "noise_channel_notes",
]

#: A pre-trigger mean this many standard errors (sigma / sqrt(m)) from 0 is a DC offset (false alarm 6e-7 for Gaussian noise).
OFFSET_STANDARD_ERRORS = 5.0
#: Force noise that scatters H1 by more than this (relative std per line, over the averages) is reported without a force window:
#: a tenth of the ~1 % to which a hammer's sensitivity is calibrated, so that it is a measurable part of the FRF's error,
#: which a force window removes at no cost.
FORCE_NOISE_SCATTER = 1e-3
#: A response whose signal (its noise removed) over the record's last samples exceeds this fraction of its peak leaks:
#: the truncated decay biases a mode's line by its amplitude left at the end over its start, and a mode may start at a
#: tenth of the response's peak, so 1e-4 of the peak is up to 0.1 % on a line.
LEAKAGE_FRACTION = 1e-4
#: The record's last fraction on which the leakage check measures the response (5 %).
LEAKAGE_TAIL = 0.05
#: Quantile of the coherence of noise uncorrelated with the force: with n averages it is Beta(1, n - 1) distributed,
#: above ``1 - (1 - q) ** (1 / (n - 1))`` on a fraction ``1 - q`` of the lines.
NOISE_COHERENCE_QUANTILE = 0.99
#: A response whose coherence exceeds that quantile on fewer than this fraction of the lines looks like noise (5x the
#: 1 % noise gives; the binomial scatter of that 1 % over a few hundred lines is well below).
NOISE_CHANNEL_FRACTION = 0.05

#: Median of a chi-square variable of one degree of freedom: ``median(x^2) / this`` estimates a Gaussian's variance.
CHI2_1_MEDIAN = 0.454936423119572


def _pulse(force: np.ndarray, o: ImpactOptions):
    """Peak, start, end (samples, per hit) and the pulse's length ``end - start`` (samples, >= 1)."""
    peak, start, end, _ = main_pulse(force, o.double_hit_fraction)
    return peak, start, end, np.maximum(end - start, 1)


def force_window_error(record: ImpactRecord, o: ImpactOptions) -> None:
    """Refuse a force window whose flat part ends before the main pulse does.

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node.
    o : ImpactOptions
        ``force_window_s`` (flat length, s) and ``force_pretrigger_s`` (its start before the pulse, s).

    Raises
    ------
    DataError
        Naming the excited node and hit, where the window ends relative to the hit's peak, and what to set.
    """
    if o.force_window_s is None:
        return
    fs = record.sample_rate_hz
    peak, start, end, length = _pulse(record.force, o)
    w_end = start / fs - o.force_pretrigger_s + o.force_window_s  # s, per hit
    cut = np.flatnonzero(w_end < (end - 1) / fs)
    if cut.size:
        i = int(cut[0])
        before = 1e3 * (peak[i] / fs - w_end[i])
        where = f"{before:.3g} ms before the hit's peak" if before > 0 else f"{-before:.3g} ms after the hit's peak, before the pulse's end"
        need = 1e3 * (o.force_pretrigger_s + length[i] / fs)
        raise DataError(
            f"excited node {record.reference}, hit {i}: the force window (from --pretrigger-ms {1e3 * o.force_pretrigger_s:g} "
            f"before the pulse's start, --force-window-ms {1e3 * o.force_window_s:g} long) ends {where}: it would cut the hit out "
            f"of the force; set --force-window-ms above --pretrigger-ms + the pulse's length ({need:.3g} ms), e.g. "
            f"--force-window-ms {math.ceil(2 * need):g}"
        )


def remove_force_offset(record: ImpactRecord, o: ImpactOptions) -> tuple[ImpactRecord, str | None]:
    """Subtract each hit's pre-trigger mean from its force when the force carries a DC offset.

    The pre-trigger samples are those before the main pulse's start less the pulse's length (its foot below the
    threshold). The offset is the median over hits of their means; it is removed when it exceeds
    :data:`OFFSET_STANDARD_ERRORS` standard errors ``sigma / sqrt(m)`` (``sigma``: the samples' standard deviation,
    median over hits; ``m`` samples per hit).

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node; force in N.
    o : ImpactOptions
        ``double_hit_fraction`` (the pulse's threshold).

    Returns
    -------
    record : ImpactRecord
        With the offset removed, or ``record`` itself.
    note : str or None
        What was removed (N, and as a fraction of the peak), or None.
    """
    F = record.force
    peak, start, _, length = _pulse(F, o)
    m = int(np.min(start - length))
    if m < 8:  # too few pre-trigger samples to measure (pretrigger_note says so)
        return record, None
    pre = F[:, :m]
    means = pre.mean(axis=1)
    offset = float(np.median(means))
    se = float(np.median(pre.std(axis=1))) / math.sqrt(m)
    if not abs(offset) > OFFSET_STANDARD_ERRORS * se:
        return record, None
    top = float(np.median(np.abs(F[np.arange(F.shape[0]), peak])))
    fixed = dataclasses.replace(record, force=F - means[:, None])
    note = (f"excited node {record.reference}: the force has a DC offset of {offset:.4g} N ({100 * abs(offset) / top:.2g} % "
            f"of the peak; mean of the {m} pre-trigger samples, {abs(offset) / se:.0f} standard errors from 0): removed "
            "(each hit's pre-trigger mean subtracted); zero the force channel (AC coupling or auto-zero) before the test")
    return fixed, note


def pretrigger_note(record: ImpactRecord, o: ImpactOptions) -> str | None:
    """One line when a hit's pulse starts within its own length of the record's first sample (no pre-trigger).

    The force rises from 0 to the threshold in up to half the pulse's length; with fewer samples than the pulse's
    length before the threshold crossing, the rise (and the force's offset and noise before the hit) is not recorded.

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node.
    o : ImpactOptions
        ``double_hit_fraction``.

    Returns
    -------
    str or None
    """
    _, start, _, length = _pulse(record.force, o)
    cut = np.flatnonzero(start < length)
    if not cut.size:
        return None
    fs = record.sample_rate_hz
    i = int(cut[0])
    return (f"excited node {record.reference}: the force pulse starts at sample {int(start[i])} (t = {1e3 * start[i] / fs:.3g} ms) "
            f"in {cut.size} of {record.n_hits} hit(s): the trigger has no pre-trigger, so the pulse's start is cut (and the "
            "force's offset cannot be measured); set a pre-trigger of a few ms (e.g. 5-10 % of the record) and repeat the hits")


def _noise_sigma2(F: np.ndarray, start: np.ndarray, end: np.ndarray, length: np.ndarray) -> float:
    """The force channel's noise variance, N^2: median over hits of ``median(x^2) / 0.455`` over the samples before the
    pulse (less its length) and after it has decayed (one more length past its end), each less its mean (before) or
    straight line (after), robust to an offset, a slow drift and a short rebound. NaN with fewer than 64 samples."""
    n = F.shape[1]
    out = []
    for f, s, e, L in zip(F, start, end, length):
        parts = []
        if s - L >= 8:
            parts.append(f[: s - L] - f[: s - L].mean())
        a = e + L
        if n - a >= 8:
            t = np.arange(n - a, dtype=float)
            parts.append(f[a:] - np.polyval(np.polyfit(t, f[a:], 1), t))
        x = np.concatenate(parts) if parts else np.zeros(0)
        if x.size >= 64:
            out.append(np.median(x * x) / CHI2_1_MEDIAN)
    return float(np.median(out)) if out else float("nan")


def force_noise_note(record: ImpactRecord, o: ImpactOptions, band_hz: tuple[float, float], n_fft: int) -> str | None:
    """One line when, without a force window, the force channel's noise outside the pulse scatters H1.

    The noise (variance ``sigma^2`` per sample, :func:`_noise_sigma2`) over the ``n`` samples outside the pulse puts
    ``sigma^2 n`` on every line of ``|X|^2`` (unnormalized rfft); the pulse puts ``|P|^2``. Their ratio over the band,
    ``r = sigma^2 n / mean_band |P|^2``, is the noise's share of the hit's energy there; it scatters H1 = Gxy / Gxx by a
    relative standard deviation ``sqrt(r / n_averages)`` per line (the term ``<N* X> / <|X|^2>``). Reported above
    :data:`FORCE_NOISE_SCATTER`.

    Parameters
    ----------
    record : ImpactRecord
        The accepted hits at one excited node; force in N.
    o : ImpactOptions
        ``force_window_s`` (the check runs only without one) and ``double_hit_fraction``.
    band_hz : (float, float)
        Output band, Hz.
    n_fft : int
        FFT length.

    Returns
    -------
    str or None
    """
    if o.force_window_s is not None:
        return None
    F = record.force
    fs, n = record.sample_rate_hz, record.n_samples
    _, start, end, length = _pulse(F, o)
    sigma2 = _noise_sigma2(F, start, end, length)
    if not sigma2 > 0:
        return None
    idx = np.arange(n)
    near = (idx >= (start - length)[:, None]) & (idx < (end + length)[:, None])
    P = np.fft.rfft(F * near, n=n_fft, axis=-1)
    hz = np.fft.rfftfreq(n_fft, 1.0 / fs)
    sel = (hz >= band_hz[0] - 1e-9) & (hz <= band_hz[1] + 1e-9)
    pulse = float(np.mean(np.abs(P[:, sel]) ** 2))
    r = sigma2 * float(np.mean(n - np.sum(near, axis=1))) / pulse
    scatter = math.sqrt(r / record.n_hits)
    if not scatter > FORCE_NOISE_SCATTER:
        return None
    pre_ms = max(0.5, math.ceil(10 * 2 * float(np.median(length)) / fs * 1e3) / 10)
    win_ms = math.ceil(10 * (pre_ms + 4 * float(np.median(length)) / fs * 1e3)) / 10
    return (f"excited node {record.reference}: force channel noise outside the pulse ({math.sqrt(sigma2):.3g} N rms) is "
            f"{100 * r:.2g} % of the hit's energy in {band_hz[0]:g}-{band_hz[1]:g} Hz, which scatters H1 by "
            f"{100 * scatter:.2g} % per line over {record.n_hits} average(s): use --force-window-ms (e.g. "
            f"--force-window-ms {win_ms:g} --pretrigger-ms {pre_ms:g})")


def leaking_responses(record: ImpactRecord, responses: np.ndarray, windowed: bool) -> tuple[list[str], tuple[Dof, ...]]:
    """Lines for the responses still ringing at the record's end (leakage), as processed, and their DOFs.

    Over the last :data:`LEAKAGE_TAIL` of the record, the noise variance is ``mean(dy^2) / 2`` (a white noise's first
    difference has twice its variance; a decaying mode far below the Nyquist frequency hardly any) and the signal's
    is ``mean(y^2)`` less that. A channel leaks when its signal there exceeds both :data:`LEAKAGE_FRACTION` of its
    peak ``max |y|`` and five standard errors of that difference (``2 var sqrt(2 / m)``, ``m`` samples).

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node (labels, sample rate).
    responses : ndarray, shape (n_hits, n_channels, n_samples)
        The accepted hits' responses as processed (exponential window applied, if any).
    windowed : bool
        Whether an exponential window was applied (changes the advice).

    Returns
    -------
    lines : list of str
        One line for the excited node, naming the channels, or empty.
    leaking : tuple of Dof
        Those channels' response DOFs (empty when none leaks).
    """
    n = responses.shape[-1]
    m = max(int(LEAKAGE_TAIL * n), 16)
    tail = responses[..., n - m:]
    ms = np.mean(tail ** 2, axis=-1)  # (H, C)
    noise = 0.5 * np.mean(np.diff(tail, axis=-1) ** 2, axis=-1)
    signal = np.median(ms - noise, axis=0)  # (C,)
    peak = np.median(np.max(np.abs(responses), axis=-1), axis=0)
    se = 2.0 * np.median(noise, axis=0) * math.sqrt(2.0 / m)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.sqrt(np.maximum(signal, 0.0)) / peak
    bad = np.flatnonzero((frac > LEAKAGE_FRACTION) & (signal > 5.0 * se))
    if not bad.size:
        return [], ()
    k = int(bad[np.argmax(frac[bad])])
    T = n / record.sample_rate_hz
    chans = ", ".join(str(record.response_dofs[c]) for c in bad)
    fix = ("use a longer record or a shorter --exp-tau-ms" if windowed else
           f"use a longer record or an exponential window (--exp-tau-ms, e.g. {1e3 * T / 5:.3g} ms for this {T:g} s record)")
    return [f"excited node {record.reference}: response(s) {chans} still ring at the record's end (last {1e3 * m / record.sample_rate_hz:.3g} ms "
            f"hold up to {100 * frac[k]:.2g} % of the peak, at {record.response_dofs[k]}; above "
            f"{100 * LEAKAGE_FRACTION:g} %): leakage biases the FRFs near the lightly damped modes; {fix}"], \
        tuple(record.response_dofs[c] for c in bad)


def noise_channel_notes(coherence: np.ndarray, n_averages: Sequence[int], responses: Sequence[Dof],
                        references: Sequence[Dof], reported: AbstractSet[tuple[int, int]] = frozenset()) -> list[str]:
    """Lines for the responses whose coherence is that of noise uncorrelated with the force (a dead channel).

    With ``n`` averages the coherence of such noise is Beta(1, n - 1) distributed: above
    ``q_n = 1 - (1 - q) ** (1 / (n - 1))`` (``q`` = :data:`NOISE_COHERENCE_QUANTILE`) on ``1 - q`` of the lines. A
    response above ``q_n`` on fewer than :data:`NOISE_CHANNEL_FRACTION` of the lines, at every excited node with
    >= 2 averages that ``reported`` does not hold, is reported once.

    Parameters
    ----------
    coherence : ndarray, shape (F, r, c)
        Ordinary coherence.
    n_averages : sequence of int, length c
        Accepted hits per excited node.
    responses, references : sequence of Dof
        Row and column labels.
    reported : set of (int, int)
        (response, excited node) indices another check already reported (a flat-zero channel, a median
        coherence below 0.1): left out.

    Returns
    -------
    list of str
        One line per such response.
    """
    use = [j for j, n in enumerate(n_averages) if n >= 2]
    frac = np.full(coherence.shape[1:], np.nan)
    limit = {}
    for j in use:
        limit[j] = 1.0 - (1.0 - NOISE_COHERENCE_QUANTILE) ** (1.0 / (n_averages[j] - 1))
        frac[:, j] = np.mean(coherence[:, :, j] > limit[j], axis=0)
    lines = []
    for i in range(coherence.shape[1]):
        cols = [j for j in use if (i, j) not in reported]
        if not cols or not all(frac[i, j] < NOISE_CHANNEL_FRACTION for j in cols):
            continue
        others = np.delete(frac[:, use], i, axis=0)
        other = f"; the other responses: {100 * np.nanmedian(others):.3g} %" if others.size else ""
        j0 = cols[0]
        lines.append(
            f"response {responses[i]}: its coherence is that of noise uncorrelated with the force at excited node(s) "
            f"{', '.join(str(references[j]) for j in cols)} (above {limit[j0]:.2g}, noise's {100 * NOISE_COHERENCE_QUANTILE:g}th "
            f"percentile with {n_averages[j0]} averages, on {100 * np.max(frac[i, cols]):.2g} % of the lines at most, noise: "
            f"{100 * (1 - NOISE_COHERENCE_QUANTILE):g} %{other}): a dead or disconnected sensor; check it and its cable, or "
            "leave it out")
    return lines
