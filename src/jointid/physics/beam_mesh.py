"""How finely to mesh a beam between its measurement nodes so its FRFs are converged in a band.

The study's nodes are the measurement grid, not the mesh. The free model's
discretization error is the floor of every inverse identification: the joint's
rotational and coupling terms are differences of nearly equal beam quantities,
so a per-cent error of the model's receptance becomes tens of per cent in
``K_theta_theta``. The criterion here is **elements per bending wavelength** at
the top of the band,

    lambda_b(f) = 2 pi / k_b,   k_b = (w^2 rho A / (E I))^(1/4),

the shortest wavelength the band excites (Euler-Bernoulli; shear makes the
Timoshenko wavelength slightly shorter, which the margin covers). The error
of ``K_theta_theta`` identified from exact FRFs of a much finer mesh falls
steeply with the elements per wavelength (the translational term's error is
far smaller); one element per segment of the benchmark's 19-node grid leaves tens
of per cent (``tests/test_coupling.py``). :data:`ELEMENTS_PER_WAVELENGTH` is
chosen to keep the discretization error of every term below 1 % on the
benchmark beam.
"""

from __future__ import annotations

import math

from ..errors import ModelError
from .elements import Material, Section

__all__ = ["ELEMENTS_PER_WAVELENGTH", "MAX_ELEMENTS_PER_SEGMENT", "bending_wavelength_m", "elements_per_segment"]

#: Elements per bending wavelength at the top of the band (see the module docstring).
ELEMENTS_PER_WAVELENGTH = 48
#: Upper limit of the automatic refinement (a band far above the beam's range would otherwise ask for millions).
MAX_ELEMENTS_PER_SEGMENT = 64


def bending_wavelength_m(section: Section, material: Material, frequency_hz: float) -> float:
    """Euler-Bernoulli bending wavelength ``2 pi / (w^2 rho A / E I)^(1/4)`` at ``frequency_hz``, m."""
    if not frequency_hz > 0:
        raise ModelError(f"the bending wavelength needs a frequency > 0 Hz, got {frequency_hz!r}")
    w = 2.0 * math.pi * frequency_hz
    k = (w * w * material.density * section.area / (material.elastic_modulus * section.second_moment)) ** 0.25
    return 2.0 * math.pi / k


def elements_per_segment(
    length_m: float,
    nodes: int,
    section: Section,
    material: Material,
    max_frequency_hz: float,
    per_wavelength: float = ELEMENTS_PER_WAVELENGTH,
) -> int:
    """Elements per segment between measurement nodes for a converged free model up to ``max_frequency_hz``.

    Returns ``ceil(segment / (lambda_b(max_frequency_hz) / per_wavelength))``,
    at least 1 and at most :data:`MAX_ELEMENTS_PER_SEGMENT`.
    """
    segment = length_m / (nodes - 1)
    element = bending_wavelength_m(section, material, max_frequency_hz) / per_wavelength
    return int(min(MAX_ELEMENTS_PER_SEGMENT, max(1, math.ceil(segment / element - 1e-9))))
