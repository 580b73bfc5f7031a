"""Test design: choose where to measure and where to hit so that the joint is best determined.

The criterion is the covariance that the default (receptance-coupling)
identification propagates (:mod:`jointid.methods.coupling_lines`), evaluated
*before* any test, on exact FRFs, for a stated FRF noise level. Per line, with
``Y`` the free receptance of the identification's model and ``H`` the exact
constrained receptance of the test article::

    Y[m,e] - H[m,e] = Y[m,n] X Y[n,e],   X = (Y[n,n] + Du^-1)^-1
    A   = (Y[n,e]^T (x) Y[m,n]) P                     (P: upper triangle of X if symmetric)
    W   = diag(1 / var H[m,e]),   var H = (noise |H|)^2  (relative noise, circular complex)
    cov(x)  = (A^H W A)^-1                            (scale s^2 = 1: the stated noise)
    cov(Du) = J cov(x) J^H,   J = d vec(Du) / dx = ((I + Du Y[n,n])^T (x) (I + Y[n,n] Du)) P

(the same algebra as :func:`~jointid.methods.coupling_lines.coupling_per_line`,
whose ``variance / scale`` it equals on exact FRFs, but without the residual
scale, which is ~1e-27 on exact data). The predicted relative standard
deviation of a term is ``sqrt(E|dK_ij|^2) / |K_ij|``; an off-diagonal term is
referred to ``sqrt(|K_ii K_jj|)`` on lines where ``|K_ij|`` is below 1e-3 of it
(a joint without coupling). These are *per-line* figures: the identification's
smoothing over frequency lowers every term's error by roughly the number of
lines in a correlation band, about equally for any layout, so the ranking holds
but the smoothed errors are smaller.

Layouts differ only in which rows and columns of the same receptances they
use, so the free receptance on the w and theta DOFs of every candidate node
(and the joint's) is computed **once**, and every layout is a slice of it.
Accelerometers on the test article are added by Sherman-Morrison-Woodbury,
``Y_a = Y - Y[:,a] dD (I + Y[a,a] dD)^-1 Y[a,:]`` with ``dD = -w^2 diag(m, J)``
on their DOFs (so sensors that ride on the observed nodes move with them, at
the cost of one small solve per observed set), and the joint the same way,
``H = Y_a - Y_a[:,n] Du (I + Y_a[n,n] Du)^-1 Y_a[n,:]``. All of it is batched
over frequency.

Criterion: ``J = exp(sum_t w_t log med_t / sum_t w_t)``, the weighted geometric
mean over the terms t of the median (over lines) predicted relative standard
deviation ``med_t``; weights default to 1 and say which terms matter
(``{"K_theta_theta": 4}`` puts the rotational term first; 0 ignores a term).

Search (observed set O of size K, excited set E of size L, both drawn from the
candidate nodes; they may share nodes):

1. **greedy forward, observed**: with every candidate excited, the best |n|-node
   observed set (|n| joint DOFs, the fewest that can identify them) by
   evaluating every |n|-subset (at most :data:`MAX_SEED_SETS`, else a fixed-seed
   random sample of that many), then add the node that lowers J most until |O| = K;
2. **greedy forward, excited**: with that O, the same for E up to L;
3. **pairwise exchange**: evaluate every swap of one member of O or E for one
   non-member; apply the best if it lowers J (by more than 1e-9 relatively) and
   repeat until no swap improves (at most :data:`MAX_EXCHANGE_PASSES` passes).
   The result is a local optimum under single exchanges, not a certified global one.

The search runs on at most ``search_lines`` lines (default 200) spread evenly over
the band (the median over 200 lines is a stable statistic of a 1000-line
band); the chosen and the current layout are then evaluated on every line.

Caveats: the noise model is relative, uncorrelated response noise (no force noise,
which correlates the errors of a whole FRF column and which no layout removes);
the linearization holds while the relative errors are small; the FE model is
assumed right (unmodelled accelerometers bias the identification, and the bias
is not in the criterion).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ..dofs import Dof, parse_dofs
from ..errors import IdentificationError
from ..frequency import Frequency
from ..physics.free_model import as_free_model
from .coupling_lines import symmetric_parametrization

__all__ = [
    "Sensors", "LayoutPredictor", "LayoutDesign", "design_layout", "term_names", "MAX_SEED_SETS", "MAX_EXCHANGE_PASSES",
]

#: Largest number of |n|-node seed sets evaluated exhaustively (more: a fixed-seed random sample).
MAX_SEED_SETS = 2000
#: Largest number of exchange passes.
MAX_EXCHANGE_PASSES = 100
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


def term_names(joint_dofs: Sequence[Dof], symmetric: bool = True) -> list[tuple[int, int, str]]:
    """``(i, j, "K_{i}_{j}")`` of the terms a design reports: the upper triangle if symmetric, else all."""
    n = len(joint_dofs)
    return [
        (i, j, f"K_{joint_dofs[i].direction}_{joint_dofs[j].direction}")
        for i in range(n) for j in range(i if symmetric else 0, n)
    ]


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
    nodes : sequence of int
        Every node a layout may observe, excite or carry a sensor at.
    noise : float
        Relative standard deviation of each measured receptance value (0.01: 1 %).
    sensors : Sensors, optional
    symmetric : bool
        The identification enforces ``Du = Du^T``.
    """

    def __init__(self, free, joint, joint_dofs, frequency: Frequency, nodes: Sequence[int], noise: float,
                 sensors: Sensors | None = None, symmetric: bool = True):
        if not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise > 0):
            raise IdentificationError(f"noise: expected a relative FRF noise level > 0 (0.01 = 1 %), got {noise!r}")
        model = as_free_model(free)
        self.joint_dofs = tuple(parse_dofs(joint_dofs))
        self.frequency = frequency
        self.noise = float(noise)
        self.sensors = sensors
        self.symmetric = symmetric
        self.terms = term_names(self.joint_dofs, symmetric)
        extra = set(sensors.nodes or ()) if sensors is not None else set()
        self.nodes = tuple(sorted(set(int(k) for k in nodes) | {d.node for d in self.joint_dofs} | extra))
        dofs = [Dof(k, x) for k in self.nodes for x in ("w", "theta")]
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

    def _w(self, nodes: Sequence[int]) -> list[int]:
        return [self._index[Dof(k, "w")] for k in nodes]

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
        sensor_nodes = self.sensors.at(observed) if self.sensors is not None else ()
        Ya = self._loaded(sensor_nodes, rows)
        Ynn = _sub(Ya, in_, in_)
        G = np.linalg.solve(np.eye(len(n))[None] + Ynn @ self.Du, _sub(Ya, in_, ie))  # (I + Y[n,n] Du)^-1 Y[n,e]
        H = _sub(Ya, im, ie) - _sub(Ya, im, in_) @ self.Du @ G
        Y = Ya if self.sensors is not None and self.sensors.modelled else self._loaded((), rows)
        return H, _sub(Y, im, in_), _sub(Y, in_, ie), _sub(Y, in_, in_)

    def exact_receptance(self, observed: Sequence[int], excited: Sequence[int]) -> np.ndarray:
        """Exact constrained receptance ``H[m,e]`` of the test article (sensors and joint), shape (F, m, e)."""
        return self._blocks(observed, excited)[0]

    def variance(self, observed: Sequence[int], excited: Sequence[int]) -> np.ndarray:
        """Predicted ``E|dDu_ij|^2`` per line for the stated noise, shape (F, n, n)."""
        n = len(self._n)
        H, Ymn, Yne, Ynn = self._blocks(observed, excited)
        m, e = len(observed), len(excited)
        F = H.shape[0]
        A = np.einsum("fkc,fri->frcik", Yne, Ymn).reshape(F, m * e, n * n) @ self._P
        sigma = self.noise * np.abs(H).reshape(F, -1)
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
        I = np.eye(n)
        L = I[None] + self.Du @ Ynn
        Rr = I[None] + Ynn @ self.Du
        J = np.einsum("fik,flj->fijkl", L, Rr).reshape(F, n * n, n * n) @ self._P
        with np.errstate(all="ignore"):
            V = np.real(np.einsum("fab,fbc,fac->fa", J, C, J.conj())).reshape(F, n, n)
        return V

    def relative_std(self, observed: Sequence[int], excited: Sequence[int]) -> np.ndarray:
        """Predicted relative standard deviation per term and line, shape (F, T) in :attr:`terms` order."""
        V = self.variance(observed, excited)
        with np.errstate(all="ignore"):
            rel = np.sqrt(np.abs(V)) / self._reference
            rel = np.where(np.isfinite(rel), rel, np.inf)
        return np.stack([rel[:, i, j] for i, j, _ in self.terms], axis=1)


