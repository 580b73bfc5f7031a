"""Roving-sensor mass correction of measured FRFs (Sherman-Morrison on the added mass)."""

from __future__ import annotations

import numpy as np

from ..errors import DataError
from .impact_records import RESPONSE_KINDS

__all__ = ["roving_sensor_correction"]


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
        raise DataError(f"unknown FRF kind {kind!r}; expected one of {RESPONSE_KINDS}")
    if np.any(den == 0):
        raise DataError("roving-sensor correction is singular (1 + w^2 m H_L,jj = 0) at some line")
    return H / den[:, :, None]
