"""Cross-sections, materials and the Timoshenko beam element in planar bending.

Element DOFs are ``(w1, theta1, w2, theta2)`` with ``w`` transverse (m, +Z) and
``theta = dw/dx`` (rad). The stiffness is the exact Timoshenko element
(shear parameter ``phi = 12 E I / (kappa G A L^2)``); the consistent mass is the
Friedman & Kosmatka (1993) / Przemieniecki form with translational and rotary
inertia. With ``euler_bernoulli=True``, ``phi = 0`` and rotary inertia is omitted,
so the element is the classical Euler-Bernoulli (Hermite cubic) element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

__all__ = ["Section", "Material", "timoshenko_element", "timoshenko_bending", "require_positive"]


def require_positive(name: str, value: float, unit: str) -> float:
    """``value`` as a float; :class:`ModelError` naming ``name`` and ``unit`` unless positive and finite."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be a number in {unit}, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ModelError(f"{name} must be a positive finite number in {unit}, got {value!r}")
    return v


@dataclass(frozen=True)
class Section:
    """A beam cross-section for bending about one axis.

    Parameters
    ----------
    area : float
        Cross-section area A, m^2.
    second_moment : float
        Second moment of area I about the bending axis, m^4.
    shape : str
        Description (``"rectangle 12.7 x 12.7 mm"``), for reports only.
    """

    area: float
    second_moment: float
    shape: str = "custom"

    def __post_init__(self) -> None:
        require_positive("section area", self.area, "m^2")
        require_positive("section second moment of area", self.second_moment, "m^4")

    @classmethod
    def rectangle(cls, width: float, height: float) -> "Section":
        """Rectangle ``width`` x ``height`` (m); bending in the height direction (I = b h^3 / 12)."""
        b = require_positive("section width", width, "m")
        h = require_positive("section height", height, "m")
        return cls(b * h, b * h**3 / 12.0, f"rectangle {b * 1e3:g} x {h * 1e3:g} mm")

    @classmethod
    def circle(cls, diameter: float) -> "Section":
        """Solid circle of ``diameter`` (m): A = pi d^2 / 4, I = pi d^4 / 64."""
        d = require_positive("section diameter", diameter, "m")
        return cls(math.pi * d**2 / 4.0, math.pi * d**4 / 64.0, f"circle d = {d * 1e3:g} mm")


@dataclass(frozen=True)
class Material:
    """Linear viscoelastic material with structural (hysteretic) damping.

    The one material type of jointid: the beam's steel and the joint's elastomer
    (:class:`jointid.physics.elastomer_joint.ElastomerMaterial`, the same fields with
    nu = 0.49 by default) alike; the study and reproduce configurations parse into it.

    Parameters
    ----------
    elastic_modulus : float
        Young's modulus E (storage part), Pa.
    density : float
        Mass density rho, kg/m^3.
    loss_factor : float
        Structural loss factor eta (E* = E (1 + j eta)), dimensionless, >= 0.
    poisson_ratio : float, optional
        nu; gives G = E / (2 (1 + nu)) when ``shear_modulus`` is not given.
    shear_modulus : float, optional
        G, Pa; overrides ``poisson_ratio``.
    """

    elastic_modulus: float
    density: float
    loss_factor: float = 0.0
    poisson_ratio: float | None = 0.3
    shear_modulus: float | None = None

    #: Prefix of the error messages (``"elastomer "`` for an elastomer).
    _what = ""

    def __post_init__(self) -> None:
        what = self._what
        require_positive(f"{what}elastic modulus", self.elastic_modulus, "Pa")
        require_positive(f"{what}density", self.density, "kg/m^3")
        if not (math.isfinite(self.loss_factor) and self.loss_factor >= 0):
            raise ModelError(f"{what}loss factor must be >= 0, got {self.loss_factor!r}")
        if self.shear_modulus is None:
            if self.poisson_ratio is None:
                raise ModelError(f"{what}material: give either poisson_ratio or shear_modulus")
            if not (-1.0 < self.poisson_ratio < 0.5):
                raise ModelError(f"{what}Poisson ratio must lie in (-1, 0.5), got {self.poisson_ratio!r}")
        else:
            require_positive(f"{what}shear modulus", self.shear_modulus, "Pa")

    @property
    def G(self) -> float:
        """Shear modulus G in Pa."""
        if self.shear_modulus is not None:
            return float(self.shear_modulus)
        return self.elastic_modulus / (2.0 * (1.0 + float(self.poisson_ratio)))

    @property
    def complex_modulus(self) -> complex:
        """E* = E (1 + j eta), Pa."""
        return self.elastic_modulus * (1.0 + 1j * self.loss_factor)


