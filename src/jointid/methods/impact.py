"""Impact-test FRF estimation: hammer force and response time histories to H1/H2 and coherence.

Input layout
------------
One :class:`ImpactRecord` holds the repeated hits at **one excited node**:

* ``force``      ``(n_hits, n_samples)``              hammer force, N;
* ``responses``  ``(n_hits, n_channels, n_samples)``  responses, m/s^2 for
  ``kind="accelerance"`` (m/s for ``"mobility"``, m for ``"receptance"``);
* ``sample_rate_hz``; ``response_dofs`` (one label per channel, e.g. ``"3w"``);
  ``reference`` (the excited DOF, e.g. ``"9w"``).

Sample 0 of every channel of a hit is the same instant (simultaneous
sampling); the trigger position within the record is free.

Files: :mod:`jointid.io.impact_files` reads and writes these records (NumPy ``.npz``, long CSV, UFF58 time records).

Processing (:func:`estimate_frf`, :func:`estimate_frfs`)
--------------------------------------------------------
1. **Hit quality**, on the raw force/response, per hit:

   * *double hit*: the main pulse is the run of samples around the force peak
     with ``|f| > double_hit_fraction * max|f|``; any other sample above that
     threshold (before or after the main pulse) means a second impact;
   * *overload*: a sample with ``|x| >= overload_fraction * clip`` when a
     clipping level is given (``force_clip_n``, ``response_clip``), or a flat
     top: ``flat_top_samples`` consecutive samples at the channel's ``max|x|``
     (what a saturated ADC or amplifier produces).

   Bad hits are dropped and listed in ``ImpactFRF.rejected``; if every hit of
   an excited node is bad, :class:`~jointid.errors.DataError` is raised.
2. **Force window** (optional, ``force_window_s``): 1 on
   ``[t_start - force_pretrigger_s, t_start - force_pretrigger_s + force_window_s]``
   with ``t_start`` the start of the main pulse, half-cosine tapers of
   ``force_taper_s`` on both sides, 0 elsewhere. It removes the force
   channel's noise outside the pulse (which would bias H1 low). It must
   contain the whole pulse.
3. **Exponential window** (optional, ``exp_tau_s``): ``w(t) = exp(-(t - t0)/tau)``
   for ``t >= t0 = t_start - force_pretrigger_s`` and 1 before, applied to the
   response *and* to the force. Because the response before the impact is zero,
   ``w y = (w h) * (w f)`` exactly, so the estimate is the FRF of ``h(t) e^{-t/tau}``:

       H_windowed(j w) = H(j w + 1/tau)                              (Laplace variable)

   i.e. every pole ``lambda_r = -sigma_r + j w_dr`` moves to
   ``lambda_r - 1/tau`` with unchanged residue: the window adds the decay rate
   ``sigma_w = 1/tau`` (rad/s) to every mode, a loss-factor increase
   ``Delta eta_r = 2 sigma_w / w_r`` (viscous: ``Delta zeta_r = sigma_w / w_r``).
4. **Window correction** (``correct_exponential=True``): for each band of
   ``mode_bands_hz`` (one isolated mode per band; detected automatically from
   the peaks of ``sum |H|^2`` when not given), a common-denominator
   second-order rational fraction ``N_m(s) / (s^2 + a1 s + a0)`` is fitted to
   all FRFs (iterated Sanathanan-Koerner weighting), giving the windowed pole
   ``lambda_w`` and each FRF's residue ``R_m``. The pole is moved back,
   ``lambda = lambda_w + 1/tau``, and the difference of the two modal terms is
   added to the measured FRF on all lines::

       H_corr = H_windowed + sum_r [ R/(s - lambda) + R*/(s - lambda*)
                                     - R/(s - lambda_w) - R*/(s - lambda_w*) ]

   which keeps the measured data (noise, other modes, residuals) and only
   replaces the modal term. Exact for viscously damped, well separated modes
   that the fit captures; for structural damping it is the viscous equivalent
   at resonance (``eta = 2 zeta``), accurate for light damping. Limits: modes
   closer than a few windowed half-power bandwidths, or a window much shorter
   than the mode's own decay (``1/tau >> sigma_r``, the loss factor then
   results from a small difference of two large numbers) make it unreliable;
   the coherence is that of the windowed data.
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
:func:`roving_sensor_correction` removes the mass of a single accelerometer
that was moved to each response point (Sherman-Morrison on the added mass).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple, Sequence

import numpy as np
import scipy.fft
import scipy.signal

from ..dofs import Dof, parse_dof, parse_dofs
from ..errors import DataError
from ..frequency import Frequency

__all__ = [
    "ImpactRecord",
    "ImpactOptions",
    "ImpactFRF",
    "RejectedHit",
    "WindowMode",
    "estimate_frf",
    "estimate_frfs",
    "check_hits",
    "force_window",
    "exponential_window",
    "correct_exponential_window",
    "roving_sensor_correction",
]

_KINDS = ("receptance", "mobility", "accelerance")


# --------------------------------------------------------------------------- layout


def where_hit(reference: Dof | str, hit: int | str) -> str:
    return f"excited node {reference}, hit {hit}"


def _check_finite(x: np.ndarray, fs: float | None, what: str, where: str) -> None:
    bad = ~np.isfinite(x)
    if bad.any():
        first = int(np.flatnonzero(bad.reshape(-1))[0])
        at = f" (first at sample {first}" + (f", t = {first / fs:.6g} s)" if fs else ")")
        raise DataError(
            f"{where}: {what} contains {int(bad.sum())} NaN/inf sample(s){at}; "
            "remove or re-export the hit (missing cells in a CSV read as NaN)"
        )


@dataclass(frozen=True, eq=False)
class ImpactRecord:
    """The hits at one excited node: hammer force and response time histories.

    Parameters
    ----------
    force : array_like, shape (n_hits, n_samples), or sequence of 1-D arrays
        Hammer force per hit, N.
    responses : array_like, shape (n_hits, n_channels, n_samples), or sequence per hit of (n_channels, n_samples)
        Response per hit and channel; m/s^2 for ``kind="accelerance"``.
    sample_rate_hz : float
        Sampling rate, Hz (> 0), the same for all hits and channels.
    response_dofs : sequence of Dof or str, length n_channels
        Response DOF of each channel, e.g. ``("1w", "3w")``.
    reference : Dof or str
        Excited DOF, e.g. ``"9w"``.
    kind : {"accelerance", "mobility", "receptance"}
        What the response channels measure (acceleration, velocity, displacement).

    Raises
    ------
    DataError
        Naming the excited node and hit: channels of different lengths, hits of
        different lengths, NaN/inf, an all-zero force, a non-positive sample rate,
        a channel count that does not match ``response_dofs``.
    """

    force: np.ndarray
    responses: np.ndarray
    sample_rate_hz: float
    response_dofs: tuple[Dof, ...]
    reference: Dof
    kind: str = "accelerance"

    def __post_init__(self) -> None:
        ref = parse_dof(self.reference)
        object.__setattr__(self, "reference", ref)
        dofs = parse_dofs(self.response_dofs)
        object.__setattr__(self, "response_dofs", dofs)
        if self.kind not in _KINDS:
            raise DataError(f"excited node {ref}: unknown response kind {self.kind!r}; expected one of {_KINDS}")
        fs = self.sample_rate_hz
        try:
            fs = float(fs)
        except (TypeError, ValueError):
            raise DataError(f"excited node {ref}, all hits: sample rate {self.sample_rate_hz!r} is not a number") from None
        if not (math.isfinite(fs) and fs > 0):
            raise DataError(
                f"excited node {ref}, all hits: sample rate must be a finite number > 0 Hz, got {fs!r}; "
                "give the acquisition rate in Hz"
            )
        object.__setattr__(self, "sample_rate_hz", fs)
        forces = list(self.force) if not isinstance(self.force, np.ndarray) else list(self.force) if self.force.ndim == 2 else None
        if forces is None:
            raise DataError(f"excited node {ref}: force must have shape (n_hits, n_samples), got {np.shape(self.force)}")
        resp = list(self.responses) if not (isinstance(self.responses, np.ndarray) and self.responses.ndim != 3) else None
        if resp is None:
            raise DataError(
                f"excited node {ref}: responses must have shape (n_hits, n_channels, n_samples), got {np.shape(self.responses)}"
            )
        if len(forces) == 0:
            raise DataError(f"excited node {ref}: no hits; give at least one hit")
        if len(resp) != len(forces):
            raise DataError(
                f"excited node {ref}: {len(forces)} force record(s) but {len(resp)} response record(s); "
                "give one force and one set of response channels per hit"
            )
        n0 = None
        for i, (f, r) in enumerate(zip(forces, resp)):
            where = where_hit(ref, i)
            f = np.asarray(f, dtype=float)
            if f.ndim != 1:
                raise DataError(f"{where}: force must be 1-D per hit, got shape {f.shape}")
            if n0 is None:
                n0 = f.size
            if f.size != n0:
                raise DataError(
                    f"{where}: force has {f.size} samples but hit 0 has {n0}; all hits must have the same "
                    "record length (re-export with a fixed block size)"
                )
            chans = list(r) if not isinstance(r, np.ndarray) or r.ndim == 2 else None
            if chans is None:
                raise DataError(f"{where}: responses must be (n_channels, n_samples) per hit, got shape {np.shape(r)}")
            if len(chans) != len(dofs):
                raise DataError(
                    f"{where}: {len(chans)} response channel(s) but {len(dofs)} response DOF label(s) "
                    f"{[str(d) for d in dofs]}; give one label per channel"
                )
            for c, (d, y) in enumerate(zip(dofs, chans)):
                y = np.asarray(y)
                if y.ndim != 1 or y.size != f.size:
                    raise DataError(
                        f"{where}: response channel {d} has {y.size} samples but the force has {f.size}; "
                        "all channels of a hit must have the same length (trim or re-export)"
                    )
        F = np.array([np.asarray(f, dtype=float) for f in forces])
        R = np.array([np.asarray(r, dtype=float) for r in resp]).reshape(len(forces), len(dofs), n0)
        if n0 < 8:
            raise DataError(f"excited node {ref}: records have {n0} samples; give at least 8")
        for i in range(F.shape[0]):
            where = where_hit(ref, i)
            _check_finite(F[i], fs, "the force", where)
            for c, d in enumerate(dofs):
                _check_finite(R[i, c], fs, f"response channel {d}", where)
            if not np.any(F[i]):
                raise DataError(
                    f"{where}: the force channel is all zeros (hammer not connected, wrong channel, or no trigger); "
                    "remove the hit or fix the channel"
                )
        F.setflags(write=False)
        R.setflags(write=False)
        object.__setattr__(self, "force", F)
        object.__setattr__(self, "responses", R)

    @property
    def n_hits(self) -> int:
        """Number of hits."""
        return int(self.force.shape[0])

    @property
    def n_samples(self) -> int:
        """Samples per record."""
        return int(self.force.shape[1])

    @property
    def time_s(self) -> np.ndarray:
        """Sample times ``n / fs``, s, shape (n_samples,)."""
        return np.arange(self.n_samples) / self.sample_rate_hz


@dataclass(frozen=True)
class ImpactOptions:
    """Settings of :func:`estimate_frfs` (see the module docstring for the algorithms).

    Parameters
    ----------
    force_window_s : float or None
        Length of the flat part of the force window, s; None: no force window.
    force_pretrigger_s : float
        Start of the force window's flat part, and of the exponential
        window's decay, before the start of the main pulse, s (the main pulse
        starts at its first sample above ``double_hit_fraction`` of the peak;
        a small pretrigger keeps the pulse's rising edge inside both windows).
    force_taper_s : float
        Half-cosine taper on each side of the flat part, s.
    exp_tau_s : float or None
        Time constant of the exponential window, s; None: no exponential window.
    correct_exponential : bool
        Remove the exponential window's added damping from H1/H2.
    mode_bands_hz : sequence of (lo, hi) or None
        One isolated mode per band, Hz, for the correction; None: detected.
    band_hz : (lo, hi) or None
        Output band, Hz; ``hi`` must be below the Nyquist frequency.
    n_fft : int or None
        FFT length (>= n_samples; zero padding); None: n_samples.
    double_hit_fraction : float
        Threshold, as a fraction of the peak ``|force|``, above which a sample
        outside the main pulse means a double hit (0 < x < 1).
    force_clip_n, response_clip : float or None
        Clipping (full-scale) levels of the force (N) and response channels
        (response units); None: not checked against a level.
    overload_fraction : float
        A sample with ``|x| >= overload_fraction * clip`` is an overload.
    flat_top_samples : int
        Consecutive samples at the channel's ``max|x|`` that mean saturation;
        0 disables the flat-top test.
    """

    force_window_s: float | None = None
    force_pretrigger_s: float = 0.0
    force_taper_s: float = 0.0
    exp_tau_s: float | None = None
    correct_exponential: bool = True
    mode_bands_hz: tuple[tuple[float, float], ...] | None = None
    band_hz: tuple[float, float] | None = None
    n_fft: int | None = None
    double_hit_fraction: float = 0.1
    force_clip_n: float | None = None
    response_clip: float | None = None
    overload_fraction: float = 0.99
    flat_top_samples: int = 3

    def __post_init__(self) -> None:
        for name in ("force_window_s", "exp_tau_s", "force_clip_n", "response_clip"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise DataError(f"impact option {name} must be > 0 (or None), got {v!r}")
        for name in ("force_pretrigger_s", "force_taper_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise DataError(f"impact option {name} must be >= 0, got {v!r}")
        if not 0 < self.double_hit_fraction < 1:
            raise DataError(f"impact option double_hit_fraction must be in (0, 1), got {self.double_hit_fraction!r}")
        if not 0 < self.overload_fraction <= 1:
            raise DataError(f"impact option overload_fraction must be in (0, 1], got {self.overload_fraction!r}")
        if self.flat_top_samples < 0 or self.flat_top_samples == 1:
            raise DataError(f"impact option flat_top_samples must be 0 (off) or >= 2, got {self.flat_top_samples!r}")
        if self.band_hz is not None and not (0 <= self.band_hz[0] < self.band_hz[1]):
            raise DataError(f"impact option band_hz must be (lo, hi) with 0 <= lo < hi, got {self.band_hz!r}")
        if self.mode_bands_hz is not None:
            for b in self.mode_bands_hz:
                if not (len(b) == 2 and 0 <= b[0] < b[1]):
                    raise DataError(f"impact option mode_bands_hz: each band must be (lo, hi) with lo < hi, got {b!r}")


class RejectedHit(NamedTuple):
    """A hit left out of the averages: excited DOF, hit index (0-based) and the reason."""

    reference: Dof
    hit: int
    reason: str


class WindowMode(NamedTuple):
    """A mode fitted for the exponential-window correction (viscous equivalent, ``eta = 2 zeta``)."""

    band_hz: tuple[float, float]
    frequency_windowed_hz: float
    loss_factor_windowed: float
    frequency_hz: float
    loss_factor: float


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
        Mode bands that were detected but not corrected, and why.
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

    def to_frf(self, estimator: str = "h1"):
        """The estimate as a labelled :class:`jointid.frf.FRF` (``estimator`` "h1" or "h2")."""
        from ..frf import FRF

        if estimator not in ("h1", "h2"):
            raise DataError(f"estimator must be 'h1' or 'h2', got {estimator!r}")
        return FRF(self.frequency, getattr(self, estimator), self.responses, self.references, self.kind)


# --------------------------------------------------------------------------- quality


def _main_pulse(force: np.ndarray, fraction: float):
    """Peak index, main-pulse start/end (inclusive/exclusive) and the above-threshold mask, per hit."""
    a = np.abs(force)
    n = a.shape[-1]
    peak = np.argmax(a, axis=-1)
    thr = fraction * a[np.arange(a.shape[0]), peak]
    above = a > thr[:, None]
    idx = np.arange(n)
    below = ~above
    end = np.where(below & (idx > peak[:, None]), idx, n).min(axis=1)
    start = np.where(below & (idx < peak[:, None]), idx, -1).max(axis=1) + 1
    return peak, start, end, above


def _flat_top(x: np.ndarray, n_flat: int) -> np.ndarray:
    """True where ``n_flat`` consecutive samples sit at the channel's max |x| (> 0); shape x.shape[:-1]."""
    a = np.abs(x)
    m = a.max(axis=-1, keepdims=True)
    at = (a >= m * (1.0 - 1e-9)) & (m > 0)
    if at.shape[-1] < n_flat:
        return np.zeros(at.shape[:-1], dtype=bool)
    runs = np.lib.stride_tricks.sliding_window_view(at, n_flat, axis=-1).all(axis=-1)
    return runs.any(axis=-1)


