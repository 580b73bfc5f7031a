"""Impact-test records and the settings of their processing.

One :class:`ImpactRecord` holds the repeated hits at **one excited node**:

* ``force``      ``(n_hits, n_samples)``              hammer force, N;
* ``responses``  ``(n_hits, n_channels, n_samples)``  responses, m/s^2 for
  ``kind="accelerance"`` (m/s for ``"mobility"``, m for ``"receptance"``);
* ``sample_rate_hz``; ``response_dofs`` (one label per channel, e.g. ``"3w"``);
  ``reference`` (the excited DOF, e.g. ``"9w"``).

Sample 0 of every channel of a hit is the same instant (simultaneous
sampling); the trigger position within the record is free.
:class:`ImpactOptions` holds the windows, hit checks, band and FFT length
used by :func:`jointid.measurement.impact.estimate_frfs` (see that module for the
algorithms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..dofs import Dof, parse_dof, parse_dofs
from ..errors import DataError

__all__ = ["ImpactRecord", "ImpactOptions", "where_hit", "RESPONSE_KINDS"]

#: Response kinds of an impact record (what its responses measure).
RESPONSE_KINDS = ("receptance", "mobility", "accelerance")


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
        if self.kind not in RESPONSE_KINDS:
            raise DataError(f"excited node {ref}: unknown response kind {self.kind!r}; expected one of {RESPONSE_KINDS}")
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