def _criterion(rel: np.ndarray, weights: np.ndarray) -> tuple[float, np.ndarray]:
    """Weighted geometric mean of the per-term medians over lines, and the medians."""
    med = np.median(rel, axis=0)
    if not np.all(np.isfinite(med[weights > 0])) or np.any(med[weights > 0] <= 0):
        return math.inf, med
    return float(np.exp(np.sum(weights * np.log(np.where(weights > 0, med, 1.0))) / weights.sum())), med


@dataclass(frozen=True, eq=False)
class LayoutDesign:
    """A designed layout, its predicted uncertainty, and the same for the current layout.

    Attributes
    ----------
    observed, excited : tuple of int
        The chosen nodes (transverse w), sorted.
    frequency : Frequency
        Lines of the predictions.
    terms : tuple of str
        Term names (``K_w_w``, ``K_w_theta``, ``K_theta_theta``).
    relative_std : ndarray, shape (F, T)
        Predicted per-line relative standard deviation of each term, chosen layout.
    criterion : float
        Weighted geometric mean of the per-term medians (what the search minimized).
    current_observed, current_excited : tuple of int or None
    current_relative_std : ndarray, shape (F, T), or None
    current_criterion : float or None
    weights : dict
        Term -> weight.
    noise : float
        Relative FRF noise (1-sigma) assumed.
    candidates : tuple of int
    search_lines : int
        Lines the search ran on.
    evaluations : int
        Layouts evaluated.
    seconds : float
        Wall time of the search and the final evaluation.
    """

    observed: tuple[int, ...]
    excited: tuple[int, ...]
    frequency: Frequency
    terms: tuple[str, ...]
    relative_std: np.ndarray
    criterion: float
    current_observed: tuple[int, ...] | None
    current_excited: tuple[int, ...] | None
    current_relative_std: np.ndarray | None
    current_criterion: float | None
    weights: dict
    noise: float
    candidates: tuple[int, ...]
    search_lines: int
    evaluations: int
    seconds: float
    history: tuple = field(default=())

    def median(self, current: bool = False) -> dict[str, float]:
        """Median over lines of the predicted relative standard deviation, per term."""
        rel = self.current_relative_std if current else self.relative_std
        if rel is None:
            return {}
        return {t: float(v) for t, v in zip(self.terms, np.median(rel, axis=0))}

    def to_dict(self) -> dict:
        """A JSON-ready summary (``design.json``): layouts, medians per term, criterion, search."""

        def num(x):
            return float(x) if x is not None and math.isfinite(x) else None

        def layout(obs, exc, crit, current):
            return {
                "observed": list(obs), "excited": list(exc),
                "median_relative_std": {k: num(v) for k, v in self.median(current).items()},
                "criterion": num(crit),
            }

        f = self.frequency.hz
        out = {
            "noise": self.noise,
            "band_hz": [float(f[0]), float(f[-1])],
            "lines": int(f.size),
            "weights": dict(self.weights),
            "candidates": list(self.candidates),
            "chosen": layout(self.observed, self.excited, self.criterion, False),
            "current": None if self.current_observed is None else layout(
                self.current_observed, self.current_excited, self.current_criterion, True),
            "search": {"lines": self.search_lines, "evaluations": self.evaluations, "seconds": round(self.seconds, 3),
                       "steps": [list(h) for h in self.history]},
            "note": "per-line predicted relative standard deviation (before smoothing over frequency) for "
                    "relative, uncorrelated FRF noise; criterion = weighted geometric mean of the per-term medians",
        }
        return out

    def plot(self, axes=None):
        """Predicted relative standard deviation per term vs frequency, chosen and current layouts; returns a Figure."""
        from ..plots.design import plot_layout_design

        return plot_layout_design(self, axes=axes)


