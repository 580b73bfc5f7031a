"""Elastomer material parameters from the direct test's complex stiffness K21(f).

Three levels, from the simplest:

1. :func:`static_estimate` -- the quasi-static stiffness ``k`` (storage part
   averaged over the lowest test frequencies, per joint) gives the naive shear
   modulus ``G = k L / A`` and ``E = 2 G (1 + nu)`` (nu = 0.49). For a short
   cylinder (L = d) the guided Timoshenko stiffness is only about 0.64 GA/L,
   so this under-reads G; the estimate also reports ``G / guided_ratio``, the
   value corrected with the joint model's static limit.
2. :func:`fit_material` -- least squares (``scipy.optimize.least_squares``
   on log-parameters, relative complex residuals ``(K_model - K) / |K|``) of
   a constant E, loss factor and density so that the FE joint model
   (:class:`~jointid.methods.joint_model.ElastomerJoint`, blocked transfer
   stiffness) reproduces the measured K21 over the band.
3. :func:`complex_modulus_per_line` -- E*(f) per line with the density fixed,
   by a vectorized complex Newton iteration on ``K21(E*) = K_measured``
   (the derivative ``dS/dE* = U^T (K_ref / E_ref) U`` of the condensed matrix
   is exact); :func:`fit_zener` fits a fractional-derivative Zener model
   ``E*(w) = (E0 + Einf (j w tau)^alpha) / (1 + (j w tau)^alpha)`` to it.

Every result is a frozen dataclass with ``to_dict()`` for JSON.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..errors import DataError, ModelError
from .joint_model import DEFAULT_DIAMETER_M, DEFAULT_LENGTH_M, DEFAULT_POISSON, ElastomerJoint

__all__ = [
    "StaticEstimate",
    "MaterialFit",
    "ComplexModulus",
    "ZenerFit",
    "static_estimate",
    "fit_material",
    "complex_modulus_per_line",
    "fit_zener",
    "zener_modulus",
]


def _as_arrays(frequency_hz, stiffness) -> tuple[np.ndarray, np.ndarray]:
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


# ---------------------------------------------------------------- static
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
    f, k = _as_arrays(frequency_hz, stiffness)
    if not (isinstance(lines, (int, np.integer)) and lines >= 1):
        raise DataError(f"static lines must be an integer >= 1, got {lines!r}")
    idx = np.argsort(f)[: int(lines)]
    if np.any(k[idx].real <= 0):
        i = idx[int(np.argmax(k[idx].real <= 0))]
        raise DataError(f"line {f[i]:g} Hz: storage stiffness {k[i].real:g} N/m is not positive; check the force sign")
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


# ---------------------------------------------------------------- constant E, eta, rho
@dataclass(frozen=True, eq=False)
class MaterialFit:
    """Constant complex modulus and density fitted to K21 over a band.

    Parameters
    ----------
    elastic_modulus_pa : float
        Storage Young's modulus E', Pa.
    loss_factor : float
        eta.
    density_kg_m3 : float
        rho, kg/m^3.
    relative_std : tuple of float
        Relative standard errors of (E, eta, rho) from the Jacobian and the residual.
    residual_rms : float
        rms of the relative complex residual ``|K_model - K| / |K|``.
    frequency_hz : ndarray, shape (F,)
        Lines fitted, Hz.
    measured, fitted : ndarray, shape (F,), complex
        Measured and model K21 per joint, N/m.
    joint : ElastomerJoint
        The joint model with the fitted material.
    success : bool
        Optimizer convergence flag.
    nfev : int
        Model evaluations.
    """

    elastic_modulus_pa: float
    loss_factor: float
    density_kg_m3: float
    relative_std: tuple
    residual_rms: float
    frequency_hz: np.ndarray
    measured: np.ndarray
    fitted: np.ndarray
    joint: ElastomerJoint
    success: bool
    nfev: int

    @property
    def shear_modulus_pa(self) -> float:
        """G' = E' / (2 (1 + nu)), Pa."""
        return self.elastic_modulus_pa / (2.0 * (1.0 + self.joint.poisson_ratio))

    def to_dict(self) -> dict:
        """JSON-ready dict of the fitted parameters and fit quality."""
        return {
            "elastic_modulus_pa": self.elastic_modulus_pa,
            "shear_modulus_pa": self.shear_modulus_pa,
            "loss_factor": self.loss_factor,
            "density_kg_m3": self.density_kg_m3,
            "relative_std": {"elastic_modulus": self.relative_std[0], "loss_factor": self.relative_std[1], "density": self.relative_std[2]},
            "residual_rms": self.residual_rms,
            "lines": int(self.frequency_hz.size),
            "band_hz": [float(self.frequency_hz.min()), float(self.frequency_hz.max())],
            "blocked_internal_mode_hz": float(self.joint.modes("blocked", 1).frequency_hz[0]),
            "poisson_ratio": self.joint.poisson_ratio,
            "length_m": self.joint.length_m,
            "diameter_m": self.joint.diameter_m,
            "elements": int(self.joint.elements),
            "success": bool(self.success),
            "nfev": int(self.nfev),
        }


def _template(joint: ElastomerJoint | None, length_m: float, diameter_m: float, poisson_ratio: float) -> ElastomerJoint:
    if joint is not None:
        return joint
    return ElastomerJoint(10e6, 0.1, 1100.0, length_m, diameter_m, poisson_ratio)


def fit_material(
    frequency_hz,
    stiffness,
    joint: ElastomerJoint | None = None,
    initial: tuple[float, float, float] | None = None,
    length_m: float = DEFAULT_LENGTH_M,
    diameter_m: float = DEFAULT_DIAMETER_M,
    poisson_ratio: float = DEFAULT_POISSON,
    static_lines: int = 2,
) -> MaterialFit:
    """Fit constant E', eta and rho so the FE joint model reproduces K21 (per joint).

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines to fit, Hz (F >= 2; drop flagged lines first).
    stiffness : array_like, shape (F,), complex
        Measured K21 per joint, N/m.
    joint : ElastomerJoint, optional
        Template giving geometry, nu, kappa and mesh (its material is ignored);
        default: a cylinder ``length_m`` x ``diameter_m`` with ``poisson_ratio``.
    initial : (E Pa, eta, rho kg/m^3), optional
        Starting point; default: E from the static limit of the model, eta the
        mean loss factor of the lowest lines, rho = 1100 kg/m^3.
    length_m, diameter_m, poisson_ratio : float
        Geometry of the default template.
    static_lines : int
        Lowest lines used for the default starting point.

    Returns
    -------
    MaterialFit
    """
    f, k = _as_arrays(frequency_hz, stiffness)
    if f.size < 2:
        raise DataError(f"fitting E, eta and rho needs at least 2 lines, got {f.size}")
    tpl = _template(joint, length_m, diameter_m, poisson_ratio)
    if initial is None:
        st = static_estimate(f, k, lines=min(static_lines, f.size), length_m=tpl.length_m, diameter_m=tpl.diameter_m, poisson_ratio=tpl.poisson_ratio)
        k_unit = tpl.static_guided_stiffness().real / tpl._static_modulus().real  # N/m per Pa
        initial = (st.stiffness_n_m / k_unit, max(st.loss_factor, 1e-3), 1100.0)
    E0, eta0, rho0 = (float(v) for v in initial)
    if not (E0 > 0 and eta0 > 0 and rho0 > 0):
        raise ModelError(f"initial (E, eta, rho) must be positive, got {initial!r}")
    scale = np.abs(k)

    def model(p: np.ndarray) -> np.ndarray:
        E, eta, rho = np.exp(p)
        _, S, _ = tpl._blocked(f, modulus=E * (1.0 + 1j * eta), density=rho)
        return -S[:, 2, 0]

    def resid(p: np.ndarray) -> np.ndarray:
        r = (model(p) - k) / scale
        return np.concatenate([r.real, r.imag])

    sol = least_squares(resid, np.log([E0, eta0, rho0]), method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    E, eta, rho = (float(v) for v in np.exp(sol.x))
    r = sol.fun
    dof = max(r.size - 3, 1)
    s2 = float(r @ r) / dof
    try:
        cov = s2 * np.linalg.inv(sol.jac.T @ sol.jac)
        rel_std = tuple(float(math.sqrt(max(c, 0.0))) for c in np.diag(cov))
    except np.linalg.LinAlgError:
        rel_std = (float("inf"),) * 3
    fitted_joint = tpl.with_material(E, eta, rho)
    kf = model(sol.x)
    return MaterialFit(
        E, eta, rho, rel_std, float(np.sqrt(np.mean(np.abs((kf - k) / k) ** 2))), f, k, kf, fitted_joint, bool(sol.success), int(sol.nfev)
    )


# ---------------------------------------------------------------- E*(f) per line
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
        """JSON-ready dict (lists per line)."""
        return {
            "frequency_hz": self.frequency_hz.tolist(),
            "storage_modulus_pa": self.storage_modulus_pa.tolist(),
            "loss_factor": self.loss_factor.tolist(),
            "density_kg_m3": self.density_kg_m3,
            "converged": self.converged.tolist(),
        }


def _newton_modulus(tpl: ElastomerJoint, f, k, rho, E, max_iterations, rtol):
    """Vectorized complex Newton on ``K21(E*) = k`` from ``E`` (F,); returns (E*, converged)."""
    n = tpl._K.shape[0]
    Kn = tpl._K / tpl.elastic_modulus
    interior = np.arange(2, n - 2)
    done = np.zeros(f.shape, dtype=bool)
    for _ in range(int(max_iterations)):
        _, S, X = tpl._blocked(f, modulus=E, density=rho)
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
    f, k = _as_arrays(frequency_hz, stiffness)
    tpl = _template(joint, DEFAULT_LENGTH_M, DEFAULT_DIAMETER_M, DEFAULT_POISSON)
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


# ---------------------------------------------------------------- Zener
def zener_modulus(f_hz, E0: float, Einf: float, tau_s: float, alpha: float) -> np.ndarray:
    """Fractional-derivative Zener modulus ``(E0 + Einf (j w tau)^alpha) / (1 + (j w tau)^alpha)``, Pa, shape (F,)."""
    s = (1j * 2.0 * np.pi * np.asarray(f_hz, dtype=float) * tau_s) ** alpha
    return (E0 + Einf * s) / (1.0 + s)


@dataclass(frozen=True)
class ZenerFit:
    """Fractional-derivative Zener model of the complex modulus.

    Parameters
    ----------
    E0 : float
        Relaxed (static) modulus, Pa.
    Einf : float
        Unrelaxed (high-frequency) modulus, Pa.
    tau_s : float
        Relaxation time, s.
    alpha : float
        Fractional order, 0 < alpha < 1.
    residual_rms : float
        rms relative complex residual of the fit.
    """

    E0: float
    Einf: float
    tau_s: float
    alpha: float
    residual_rms: float

    def modulus(self, f_hz) -> np.ndarray:
        """E*(f), Pa, complex, shape (F,) (usable as ``ElastomerJoint(modulus=...)``)."""
        return zener_modulus(f_hz, self.E0, self.Einf, self.tau_s, self.alpha)

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {"E0_pa": self.E0, "Einf_pa": self.Einf, "tau_s": self.tau_s, "alpha": self.alpha, "residual_rms": self.residual_rms}


def fit_zener(frequency_hz, modulus_pa, initial: tuple[float, float, float, float] | None = None) -> ZenerFit:
    """Least-squares fit of a fractional Zener model to E*(f) (relative complex residuals).

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz (F >= 2).
    modulus_pa : array_like, shape (F,), complex
        E*(f), Pa.
    initial : (E0, Einf, tau, alpha), optional
        Starting point; default: several starts spread over the band, best kept.
    """
    f, E = _as_arrays(frequency_hz, modulus_pa)
    if f.size < 2:
        raise DataError(f"a Zener fit needs at least 2 lines, got {f.size}")
    w = np.abs(E)

    def unpack(p):
        E0 = math.exp(p[0])
        return E0, E0 * (1.0 + math.exp(p[1])), math.exp(p[2]), 1.0 / (1.0 + math.exp(-p[3]))

    def resid(p):
        r = (zener_modulus(f, *unpack(p)) - E) / w
        return np.concatenate([r.real, r.imag])

    if initial is not None:
        E0, Einf, tau, a = initial
        starts = [np.array([math.log(E0), math.log(max(Einf / E0 - 1.0, 1e-6)), math.log(tau), math.log(a / (1 - a))])]
    else:
        e_lo = float(np.abs(E[np.argmin(f)]))
        fpos = f[f > 0] if np.any(f > 0) else np.array([1.0])
        starts = []
        for ratio in (0.5, 2.0, 5.0):
            for fc in (fpos.min(), math.sqrt(fpos.min() * fpos.max()), fpos.max()):
                for a in (0.3, 0.6):
                    starts.append(np.array([math.log(0.8 * e_lo), math.log(ratio), math.log(1.0 / (2 * math.pi * fc)), math.log(a / (1 - a))]))
    best = None
    for p0 in starts:
        sol = least_squares(resid, p0, method="lm", xtol=1e-12, ftol=1e-12, max_nfev=4000)
        if best is None or sol.cost < best.cost:
            best = sol
    E0, Einf, tau, a = unpack(best.x)
    rr = np.abs(zener_modulus(f, E0, Einf, tau, a) - E) / w
    return ZenerFit(E0, Einf, tau, a, float(np.sqrt(np.mean(rr**2))))