def check_hits(record: ImpactRecord, options: ImpactOptions | None = None) -> tuple[RejectedHit, ...]:
    """Double-hit and overload checks of every hit of ``record``.

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node.
    options : ImpactOptions, optional
        Uses ``double_hit_fraction``, ``force_clip_n``, ``response_clip``,
        ``overload_fraction`` and ``flat_top_samples``.

    Returns
    -------
    tuple of RejectedHit
        One entry per bad hit (all reasons of a hit joined by ``"; "``).
    """
    o = options or ImpactOptions()
    fs = record.sample_rate_hz
    F, R = record.force, record.responses
    peak, start, end, above = _main_pulse(F, o.double_hit_fraction)
    idx = np.arange(F.shape[1])
    outside = above & ((idx < start[:, None]) | (idx >= end[:, None]))
    reasons: list[list[str]] = [[] for _ in range(F.shape[0])]
    pk = np.abs(F[np.arange(F.shape[0]), peak])
    for i in np.flatnonzero(outside.any(axis=1)):
        j = int(np.flatnonzero(outside[i])[0])
        k = j + int(np.argmax(np.abs(F[i, j:]) * outside[i, j:]))
        reasons[i].append(
            f"double hit: a second force pulse at t = {k / fs:.4g} s reaches {abs(F[i, k]) / pk[i]:.0%} of the "
            f"peak (main pulse at t = {peak[i] / fs:.4g} s, threshold {o.double_hit_fraction:.0%}); repeat the hit"
        )
    if o.force_clip_n is not None:
        for i in np.flatnonzero(np.abs(F).max(axis=1) >= o.overload_fraction * o.force_clip_n):
            reasons[i].append(
                f"overload: force reaches {np.abs(F[i]).max():.4g} N, >= {o.overload_fraction:.0%} of the "
                f"clipping level {o.force_clip_n:g} N; hit softer or raise the range"
            )
    if o.response_clip is not None:
        over = np.abs(R).max(axis=2) >= o.overload_fraction * o.response_clip
        for i, c in zip(*np.nonzero(over)):
            reasons[i].append(
                f"overload: response channel {record.response_dofs[c]} reaches {np.abs(R[i, c]).max():.4g}, "
                f">= {o.overload_fraction:.0%} of the clipping level {o.response_clip:g}; hit softer or raise the range"
            )
    if o.flat_top_samples:
        ff = _flat_top(F, o.flat_top_samples)
        fr = _flat_top(R, o.flat_top_samples)
        for i in np.flatnonzero(ff):
            reasons[i].append(
                f"overload: the force has a flat top ({o.flat_top_samples}+ consecutive samples at its maximum "
                f"{np.abs(F[i]).max():.4g} N): the channel saturated; hit softer or raise the range"
            )
        for i, c in zip(*np.nonzero(fr)):
            reasons[i].append(
                f"overload: response channel {record.response_dofs[c]} has a flat top ({o.flat_top_samples}+ "
                f"consecutive samples at its maximum {np.abs(R[i, c]).max():.4g}): the channel saturated; "
                "hit softer or raise the range"
            )
    return tuple(
        RejectedHit(record.reference, i, f"{where_hit(record.reference, i)}: " + "; ".join(r))
        for i, r in enumerate(reasons)
        if r
    )


