"""Predicted error of the joint identification for one layout: the layout predictor of ``jointid design``.

See :mod:`jointid.methods.design.layout` for the equations, the scenarios and the search
that uses it; :mod:`jointid.methods.design.estimator` for the smoothing and
column-calibration parts.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...dofs import Dof, parse_dof, parse_dofs
from ...errors import DofError, IdentificationError
from ...frequency import Frequency
from ...physics.free_model import as_free_model
from ..receptance.coupling_lines import symmetric_parametrization
from .estimator import SmootherPrediction, common_variance, spline_bound
from ...terms import dof_term_labels
from ..receptance.smoothing import MAX_BASIS

__all__ = [
    "Sensors", "LayoutPredictor", "Scenario", "DEFAULT_SCENARIOS", "NOISE_MODELS", "ESTIMATORS", "term_names",
    "geometric_mean", "layout_dofs", "joint_blocks",
]

#: FRF noise models of :meth:`LayoutPredictor.frf_variance`.
NOISE_MODELS = ("relative", "additive")
#: What the prediction is of: the per-line estimate, the default estimator's smoothed one (per-term P-spline), or the
#: joint spline fit (the default for a mount of 4-6 DOFs: its Cramer-Rao bound, :func:`~.estimator.spline_bound`).
ESTIMATORS = ("per-line", "smoothed", "spline")
#: Off-diagonal terms smaller than this fraction of sqrt(|K_ii K_jj|) are referred to the latter.
_COUPLING_FLOOR = 1e-3


@dataclass(frozen=True)
class Sensors:
    """Accelerometers on the test article.

    Parameters
    ----------
    mass : float
        kg each.
    rotary_inertia : float
        kg*m^2 each.
    nodes : tuple of int, optional
        Where they are; None: on the observed nodes of each layout (they move with it).
    modelled : bool
        They are part of the identification's free model (``[identification].model_accelerometers``).
    """

    mass: float
    rotary_inertia: float = 0.0
    nodes: tuple[int, ...] | None = None
    modelled: bool = True

    def at(self, observed: Sequence[int]) -> tuple[int, ...]:
        """The sensor nodes for a layout with these observed nodes."""
        return tuple(observed) if self.nodes is None else tuple(self.nodes)


def joint_blocks(joint_dofs: Sequence[Dof], blocks: Sequence[tuple[str, int]] | None = None) -> tuple[tuple[str, int], ...]:
    """The joints as ``(name, number of DOFs)`` in ``joint_dofs`` order (default: one unnamed joint of all of them).

    Raises
    ------
    IdentificationError
        Sizes that do not add up to the joint DOFs, or a repeated name.
    """
    if blocks is None:
        return (("", len(joint_dofs)),)
    out = tuple((str(name), int(k)) for name, k in blocks)
    if sum(k for _, k in out) != len(joint_dofs) or any(k < 1 for _, k in out):
        raise IdentificationError(
            f"joint blocks: sizes {[k for _, k in out]} do not split the {len(joint_dofs)} joint DOFs; give each joint's DOF count in order"
        )
    if len(out) > 1 and len({name for name, _ in out}) != len(out):
        raise IdentificationError(f"joint blocks: repeated joint name in {[name for name, _ in out]}; name each joint once")
    return out


def term_names(joint_dofs: Sequence[Dof], symmetric: bool = True,
               blocks: Sequence[tuple[str, int]] | None = None) -> list[tuple[int, int, str]]:
    """``(i, j, "K_{i}_{j}")`` of the terms a design reports: the upper triangle if symmetric, else all.

    Without ``blocks`` (one joint, the beam's): direction names, ``K_w_theta``. With
    ``blocks`` (``(name, size)`` per joint, :func:`joint_blocks`): each joint's own terms
    only -- the terms *between* joints are identified (and should vanish) but are not a
    design target -- named as in ``joint_stiffness.csv`` (``K_x_ry`` on one node,
    ``K_101x_201x`` for a joint between two nodes), prefixed ``"<joint name>:"`` when
    there are several joints (``"front:K_x_x"``).
    """
    n = len(joint_dofs)
    if blocks is None:
        return [
            (i, j, f"K_{joint_dofs[i].direction}_{joint_dofs[j].direction}")
            for i in range(n) for j in range(i if symmetric else 0, n)
        ]
    blocks = joint_blocks(joint_dofs, blocks)
    out, start = [], 0
    for name, k in blocks:
        labels = dof_term_labels(joint_dofs[start:start + k])
        prefix = f"{name}:" if len(blocks) > 1 else ""
        out += [(start + a, start + b, f"{prefix}K_{labels[a]}_{labels[b]}")
                for a in range(k) for b in range(a if symmetric else 0, k)]
        start += k
    return out


def layout_dofs(items, what: str = "candidates") -> tuple[Dof, ...]:
    """DOFs of a layout given as beam node numbers (``n`` is ``"nw"``), DOF labels (``"12x"``) or :class:`Dof`.

    Raises
    ------
    IdentificationError
        A label that is not a DOF (one line naming ``what``).
    """
    try:
        return tuple(parse_dof(k) for k in items)
    except DofError as exc:
        raise IdentificationError(f"{what}: {exc}") from None


def _sub(Y: np.ndarray, rows, cols) -> np.ndarray:
    """``Y[:, rows, cols]`` as a block (one gather), shape (F, len(rows), len(cols))."""
    return Y[:, np.asarray(rows, dtype=int)[:, None], np.asarray(cols, dtype=int)[None, :]]


class LayoutPredictor:
    """Predicted relative standard deviation of the joint terms for any layout on given nodes.

    Computes the free receptance on the w and theta DOFs of ``nodes`` (and the
    joint's) once; :meth:`relative_std` then slices it per layout (see the
    module docstring for the equations).

    Parameters
    ----------
    free : Structure or FreeModel
        The free structure *without* the accelerometers (they are added per layout).
    joint : callable
        ``joint(f_hz) -> (F, n, n)`` complex: the true joint stiffness on ``joint_dofs``.
    joint_dofs : sequence of Dof or labels
    frequency : Frequency
        Lines to predict on (> 0 Hz).
    nodes : sequence of int, DOF labels or Dof
        Every DOF a layout may observe or excite (and, with sensors, every node that may carry
        one): beam node numbers (``n`` is the transverse ``"nw"``), or DOFs of any model
        (``"12x"``, ``"40z"``). Layouts are then given the same way.
    noise : float
        Relative standard deviation of each measured receptance value (0.01: 1 %).
    sensors : Sensors, optional
    symmetric : bool
        The identification enforces ``Du = Du^T``.
    blocks : sequence of (name, size), optional
        Several joints on ``joint_dofs`` (their block-diagonal assembly is ``joint``): the
        reported terms are each joint's own (:func:`term_names`).

    Raises
    ------
    IdentificationError
        A DOF not in the model; ``sensors`` with candidates other than beam ``w`` DOFs
        (accelerometers are modelled on beam nodes only).
    """

    def __init__(self, free, joint, joint_dofs, frequency: Frequency, nodes: Sequence, noise: float,
                 sensors: Sensors | None = None, symmetric: bool = True, *, noise_model: str = "relative",
                 estimator: str = "per-line", calibration: bool = False, estimator_lines: int | None = None,
                 smoother_basis: int | None = None, blocks: Sequence[tuple[str, int]] | None = None):
        if not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise > 0):
            raise IdentificationError(f"noise: expected a relative FRF noise level > 0 (0.01 = 1 %), got {noise!r}")
        if noise_model not in NOISE_MODELS:
            raise IdentificationError(f"noise model: expected one of {', '.join(NOISE_MODELS)}, got {noise_model!r}")
        if estimator not in ESTIMATORS:
            raise IdentificationError(f"estimator: expected one of {', '.join(ESTIMATORS)}, got {estimator!r}")
        self.noise_model, self.estimator, self.calibration = noise_model, estimator, bool(calibration)
        self._smoother = None
        # a search grid stands for the estimator's lines: each grid line carries the information of
        # estimator_lines / F lines, so its variance is divided by that (smoothing and calibration only)
        self._lines = int(estimator_lines or frequency.hz.size)
        self._thin = self._lines / frequency.hz.size
        self._basis = smoother_basis
        model = as_free_model(free)
        self.joint_dofs = tuple(parse_dofs(joint_dofs))
        self.frequency = frequency
        self.noise = float(noise)
        self.sensors = sensors
        self.symmetric = symmetric
        self.terms = term_names(self.joint_dofs, symmetric, blocks)
        layout = layout_dofs(nodes)
        if all(d.direction == "w" for d in layout):  # beam nodes: w and theta of each (sensors need theta)
            extra = set(sensors.nodes or ()) if sensors is not None else set()
            self.nodes = tuple(sorted({d.node for d in layout} | {d.node for d in self.joint_dofs} | extra))
            dofs = [Dof(k, x) for k in self.nodes for x in ("w", "theta")]
        else:
            if sensors is not None:
                raise IdentificationError(
                    "sensors: accelerometers are modelled on beam nodes (w, theta) only; with DOF candidates such as "
                    f"{str(next(d for d in layout if d.direction != 'w'))!r} put their masses into the model and pass sensors=None"
                )
            dofs = sorted(set(layout) | set(self.joint_dofs))
            self.nodes = tuple(sorted({d.node for d in dofs}))
        have = set(model.dofs)
        missing = [str(d) for d in dofs if d not in have]
        if missing:
            raise IdentificationError(f"DOF(s) {missing} are not DOFs of the free model")
        self._index = {d: i for i, d in enumerate(dofs)}
        self.Y0 = model.receptance(frequency, dofs, dofs)  # (F, D, D), the one expensive step
        self.Du = np.asarray(joint(frequency.hz), dtype=complex)
        self._n = [self._index[d] for d in self.joint_dofs]
        self._P = symmetric_parametrization(len(self.joint_dofs), symmetric)
        diag = np.abs(np.einsum("fii->fi", self.Du))
        ref = np.abs(self.Du).copy()
        for i, j, _ in self.terms:
            if i != j:
                geo = np.sqrt(diag[:, i] * diag[:, j])
                ref[:, i, j] = np.where(ref[:, i, j] < _COUPLING_FLOOR * geo, geo, ref[:, i, j])
        self._reference = ref

    def variant(self, scenario: "Scenario") -> "LayoutPredictor":
        """The same predictor (receptances shared, not recomputed) for another scenario."""
        other = copy.copy(self)
        other.noise_model, other.estimator, other.calibration = scenario.noise_model, scenario.estimator, scenario.calibration
        if scenario.level is not None:
            other.noise = float(scenario.level)
        return other

    def _w(self, items: Sequence) -> list[int]:
        """Positions of a layout's DOFs (beam node numbers are their ``w``) in the receptance."""
        try:
            return [self._index[parse_dof(k)] for k in items]
        except KeyError as exc:
            raise IdentificationError(f"layout: DOF {exc.args[0]} is not one of the predictor's candidate DOFs") from None

    def _loaded(self, sensor_nodes: Sequence[int], rows: list[int]) -> np.ndarray:
        """Free receptance on DOF indices ``rows`` with accelerometers at ``sensor_nodes`` (Woodbury), (F, r, r)."""
        Y = _sub(self.Y0, rows, rows)
        if self.sensors is None or not len(sensor_nodes):
            return Y
        a = [self._index[Dof(k, x)] for k in sensor_nodes for x in ("w", "theta")]
        dD = -(self.frequency.omega**2)[:, None] * np.tile([self.sensors.mass, self.sensors.rotary_inertia], len(sensor_nodes))
        S = np.eye(len(a))[None] + _sub(self.Y0, a, a) * dD[:, None, :]  # I + Y[a,a] dD
        return Y - (_sub(self.Y0, rows, a) * dD[:, None, :]) @ np.linalg.solve(S, _sub(self.Y0, a, rows))

    def _blocks(self, observed: Sequence[int], excited: Sequence[int]):
        """Exact ``H[m,e]`` of the test article and the identification model's ``Y[m,n], Y[n,e], Y[n,n]``."""
        m, e, n = self._w(observed), self._w(excited), self._n
        rows = list(dict.fromkeys(m + n + e))
        pos = {r: i for i, r in enumerate(rows)}
        im, ie, in_ = [pos[r] for r in m], [pos[r] for r in e], [pos[r] for r in n]
        sensor_nodes = self.sensors.at([parse_dof(k).node for k in observed]) if self.sensors is not None else ()
        Ya = self._loaded(sensor_nodes, rows)
        Ynn = _sub(Ya, in_, in_)
        G = np.linalg.solve(np.eye(len(n))[None] + Ynn @ self.Du, _sub(Ya, in_, ie))  # (I + Y[n,n] Du)^-1 Y[n,e]
        H = _sub(Ya, im, ie) - _sub(Ya, im, in_) @ self.Du @ G
        Y = Ya if self.sensors is not None and self.sensors.modelled else self._loaded((), rows)
        return H, _sub(Y, im, in_), _sub(Y, in_, ie), _sub(Y, in_, in_)

    @property
    def reference(self) -> np.ndarray:
        """``|K_ij|`` (off-diagonal terms floored as in the module docstring), shape (F, n, n)."""
        return self._reference

    def identification_model(self, observed: Sequence[int], excited: Sequence[int]):
        """The identification's free model on the layout's DOFs, and its observed and excited DOFs.

        Returns ``(BlockModel, m_dofs, e_dofs)`` (:class:`~jointid.methods.design.check.BlockModel`).
        """
        from .check import BlockModel

        m = list(layout_dofs(observed, "observed"))
        e = list(layout_dofs(excited, "excited"))
        dofs = list(dict.fromkeys(m + list(self.joint_dofs) + e))
        rows = [self._index[d] for d in dofs]
        modelled = self.sensors is not None and self.sensors.modelled
        Y = self._loaded(self.sensors.at([d.node for d in m]) if modelled else (), rows)
        return BlockModel(dofs, self.frequency.hz, Y), m, e

    def exact_receptance(self, observed: Sequence[int], excited: Sequence[int]) -> np.ndarray:
        """Exact constrained receptance ``H[m,e]`` of the test article (sensors and joint), shape (F, m, e)."""
        return self._blocks(observed, excited)[0]

    def frf_variance(self, H: np.ndarray) -> np.ndarray:
        """``E|dH|^2`` of each measured receptance value under the noise model, shape (F, m, e).

        ``"relative"``: ``(noise |H|)^2``. ``"additive"``: a noise floor per FRF,
        constant in accelerance, ``noise^2 mean_f |w^2 H|^2 / w^4`` (a roving-hammer
        test: response noise proportional to the response's rms, divided by a flat
        force spectrum; the mean is over this predictor's lines).
        """
        if self.noise_model == "relative":
            return (self.noise * np.abs(H)) ** 2
        w2 = (self.frequency.omega**2)[:, None, None]
        level = np.mean(np.abs(w2 * H) ** 2, axis=0, keepdims=True)
        return self.noise**2 * level / w2**2

    def variance(self, observed: Sequence, excited: Sequence, blocks=None, shared: dict | None = None) -> np.ndarray:
        """Predicted ``E|dDu_ij|^2`` per line for the stated noise, shape (F, n, n).

        ``shared``: a dict kept between calls on the same layout's ``blocks`` (the
        design matrix and the Jacobian do not depend on the noise model).
        """
        n = len(self._n)
        H, Ymn, Yne, Ynn = blocks if blocks is not None else self._blocks(observed, excited)
        m, e = len(observed), len(excited)
        F = H.shape[0]
        shared = {} if shared is None else shared
        if "A" not in shared:
            shared["A"] = np.einsum("fkc,fri->frcik", Yne, Ymn).reshape(F, m * e, n * n) @ self._P
        A = shared["A"]
        sigma = np.sqrt(self.frf_variance(H)).reshape(F, -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            Aw = A / sigma[:, :, None]
        Aw = np.where(np.isfinite(Aw), Aw, 0.0)
        cs = np.linalg.norm(Aw, axis=1)
        cs = np.where(cs > 0, cs, 1.0)
        R = np.linalg.qr(Aw / cs[:, None, :], mode="r")
        p = R.shape[-1]
        with np.errstate(all="ignore"):
            try:
                Ri = np.linalg.solve(R, np.broadcast_to(np.eye(p), R.shape))
            except np.linalg.LinAlgError:  # an exactly singular line: that layout cannot identify the joint
                Ri = np.linalg.pinv(R) * np.nan
            C = (Ri @ np.conj(np.swapaxes(Ri, 1, 2))) / (cs[:, :, None] * cs[:, None, :])
        if "J" not in shared:
            I = np.eye(n)
            L = I[None] + self.Du @ Ynn
            Rr = I[None] + Ynn @ self.Du
            shared["J"] = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ self._P
        J = shared["J"]
        with np.errstate(all="ignore"):
            V = np.real(np.einsum("fab,fbc,fac->fa", J, C, J.conj())).reshape(F, n, n)
        return V

    def scenario_variances(self, observed: Sequence[int], excited: Sequence[int], scenarios: Sequence["Scenario"],
                           terms: Sequence[int] | None = None) -> list[np.ndarray]:
        """Predicted ``E|dDu_ij|^2`` per line for each scenario, each shape (F, n, n).

        Parts shared by scenarios (the blocks, the per-line variance of a noise model,
        its smoothed error) are computed once. ``terms``: indices into :attr:`terms` to
        predict (others are NaN in the smoothed scenarios; default all).
        """
        blocks = self._blocks(observed, excited)
        H, Ymn, Yne, Ynn = blocks
        active = [self.terms[k] for k in (range(len(self.terms)) if terms is None else terms)]
        per_line, smoothed, common, out, shared = {}, {}, {}, [], {}
        for sc in scenarios:
            nm = sc.noise_model
            level = self.noise if sc.level is None else sc.level
            key = (nm, level)
            g = (level / self.noise) ** 2  # variances scale with the square of the noise level
            if sc.estimator == "spline":  # every line at once: the bound of its class (calibration does not apply)
                if ("spline",) + key not in smoothed:
                    saved, self.noise_model = self.noise_model, nm
                    try:
                        var_h = g * self.frf_variance(H) / self._thin
                    finally:
                        self.noise_model = saved
                    smoothed[("spline",) + key] = spline_bound(self.frequency.hz, Ymn, Ynn, Yne, var_h, self.Du, self.symmetric)
                out.append(smoothed[("spline",) + key])
                continue
            if key not in per_line:
                saved, self.noise_model = self.noise_model, nm
                try:
                    per_line[key] = g * self.variance(observed, excited, blocks, shared)
                finally:
                    self.noise_model = saved
            if sc.estimator == "per-line":
                out.append(per_line[key])
                continue
            if key not in smoothed:
                if self._smoother is None:
                    K = self._basis or min(max(self._lines // 2, 4), MAX_BASIS)
                    self._smoother = SmootherPrediction(self.frequency.hz, min(K, self.frequency.hz.size - 1))
                V = np.full_like(per_line[key], np.nan)
                for i, j, _ in active:
                    V[:, i, j] = self._smoother.squared_error(self.Du[:, i, j], per_line[key][:, i, j] / self._thin)
                    V[:, j, i] = V[:, i, j]
                smoothed[key] = V
            V = smoothed[key]
            if sc.calibration:
                if key not in common:
                    saved, self.noise_model = self.noise_model, nm
                    try:
                        var_h = g * self.frf_variance(H) / self._thin
                    finally:
                        self.noise_model = saved
                    common[key] = common_variance(self.frequency.hz, Ymn, Yne, Ynn, H, var_h, self.Du, self.symmetric)
                V = V + common[key]
            out.append(V)
        return out

    def relative_std(self, observed: Sequence[int], excited: Sequence[int]) -> np.ndarray:
        """Predicted relative standard deviation per term and line, shape (F, T) in :attr:`terms` order.

        With ``estimator="per-line"`` the per-line estimate's; with ``"smoothed"`` the
        default estimator's expected error after smoothing over frequency, plus (with
        ``calibration``) the common error of its column calibration
        (:mod:`jointid.methods.design.estimator`).
        """
        sc = Scenario(self.noise_model, self.estimator, self.calibration)
        return self.relative(self.scenario_variances(observed, excited, [sc])[0])

    def relative(self, V: np.ndarray) -> np.ndarray:
        """``sqrt(V) / |K|`` per term (off-diagonal terms as in the module docstring), shape (F, T)."""
        with np.errstate(all="ignore"):
            rel = np.sqrt(np.abs(V)) / self._reference
            rel = np.where(np.isfinite(rel), rel, np.inf)
        return np.stack([rel[:, i, j] for i, j, _ in self.terms], axis=1)


@dataclass(frozen=True)
class Scenario:
    """What a design predicts: the FRF noise model, the estimator, and whether it calibrates the columns.

    Parameters
    ----------
    noise_model : {"relative", "additive"}
        See :meth:`LayoutPredictor.frf_variance`.
    estimator : {"per-line", "smoothed", "spline"}
        The per-line estimate, the default estimator's for a joint of 1-3 DOFs (smoothed over
        frequency), or the joint spline fit's bound (the default for a mount of 4-6 DOFs; the
        column calibration does not apply to it).
    calibration : bool
        Include the common error of the column calibration (what the estimator adds
        when the test has force noise).
    level : float, optional
        Noise level of this scenario (default: the design's ``noise``), e.g. a hammer
        test's response noise per FRF line after averaging.
    """

    noise_model: str = "relative"
    estimator: str = "smoothed"
    calibration: bool = False
    level: float | None = None

    @property
    def name(self) -> str:
        """E.g. ``"relative, smoothed"`` or ``"additive, smoothed, calibrated"``."""
        level = [] if self.level is None else [f"{100 * self.level:.2g} %"]
        return ", ".join([self.noise_model] + level + [self.estimator] + (["calibrated"] if self.calibration else []))


#: The default scenarios: relative and additive noise, each without and with column calibration.
DEFAULT_SCENARIOS = (
    Scenario("relative", "smoothed", False), Scenario("additive", "smoothed", False),
    Scenario("relative", "smoothed", True), Scenario("additive", "smoothed", True),
)


class _Combined:
    """Predictors of several scenarios; ``relative_std`` is their geometric mean per line and term."""

    def __init__(self, free, joint, joint_dofs, frequency, nodes, noise, sensors, symmetric, scenarios, lines=None,
                 basis=None, terms=None, blocks=None):
        self.predictor = LayoutPredictor(free, joint, joint_dofs, frequency, nodes, noise, sensors, symmetric,
                                         estimator_lines=lines, smoother_basis=basis, blocks=blocks)
        self.scenarios = tuple(scenarios)
        self.terms = terms

    def without_calibration(self) -> "_Combined":
        """The same predictor for the scenarios without column calibration (all of them if none is left)."""
        other = copy.copy(self)
        other.scenarios = tuple(s for s in self.scenarios if not s.calibration) or tuple(
            dataclasses.replace(s, calibration=False) for s in self.scenarios)
        return other

    def each(self, observed, excited) -> list[np.ndarray]:
        """Relative std per scenario, each (F, T)."""
        p = self.predictor
        return [p.relative(V) for V in p.scenario_variances(observed, excited, self.scenarios, self.terms)]

    def relative_std(self, observed, excited) -> np.ndarray:
        return geometric_mean(self.each(observed, excited))


def geometric_mean(rels: Sequence[np.ndarray]) -> np.ndarray:
    """Geometric mean over scenarios, per line and term (NaN terms stay NaN)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.exp(np.mean([np.log(r) for r in rels], axis=0))
