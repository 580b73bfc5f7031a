"""FE model of the elastomeric joint: a short elastomer cylinder between two steel end caps.

Geometry and coordinates
------------------------
The elastomer cylinder (length ``L``, diameter ``d``, default 2.54 cm x
2.54 cm) lies along its own axis ``x`` from ``x = 0`` to ``x = L`` and is loaded
laterally (shear plus bending) in ``w``; ``theta = dw/dx`` (rad) is the
rotation of the end cross-sections, the same convention as the beam model
(:mod:`jointid.dofs`). It is meshed with ``elements`` Timoshenko elements
(:func:`~jointid.physics.elements.timoshenko_element`) that carry the
elastomer's distributed mass and rotary inertia; the shear coefficient of a
solid circle is ``kappa = 6 (1 + nu) / (7 + 6 nu)`` (0.899 at nu = 0.49).

Material
--------
Complex Young's modulus ``E*(f) = E' (1 + j eta)`` (constant ``E``, ``eta``) or
any callable ``E*(f_hz)``; ``G* = E* / (2 (1 + nu))`` with real ``nu`` (0.49,
nearly incompressible rubber), so the shear parameter ``phi = 12 E I / (kappa G A L^2)``
is real and the stiffness matrix is ``E*(f) / E_ref`` times one real matrix:
``D(f) = (E*(f) / E_ref) K_ref - w^2 M``.

Boundary conditions
-------------------
*Direct test* (:meth:`ElastomerJoint.blocked_transfer_stiffness`): the
actuator-side cap (``x = 0``) is driven in ``w`` with its rotation held
(``theta = 0``: the test system's guided crosshead), the load-cell-side cap
(``x = L``) is blocked (``w = theta = 0``). ``K21 = F2 / X1`` is the force the
cylinder transmits to the load cell, in the direction of the imposed
displacement, per unit displacement (positive static value). Both caps move
with prescribed motion, so their inertia does not enter ``K21`` (the load
cell sits behind the blocked cap; the driven cap's inertia only loads the
actuator). The guided ends are what the double-shear fixture does; with them
the static lateral stiffness is the Timoshenko guided-guided value
``12 E I / ((1 + phi) L^3)`` = ``kappa phi / (1 + phi)`` GA/L, about 0.64 GA/L
for L = d, nu = 0.49 (the notes' "about 0.67"): for a cylinder as long as it is
wide bending is not negligible, and ``G = k L / A`` under-reads the shear
modulus by that factor (:meth:`ElastomerJoint.guided_ratio`).

*Joint of the inverse experiment* (:meth:`ElastomerJoint.driving_point_matrix`):
the cap at ``x = 0`` is on the ground (fixed), the cap at ``x = L`` is bolted
to the beam; the 2x2 matrix on (``w``, ``theta``) of that free end includes
this cap as a rigid body (mass, rotary inertia, its centroid ``t/2`` outboard
of the elastomer face), so the cap belongs to the joint model and must not be
added to the beam model as well (method notes, section 2). The cylinder's
``x`` axis is taken along the beam's ``x`` so that ``theta`` of the joint
equals the beam's ``theta``; a cylinder pointing the other way flips the sign
of the ``w``-``theta`` coupling terms.

Both condensations are dynamic (exact for the FE model):
``S = D_bb - D_bi D_ii^-1 D_ib``. Both keep the same interior (every node but the two ends), whose
``D_ii = s K_ii - w^2 r M_ii`` (``s = E*(f) / E_ref``, ``r = rho / rho_ref``) is diagonal in the interior's
clamped modes (``K_ii Phi = M_ii Phi Lambda``, ``Phi^T M_ii Phi = I``, computed once):
``D_ii^-1 = Phi (s Lambda - w^2 r)^-1 Phi^T``, so that
``S = D_bb - G^T (s Lambda - w^2 r)^-1 G`` with ``G = Phi^T D_ib = s Phi^T K_ib - w^2 r Phi^T M_ib``:
``O(n b^2)`` per line, no ``(F, n, n)`` array and no solve per line (the dense batched solve took 2 s
per call on a virtual hammer test's 8 000 lines). The rounding is that of the symmetric-definite
eigenproblem, within ``n eps cond(D_ii)`` of the dense solve (``tests/test_joint_model.py``; measured 2e-12 relative
on Material A's cylinder over 1-4000 Hz, where ``cond(D_ii)`` is 4e5-3e6).

End caps (:class:`EndCap`) and the built-in elastomers (:data:`MATERIALS`) are defined in
:mod:`jointid.physics.elastomer_material` (re-exported here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.linalg import eigh

from ..dofs import Dof
from ..errors import ModelError
from .elastomer_material import DEFAULT_DIAMETER_M, DEFAULT_LENGTH_M, DEFAULT_POISSON, MATERIALS, ElastomerMaterial, EndCap
from .elements import Material, Section, require_positive
from .structure import ComplexStiffness, build_beam

__all__ = [
    "ElastomerMaterial",
    "EndCap",
    "ElastomerJoint",
    "JointModes",
    "MATERIALS",
    "circle_shear_coefficient",
    "elastomer_joint_from_parameters",
    "elastomer_joint_model",
    "ELASTOMER_PARAMETERS",
]


def circle_shear_coefficient(poisson_ratio: float) -> float:
    """Timoshenko shear coefficient of a solid circle, ``6 (1 + nu) / (7 + 6 nu)`` (Cowper)."""
    nu = float(poisson_ratio)
    return 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)


@dataclass(frozen=True)
class JointModes:
    """Undamped modes of the joint model for one boundary condition.

    Parameters
    ----------
    boundary : str
        ``"blocked"`` (both end faces held) or ``"grounded"`` (x = 0 fixed, cap at x = L free).
    frequency_hz : ndarray, shape (n,)
        Natural frequencies, Hz.
    x_m : ndarray, shape (nodes,)
        Node positions along the cylinder, m.
    w : ndarray, shape (n, nodes)
        Transverse mode shapes (max |w| = 1).
    theta : ndarray, shape (n, nodes)
        Rotation mode shapes, same scaling, rad per unit w.
    """

    boundary: str
    frequency_hz: np.ndarray
    x_m: np.ndarray
    w: np.ndarray
    theta: np.ndarray


@dataclass(frozen=True)
class ElastomerJoint:
    """FE model of an elastomer cylinder with steel end caps (see the module docstring).

    Parameters
    ----------
    elastic_modulus : float
        Storage Young's modulus E', Pa (used when ``modulus`` is None, and as
        the reference modulus of the assembled matrices).
    loss_factor : float
        Loss factor eta, E* = E' (1 + j eta).
    density : float
        Elastomer density, kg/m^3.
    length_m : float
        Elastomer length L (between the caps), m.
    diameter_m : float
        Elastomer diameter d, m.
    poisson_ratio : float
        nu (G = E / (2 (1 + nu))), default 0.49.
    shear_coefficient : float or None
        Timoshenko kappa; None: ``6 (1 + nu) / (7 + 6 nu)``.
    elements : int
        Number of Timoshenko elements along the cylinder (>= 2).
    cap : EndCap or None
        End cap at the free end of the grounded joint (None: no cap).
    modulus : callable or None
        ``modulus(f_hz)`` -> complex E*(f), Pa, shape (F,) for ``f_hz`` (F,);
        overrides ``elastic_modulus`` and ``loss_factor`` when given.
    """

    elastic_modulus: float
    loss_factor: float
    density: float
    length_m: float = DEFAULT_LENGTH_M
    diameter_m: float = DEFAULT_DIAMETER_M
    poisson_ratio: float = DEFAULT_POISSON
    shear_coefficient: float | None = None
    elements: int = 16
    cap: EndCap | None = field(default_factory=EndCap)
    modulus: Callable[[np.ndarray], np.ndarray] | None = None
    _K: np.ndarray = field(init=False, repr=False, compare=False)
    _M: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        material = self.material  # checks E, density, loss factor, Poisson ratio
        L = require_positive("elastomer length", self.length_m, "m")
        require_positive("elastomer diameter", self.diameter_m, "m")
        if not isinstance(self.elements, (int, np.integer)) or isinstance(self.elements, bool) or self.elements < 2:
            raise ModelError(f"joint model: elements must be an integer >= 2, got {self.elements!r}")
        if self.modulus is not None and not callable(self.modulus):
            raise ModelError("joint model: modulus must be a callable E*(f_hz) -> complex Pa, or None")
        kappa = self.kappa
        require_positive("shear coefficient", kappa, "(dimensionless)")
        mat = replace(material, loss_factor=0.0)
        cylinder = build_beam(L, self.section, mat, int(self.elements) + 1, kappa)  # undamped: eta is applied per line
        K, M = cylinder.K.real, cylinder.M
        object.__setattr__(self, "_K", K)
        object.__setattr__(self, "_M", M)
        i = np.arange(2, K.shape[0] - 2)  # the interior: every node but the two ends
        lam, phi = eigh(K[np.ix_(i, i)], M[np.ix_(i, i)])
        object.__setattr__(self, "_interior_modes", (lam, phi))

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_material(cls, material: "Material | str", **kwargs) -> "ElastomerJoint":
        """A joint of a built-in (``"A"``, ``"B"``) or given material (an :class:`ElastomerMaterial`, or any
        :class:`~jointid.physics.elements.Material` with a Poisson ratio); ``kwargs`` set geometry etc."""
        if isinstance(material, str):
            if material not in MATERIALS:
                raise ModelError(f"unknown elastomer material {material!r}; built-in materials: {', '.join(MATERIALS)}")
            material = MATERIALS[material]
        if material.shear_modulus is not None:  # the joint takes G from E and nu: never ignore a given G
            raise ModelError("elastomer material: give poisson_ratio (G = E / (2 (1 + nu))), not shear_modulus")
        kwargs.setdefault("poisson_ratio", material.poisson_ratio)
        return cls(material.elastic_modulus, material.loss_factor, material.density, **kwargs)

    def with_material(self, elastic_modulus: float, loss_factor: float, density: float) -> "ElastomerJoint":
        """A copy with another constant complex modulus and density (same geometry, mesh and caps)."""
        return replace(self, elastic_modulus=elastic_modulus, loss_factor=loss_factor, density=density, modulus=None)

    # ------------------------------------------------------------ properties
    @property
    def material(self) -> ElastomerMaterial:
        """The elastomer's constant-modulus material (E', eta, rho, nu) of this joint."""
        return ElastomerMaterial(self.elastic_modulus, self.density, self.loss_factor, self.poisson_ratio)

    @property
    def kappa(self) -> float:
        """Shear coefficient used."""
        if self.shear_coefficient is not None:
            return float(self.shear_coefficient)
        return circle_shear_coefficient(self.poisson_ratio)

    @property
    def section(self) -> Section:
        """Circular cross-section of the elastomer."""
        return Section.circle(self.diameter_m)

    @property
    def area_m2(self) -> float:
        """Cross-section area A, m^2."""
        return math.pi * self.diameter_m**2 / 4.0

    @property
    def shear_parameter(self) -> float:
        """Timoshenko ``phi = 12 E I / (kappa G A L^2)`` of the whole cylinder (independent of E)."""
        s = self.section
        return 12.0 * 2.0 * (1.0 + self.poisson_ratio) * s.second_moment / (self.kappa * s.area * self.length_m**2)

    @property
    def guided_ratio(self) -> float:
        """Static guided lateral stiffness over GA/L: ``kappa phi / (1 + phi)`` (about 0.64 for L = d)."""
        phi = self.shear_parameter
        return self.kappa * phi / (1.0 + phi)

    @property
    def x_m(self) -> np.ndarray:
        """Node positions along the cylinder, m, shape (elements + 1,)."""
        return np.linspace(0.0, self.length_m, int(self.elements) + 1)

    @property
    def mass_kg(self) -> float:
        """Elastomer mass (without caps), kg."""
        return self.density * self.area_m2 * self.length_m

    def complex_modulus(self, f_hz) -> np.ndarray:
        """Complex Young's modulus E*(f), Pa, shape (F,) for ``f_hz`` (F,) in Hz."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        if self.modulus is None:
            return np.full(f.shape, self.elastic_modulus * (1.0 + 1j * self.loss_factor), dtype=complex)
        e = np.asarray(self.modulus(f), dtype=complex)
        if e.shape == ():
            e = np.full(f.shape, complex(e))
        if e.shape != f.shape:
            raise ModelError(f"joint model: modulus(f_hz) returned shape {e.shape}, expected {f.shape}")
        if not np.all(np.isfinite(e)) or np.any(e.real <= 0):
            bad = f[~(np.isfinite(e) & (e.real > 0))][0]
            raise ModelError(f"joint model: modulus(f_hz) at {bad:g} Hz is not finite with a positive real part")
        return e

    # ------------------------------------------------------------ dynamics
    def dynamic_stiffness(self, f_hz) -> np.ndarray:
        """Dynamic stiffness of the free cylinder (no caps), shape (F, n, n) complex, n = 2 (elements + 1).

        DOFs ordered (node 0 w, node 0 theta, node 1 w, ...), node 0 at x = 0.
        """
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        return self._dynamic(f, self.complex_modulus(f), self.density)

    def _dynamic(self, f: np.ndarray, modulus: np.ndarray, density: float) -> np.ndarray:
        """``(E*/E_ref) K_ref - w^2 (rho/rho_ref) M_ref`` for E* (F,) complex and rho (the fit varies both)."""
        scale = np.asarray(modulus, dtype=complex) / self.elastic_modulus
        w2 = (2.0 * np.pi * f) ** 2 * (density / self.density)
        return scale[:, None, None] * self._K[None] - w2[:, None, None] * self._M[None]

    def _condense(self, f: np.ndarray, modulus: np.ndarray, density: float, boundary: Sequence[int], interior: bool = False):
        """``S = D_bb - D_bi D_ii^-1 D_ib`` (F, b, b) on ``boundary`` DOFs, the interior's modes (module docstring),
        and with ``interior`` also ``X = D_ii^-1 D_ib`` (F, i, b) (else None); ``modulus`` E* (F,) complex, Pa."""
        b = np.asarray(boundary)
        lam, phi = self._interior_modes
        i = np.arange(2, self._K.shape[0] - 2)
        s = np.asarray(modulus, dtype=complex) / self.elastic_modulus
        w2 = (2.0 * np.pi * f) ** 2 * (density / self.density)
        Dbb = s[:, None, None] * self._K[np.ix_(b, b)][None] - w2[:, None, None] * self._M[np.ix_(b, b)][None]
        G = s[:, None, None] * (phi.T @ self._K[np.ix_(i, b)])[None] - w2[:, None, None] * (phi.T @ self._M[np.ix_(i, b)])[None]
        qG = G / (s[:, None] * lam[None, :] - w2[:, None])[:, :, None]  # (s Lambda - w^2 r)^-1 G, (F, i, b)
        S = Dbb - np.swapaxes(G, 1, 2) @ qG  # D_bi = D_ib^T (complex symmetric)
        return S, (phi @ qG if interior else None)

    def _blocked(self, f_hz, modulus=None, density=None, interior: bool = False):
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        n = self._K.shape[0]
        E = self.complex_modulus(f) if modulus is None else np.broadcast_to(np.asarray(modulus, dtype=complex), f.shape)
        S, X = self._condense(f, E, self.density if density is None else density, [0, 1, n - 2, n - 1], interior)
        return f, S, X

    def blocked_transfer_stiffness(self, f_hz) -> np.ndarray:
        """Blocked cross-point stiffness K21 of the direct test, complex, N/m, shape (F,).

        The end at x = 0 is driven in ``w`` with ``theta`` held, the end at
        x = L is blocked; K21 is the force transmitted to the blocked end (in
        the direction of the imposed displacement) per unit displacement.

        Parameters
        ----------
        f_hz : array_like, shape (F,)
            Frequency lines, Hz.
        """
        _, S, _ = self._blocked(f_hz)
        return -S[:, 2, 0]

    def blocked_driving_stiffness(self, f_hz) -> np.ndarray:
        """Blocked driving-point stiffness K11 of the direct test (elastomer only, no cap), N/m, shape (F,)."""
        _, S, _ = self._blocked(f_hz)
        return S[:, 0, 0]

    def blocked_condensed_matrix(self, f_hz) -> np.ndarray:
        """Condensed dynamic stiffness on (w0, theta0, wL, thetaL) of the elastomer (no caps), shape (F, 4, 4)."""
        _, S, _ = self._blocked(f_hz)
        return S

    def deformed_shape(self, f_hz) -> tuple[np.ndarray, np.ndarray]:
        """Deflection along the cylinder in the direct test per unit imposed displacement.

        Parameters
        ----------
        f_hz : float or array_like, shape (F,)
            Frequency, Hz.

        Returns
        -------
        x_m : ndarray, shape (nodes,)
            Positions from the driven end (x = 0) to the blocked end, m.
        w : ndarray, shape (nodes,) or (F, nodes), complex
            Transverse displacement per unit imposed displacement (w(0) = 1, w(L) = 0).
        """
        scalar = np.ndim(f_hz) == 0
        f, _, X = self._blocked(f_hz, interior=True)
        n = self._K.shape[0]
        w = np.zeros((f.size, n // 2), dtype=complex)
        w[:, 0] = 1.0
        # interior DOFs 2..n-3 alternate (w, theta); interior displacement = -X[:, :, 0]
        w[:, 1:-1] = -X[:, 0::2, 0]
        return self.x_m, (w[0] if scalar else w)

    def driving_point_matrix(self, f_hz, include_cap: bool = True) -> np.ndarray:
        """2x2 driving-point dynamic stiffness of the grounded joint, shape (F, 2, 2), complex.

        The end at x = 0 is fixed (ground); the matrix acts on (``w``, ``theta``)
        of the end at x = L, which carries the end cap (``include_cap``).
        Units: N/m, N/rad (row w, column theta), N*m/m, N*m/rad.

        Parameters
        ----------
        f_hz : array_like, shape (F,)
            Frequency lines, Hz.
        include_cap : bool
            Include the free-end cap's rigid-body inertia (default True).
        """
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        n = self._K.shape[0]
        S, _ = self._condense(f, self.complex_modulus(f), self.density, [n - 2, n - 1])
        if include_cap and self.cap is not None:
            w2 = (2.0 * np.pi * f) ** 2
            S = S - w2[:, None, None] * self.cap.mass_matrix(+1.0)[None]
        return S

    def complex_stiffness(self, node: int, dofs: Sequence[str] = ("w", "theta"), name: str = "elastomer joint"):
        """This joint at beam ``node`` as a :class:`~jointid.physics.structure.ComplexStiffness` (grounded, 2x2 or a subset)."""

        keep = [("w", "theta").index(d) for d in dofs]

        def stiffness(f_hz: np.ndarray) -> np.ndarray:
            return self.driving_point_matrix(f_hz)[:, keep][:, :, keep]

        return ComplexStiffness(tuple(Dof(int(node), d) for d in dofs), stiffness, name)

    # ------------------------------------------------------------ modes
    def modes(self, boundary: str = "blocked", count: int = 4, reference_hz: float = 0.0) -> JointModes:
        """Undamped modes (storage modulus at ``reference_hz``) of the joint.

        Parameters
        ----------
        boundary : {"blocked", "grounded"}
            ``"blocked"``: both end faces held (the internal modes of the direct
            test); ``"grounded"``: x = 0 fixed, free end with its cap (the joint
            of the inverse experiment).
        count : int
            Number of modes returned.
        reference_hz : float
            Frequency at which the storage modulus is taken, Hz.
        """
        n = self._K.shape[0]
        scale = float(self.complex_modulus([reference_hz])[0].real / self.elastic_modulus)
        K = scale * self._K
        M = np.array(self._M)
        if boundary == "blocked":
            free = np.arange(2, n - 2)
        elif boundary == "grounded":
            free = np.arange(2, n)
            if self.cap is not None:
                M[n - 2 :, n - 2 :] += self.cap.mass_matrix(+1.0)
        else:
            raise ModelError(f"joint modes: boundary must be 'blocked' or 'grounded', got {boundary!r}")
        count = max(1, min(int(count), free.size))
        lam, vec = eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], subset_by_index=[0, count - 1])
        full = np.zeros((count, n))
        full[:, free] = vec.T
        w, th = full[:, 0::2], full[:, 1::2]
        norm = np.max(np.abs(w), axis=1)
        norm[norm == 0] = 1.0
        return JointModes(boundary, np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi), self.x_m, w / norm[:, None], th / norm[:, None])

    # ------------------------------------------------------------ statics (analytic)
    def _static_modulus(self) -> complex:
        return complex(self.complex_modulus([0.0])[0])

    def static_shear_stiffness(self) -> complex:
        """Pure-shear stiffness ``G* A / L`` (no bending, kappa = 1), N/m, complex (E* at 0 Hz)."""
        E = self._static_modulus()
        return E / (2.0 * (1.0 + self.poisson_ratio)) * self.area_m2 / self.length_m

    def static_guided_stiffness(self) -> complex:
        """Analytic static K21 of the direct test: guided Timoshenko ``12 E* I / ((1 + phi) L^3)``, N/m."""
        E = self._static_modulus()
        I = self.section.second_moment
        return 12.0 * E * I / ((1.0 + self.shear_parameter) * self.length_m**3)

    def static_cantilever_matrix(self) -> np.ndarray:
        """Analytic static 2x2 stiffness of the grounded joint on (w, theta) of the free end, complex.

        The inverse of the Timoshenko cantilever flexibility
        ``[[L^3/(3EI) + L/(kappa G A), L^2/(2EI)], [L^2/(2EI), L/(EI)]]``.
        """
        E = self._static_modulus()
        G = E / (2.0 * (1.0 + self.poisson_ratio))
        I, A, L = self.section.second_moment, self.area_m2, self.length_m
        C = np.array(
            [[L**3 / (3 * E * I) + L / (self.kappa * G * A), L**2 / (2 * E * I)], [L**2 / (2 * E * I), L / (E * I)]]
        )
        return np.linalg.inv(C)

    def shear_wave_frequency_hz(self) -> float:
        """1-D shear-wave estimate of the blocked internal mode, ``c_s / 2L`` with ``c_s = sqrt(kappa G'/rho)``, Hz."""
        G = self._static_modulus().real / (2.0 * (1.0 + self.poisson_ratio))
        return math.sqrt(self.kappa * G / self.density) / (2.0 * self.length_m)