# --------------------------------------------------------------------------- windows


def force_window(n_samples: int, sample_rate_hz: float, start_s: np.ndarray, length_s: float, taper_s: float = 0.0) -> np.ndarray:
    """Rectangular window with half-cosine tapers, one row per hit.

    Parameters
    ----------
    n_samples : int
        Record length.
    sample_rate_hz : float
        Sampling rate, Hz.
    start_s : array_like, shape (n_hits,)
        Start of the flat part per hit, s.
    length_s : float
        Length of the flat part, s.
    taper_s : float
        Length of the half-cosine taper before and after the flat part, s.

    Returns
    -------
    ndarray, shape (n_hits, n_samples)
        1 on the flat part, 0 outside the tapers.
    """
    t = np.arange(n_samples) / sample_rate_hz
    a = np.asarray(start_s, dtype=float).reshape(-1, 1)
    b = a + length_s
    if taper_s > 0:
        up = np.clip((t - (a - taper_s)) / taper_s, 0.0, 1.0)
        down = np.clip((b + taper_s - t) / taper_s, 0.0, 1.0)
        return 0.25 * (1.0 - np.cos(np.pi * up)) * (1.0 - np.cos(np.pi * down))
    tol = 1e-9 / sample_rate_hz
    return ((t >= a - tol) & (t <= b + tol)).astype(float)


