"""Inputs of the material fits and the quasi-static estimate of the elastomer's G and E.

:func:`as_band_arrays` validates a band of complex values (same length, finite,
non-zero); :func:`joint_template` gives the default FE joint template;
:func:`static_estimate` turns the storage stiffness averaged over the lowest
test lines into the naive shear modulus ``G = k L / A`` and
``E = 2 G (1 + nu)`` (nu = 0.49). For a short cylinder (L = d) the guided
Timoshenko stiffness is only about 0.64 GA/L, so this under-reads G; the
estimate also reports ``G / guided_ratio``, the value corrected with the
joint model's static limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import DataError, ModelError
from ...physics.elastomer_joint import DEFAULT_DIAMETER_M, DEFAULT_LENGTH_M, DEFAULT_POISSON, ElastomerJoint

__all__ = ["StaticEstimate", "static_estimate", "as_band_arrays", "joint_template"]


def as_band_arrays(frequency_hz, stiffness) -> tuple[np.ndarray, np.ndarray]:
    """Validated (frequency (F,), complex values (F,)) of a band; DataError naming the problem."""
    f = np.asarray(frequency_hz, dtype=float).reshape(-1)
    k = np.asarray(stiffness, dtype=complex).reshape(-1)
    if f.shape != k.shape:
        raise DataError(f"frequency ({f.size} lines) and stiffness ({k.size} values) differ in length")
    if f.size == 0:
        raise DataError("no frequency lines to fit; check the amplitude flags and the band")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(k))):
        raise DataError("frequency or stiffness contains NaN/inf; drop those lines before fitting")
    if np.any(k == 0):
        raise DataError(f"line {f[int(np.argmax(k == 0))]:g} Hz: the stiffness is zero; check the force channel")
    return f, k



def joint_template(joint: ElastomerJoint | None, length_m: float, diameter_m: float, poisson_ratio: float) -> ElastomerJoint:
    """``joint`` or, if None, a cylinder ``length_m`` x ``diameter_m`` with ``poisson_ratio`` (material ignored by the fits)."""
    if joint is not None:
        return joint
    return ElastomerJoint(10e6, 0.1, 1100.0, length_m, diameter_m, poisson_ratio)


@dataclass(frozen=True)
class StaticEstimate:
    """Quasi-static shear and Young's moduli from the lowest test frequencies.

    Parameters
    ----------
    stiffness_n_m : float
        Storage stiffness per joint averaged over ``frequency_hz``, N/m.
    loss_factor : float
        Mean loss factor over the same lines.
    shear_modulus_pa : float
        ``G = k L / A``, Pa.
    elastic_modulus_pa : float
        ``E = 2 G (1 + nu)``, Pa.
    guided_ratio : float
        Static guided Timoshenko stiffness over GA/L of the cylinder.
    corrected_shear_modulus_pa, corrected_elastic_modulus_pa : float
        ``G / guided_ratio`` and the matching E, Pa.
    frequency_hz : tuple of float
        Lines used, Hz.
    length_m, area_m2, poisson_ratio : float
        Geometry and nu used.
    """

    stiffness_n_m: float
    loss_factor: float
    shear_modulus_pa: float
    elastic_modulus_pa: float
    guided_ratio: float
    corrected_shear_modulus_pa: float
    corrected_elastic_modulus_pa: float
    frequency_hz: tuple
    length_m: float
    area_m2: float
    poisson_ratio: float

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        d = dict(self.__dict__)
        d["frequency_hz"] = [float(x) for x in self.frequency_hz]
        return d


def static_estimate(
    frequency_hz,
    stiffness,
    lines: int = 2,
    length_m: float = DEFAULT_LENGTH_M,
    diameter_m: float = DEFAULT_DIAMETER_M,
    area_m2: float | None = None,
    poisson_ratio: float = DEFAULT_POISSON,
) -> StaticEstimate:
    """Quasi-static G and E from the ``lines`` lowest test frequencies.

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Test frequencies, Hz.
    stiffness : array_like, shape (F,), complex
        K21 per joint, N/m.
    lines : int
        Number of lowest lines averaged.
    length_m : float
        Elastomer length L, m (default 2.54 cm).
    diameter_m : float
        Elastomer diameter, m (default 2.54 cm); gives A = pi d^2 / 4.
    area_m2 : float, optional
        Shear area A, m^2; overrides ``diameter_m``.
    poisson_ratio : float
        nu for E = 2 G (1 + nu).
    """
    f, k = as_band_arrays(frequency_hz, stiffness)
    if not (isinstance(lines, (int, np.integer)) and lines >= 1):
        raise DataError(f"static lines must be an integer >= 1, got {lines!r}")
    if lines > f.size:
        raise DataError(f"static lines: {lines} asked for, the test has {f.size}; the static estimate averages the lowest "
                        "few lines (default 2)")
    idx = np.argsort(f)[: int(lines)]
    if np.any(k[idx].real <= 0):
        i = idx[int(np.argmax(k[idx].real <= 0))]
        if i == idx[0]:
            raise DataError(f"line {f[i]:g} Hz: storage stiffness {k[i].real:g} N/m is not positive; check the force sign")
        raise DataError(f"line {f[i]:g} Hz: storage stiffness {k[i].real:g} N/m is not positive: it is not quasi-static, "
                        f"yet one of the {lines} lowest lines the static estimate averages; average fewer")
    ks = float(np.mean(k[idx].real))
    eta = float(np.mean(k[idx].imag / k[idx].real))
    A = math.pi * diameter_m**2 / 4.0 if area_m2 is None else float(area_m2)
    if not (A > 0 and length_m > 0):
        raise ModelError(f"length ({length_m!r} m) and area ({A!r} m^2) must be positive")
    G = ks * length_m / A
    E = 2.0 * G * (1.0 + poisson_ratio)
    d_eq = math.sqrt(4.0 * A / math.pi)
    ratio = ElastomerJoint(1e6, 0.0, 1000.0, length_m, d_eq, poisson_ratio, elements=2, cap=None).guided_ratio
    return StaticEstimate(ks, eta, G, E, ratio, G / ratio, E / ratio, tuple(float(x) for x in f[idx]), float(length_m), A, float(poisson_ratio))
