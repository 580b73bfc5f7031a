"""Synthetic step-sine test data with a known complex stiffness (for tests, studies and the report).

Each block imposes ``x(t) = r(f) a e(t) cos(w t + p)`` (peak amplitude ``a``,
achieved ratio ``r(f)``, random start phase ``p``) with a settling envelope
``e(t)`` that rises as a half-cosine from 0 to 1 over ``settling_cycles``
cycles, and records the force ``F(t) = n Re{K(f) X e^{j w t}} e(t)`` plus
harmonics ``h`` of relative amplitude ``force_harmonics[h]`` (of the force
fundamental, random phase) and Gaussian noise on both channels of rms
``noise x`` the channel's steady fundamental amplitude. ``n`` joints are
loaded in parallel. The record covers ``cycles`` (non-integer by default)
cycles sampled at ``samples_per_cycle`` x f, or at a fixed ``sample_rate_hz``.
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from ..errors import DataError
from .stepsine import StepSineBlock

__all__ = ["synthesize_stepsine", "example_stepsine", "EXAMPLE"]


def _per_line(value, f: np.ndarray, name: str) -> np.ndarray:
    v = value(f) if callable(value) else value
    v = np.asarray(v)
    if v.ndim == 0:
        v = np.full(f.shape, v.item())
    if v.shape != f.shape:
        raise DataError(f"synthesize_stepsine: {name} has shape {v.shape}, expected one value or shape {f.shape}")
    return v


def synthesize_stepsine(
    frequency_hz: Sequence[float],
    stiffness: "Callable[[np.ndarray], np.ndarray] | Sequence[complex] | complex",
    amplitude_m: float = 2.5e-5,
    *,
    parallel_joints: int = 2,
    cycles: float = 12.37,
    settling_cycles: float = 3.0,
    samples_per_cycle: float = 64.0,
    sample_rate_hz: float | None = None,
    force_harmonics: Mapping[int, float] | None = None,
    displacement_noise: float = 0.005,
    force_noise: float = 0.005,
    amplitude_ratio: "Callable[[np.ndarray], np.ndarray] | Sequence[float] | float" = 1.0,
    seed: int = 0,
) -> tuple[StepSineBlock, ...]:
    """Step-sine blocks of a joint with a known complex stiffness (see the module docstring).

    Parameters
    ----------
    frequency_hz : sequence of float, shape (F,)
        Test frequencies, Hz.
    stiffness : callable, sequence or complex
        Complex stiffness per joint, N/m: ``stiffness(f_hz)`` -> (F,), or values (F,), or one value.
    amplitude_m : float
        Commanded displacement amplitude (peak), m (0.05 mm peak-to-peak -> 2.5e-5).
    parallel_joints : int
        Joints in parallel; the recorded force is ``parallel_joints`` times one joint's.
    cycles : float
        Recorded cycles per block, settling included (non-integer on purpose).
    settling_cycles : float
        Length of the settling ramp, cycles.
    samples_per_cycle : float
        Sampling density when ``sample_rate_hz`` is None.
    sample_rate_hz : float, optional
        Fixed sample rate, Hz, for every block.
    force_harmonics : mapping int -> float, optional
        Harmonic number -> amplitude relative to the force fundamental (default {3: 0.03}).
    displacement_noise, force_noise : float
        Noise rms relative to the channel's fundamental amplitude.
    amplitude_ratio : callable, sequence or float
        Achieved / commanded amplitude per line (1: the machine reaches the amplitude).
    seed : int
        Random seed.

    Returns
    -------
    tuple of StepSineBlock
        One block per frequency, in the order given.
    """
    f = np.asarray(frequency_hz, dtype=float).reshape(-1)
    k = _per_line(stiffness, f, "stiffness").astype(complex)
    r = _per_line(amplitude_ratio, f, "amplitude_ratio").astype(float)
    harmonics = {3: 0.03} if force_harmonics is None else dict(force_harmonics)
    rng = np.random.default_rng(seed)
    blocks = []
    for fi, ki, ri in zip(f, k, r):
        fs = samples_per_cycle * fi if sample_rate_hz is None else float(sample_rate_hz)
        n = int(np.floor(cycles * fs / fi))
        t = np.arange(n) / fs
        w = 2.0 * np.pi * fi
        env = np.where(t * fi < settling_cycles, 0.5 - 0.5 * np.cos(np.pi * t * fi / max(settling_cycles, 1e-12)), 1.0)
        X = amplitude_m * ri * np.exp(1j * rng.uniform(0, 2 * np.pi))
        F = parallel_joints * ki * X
        x = env * np.real(X * np.exp(1j * w * t))
        force = np.real(F * np.exp(1j * w * t))
        for h, rel in harmonics.items():
            force = force + rel * abs(F) * np.cos(h * w * t + rng.uniform(0, 2 * np.pi))
        force = env * force
        x = x + displacement_noise * abs(X) * rng.standard_normal(n)
        force = force + force_noise * abs(F) * rng.standard_normal(n)
        blocks.append(StepSineBlock(float(fi), t, x, force))
    return tuple(blocks)


#: Settings of :func:`example_stepsine` (documented in the README and the CLI's ``--example``).
EXAMPLE = {"material": "B", "start_hz": 25.0, "stop_hz": 1500.0, "step_hz": 25.0, "amplitude_m": 2.5e-5,
           "parallel_joints": 2, "noise": 0.01, "seed": 0}


def example_stepsine(seed: int = EXAMPLE["seed"]) -> tuple[StepSineBlock, ...]:
    """The built-in example step-sine test: Material B (E 8.8 MPa, eta 0.15, rho 1100) through its internal mode.

    Blocks every 25 Hz from 25 to 1500 Hz (the blocked internal mode of the
    2.54 cm x 2.54 cm cylinder is ~925 Hz, so the band identifies the density),
    2.5e-5 m peak, two joints in parallel, 1 % noise on both channels, a 3 %
    third harmonic in the force, 32 samples per cycle (:data:`EXAMPLE`).

    Parameters
    ----------
    seed : int
        Random seed.
    """
    from ..physics.elastomer_joint import ElastomerJoint

    e = EXAMPLE
    f = np.arange(e["start_hz"], e["stop_hz"] + 1e-9, e["step_hz"])
    joint = ElastomerJoint.from_material(e["material"])
    return synthesize_stepsine(f, joint.blocked_transfer_stiffness, e["amplitude_m"], parallel_joints=e["parallel_joints"],
                               displacement_noise=e["noise"], force_noise=e["noise"], samples_per_cycle=32.0, seed=seed)