def exponential_window(n_samples: int, sample_rate_hz: float, start_s: np.ndarray, tau_s: float) -> np.ndarray:
    """``exp(-(t - t_start)/tau)`` after ``t_start`` and 1 before, one row per hit.

    Parameters
    ----------
    n_samples : int
        Record length.
    sample_rate_hz : float
        Sampling rate, Hz.
    start_s : array_like, shape (n_hits,)
        Start of the decay per hit (start of the impact), s.
    tau_s : float
        Time constant, s; the window adds the decay rate ``1/tau`` rad/s to every mode.

    Returns
    -------
    ndarray, shape (n_hits, n_samples)
    """
    t = np.arange(n_samples) / sample_rate_hz
    a = np.asarray(start_s, dtype=float).reshape(-1, 1)
    return np.exp(-np.clip(t - a, 0.0, None) / tau_s)


# --------------------------------------------------------------------------- estimation


def _spectra(record: ImpactRecord, keep: np.ndarray, o: ImpactOptions, n_fft: int):
    """Averaged Gxx (K,), Gyy (K, C), Gxy (K, C) over the kept hits (one batched rfft)."""
    fs = record.sample_rate_hz
    F = record.force[keep]
    Y = record.responses[keep]
    _, start, _, _ = _main_pulse(F, o.double_hit_fraction)
    t_start = start / fs
    if o.force_window_s is not None:
        F = F * force_window(record.n_samples, fs, t_start - o.force_pretrigger_s, o.force_window_s, o.force_taper_s)
    if o.exp_tau_s is not None:
        w = exponential_window(record.n_samples, fs, t_start - o.force_pretrigger_s, o.exp_tau_s)
        F = F * w
        Y = Y * w[:, None, :]
    X = scipy.fft.rfft(F, n=n_fft, axis=-1)  # (H, K)
    Yf = scipy.fft.rfft(Y, n=n_fft, axis=-1)  # (H, C, K)
    gxx = np.mean(np.abs(X) ** 2, axis=0)
    gyy = np.mean(np.abs(Yf) ** 2, axis=0).T
    gxy = np.mean(np.conj(X)[:, None, :] * Yf, axis=0).T
    return gxx, gyy, gxy


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
    for rec in records:
        bad = check_hits(rec, o)
        rejected.extend(bad)
        keep = np.ones(rec.n_hits, dtype=bool)
        keep[[b.hit for b in bad]] = False
        if not keep.any():
            raise DataError(
                f"excited node {rec.reference}: all {rec.n_hits} hits were rejected: " + " | ".join(b.reason for b in bad)
            )
        a, b, c = _spectra(rec, keep, o, n_fft)
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
        notes=notes,
    )


