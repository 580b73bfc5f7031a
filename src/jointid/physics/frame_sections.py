"""Cross-sections of 3-D frame (beam) elements: circular (solid or hollow) and rectangular.

A :class:`FrameSection` gives, in the element's local axes (x along the
member, y and z the section's principal axes, see :mod:`jointid.physics.frame`):

* ``area`` A (m^2);
* ``second_moment_y`` ``Iy = int z^2 dA`` (bending in the local x-z plane,
  deflection along z) and ``second_moment_z`` ``Iz = int y^2 dA`` (bending in
  the x-y plane, deflection along y), m^4;
* ``torsion_constant`` J (St Venant), m^4: ``G J`` is the torsional stiffness
  per unit length;
* ``shear_coefficient_y`` / ``_z``: Timoshenko shear coefficients kappa for
  shear along local y and z, or None for Cowper's (1966) value at the member
  material's Poisson ratio (:meth:`FrameSection.shear_coefficients`).

The rotary inertia of torsion uses the polar moment ``Iy + Iz`` (exact for any
section: the mass moment of inertia per unit length is ``rho (Iy + Iz)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .elements import Material, require_positive

__all__ = ["FrameSection", "rectangle_torsion_constant", "cowper_rectangle", "cowper_circle"]

#: Odd terms of the rectangle torsion series (n = 1, 3, ..., 2 * _SERIES_TERMS - 1).
_SERIES_TERMS = 50


def rectangle_torsion_constant(width: float, height: float) -> float:
    """St Venant torsion constant J of a solid ``width`` x ``height`` rectangle, m^4.

    The exact series of the Prandtl stress function (Timoshenko & Goodier,
    *Theory of Elasticity*, sec. 109), with ``a >= b`` the long and short sides::

        J = a b^3 / 3 * (1 - 192 b / (pi^5 a) * sum_{n = 1, 3, 5, ...} tanh(n pi a / (2 b)) / n^5)

    summed over the first 50 odd terms (the neglected tail is below
    ``1e-10`` of J). A square gives ``0.140577 a^4``; a thin strip tends to
    ``a b^3 / 3``.

    Parameters
    ----------
    width, height : float
        Side lengths, m (either may be the longer).
    """
    a, b = max(width, height), min(width, height)
    n = 2.0 * np.arange(_SERIES_TERMS) + 1.0
    s = float(np.sum(np.tanh(n * math.pi * a / (2.0 * b)) / n**5))
    return a * b**3 / 3.0 * (1.0 - 192.0 * b / (math.pi**5 * a) * s)


def cowper_rectangle(poisson_ratio: float) -> float:
    """Cowper's (1966) shear coefficient of a solid rectangle: ``10 (1 + nu) / (12 + 11 nu)`` (0.850 at nu = 0.3)."""
    nu = poisson_ratio
    return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)


def cowper_circle(poisson_ratio: float, diameter_ratio: float = 0.0) -> float:
    """Cowper's (1966) shear coefficient of a circular tube of inner/outer diameter ratio ``m`` (0: solid).

    ``kappa = 6 (1 + nu) (1 + m^2)^2 / ((7 + 6 nu) (1 + m^2)^2 + (20 + 12 nu) m^2)``:
    ``6 (1 + nu) / (7 + 6 nu)`` (0.886 at nu = 0.3) for a solid circle, tending
    to ``2 (1 + nu) / (4 + 3 nu)`` (0.531) for a thin tube.
    """
    nu, m2 = poisson_ratio, diameter_ratio**2
    return 6.0 * (1.0 + nu) * (1.0 + m2) ** 2 / ((7.0 + 6.0 * nu) * (1.0 + m2) ** 2 + (20.0 + 12.0 * nu) * m2)