def timoshenko_element(
    length: float,
    section: Section,
    material: Material,
    shear_coefficient: float = 5.0 / 6.0,
    euler_bernoulli: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass matrices of one planar bending element.

    Parameters
    ----------
    length : float
        Element length L, m.
    section : Section
        Cross-section (A in m^2, I in m^4).
    material : Material
        E (Pa), G (Pa), rho (kg/m^3); the loss factor is not applied here.
    shear_coefficient : float
        Timoshenko shear coefficient kappa (5/6 for a rectangle).
    euler_bernoulli : bool
        If True, no shear deformation and no rotary inertia.

    Returns
    -------
    K : ndarray, shape (4, 4)
        Real (storage) stiffness, units N/m, N/rad, N*m/rad on (w1, theta1, w2, theta2).
    M : ndarray, shape (4, 4)
        Consistent mass, kg, kg*m, kg*m^2.
    """
    L = require_positive("element length", length, "m")
    E, rho = material.elastic_modulus, material.density
    A, I = section.area, section.second_moment
    kappa = 1.0 if euler_bernoulli else require_positive("shear coefficient", shear_coefficient, "(dimensionless)")
    K, M = timoshenko_bending(L, E, material.G, rho, A, I, kappa, euler_bernoulli)
    return K[0], M[0]


def timoshenko_bending(L, E, G, rho, A, I, kappa, euler_bernoulli: bool = False):
    """Planar Timoshenko bending elements on (w1, theta1, w2, theta2), vectorized over elements.

    Parameters
    ----------
    L, E, G, rho, A, I, kappa : ndarray, shape (n,), or scalars
        Length (m), Young's and shear moduli (Pa), density (kg/m^3), area (m^2), second
        moment (m^4), shear coefficient (ignored if ``euler_bernoulli``).
    euler_bernoulli : bool
        No shear deformation (``phi = 0``) and no rotary inertia.

    Returns
    -------
    K, M : ndarray, shape (n, 4, 4)
        Stiffness ``E I / ((1 + phi) L^3) [...]``, ``phi = 12 E I / (kappa G A L^2)``, and the
        consistent translational plus rotary mass (Przemieniecki's interdependent interpolation).
    """
    L, E, G, rho, A, I, kappa = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (L, E, G, rho, A, I, kappa)))
    phi = np.zeros_like(L) if euler_bernoulli else 12.0 * E * I / (kappa * G * A * L**2)
    k = E * I / ((1.0 + phi) * L**3)
    one = np.ones_like(L)
    K = np.stack([
        np.stack([12.0 * one, 6 * L, -12.0 * one, 6 * L], -1),
        np.stack([6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2], -1),
        np.stack([-12.0 * one, -6 * L, 12.0 * one, -6 * L], -1),
        np.stack([6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2], -1),
    ], -2) * k[:, None, None]
    p, p2 = phi, phi**2
    m11 = 13 / 35 + 7 / 10 * p + 1 / 3 * p2
    m12 = (11 / 210 + 11 / 120 * p + 1 / 24 * p2) * L
    m13 = 9 / 70 + 3 / 10 * p + 1 / 6 * p2
    m14 = -(13 / 420 + 3 / 40 * p + 1 / 24 * p2) * L
    m22 = (1 / 105 + 1 / 60 * p + 1 / 120 * p2) * L**2
    m24 = -(1 / 140 + 1 / 60 * p + 1 / 120 * p2) * L**2
    M = np.stack([
        np.stack([m11, m12, m13, m14], -1),
        np.stack([m12, m22, -m14, m24], -1),
        np.stack([m13, -m14, m11, -m12], -1),
        np.stack([m14, m24, -m12, m22], -1),
    ], -2) * (rho * A * L / (1.0 + p) ** 2)[:, None, None]
    if euler_bernoulli:
        return K, M
    r11 = 6 / 5 * one
    r12 = (1 / 10 - 1 / 2 * p) * L
    r22 = (2 / 15 + 1 / 6 * p + 1 / 3 * p2) * L**2
    r24 = (-1 / 30 - 1 / 6 * p + 1 / 6 * p2) * L**2
    Mr = np.stack([
        np.stack([r11, r12, -r11, r12], -1),
        np.stack([r12, r22, -r12, r24], -1),
        np.stack([-r11, -r12, r11, -r12], -1),
        np.stack([r12, r24, -r12, r22], -1),
    ], -2) * (rho * I / ((1.0 + p) ** 2 * L))[:, None, None]
    return K, M + Mr