# --------------------------------------------------------------------------- window correction


def _detect_mode_bands(hz: np.ndarray, H: np.ndarray) -> list[tuple[float, float]]:
    """Bands around the peaks (>= 10 dB prominence) of ``sum |H|^2``: +-3 half-power half-widths."""
    mif = np.sum(np.abs(H.reshape(H.shape[0], -1)) ** 2, axis=1)
    if not np.any(mif > 0):
        return []
    db = 10.0 * np.log10(np.maximum(mif, mif.max() * 1e-30))
    peaks, _ = scipy.signal.find_peaks(db, prominence=10.0)
    bands = []
    for i, p in enumerate(peaks):
        under = np.flatnonzero(mif <= mif[p] / 2.0)
        lo = under[under < p].max(initial=0)
        hi = under[under > p].min(initial=mif.size - 1)
        hw = max((hz[hi] - hz[lo]) / 2.0, hz[1] - hz[0])
        a, b = hz[p] - 3.0 * hw, hz[p] + 3.0 * hw
        if i > 0:
            a = max(a, 0.5 * (hz[peaks[i - 1]] + hz[p]))
        if i < len(peaks) - 1:
            b = min(b, 0.5 * (hz[peaks[i + 1]] + hz[p]))
        bands.append((float(a), float(b)))
    return bands


