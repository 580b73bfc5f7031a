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

__all__ = ["MAX_THD", "MAX_FLAT_SHARE", "flat_top_share", "distortion_problems"]

#: Total harmonic distortion (harmonics 2..H over the fundamental) of either channel above which a block
#: is flagged distorted. Smooth distortion does not bias the fundamental (the harmonics are fitted with it:
#: a 20 % third harmonic leaves K21 exact), clipping does; far beyond an elastomer's own nonlinearity (a few
#: per cent), a THD above 25 % means clipping that noise hides from the flat-top test (a sine clipped at
#: 30 % of its peak has a THD of ~0.32) or a test too nonlinear for one K21.
MAX_THD = 0.25
#: Share of a channel's samples on flat tops (runs of >= 3 equal samples at its maximum or minimum) above
#: which the channel is flagged clipped (a saturated load cell, amplifier or actuator).
MAX_FLAT_SHARE = 0.01


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


def distortion_problems(force: np.ndarray, force_thd: float, displacement: np.ndarray, displacement_thd: float) -> list[str]:
    """What is wrong with a block's channels: ``["force clipped (flat tops on 33% of the samples)"]``, or ``[]``.

    Parameters
    ----------
    force, displacement : ndarray, shape (n,)
        The samples the fit used (N, m).
    force_thd, displacement_thd : float
        Their total harmonic distortion ``sqrt(sum_{h>=2} |P_h|^2) / |P_1|``.
    """
    problems = []
    for name, y, d in (("force", force, force_thd), ("displacement", displacement, displacement_thd)):
        flat = flat_top_share(y)
        if flat > MAX_FLAT_SHARE:
            problems.append(f"{name} clipped (flat tops on {flat:.0%} of the samples)")
        elif d > MAX_THD:
            problems.append(f"{name} distorted (harmonic distortion {d:.0%})")
    return problems
