"""Impact-test FRF estimation: hammer force and response time histories to H1/H2 and coherence.

The records (:class:`ImpactRecord`, one per excited node) and settings
(:class:`ImpactOptions`) are defined in :mod:`jointid.measurement.impact_records`;
files: :mod:`jointid.measurement.impact_files` (NumPy ``.npz``, long CSV, UFF58 time
records). Every public name of the impact modules is importable from here.

Processing (:func:`estimate_frf`, :func:`estimate_frfs`)
--------------------------------------------------------
0. **Acquisition** (:mod:`jointid.measurement.impact_acquisition`): a force window that cuts the
   pulse is refused; a DC offset on the force (pre-trigger mean) is removed; no pre-trigger, force
   noise without a force window, leakage and noise-only responses are noted.
1. **Hit quality** (:mod:`jointid.measurement.impact_checks`): double hits and
   overloads, per hit, on the raw data. Bad hits are dropped and listed in
   ``ImpactFRF.rejected``; if every hit of an excited node is bad,
   :class:`~jointid.errors.DataError` is raised.
2. **Force window** (optional, ``force_window_s``), 3. **exponential window**
   (optional, ``exp_tau_s``; it adds the decay rate ``1/tau`` to every mode,
   ``H_windowed(j w) = H(j w + 1/tau)``) and 4. its **correction**
   (``correct_exponential=True``, mode by mode): :mod:`jointid.measurement.impact_windows`.
5. **Estimators**: one batched real FFT over hits (and channels), then averaged
   over accepted hits::

       Gxx = <|X|^2>,  Gyy = <|Y|^2>,  Gxy = <X* Y>
       H1 = Gxy / Gxx,  H2 = Gyy / Gyx = Gyy / conj(Gxy),
       coherence = |Gxy|^2 / (Gxx Gyy)

   on the rfft grid ``k * fs / n_fft`` (``n_fft`` >= ``n_samples``: zero
   padding, legitimate when the windowed response has decayed), optionally
   restricted to ``band_hz``. With one accepted hit the coherence is 1.

Roving sensor
-------------
:func:`roving_sensor_correction` (:mod:`jointid.measurement.sensor_correction`)
removes the mass of a single accelerometer that was moved to each response
point (Sherman-Morrison on the added mass).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import scipy.fft

from ..dofs import Dof
from ..errors import DataError
from ..frequency import Frequency
from .impact_acquisition import (
    force_noise_note,
    force_window_error,
    leaking_responses,
    noise_channel_notes,
    pretrigger_note,
    remove_force_offset,
)
from .impact_checks import HitProblem, RejectedHit, check_hits, main_pulse, rejected_hits_table
from .impact_consistency import agreement_threshold, inconsistent_hits, pairwise_misfits
from .impact_records import ImpactOptions, ImpactRecord, where_hit
from .impact_windows import WindowMode, correct_exponential_window, exponential_window, force_window
from .sensor_correction import roving_sensor_correction

#: An exponential window that keeps less than this fraction of the responses' energy is reported (a ms/s slip).
WINDOW_MIN_ENERGY = 0.01
#: A response whose median coherence over the band is below this (with >= 2 averages) is reported as dead.
DEAD_CHANNEL_COHERENCE = 0.1
#: H1 biased low by more than this (the force channel's noise in Gxx, measured after the pulse) on some line is reported.
FORCE_NOISE_BIAS = 0.02
#: Fewest force samples after the pulse (and its tail of as many samples again) to measure the force channel's noise.
FORCE_NOISE_MIN_SAMPLES = 64

__all__ = [
    "ImpactRecord",
    "ImpactOptions",
    "ImpactFRF",
    "RejectedHit",
    "HitProblem",
    "WindowMode",
    "estimate_frf",
    "estimate_frfs",
    "check_hits",
    "rejected_hits_table",
    "force_window",
    "exponential_window",
    "correct_exponential_window",
    "roving_sensor_correction",
    "where_hit",
]

@dataclass(frozen=True, eq=False)
class ImpactFRF:
    """FRFs estimated from impact tests, shaped (frequency, responses, references).

    Parameters
    ----------
    frequency : Frequency
        Output lines, Hz, F of them.
    h1, h2 : ndarray, shape (F, r, c), complex
        H1 = Gxy/Gxx and H2 = Gyy/Gyx in the units of ``kind`` (accelerance: (m/s^2)/N).
    coherence : ndarray, shape (F, r, c), float
        Ordinary coherence of the (windowed) data, 0..1.
    responses, references : tuple of Dof
        Row and column labels.
    kind : str
        ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    n_averages : tuple of int, length c
        Accepted hits per excited node.
    rejected : tuple of RejectedHit
        Hits left out, with the reason.
    exp_tau_s : float or None
        Exponential window time constant used, s.
    window_modes : tuple of WindowMode
        Modes fitted for the window correction (empty if none).
    notes : tuple of str
        Data checks, one line each: excited nodes with one accepted hit (coherence 1 by construction),
        a response channel that is flat zero (dead), a median coherence
        below :data:`DEAD_CHANNEL_COHERENCE`, an exponential window that keeps less than
        :data:`WINDOW_MIN_ENERGY` of the responses' energy, lines where the force channel's noise is more
        than :data:`FORCE_NOISE_BIAS` of Gxx (H1 low by as much); then the acquisition checks of
        :mod:`jointid.measurement.impact_acquisition` (a DC offset removed from the force, no pre-trigger, force noise
        without a force window, responses ringing at the record's end, a noise-only response); then mode bands
        that were detected but not corrected, and why.
    leaking : tuple of (Dof, Dof)
        ``(response, reference)`` of the FRFs whose response still rings at the record's end (leakage:
        :func:`~jointid.measurement.impact_acquisition.leaking_responses`); ``jointid frf`` marks their records in
        the UFF file it writes (:data:`jointid.io.uff.LEAKAGE_MARK`).
    """

    frequency: Frequency
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    responses: tuple[Dof, ...]
    references: tuple[Dof, ...]
    kind: str
    n_averages: tuple[int, ...]
    rejected: tuple[RejectedHit, ...] = ()
    exp_tau_s: float | None = None
    window_modes: tuple[WindowMode, ...] = ()
    notes: tuple[str, ...] = field(default=())
    leaking: tuple[tuple[Dof, Dof], ...] = ()

    def to_frf(self, estimator: str = "h1"):
        """The estimate as a labelled :class:`jointid.frf.FRF` (``estimator`` "h1" or "h2"), with its coherence."""
        from ..frf import FRF

        if estimator not in ("h1", "h2"):
            raise DataError(f"estimator must be 'h1' or 'h2', got {estimator!r}")
        return FRF(self.frequency, getattr(self, estimator), self.responses, self.references, self.kind, coherence=self.coherence)


# --------------------------------------------------------------------------- estimation


def _spectra(record: ImpactRecord, keep: np.ndarray, o: ImpactOptions, n_fft: int, sel: np.ndarray):
    """Averaged Gxx (K,), Gyy (K, C), Gxy (K, C) over the kept hits (one batched rfft), the fraction of the
    responses' energy the exponential window keeps (1.0 without one), the force noise's share of Gxx (K,) (NaN
    where it cannot be measured: :func:`_force_noise_share`), the responses as processed (H, C, n) and each kept
    hits' pairwise misfits on the band's lines ``sel`` (:func:`~.impact_consistency.pairwise_misfits`)."""
    fs = record.sample_rate_hz
    F = record.force[keep]
    Y = record.responses[keep]
    _, start, end, _ = main_pulse(F, o.double_hit_fraction)
    t_start = start / fs
    weight = np.ones((F.shape[0], record.n_samples))  # what multiplies each force sample (the windows)
    if o.force_window_s is not None:
        weight = weight * force_window(record.n_samples, fs, t_start - o.force_pretrigger_s, o.force_window_s, o.force_taper_s)
    if o.exp_tau_s is not None:
        w = exponential_window(record.n_samples, fs, t_start - o.force_pretrigger_s, o.exp_tau_s)
        weight = weight * w
        e0 = float(np.sum(Y ** 2))
        Y = Y * w[:, None, :]
        kept = float(np.sum(Y ** 2)) / e0 if e0 > 0 else 1.0
    else:
        kept = 1.0
    noise = _force_noise_share(F, start, end, weight)
    F = F * weight
    X = scipy.fft.rfft(F, n=n_fft, axis=-1)  # (H, K)
    Yf = scipy.fft.rfft(Y, n=n_fft, axis=-1)  # (H, C, K)
    gxx = np.mean(np.abs(X) ** 2, axis=0)
    gyy = np.mean(np.abs(Yf) ** 2, axis=0).T
    gxy = np.mean(np.conj(X)[:, None, :] * Yf, axis=0).T
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.minimum(noise / gxx, 1.0)
    return gxx, gyy, gxy, kept, share, Y, pairwise_misfits(X[:, sel], Yf[:, :, sel])


#: Median of a chi-square variable of one degree of freedom: ``median(x^2) / this`` estimates a Gaussian's variance.
_CHI2_1_MEDIAN = 0.454936423119572


def _force_noise_share(F: np.ndarray, start: np.ndarray, end: np.ndarray, weight: np.ndarray) -> float:
    """The force channel's noise in the averaged ``Gxx``: ``sigma^2 sum_n w_n^2`` (white noise of variance ``sigma^2``
    weighted by the windows ``w``, unnormalized rfft); NaN when fewer than :data:`FORCE_NOISE_MIN_SAMPLES` samples
    are left after the pulse (and as many samples again past its end).

    ``sigma^2`` is the median over hits of ``median(x^2) / 0.455`` over the force after the pulse less its straight
    line: a Gaussian's variance, robust to a DC offset or a slow drift (near 0 Hz, not on the band's lines) and to a
    short rebound below the double-hit threshold (a few samples), which a mean square counted as noise on every
    line. H1 = Gxy / Gxx is low by this share of Gxx (the noise is in Gxx, not in Gxy)."""
    n = F.shape[1]
    after = end + (end - start) + 1
    if np.min(n - after) < FORCE_NOISE_MIN_SAMPLES:
        return float("nan")
    sigma2 = []
    for f, a in zip(F, after):
        t = np.arange(n - a, dtype=float)
        x = f[a:] - np.polyval(np.polyfit(t, f[a:], 1), t)  # a DC offset or a slow drift is not noise on the lines
        sigma2.append(np.median(x * x) / _CHI2_1_MEDIAN)
    return float(np.median(sigma2)) * float(np.mean(np.sum(weight ** 2, axis=1)))


def estimate_frf(record: ImpactRecord, options: ImpactOptions | None = None) -> ImpactFRF:
    """H1, H2 and coherence for one excited node (arrays shaped (F, r, 1)).

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node.
    options : ImpactOptions, optional
        See :func:`estimate_frfs`.
    """
    return estimate_frfs([record], options)


def estimate_frfs(records: Sequence[ImpactRecord], options: ImpactOptions | None = None) -> ImpactFRF:
    """H1, H2 and coherence from impact tests, one record per excited node.

    Parameters
    ----------
    records : sequence of ImpactRecord, length c
        One per excited node; all with the same response DOFs (same order),
        sample rate, record length and kind.
    options : ImpactOptions, optional
        Windows, hit checks, band, FFT length (defaults: no windows, full rfft grid).

    Returns
    -------
    ImpactFRF
        ``h1``, ``h2``, ``coherence`` shaped (F, r, c).

    Raises
    ------
    DataError
        Inconsistent records, a band above the Nyquist frequency, every hit of
        an excited node rejected, or a failed window-correction fit of a given band.
    """
    o = options or ImpactOptions()
    if isinstance(records, ImpactRecord):
        records = [records]
    records = list(records)
    if not records:
        raise DataError("no impact records given; give one ImpactRecord per excited node")
    r0 = records[0]
    refs = tuple(r.reference for r in records)
    if len(set(refs)) != len(refs):
        raise DataError(f"excited node given twice in {[str(r) for r in refs]}; merge the hits into one record")
    for r in records[1:]:
        if r.response_dofs != r0.response_dofs:
            raise DataError(
                f"excited node {r.reference}, all hits: response DOFs {[str(d) for d in r.response_dofs]} differ from "
                f"those of excited node {r0.reference} {[str(d) for d in r0.response_dofs]}"
            )
        if r.n_samples != r0.n_samples:
            raise DataError(
                f"excited node {r.reference}, all hits: {r.n_samples} samples per hit, excited node {r0.reference} "
                f"has {r0.n_samples}; use the same record length for all excited nodes"
            )
        if not math.isclose(r.sample_rate_hz, r0.sample_rate_hz, rel_tol=1e-9):
            raise DataError(
                f"excited node {r.reference}, all hits: sample rate {r.sample_rate_hz:g} Hz differs from "
                f"{r0.sample_rate_hz:g} Hz of excited node {r0.reference}"
            )
        if r.kind != r0.kind:
            raise DataError(f"excited node {r.reference}: response kind {r.kind!r} differs from {r0.kind!r}")
    fs, n = r0.sample_rate_hz, r0.n_samples
    if o.band_hz is not None and o.band_hz[1] > fs / 2 * (1 + 1e-12):
        raise DataError(
            f"excited node {r0.reference}, all hits: sample rate {fs:g} Hz is below 2 x the requested maximum "
            f"frequency {o.band_hz[1]:g} Hz (Nyquist {fs / 2:g} Hz); check the sample rate or lower band_hz"
        )
    n_fft = n if o.n_fft is None else int(o.n_fft)
    if n_fft < n:
        raise DataError(f"impact option n_fft = {n_fft} is shorter than the records ({n} samples)")
    hz = scipy.fft.rfftfreq(n_fft, 1.0 / fs)
    sel = np.ones(hz.size, dtype=bool) if o.band_hz is None else (hz >= o.band_hz[0] - 1e-9) & (hz <= o.band_hz[1] + 1e-9)
    if not sel.any():
        raise DataError(f"no FFT line in band_hz {o.band_hz} (line spacing {fs / n_fft:g} Hz)")

    rejected: list[RejectedHit] = []
    gxx, gyy, gxy, n_avg = [], [], [], []
    checks: list[str] = []
    dead: dict = {}
    acquisition: list[str] = []
    leaking: list[tuple[Dof, Dof]] = []  # (response, reference) of the records still ringing at their end
    for k, rec in enumerate(records):
        force_window_error(rec, o)
        rec, offset = remove_force_offset(rec, o)
        records[k] = rec
        acquisition.extend(x for x in (offset, pretrigger_note(rec, o)) if x)
        bad = check_hits(rec, o)
        rejected.extend(bad)
        keep = np.ones(rec.n_hits, dtype=bool)
        keep[[b.hit for b in bad]] = False
        if not keep.any():
            raise DataError(
                f"excited node {rec.reference}: all {rec.n_hits} hits were rejected: " + " | ".join(b.reason for b in bad)
            )
        a, b, c, kept, share, y, pairwise = _spectra(rec, keep, o, n_fft, sel)
        odd = inconsistent_hits(pairwise)
        if odd.size:  # hits that disagree with most others (a hit elsewhere): left out, as a double hit is
            hits = np.flatnonzero(keep)
            good = np.setdiff1d(np.arange(hits.size), odd)
            typical = float(np.median(pairwise[np.ix_(good, good)][~np.eye(good.size, dtype=bool)])) if good.size > 1 else float("nan")
            for i in odd:
                own = float(np.median(pairwise[i, good]))
                text = (f"does not agree with most other hits: {100 * np.sqrt(own):.2g} % of its response (median over the "
                        f"band) is not what their FRFs predict from its force, between them {100 * np.sqrt(typical):.2g} %: a hit "
                        "at another point?")
                problem = HitProblem("inconsistent", "responses", float(np.sqrt(own)), float(np.sqrt(agreement_threshold(pairwise))),
                                     "", float("nan"), text)
                rejected.append(RejectedHit(rec.reference, int(hits[i]), f"{where_hit(rec.reference, int(hits[i]))}: {text}", (problem,)))
            keep[hits[odd]] = False
            a, b, c, kept, share, y, _ = _spectra(rec, keep, o, n_fft, sel)
        band = (float(hz[sel][0]), float(hz[sel][-1]))
        accepted = dataclasses.replace(rec, force=rec.force[keep], responses=rec.responses[keep])
        acquisition.extend(x for x in (force_noise_note(accepted, o, band, n_fft),) if x)
        leak_lines, rings = leaking_responses(rec, y, o.exp_tau_s is not None)
        acquisition.extend(leak_lines)
        leaking.extend((dof, rec.reference) for dof in rings)
        bias = share[sel]
        above = bias > FORCE_NOISE_BIAS
        if np.any(above):
            f_above = hz[sel][above]
            checks.append(
                f"excited node {rec.reference}: the force channel's noise (measured after the pulse) is more than "
                f"{100 * FORCE_NOISE_BIAS:g} % of the force spectrum on {100 * above.mean():.3g} % of the lines "
                f"({f_above.min():g}-{f_above.max():g} Hz; up to {100 * np.nanmax(bias):.3g} %), so H1 is low by as much "
                "there; use a force window (--force-window-ms) and an exponential window (--exp-tau-ms), hit harder, or "
                "keep to the band the hammer tip excites"
            )
        if kept < WINDOW_MIN_ENERGY:
            checks.append(
                f"excited node {rec.reference}: the exponential window (tau {1e3 * o.exp_tau_s:g} ms) keeps "
                f"{100 * kept:.2g} % of the responses' energy: it damps every mode far more than the structure does; "
                f"check the time constant (--exp-tau-ms is in ms: {1e3 * o.exp_tau_s:g} ms = {o.exp_tau_s:g} s)"
            )
        for ch in np.flatnonzero(~np.any(rec.responses[keep] != 0, axis=(0, 2))):
            dead.setdefault(rec.response_dofs[ch], []).append(str(rec.reference))
        gxx.append(a[sel])
        gyy.append(b[sel])
        gxy.append(c[sel])
        n_avg.append(int(keep.sum()))
    gxx = np.stack(gxx, axis=-1)[:, None, :]  # (F, 1, c)
    gyy = np.stack(gyy, axis=-1)  # (F, r, c)
    gxy = np.stack(gxy, axis=-1)
    h1 = np.divide(gxy, gxx, out=np.zeros_like(gxy), where=gxx > 0)
    gyx = np.conj(gxy)
    h2 = np.divide(gyy.astype(complex), gyx, out=np.zeros_like(gxy), where=gyx != 0)
    den = gxx * gyy
    coh = np.divide(np.abs(gxy) ** 2, den, out=np.zeros_like(gyy), where=den > 0)
    coh = np.clip(coh, 0.0, 1.0)
    for d, refs_d in dead.items():
        checks.append(f"response {d}: flat zero in every hit of excited node(s) {', '.join(refs_d)} (a dead channel): "
                      "its FRF is 0 and its coherence 0; check the sensor and its cable")
    single = [str(ref) for ref, n in zip(refs, n_avg) if n == 1]
    if single:
        checks.append(f"excited node(s) {', '.join(single)}: one accepted hit: the coherence is 1 by construction and says "
                      "nothing about the noise (identify then measures the noise from the residuals); average several hits")
    reported = {(i, j) for i, d in enumerate(r0.response_dofs) if d in dead for j in range(len(refs))}
    if all(n > 1 for n in n_avg):
        med = np.median(coh, axis=0)  # (r, c)
        for i, j in zip(*np.nonzero(med < DEAD_CHANNEL_COHERENCE)):
            reported.add((int(i), int(j)))
            if r0.response_dofs[i] not in dead:
                checks.append(f"response {r0.response_dofs[i]}, excited node {refs[j]}: median coherence {med[i, j]:.2g} over "
                              f"the band (below {DEAD_CHANNEL_COHERENCE:g}): a dead or disconnected channel, or no signal")
    acquisition.extend(noise_channel_notes(coh, n_avg, r0.response_dofs, refs, reported))
    freq = Frequency(hz[sel])
    modes: tuple[WindowMode, ...] = ()
    notes: tuple[str, ...] = ()
    if o.exp_tau_s is not None and o.correct_exponential:
        h1, modes, notes = correct_exponential_window(freq.hz, h1, o.exp_tau_s, o.mode_bands_hz)
        # H2 in the bands H1 was corrected in; a band H2 cannot fit is skipped with a note, never fatal
        h2, _, notes2 = correct_exponential_window(
            freq.hz, h2, o.exp_tau_s, tuple(m.band_hz for m in modes), strict=o.mode_bands_hz is not None
        )
        notes = notes + tuple(f"H2 {n}" for n in notes2)
    return ImpactFRF(
        frequency=freq,
        h1=h1,
        h2=h2,
        coherence=coh,
        responses=r0.response_dofs,
        references=refs,
        kind=r0.kind,
        n_averages=tuple(n_avg),
        rejected=tuple(rejected),
        exp_tau_s=o.exp_tau_s,
        window_modes=modes,
        notes=tuple(checks) + tuple(acquisition) + notes,
        leaking=tuple(leaking),
    )