def _fit_pole(s: np.ndarray, H: np.ndarray, n_iter: int = 8):
    """Common-denominator SDOF rational fit ``N_m(s)/(s^2 + a1 s + a0)`` (s scaled).

    Sanathanan-Koerner iterations (weights ``1/|D_previous|``); the numerators
    (degree 2, one per FRF) are eliminated by orthogonal projection, so each
    iteration is one real least-squares problem in ``(a0, a1)``.

    Parameters
    ----------
    s : ndarray, shape (K,)
        Laplace variable ``j w / w_c`` of the band's lines (scaled by the band centre).
    H : ndarray, shape (K, M)
        FRFs in the band (scaled to unit RMS per column).

    Returns
    -------
    a0, a1 : float
        Denominator ``s^2 + a1 s + a0`` (scaled variable).
    b : ndarray, shape (3, M)
        Real numerator coefficients ``b0 + b1 s + b2 s^2`` per FRF.
    """
    K, M = H.shape
    w = np.ones(K)
    V = np.stack([np.ones_like(s), s, s * s], axis=1)  # (K, 3)
    for _ in range(n_iter):
        Phi = w[:, None] * V
        Phir = np.concatenate([Phi.real, Phi.imag])  # (2K, 3)
        Q, _ = np.linalg.qr(Phir)
        Psi = -(w[:, None, None] * H[:, :, None] * V[:, None, :2])  # (K, M, 2)  columns a0, a1
        rhs = w[:, None] * H * s[:, None] ** 2  # (K, M)
        Psir = np.concatenate([Psi.real, Psi.imag])  # (2K, M, 2)
        rr = np.concatenate([rhs.real, rhs.imag])  # (2K, M)
        Pp = Psir - np.einsum("ik,kmj->imj", Q, np.einsum("ik,imj->kmj", Q, Psir))
        Pr = rr - Q @ (Q.T @ rr)
        a, *_ = np.linalg.lstsq(Pp.reshape(-1, 2), Pr.reshape(-1), rcond=None)
        D = s * s + a[1] * s + a[0]
        if not np.all(np.abs(D) > 0):
            break
        w = 1.0 / np.abs(D)
    Phi = w[:, None] * V
    Phir = np.concatenate([Phi.real, Phi.imag])
    rhs = w[:, None] * H * D[:, None]
    b, *_ = np.linalg.lstsq(Phir, np.concatenate([rhs.real, rhs.imag]), rcond=None)  # (3, M)
    return float(a[0]), float(a[1]), b