@dataclass(frozen=True)
class FrameSection:
    """A 3-D beam cross-section in its principal axes (local y, z).

    Parameters
    ----------
    area : float
        A, m^2.
    second_moment_y : float
        ``Iy = int z^2 dA``, m^4: bending with deflection along local z.
    second_moment_z : float
        ``Iz = int y^2 dA``, m^4: bending with deflection along local y.
    torsion_constant : float
        St Venant J, m^4.
    shear_coefficient_y, shear_coefficient_z : float or None
        Timoshenko shear coefficient for shear along local y / z (the area
        carrying shear is ``kappa A``); None: Cowper's value for ``kind`` at
        the material's Poisson ratio (a custom section then needs numbers).
    kind : {"circle", "rectangle", "custom"}
        Shape, for the Cowper default.
    diameter_ratio : float
        Inner/outer diameter of a circular tube (0: solid), for the Cowper default.
    shape : str
        Description for reports (``"tube 40 x 3 mm"``).
    """

    area: float
    second_moment_y: float
    second_moment_z: float
    torsion_constant: float
    shear_coefficient_y: float | None = None
    shear_coefficient_z: float | None = None
    kind: str = "custom"
    diameter_ratio: float = 0.0
    shape: str = "custom"

    def __post_init__(self) -> None:
        require_positive("section area", self.area, "m^2")
        require_positive("section second moment Iy", self.second_moment_y, "m^4")
        require_positive("section second moment Iz", self.second_moment_z, "m^4")
        require_positive("section torsion constant", self.torsion_constant, "m^4")
        for name in ("shear_coefficient_y", "shear_coefficient_z"):
            v = getattr(self, name)
            if v is not None:
                require_positive(f"section {name.replace('_', ' ')}", v, "(dimensionless)")
            elif self.kind not in ("circle", "rectangle"):
                raise ModelError(f"a custom frame section needs {name} (Cowper's default exists for circles and rectangles only)")

    @classmethod
    def circle(cls, outer_diameter: float, inner_diameter: float = 0.0, shear_coefficient: float | None = None) -> "FrameSection":
        """Solid or hollow circle (m): ``A = pi (D^2 - d^2) / 4``, ``Iy = Iz = pi (D^4 - d^4) / 64``, ``J = 2 Iy`` (exact).

        ``shear_coefficient=None``: Cowper's value for a tube (:func:`cowper_circle`).
        """
        D = require_positive("section outer diameter", outer_diameter, "m")
        try:
            d = float(inner_diameter)
        except (TypeError, ValueError):
            d = float("nan")
        if not (math.isfinite(d) and 0.0 <= d < D):
            raise ModelError(f"section inner diameter must be >= 0 and smaller than the outer diameter {D!r} m, got {inner_diameter!r}")
        A = math.pi * (D**2 - d**2) / 4.0
        I = math.pi * (D**4 - d**4) / 64.0
        shape = f"circle d = {D * 1e3:g} mm" if d == 0 else f"tube {D * 1e3:g} / {d * 1e3:g} mm"
        return cls(A, I, I, 2.0 * I, shear_coefficient, shear_coefficient, "circle", d / D, shape)

    @classmethod
    def rectangle(cls, width: float, height: float, shear_coefficient: float | None = None) -> "FrameSection":
        """Solid rectangle, ``width`` along local y and ``height`` along local z (m).

        ``A = b h``, ``Iy = b h^3 / 12`` (bending along z, as the planar beam's
        :meth:`~jointid.physics.elements.Section.rectangle`), ``Iz = h b^3 / 12``,
        J from the exact series (:func:`rectangle_torsion_constant`);
        ``shear_coefficient=None``: Cowper's value (:func:`cowper_rectangle`).
        """
        b = require_positive("section width", width, "m")
        h = require_positive("section height", height, "m")
        return cls(
            b * h, b * h**3 / 12.0, h * b**3 / 12.0, rectangle_torsion_constant(b, h),
            shear_coefficient, shear_coefficient, "rectangle", 0.0, f"rectangle {b * 1e3:g} x {h * 1e3:g} mm",
        )

    @property
    def polar_moment(self) -> float:
        """``Iy + Iz``, m^4 (rotary inertia in torsion is ``rho (Iy + Iz)`` per unit length)."""
        return self.second_moment_y + self.second_moment_z

    def shear_coefficients(self, material: Material) -> tuple[float, float]:
        """``(kappa_y, kappa_z)``: the given ones, or Cowper's at the material's ``nu = E / (2 G) - 1``."""
        nu = material.elastic_modulus / (2.0 * material.G) - 1.0
        if self.kind == "circle":
            default = cowper_circle(nu, self.diameter_ratio)
        elif self.kind == "rectangle":
            default = cowper_rectangle(nu)
        else:
            default = None
        ky = self.shear_coefficient_y if self.shear_coefficient_y is not None else default
        kz = self.shear_coefficient_z if self.shear_coefficient_z is not None else default
        return float(ky), float(kz)