def _check_counts(n_joint: int, n_candidates: int, n_observed: int, n_excited: int) -> None:
    for what, k in (("observed", n_observed), ("excited", n_excited)):
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise IdentificationError(f"{what}: expected a number of nodes, got {k!r}")
        if k < n_joint:
            raise IdentificationError(
                f"{what}: {k} node{'s' if k != 1 else ''} cannot identify the {n_joint} joint DOFs; choose at least {n_joint}"
            )
        if k > n_candidates:
            raise IdentificationError(
                f"{what}: {k} nodes asked for but there are only {n_candidates} candidate nodes; choose at most {n_candidates}"
            )


def _weights(terms: Sequence[str], weights: Mapping[str, float] | None) -> np.ndarray:
    w = dict.fromkeys(terms, 1.0)
    for name, value in (weights or {}).items():
        if name not in w:
            raise IdentificationError(f"weights: unknown term {name!r}; expected one of {', '.join(terms)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise IdentificationError(f"weights: {name} = {value!r}; expected a number >= 0")
        w[name] = float(value)
    arr = np.array([w[t] for t in terms])
    if not arr.sum() > 0:
        raise IdentificationError("weights: every term has weight 0; give at least one a positive weight")
    return arr


def _search_grid(frequency: Frequency, lines: int) -> Frequency:
    if frequency.hz.size <= lines:
        return frequency
    idx = np.unique(np.round(np.linspace(0, frequency.hz.size - 1, lines)).astype(int))
    return Frequency(frequency.hz[idx])


def design_layout(
    free, joint, joint_dofs, frequency: Frequency, candidates: Sequence[int], n_observed: int, n_excited: int, *,
    noise: float = 0.01, weights: Mapping[str, float] | None = None, sensors: Sensors | None = None,
    symmetric: bool = True, current: tuple[Sequence[int], Sequence[int]] | None = None, search_lines: int = 200,
) -> LayoutDesign:
    """Choose observed and excited nodes that minimize the predicted uncertainty of the joint terms.

    Parameters
    ----------
    free : Structure or FreeModel
        The free structure without accelerometers (``sensors`` adds them).
    joint : callable
        ``joint(f_hz) -> (F, n, n)``: the (expected) joint stiffness, e.g. a
        :class:`~jointid.physics.structure.ComplexStiffness`.
    joint_dofs : sequence of Dof or labels
    frequency : Frequency
        The band's lines (> 0 Hz).
    candidates : sequence of int
        Nodes that may be observed or excited (transverse w).
    n_observed, n_excited : int
        K and L: at least the number of joint DOFs, at most ``len(candidates)``.
    noise : float
        Relative 1-sigma noise of each measured FRF value (0.01 = 1 %).
    weights : mapping, optional
        Term name -> weight >= 0 (default 1 each).
    sensors : Sensors, optional
        Accelerometers on the test article.
    symmetric : bool
        The identification enforces ``Du = Du^T``.
    current : (observed, excited), optional
        A layout to compare against (e.g. the study's).
    search_lines : int
        Lines of the search grid (evenly spread over ``frequency``).

    Returns
    -------
    LayoutDesign

    Raises
    ------
    IdentificationError
        K or L below the number of joint DOFs or above the candidates, an unknown
        term weight, a node that is not in the model.
    """
    t0 = time.perf_counter()
    joint_dofs = tuple(parse_dofs(joint_dofs))
    cands = tuple(dict.fromkeys(int(c) for c in candidates))
    _check_counts(len(joint_dofs), len(cands), n_observed, n_excited)
    terms = [t for _, _, t in term_names(joint_dofs, symmetric)]
    w = _weights(terms, weights)
    if isinstance(search_lines, bool) or not (isinstance(search_lines, int) and search_lines >= 8):
        raise IdentificationError(f"search lines: expected an integer >= 8, got {search_lines!r}")
    free = as_free_model(free)  # built once (its modes), used by the search and the final evaluation
    cur_nodes = set(current[0]) | set(current[1]) if current is not None else set()
    grid = _search_grid(frequency, search_lines)
    pred = LayoutPredictor(free, joint, joint_dofs, grid, sorted(set(cands) | cur_nodes), noise, sensors, symmetric)
    cache: dict = {}

    def cost(obs, exc) -> float:
        key = (frozenset(obs), frozenset(exc))
        if key not in cache:
            cache[key] = _criterion(pred.relative_std(sorted(obs), sorted(exc)), w)[0]
        return cache[key]

    n = len(joint_dofs)
    history: list = []

    def seed_and_grow(size: int, other: tuple[int, ...], observed_side: bool) -> tuple[int, ...]:
        def c(s):
            return cost(s, other) if observed_side else cost(other, s)

        seeds = list(itertools.combinations(cands, n))
        if len(seeds) > MAX_SEED_SETS:
            rng = np.random.default_rng(0)
            seeds = [seeds[i] for i in sorted(rng.choice(len(seeds), MAX_SEED_SETS, replace=False))]
        chosen = min(seeds, key=c)
        while len(chosen) < size:
            chosen = min((chosen + (k,) for k in cands if k not in chosen), key=c)
        return tuple(sorted(chosen))

    obs = seed_and_grow(n_observed, cands, True)
    history.append(("greedy observed", cost(obs, cands)))
    exc = seed_and_grow(n_excited, obs, False)
    best = cost(obs, exc)
    history.append(("greedy excited", best))
    for _ in range(MAX_EXCHANGE_PASSES):
        moves = []
        for side, group in (("observed", obs), ("excited", exc)):
            for out_ in group:
                for in_ in cands:
                    if in_ in group:
                        continue
                    new = tuple(sorted(set(group) - {out_} | {in_}))
                    o, e = (new, exc) if side == "observed" else (obs, new)
                    moves.append((cost(o, e), o, e))
        if not moves:
            break
        c_new, o_new, e_new = min(moves, key=lambda t: t[0])
        if not c_new < best * (1 - 1e-9):
            break
        obs, exc, best = o_new, e_new, c_new
        history.append(("exchange", best))
    evaluations = len(cache)

    final = LayoutPredictor(
        free, joint, joint_dofs, frequency, sorted(set(obs) | set(exc) | cur_nodes), noise, sensors, symmetric
    )
    rel = final.relative_std(obs, exc)
    crit = _criterion(rel, w)[0]
    cur_rel = cur_crit = None
    if current is not None:
        cur_rel = final.relative_std(list(current[0]), list(current[1]))
        cur_crit = _criterion(cur_rel, w)[0]
    return LayoutDesign(
        tuple(obs), tuple(exc), frequency, tuple(terms), rel, crit,
        None if current is None else tuple(current[0]), None if current is None else tuple(current[1]),
        cur_rel, cur_crit, dict(zip(terms, w.tolist())), float(noise), cands, grid.hz.size, evaluations,
        time.perf_counter() - t0, tuple((s, float(c)) for s, c in history),
    )