def correct_exponential_window(
    frequency_hz: np.ndarray,
    H: np.ndarray,
    tau_s: float,
    mode_bands_hz: Sequence[tuple[float, float]] | None = None,
    strict: bool | None = None,
) -> tuple[np.ndarray, tuple[WindowMode, ...], tuple[str, ...]]:
    """Remove an exponential window's added damping ``1/tau`` from FRFs, mode by mode.

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz (uniform or not).
    H : ndarray, shape (F, ...)
        Windowed FRFs (any kind; all share the poles).
    tau_s : float
        Time constant of the window, s.
    mode_bands_hz : sequence of (lo, hi), optional
        One isolated mode per band, Hz. None: detected at the >= 10 dB peaks of
        ``sum |H|^2`` (bands that cannot be fitted are then skipped and noted).
    strict : bool or None
        Raise on a band that cannot be fitted (True) or skip it with a note
        (False); None: strict exactly when ``mode_bands_hz`` is given.

    Returns
    -------
    H_corrected : ndarray, shape of H
        ``H + sum_r [modal term with pole lambda_w + 1/tau - modal term with lambda_w]``.
    modes : tuple of WindowMode
        Windowed and corrected frequency / loss factor (``eta = 2 zeta``) per band.
    notes : tuple of str
        Bands skipped (auto-detected only).

    Raises
    ------
    DataError
        A given band holds fewer than 6 lines, or its fit gives no oscillating
        pole, or a decay rate below ``1/tau`` (the fitted mode cannot carry the
        window's damping: band holds no isolated mode, or noise).
    """
    hz = np.asarray(frequency_hz, dtype=float)
    H = np.asarray(H, dtype=complex)
    shape = H.shape
    Hm = H.reshape(shape[0], -1)
    auto = mode_bands_hz is None
    if strict is None:
        strict = not auto  # bands the user gave must fit; detected ones may be skipped with a note
    bands = _detect_mode_bands(hz, Hm) if auto else [tuple(map(float, b)) for b in mode_bands_hz]
    out = Hm.copy()
    modes, notes = [], []
    sigma_w = 1.0 / tau_s
    for lo, hi in bands:
        m = (hz >= lo) & (hz <= hi)
        try:
            if m.sum() < 6:
                raise DataError(f"mode band {lo:g}-{hi:g} Hz holds {int(m.sum())} lines; widen it to >= 6 lines")
            wc = 2.0 * np.pi * 0.5 * (lo + hi)
            s = 1j * 2.0 * np.pi * hz[m] / wc
            scale = np.sqrt(np.mean(np.abs(Hm[m]) ** 2, axis=0))
            scale[scale == 0] = 1.0
            a0, a1, b = _fit_pole(s, Hm[m] / scale)
            disc = a1 * a1 - 4.0 * a0
            if not disc < 0:
                raise DataError(
                    f"mode band {lo:g}-{hi:g} Hz: the fit found no oscillating mode; give a band around one resonance"
                )
            lam_w = complex(-a1 / 2.0, math.sqrt(-disc) / 2.0)  # scaled by wc
            lam = lam_w + sigma_w / wc
            if not lam.real < 0:
                raise DataError(
                    f"mode band {lo:g}-{hi:g} Hz: the fitted decay rate {-lam_w.real * wc:.4g} rad/s is below the "
                    f"window's 1/tau = {sigma_w:.4g} rad/s; the band holds no clean mode or tau is wrong"
                )
            num = b[0] + b[1] * lam_w + b[2] * lam_w**2  # (M,)
            R = num / (lam_w - np.conj(lam_w)) * scale
            sa = 1j * 2.0 * np.pi * hz[:, None] / wc
            delta = (
                R / (sa - lam) + np.conj(R) / (sa - np.conj(lam)) - R / (sa - lam_w) - np.conj(R) / (sa - np.conj(lam_w))
            )
            out += delta
            wn_w, wn = abs(lam_w) * wc, abs(lam) * wc
            modes.append(
                WindowMode((lo, hi), wn_w / (2 * np.pi), -2.0 * lam_w.real / abs(lam_w), wn / (2 * np.pi), -2.0 * lam.real / abs(lam))
            )
        except DataError as e:
            if strict:
                raise
            notes.append(f"not corrected: {e}")
    return out.reshape(shape), tuple(modes), tuple(notes)


