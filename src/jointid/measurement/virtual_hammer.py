"""Virtual roving-hammer test: time histories of hammer hits on an FE structure.

The structure's response to a half-sine hammer pulse is computed exactly in
the frequency domain and sampled: with ``X(f)`` the continuous Fourier
transform of the pulse (analytic) and ``A(f)`` the structure's accelerance,
the sampled acceleration is ``a[n] = fs * irfft(A(f_k) X(f_k))``. This is the
same as an ideal (zero-phase) anti-aliasing filter at ``fs / 2`` on both
channels: the sampled force rings before and after the pulse (about 0.5 % of
the peak 4 samples away for a 4-sample pulse), so a force window must leave
some 8-16 samples either side of the pulse (see :func:`jointid.pipeline.experiment`).
No time stepping is involved: the result is exact for any linear model,
including hysteretic and frequency-dependent joints (whose time-domain
response is defined through the frequency domain anyway).

Two kinds of record (``HammerSettings.pad``):

``pad >= 2`` (transient test)
    The grid is padded to ``>= pad`` records, so the periodic extension has
    decayed before it wraps into the record (time aliasing below
    ``exp(-pad*T*sigma)``); the record is the first ``duration`` of the
    response to one hit. Its H1 carries the physical bias of any transient
    test: leakage of the response still ringing at the end of the record, and,
    for hysteretic (non-causal) damping, the loss of the response *before* the
    record starts (a hysteretic model's impulse response has a precursor that
    decays only like ``1/|t|``). A longer record shrinks the leakage (the
    ringing left at its end decays like ``exp(-sigma T)``) but no record length
    removes the lost precursor; a periodic test has neither bias.
``pad == 1`` (periodic test)
    The grid is the record: each record is one period of the steady response
    to a hit repeated every ``duration``. The record's DFT is exactly
    ``fs X(f_k) A(f_k)`` on its own lines, so H1 (rectangular window on the
    response, a force window wide enough for the ringing) equals the model's
    FRF to rounding, for any damping, causal or not. No exponential window
    is needed (or correct) on such records.

Noise: force noise std = ``force_noise * peak |force|``; response noise std =
``response_noise * rms(response over the record)``, independent per channel and hit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..dofs import Dof, parse_dofs
from ..errors import DataError
from ..frequency import Frequency
from ..physics.structure import Structure
from ..physics.synthesis import synthesize_frf

__all__ = ["HammerSettings", "ImpactHits", "half_sine_spectrum", "simulate_hits"]


@dataclass(frozen=True)
class HammerSettings:
    """Settings of a virtual impact test.

    Parameters
    ----------
    sample_rate : float
        Hz.
    duration : float
        Record length per hit, s.
    averages : int
        Hits per excited node.
    force_noise, response_noise : float
        Relative noise levels (see module doc).
    pulse_duration : float
        Half-sine pulse length, s.
    pulse_amplitude : float
        Peak force, N (varies +-10% from hit to hit).
    pretrigger : float
        Time before the pulse starts, s.
    pad : int
        Length of the synthesis grid in records: 1 for a periodic (leakage-free)
        test, >= 2 for a transient test (see the module doc).
    """

    sample_rate: float = 8192.0
    duration: float = 2.0
    averages: int = 5
    force_noise: float = 0.01
    response_noise: float = 0.01
    pulse_duration: float = 0.0005
    pulse_amplitude: float = 100.0
    pretrigger: float = 0.005
    pad: int = 8


@dataclass(frozen=True, eq=False)
class ImpactHits:
    """Sampled hits at one excited DOF.

    Attributes
    ----------
    force : ndarray, shape (hits, samples)
        Hammer force, N.
    responses : ndarray, shape (hits, channels, samples)
        Accelerations, m/s^2.
    sample_rate : float
        Hz.
    reference : Dof
        Excited DOF.
    response_dofs : tuple of Dof
        DOF of each response channel.
    """

    force: np.ndarray
    responses: np.ndarray
    sample_rate: float
    reference: Dof
    response_dofs: tuple[Dof, ...]


def half_sine_spectrum(f_hz: np.ndarray, duration: float, amplitude: float, start: float) -> np.ndarray:
    """Continuous Fourier transform (N*s) of ``amplitude * sin(pi t / duration)`` on ``[start, start + duration]``.

    ``X(w) = P (pi/T) (1 + exp(-j w T)) / ((pi/T)^2 - w^2) exp(-j w t0)``, with the
    limit ``-j P T / 2 exp(-j w t0)`` at ``w = pi / T``.
    """
    w = 2.0 * np.pi * np.asarray(f_hz, dtype=float)
    a = np.pi / duration
    den = a**2 - w**2
    near = np.abs(den) < 1e-9 * a**2
    safe = np.where(near, 1.0, den)
    x = np.where(near, -0.5j * duration, a * (1.0 + np.exp(-1j * w * duration)) / safe)
    return amplitude * x * np.exp(-1j * w * start)


def simulate_hits(
    structure: Structure,
    responses: Sequence,
    references: Sequence,
    settings: HammerSettings,
    rng: np.random.Generator,
) -> list[ImpactHits]:
    """Hits at each reference DOF with the responses at ``responses`` (accelerations).

    Parameters
    ----------
    structure : Structure or model with ``receptance(frequency, rows, cols)``
        The test article (beam, accelerometer masses, joint to ground; or any
        constrained model giving its receptance in m/N, shape (F, rows, cols));
        must have no rigid-body mode (the response must decay).
    responses, references : sequence of Dof or labels
    settings : HammerSettings
    rng : numpy.random.Generator
        Source of pulse-amplitude variation, trigger jitter and noise.

    Returns
    -------
    list of ImpactHits, one per reference.
    """
    s = settings
    if s.pad < 1:
        raise DataError(f"pad must be >= 1 record (1: periodic test), got {s.pad}")
    responses, references = parse_dofs(responses), parse_dofs(references)
    n = int(round(s.duration * s.sample_rate))
    if n < 16:
        raise DataError(f"record of {n} samples is too short: raise duration or sample_rate")
    npad = n if s.pad == 1 else int(2 ** np.ceil(np.log2(n * s.pad)))
    fk = np.fft.rfftfreq(npad, 1.0 / s.sample_rate)
    acc = np.zeros((fk.size, len(responses), len(references)), complex)
    grid = Frequency(fk[1:])
    if isinstance(structure, Structure):
        acc[1:] = synthesize_frf(structure, grid, responses, references, kind="accelerance").data
    else:  # accelerance = -w^2 receptance
        acc[1:] = -((2.0 * np.pi * grid.hz) ** 2)[:, None, None] * structure.receptance(grid, responses, references)
    out = []
    for j, ref in enumerate(references):
        amp = s.pulse_amplitude * (1.0 + 0.1 * rng.uniform(-1, 1, s.averages))
        start = s.pretrigger + rng.uniform(0, 1.0 / s.sample_rate, s.averages)
        X = np.stack([half_sine_spectrum(fk, s.pulse_duration, a, t0) for a, t0 in zip(amp, start)])  # (hits, K)
        force = s.sample_rate * np.fft.irfft(X, npad, axis=-1)[:, :n]
        resp = s.sample_rate * np.fft.irfft(X[:, None, :] * acc[:, :, j].T[None], npad, axis=-1)[:, :, :n]
        force = force + s.force_noise * np.abs(force).max(axis=-1, keepdims=True) * rng.standard_normal(force.shape)
        rms = np.sqrt(np.mean(resp**2, axis=-1, keepdims=True))
        resp = resp + s.response_noise * rms * rng.standard_normal(resp.shape)
        out.append(ImpactHits(force, resp, s.sample_rate, ref, responses))
    return out
