"""Elastomer materials and the steel end caps of the elastomer joint (:mod:`.elastomer_joint`).

:class:`ElastomerMaterial` is a :class:`~jointid.physics.elements.Material` (the one
material type) with nu = 0.49 by default. :data:`MATERIALS` holds the two elastomers of
the benchmark. The source study's material table is not public: these values are
documented assumptions chosen to give realistic rubber properties and the internal-mode
frequencies the study reports (Material A: blocked internal mode about 1.2 kHz;
Material B: about 950 Hz for the 2.54 cm x 2.54 cm cylinder).

End caps (fixture assumption): steel discs 2.54 cm diameter x 3 mm, density
7850 kg/m^3: mass 11.9 g, rotary inertia about a diameter through their centroid
``m (r^2/4 + t^2/12)`` = 4.9e-7 kg*m^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..errors import ModelError
from .elements import Material, require_positive

__all__ = ["ElastomerMaterial", "EndCap", "MATERIALS", "DEFAULT_LENGTH_M", "DEFAULT_DIAMETER_M", "DEFAULT_POISSON"]

#: Default elastomer length and diameter, m (1 in x 1 in).
DEFAULT_LENGTH_M = 0.0254
DEFAULT_DIAMETER_M = 0.0254
#: Default Poisson ratio of the elastomer (nearly incompressible rubber).
DEFAULT_POISSON = 0.49


@dataclass(frozen=True)
class ElastomerMaterial(Material):
    """An elastomer with a constant complex modulus: a :class:`~jointid.physics.elements.Material`.

    The same fields and checks as :class:`~jointid.physics.elements.Material` (error
    messages say "elastomer ..."), with nu = 0.49 by default (nearly incompressible)
    and without a separate shear modulus (G follows from E and nu). A frequency-dependent
    modulus is given to :class:`ElastomerJoint` as ``modulus=E*(f)``.

    Parameters
    ----------
    elastic_modulus : float
        Storage Young's modulus E', Pa.
    density : float
        Density, kg/m^3.
    loss_factor : float
        Loss factor (E* = E' (1 + j eta)), dimensionless.
    poisson_ratio : float
        Poisson ratio (default 0.49).
    """

    poisson_ratio: float | None = DEFAULT_POISSON

    _what = "elastomer "

    def __post_init__(self) -> None:
        if self.shear_modulus is not None or self.poisson_ratio is None:
            raise ModelError("elastomer material: give poisson_ratio (G = E / (2 (1 + nu))), not shear_modulus")
        super().__post_init__()

    # Short names of the fields (E* = E (1 + j eta), rho, nu).
    @property
    def E(self) -> float:
        """Storage Young's modulus E' (``elastic_modulus``), Pa."""
        return self.elastic_modulus

    @property
    def eta(self) -> float:
        """Loss factor (``loss_factor``)."""
        return self.loss_factor

    @property
    def rho(self) -> float:
        """Density (``density``), kg/m^3."""
        return self.density

    @property
    def nu(self) -> float:
        """Poisson ratio (``poisson_ratio``)."""
        return float(self.poisson_ratio)

    def to_dict(self) -> dict:
        """JSON-ready dict (Pa, -, kg/m^3, -)."""
        return {"elastic_modulus_pa": self.E, "loss_factor": self.eta, "density_kg_m3": self.rho, "poisson_ratio": self.nu}


#: Built-in elastomers of the benchmark (assumed values: the source's table is not public).
MATERIALS: Mapping[str, ElastomerMaterial] = {
    "A": ElastomerMaterial(elastic_modulus=15e6, density=1200.0, loss_factor=0.10),
    "B": ElastomerMaterial(elastic_modulus=8.8e6, density=1100.0, loss_factor=0.15),
}


@dataclass(frozen=True)
class EndCap:
    """A rigid steel end cap (disc) bonded to an end face of the elastomer.

    Parameters
    ----------
    diameter_m : float
        Disc diameter, m (default 2.54 cm).
    thickness_m : float
        Disc thickness along the cylinder axis, m (default 3 mm).
    density_kg_m3 : float
        Density, kg/m^3 (default steel, 7850).
    """

    diameter_m: float = 0.0254
    thickness_m: float = 0.003
    density_kg_m3: float = 7850.0

    def __post_init__(self) -> None:
        require_positive("end cap diameter", self.diameter_m, "m")
        require_positive("end cap thickness", self.thickness_m, "m")
        require_positive("end cap density", self.density_kg_m3, "kg/m^3")

    @property
    def mass_kg(self) -> float:
        """Cap mass, kg."""
        return self.density_kg_m3 * math.pi * self.diameter_m**2 / 4.0 * self.thickness_m

    @property
    def rotary_inertia_kg_m2(self) -> float:
        """Rotary inertia about a diameter through the centroid, ``m (r^2/4 + t^2/12)``, kg*m^2."""
        r = self.diameter_m / 2.0
        return self.mass_kg * (r**2 / 4.0 + self.thickness_m**2 / 12.0)

    @property
    def offset_m(self) -> float:
        """Distance from the elastomer face to the cap's centroid, m (``t / 2``)."""
        return self.thickness_m / 2.0

    def mass_matrix(self, outward: float = 1.0) -> np.ndarray:
        """Rigid-body mass matrix (2, 2) on (w, theta) of the elastomer face node.

        Parameters
        ----------
        outward : {+1, -1}
            Direction of the cap's centroid from the face along the cylinder's x.
        """
        m, e = self.mass_kg, outward * self.offset_m
        return np.array([[m, m * e], [m * e, self.rotary_inertia_kg_m2 + m * e**2]])