# --------------------------------------------------------------------------- roving sensor


def roving_sensor_correction(
    H_loaded: np.ndarray,
    driving_point: np.ndarray,
    sensor_mass_kg: float | np.ndarray,
    omega: np.ndarray,
    kind: str = "receptance",
) -> np.ndarray:
    """Remove the mass of a roving accelerometer from measured FRFs.

    The sensor (mass ``m_a``) sits at response point j while row j is
    measured. Its added dynamic stiffness ``-w^2 m_a`` at j gives, by
    Sherman-Morrison, ``H_L[j, k] = H[j, k] / (1 - w^2 m_a H[j, j])``, whence::

        H[j, k] = H_L[j, k] / (1 + w^2 m_a H_L[j, j])        (receptance)
                = A_L[j, k] / (1 - m_a A_L[j, j])             (accelerance)
                = Y_L[j, k] / (1 - j w m_a Y_L[j, j])         (mobility)

    ``H_L[j, j]`` is the *loaded* driving-point FRF at j (hammer at j, sensor at j).

    Assumptions and limits: translational mass only (the sensor's rotary
    inertia and its offset from the surface are ignored, so it cannot correct
    rotational DOFs or rotary-inertia effects, which matter at high frequency on
    slender beams); a single sensor that moves to each response point, every
    other sensor's mass is absent or constant (fixed sensors belong in the FE
    model, not here); the driving point at every response point must be
    measured, and the correction amplifies its noise near the loaded
    anti-resonances of ``1 + w^2 m_a H_L[j, j]``.

    Parameters
    ----------
    H_loaded : array_like, shape (F, r, c)
        Measured FRFs; row j measured with the sensor at response point j.
    driving_point : array_like, shape (F, r)
        Loaded driving-point FRF at each response point (same kind).
    sensor_mass_kg : float or array_like, shape (r,)
        Sensor mass (including mounting), kg, per response point or one for all.
    omega : array_like, shape (F,)
        Angular frequency, rad/s.
    kind : {"receptance", "mobility", "accelerance"}
        Kind of ``H_loaded`` and ``driving_point``.

    Returns
    -------
    ndarray, shape (F, r, c), complex
        FRFs without the sensor's mass.
    """
    H = np.asarray(H_loaded, dtype=complex)
    dp = np.asarray(driving_point, dtype=complex)
    w = np.asarray(omega, dtype=float).reshape(-1)
    if H.ndim != 3:
        raise DataError(f"H_loaded must be (frequency, responses, references), got shape {H.shape}")
    F, r, _ = H.shape
    if dp.shape == (F,) and r == 1:
        dp = dp[:, None]
    if dp.shape != (F, r):
        raise DataError(f"driving_point must have shape (frequency, responses) = {(F, r)}, got {dp.shape}")
    if w.shape != (F,):
        raise DataError(f"omega has {w.size} lines, the FRFs have {F}")
    m = np.broadcast_to(np.asarray(sensor_mass_kg, dtype=float), (r,)) if np.ndim(sensor_mass_kg) <= 1 else None
    if m is None or not np.all(np.isfinite(m)) or np.any(m < 0):
        raise DataError(f"sensor_mass_kg must be >= 0, one value or one per response ({r}), got {sensor_mass_kg!r}")
    if kind == "receptance":
        den = 1.0 + (w**2)[:, None] * m[None, :] * dp
    elif kind == "accelerance":
        den = 1.0 - m[None, :] * dp
    elif kind == "mobility":
        den = 1.0 - 1j * w[:, None] * m[None, :] * dp
    else:
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {_KINDS}")
    if np.any(den == 0):
        raise DataError("roving-sensor correction is singular (1 + w^2 m H_L,jj = 0) at some line")
    return H / den[:, :, None]
