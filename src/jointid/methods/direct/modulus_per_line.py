"""Complex Young's modulus per line, E*(f), that makes the FE joint model reproduce the measured K21.

:func:`complex_modulus_per_line` solves ``K21(E*) = K_measured`` on every line
with the density fixed, by a vectorized complex Newton iteration (the
derivative ``dS/dE* = U^T (K_ref / E_ref) U`` of the condensed matrix is
exact), continued in frequency from the static limit so that it follows the
physical root through the joint's internal modes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ModelError
from ...physics.elastomer_joint import DEFAULT_DIAMETER_M, DEFAULT_LENGTH_M, DEFAULT_POISSON, ElastomerJoint
from .material_static import as_band_arrays, joint_template

__all__ = ["ComplexModulus", "complex_modulus_per_line"]


@dataclass(frozen=True, eq=False)
class ComplexModulus:
    """Complex Young's modulus per line that makes the joint model reproduce K21 exactly.

    Parameters
    ----------
    frequency_hz : ndarray, shape (F,)
        Lines, Hz.
    modulus_pa : ndarray, shape (F,), complex
        E*(f), Pa.
    density_kg_m3 : float
        Density held fixed, kg/m^3.
    converged : ndarray of bool, shape (F,)
        Newton converged on the line.
    poisson_ratio : float
        nu (for G* = E* / (2 (1 + nu))).
    """

    frequency_hz: np.ndarray
    modulus_pa: np.ndarray
    density_kg_m3: float
    converged: np.ndarray
    poisson_ratio: float = DEFAULT_POISSON

    @property
    def storage_modulus_pa(self) -> np.ndarray:
        """E'(f), Pa."""
        return self.modulus_pa.real

    @property
    def loss_factor(self) -> np.ndarray:
        """eta(f) = E'' / E'."""
        return self.modulus_pa.imag / self.modulus_pa.real

    @property
    def shear_modulus_pa(self) -> np.ndarray:
        """G*(f), Pa, complex."""
        return self.modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    def to_dict(self) -> dict:
        """JSON-ready dict (lists per line; null on lines where Newton did not converge)."""
        def vals(a):
            return [float(v) if (c and math.isfinite(v)) else None for v, c in zip(a, self.converged)]

        with np.errstate(divide="ignore", invalid="ignore"):
            return {
                "frequency_hz": self.frequency_hz.tolist(),
                "storage_modulus_pa": vals(self.storage_modulus_pa),
                "loss_factor": vals(self.loss_factor),
                "density_used_kg_m3": self.density_kg_m3,
                "converged": self.converged.tolist(),
            }


def _newton_modulus(tpl: ElastomerJoint, f, k, rho, E, max_iterations, rtol):
    """Vectorized complex Newton on ``K21(E*) = k`` from ``E`` (F,); returns (E*, converged)."""
    n = tpl._K.shape[0]
    Kn = tpl._K / tpl.elastic_modulus
    interior = np.arange(2, n - 2)
    done = np.zeros(f.shape, dtype=bool)
    for _ in range(int(max_iterations)):
        _, S, X = tpl._blocked(f, modulus=E, density=rho, interior=True)
        # every DOF's displacement for a unit w at x = 0 (u) and at x = L (v), other boundary DOFs held
        u = np.zeros((f.size, n), dtype=complex)
        u[:, 0] = 1.0
        u[:, interior] = -X[:, :, 0]
        v = np.zeros((f.size, n), dtype=complex)
        v[:, n - 2] = 1.0
        v[:, interior] = -X[:, :, 2]
        g = -S[:, 2, 0] - k
        dg = -np.einsum("fi,ij,fj->f", v, Kn, u)  # d(-S_20)/dE* = -v^T (K_ref / E_ref) u
        step = g / dg
        # at most a factor 2 change of |E*| per step
        big = np.abs(step) > 0.5 * np.abs(E)
        step[big] *= 0.5 * np.abs(E[big]) / np.abs(step[big])
        E = E - step
        done = np.abs(step) <= rtol * np.abs(E)
        if done.all():
            break
    _, S, _ = tpl._blocked(f, modulus=E, density=rho)
    ok = done & (np.abs(-S[:, 2, 0] - k) <= 1e-8 * np.abs(k)) & (E.real > 0)
    return E, ok


def complex_modulus_per_line(
    frequency_hz,
    stiffness,
    density_kg_m3: float,
    joint: ElastomerJoint | None = None,
    initial_modulus=None,
    max_iterations: int = 50,
    rtol: float = 1e-12,
) -> ComplexModulus:
    """Solve ``K21_model(E*, rho; f) = K21_measured`` for E* on every line (vectorized Newton).

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz.
    stiffness : array_like, shape (F,), complex
        Measured K21 per joint, N/m.
    density_kg_m3 : float
        Elastomer density held fixed (e.g. from :func:`fit_material`), kg/m^3.
    joint : ElastomerJoint, optional
        Template (geometry, nu, mesh); default 2.54 cm x 2.54 cm, nu = 0.49.
    initial_modulus : complex or array_like (F,), optional
        Starting E*, Pa, for one vectorized Newton solve of all lines. Default:
        continuation in frequency (each line starts from the solution of the
        line below, the lowest from the static limit), which follows the
        physical root through the internal modes, where K21(E*) = K has
        several roots.
    max_iterations : int
        Newton iterations at most.
    rtol : float
        Relative step size below which a line has converged.
    """
    f, k = as_band_arrays(frequency_hz, stiffness)
    tpl = joint_template(joint, DEFAULT_LENGTH_M, DEFAULT_DIAMETER_M, DEFAULT_POISSON)
    rho = float(density_kg_m3)
    if not rho > 0:
        raise ModelError(f"density must be positive (kg/m^3), got {density_kg_m3!r}")
    if initial_modulus is not None:
        E0 = np.broadcast_to(np.asarray(initial_modulus, dtype=complex), f.shape).copy()
        E, ok = _newton_modulus(tpl, f, k, rho, E0, max_iterations, rtol)
    else:
        # continuation in frequency: each line starts from the solution of the line below it,
        # the lowest from the static limit; this follows the physical root through internal modes
        k_unit = tpl.static_guided_stiffness() / tpl._static_modulus()
        order = np.argsort(f)
        E = np.empty(f.shape, dtype=complex)
        ok = np.zeros(f.shape, dtype=bool)
        guess = k[order[0]] / k_unit
        for i in order:
            e, c = _newton_modulus(tpl, f[i : i + 1], k[i : i + 1], rho, np.array([guess]), max_iterations, rtol)
            E[i], ok[i] = e[0], c[0]
            if c[0]:
                guess = e[0]
    return ComplexModulus(f, E, rho, ok, tpl.poisson_ratio)