def elastomer_joint_from_parameters(node: int, dofs: Sequence[str], parameters: Mapping) -> ComplexStiffness:
    """The grounded elastomer joint of a study's ``[joint.model]`` (type ``"elastomer"``) as a ComplexStiffness.

    Parameters
    ----------
    node : int
        Beam node the joint connects to ground.
    dofs : sequence of {"w", "theta"}
        Joint DOFs kept.
    parameters : mapping
        See :func:`elastomer_joint_model`.
    """
    joint = elastomer_joint_model(parameters)
    name = dict(parameters).get("material", "A")
    return joint.complex_stiffness(node, tuple(dofs), name=f"elastomer joint (material {name})")


def elastomer_joint_model(parameters: Mapping) -> ElastomerJoint:
    """The :class:`ElastomerJoint` of a study's ``[joint.model]`` parameters (type ``"elastomer"``).

    Parameters
    ----------
    parameters : mapping
        ``material`` (``"A"`` or ``"B"``, default ``"A"``) and optional overrides
        ``elastic_modulus`` (Pa), ``loss_factor``, ``density`` (kg/m^3),
        ``length`` (m), ``diameter`` (m), ``poisson_ratio``, ``elements``;
        the end cap(s): ``cap`` (bool, default True: the cap belongs to
        the joint model, not to the structure), ``cap_diameter`` (m),
        ``cap_thickness`` (m), ``cap_density`` (kg/m^3).

    Raises
    ------
    ModelError
        An unknown material or parameter (one line).
    """
    p = dict(parameters)
    name = p.pop("material", "A")
    if name not in MATERIALS:
        raise ModelError(f"[joint.model].material: unknown elastomer {name!r}; built-in materials: {', '.join(MATERIALS)}")
    base = MATERIALS[name]
    unknown = sorted(set(p) - set(ELASTOMER_PARAMETERS))
    if unknown:
        raise ModelError(f"[joint.model]: unknown elastomer parameter {unknown[0]!r}; expected one of {', '.join(sorted(ELASTOMER_PARAMETERS))}")
    default_cap = EndCap()
    cap = None
    if p.get("cap", True):
        cap = EndCap(
            p.get("cap_diameter", default_cap.diameter_m),
            p.get("cap_thickness", default_cap.thickness_m),
            p.get("cap_density", default_cap.density_kg_m3),
        )
    return ElastomerJoint(
        elastic_modulus=p.get("elastic_modulus", base.elastic_modulus),
        loss_factor=p.get("loss_factor", base.loss_factor),
        density=p.get("density", base.density),
        length_m=p.get("length", DEFAULT_LENGTH_M),
        diameter_m=p.get("diameter", DEFAULT_DIAMETER_M),
        poisson_ratio=p.get("poisson_ratio", base.nu),
        elements=int(p.get("elements", 16)),
        cap=cap,
    )


#: Optional keys of :func:`elastomer_joint_model` besides ``material``.
ELASTOMER_PARAMETERS = ("elastic_modulus", "loss_factor", "density", "length", "diameter", "poisson_ratio", "elements",
                        "cap", "cap_diameter", "cap_thickness", "cap_density")
