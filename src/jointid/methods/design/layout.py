"""Test design: choose where to measure and where to hit so that the joint is best determined.

The criterion is the error that the default identification
(:func:`~jointid.methods.receptance.coupling.identify_joint_coupling`) is predicted to make,
evaluated *before* any test, on exact FRFs, for a stated FRF noise level. Three
parts, each computed for every layout:

1. **Per line** (the covariance :mod:`jointid.methods.receptance.coupling_lines` propagates).
   With ``Y`` the free receptance of the identification's model and ``H`` the
   exact constrained receptance of the test article::

       Y[m,e] - H[m,e] = Y[m,n] X Y[n,e],   X = (Y[n,n] + Du^-1)^-1
       A   = (Y[n,e]^T (x) Y[m,n]) P                     (P: upper triangle of X if symmetric)
       W   = diag(1 / var H[m,e])                        (noise model, below)
       cov(x)  = (A^H W A)^-1                            (scale s^2 = 1: the stated noise)
       cov(Du) = J cov(x) J^H,   J = d vec(Du) / dx = ((I + Du Y[n,n])^T (x) (I + Y[n,n] Du)) P

   (equal to :func:`~jointid.methods.receptance.coupling_lines.coupling_per_line`'s ``variance /
   scale`` on exact FRFs).
2. **Smoothed over frequency** as the estimator smooths (P-spline per term, lambda
   minimizing the *expected* GCV score): expected squared error = smoothing bias
   on the expected joint + the smoother's variance
   (:mod:`jointid.methods.design.estimator`). This is what a test's error is:
   the per-line median (the criterion before) ranks layouts differently, because
   smoothing pools the information of the best lines of a band.
3. **Column calibration**: with force noise the estimator estimates a smooth
   calibration error per excitation column, whose uncertainty is common to all
   lines and dominates K_theta_theta (:func:`~jointid.methods.design.estimator.common_variance`).

**Scenarios** (:class:`Scenario`): the FRF noise model -- ``"relative"``
(``var H = (noise |H|)^2``) or ``"additive"`` (a noise floor per FRF, constant in
accelerance: a roving-hammer test, see :meth:`LayoutPredictor.frf_variance`) -- and
whether the column calibration is applied. The default uses all four
combinations (:data:`DEFAULT_SCENARIOS`), because one test layout meets all of
them: relative noise is what synthetic studies assume, additive is the hammer's
response noise, calibration is what the estimator does when there is force noise.
A term's predicted relative error on a line is ``sqrt(E|dK_ij|^2) / |K_ij|``
(an off-diagonal term is referred to ``sqrt(|K_ii K_jj|)`` on lines where
``|K_ij|`` is below 1e-3 of it), and ``relative_std`` is its geometric mean over
the scenarios.

Layouts differ only in which rows and columns of the same receptances they
use, so the free receptance on the w and theta DOFs of every candidate node
(and the joint's) is computed **once**, and every layout is a slice of it.
Accelerometers on the test article are added by Sherman-Morrison-Woodbury,
``Y_a = Y - Y[:,a] dD (I + Y[a,a] dD)^-1 Y[a,:]`` with ``dD = -w^2 diag(m, J)``
on their DOFs (so sensors that ride on the observed nodes move with them, at
the cost of one small solve per observed set), and the joint the same way,
``H = Y_a - Y_a[:,n] Du (I + Y_a[n,n] Du)^-1 Y_a[n,:]``. All of it is batched
over frequency.

Criterion: ``J = exp(mean_s sum_t w_t log med_st / sum_t w_t)``, the geometric
mean over scenarios s and the weighted geometric mean over terms t of the median
(over lines) predicted relative error ``med_st``; weights default to 1 and say
which terms matter (``{"K_theta_theta": 4}`` puts the rotational term first; 0
ignores a term, and its smoothing is then not even computed in the search). With
a current layout (``dominate=True``), a layout predicted worse than it in a
scenario by a ratio ``r > 1`` (of the weighted per-scenario criterion) has its
``J`` multiplied by ``r ** DOMINANCE_PENALTY``: the design should not trade one
kind of test for another.

Search (observed set O of size K, excited set E of size L, both drawn from the
candidate nodes; they may share nodes):

1. **greedy forward, observed**: with every candidate excited, the best |n|-node
   observed set (|n| joint DOFs, the fewest that can identify them) by
   evaluating every |n|-subset (at most :data:`MAX_SEED_SETS`, else a fixed-seed
   random sample of that many), then add the node that lowers J most until |O| = K
   (this step leaves the calibration scenarios out: with every candidate a
   column they are costly, and no real layout excites them all);
2. **greedy forward, excited**: with that O, the same for E up to L;
3. **pairwise exchange**: evaluate every swap of one member of O or E for one
   non-member; apply the best if it lowers J (by more than 1e-9 relatively) and
   repeat until no swap improves (at most :data:`MAX_EXCHANGE_PASSES` passes).
   The result is a local optimum under single exchanges, not a certified global one;
4. **re-rank**: the ``rerank`` best layouts of the search are evaluated again on
   every line of the band with the estimator's own smoother, and the best is chosen.

Steps 1-3 run on ``search_lines`` lines (default 300) spread evenly over the
band; each stands for ``F / search_lines`` lines of the band (its variance is
divided by that) and the smoother has :data:`SEARCH_BASIS` functions. That grid
samples the narrow resonances of a lightly damped beam by luck (the smoothed
prediction of one layout can move substantially between the search grid and the
full band), hence step 4. The layouts of each step (and the re-ranked ones) are
evaluated on forked workers, one BLAS thread each (:mod:`jointid.methods.design.pool`;
BLAS threads only contend on these small matrices); ``benchmarks/design.py`` prints the time.

Caveats: the prediction is linear in the FRF errors (at the true joint) and
uses the *expected* GCV lambda; on data lambda scatters with the noise, and
with it the error of one test (the rotational term's varies severalfold between
noise seeds, a scatter the prediction reproduces when the scatter of lambda is
simulated). Per-line errors of 100 % and more (the rotational term on most
lines) make the estimator nonlinear: the actual error of a layout can exceed the
linear prediction, so small differences between layouts are not resolved; the
large differences that the column calibration makes are (``benchmarks/design.py``
prints the predicted error per term and noise scenario and the actual error per
seed, chosen layout against Model 3). The FE model is assumed right (unmodelled
accelerometers bias the identification, and the bias is not in the criterion).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

from ...dofs import parse_dofs
from ...errors import IdentificationError
from ...frequency import Frequency
from ...parallel import single_threaded_blas
from ...physics.free_model import as_free_model
from .pool import MAX_SEED_SETS, LayoutPool, pool_workers
from .term_goals import target_report, term_targets, term_weights
from .pool import seed_sets as _seed_sets
from .predictor import (
    DEFAULT_SCENARIOS, ESTIMATORS, NOISE_MODELS, LayoutPredictor, Scenario, Sensors, _Combined, geometric_mean,
    joint_blocks, layout_dofs, term_names,
)

__all__ = [
    "Sensors", "LayoutPredictor", "LayoutDesign", "Scenario", "DEFAULT_SCENARIOS", "NOISE_MODELS", "ESTIMATORS",
    "design_layout", "term_names", "MAX_SEED_SETS", "MAX_EXCHANGE_PASSES", "SEARCH_BASIS", "DOMINANCE_PENALTY",
]

#: B-spline functions of the smoother predicted on the search grid (the estimator's own on the final evaluation).
SEARCH_BASIS = 60
#: With a current layout, a layout predicted worse than it in a scenario by the ratio r pays r**DOMINANCE_PENALTY.
DOMINANCE_PENALTY = 10.0
#: Largest number of exchange passes.
MAX_EXCHANGE_PASSES = 100
#: Noise models of the Monte Carlo check (each adds one entry to the final criterion).
MONTE_CARLO_NOISE_MODELS = ("relative", "additive")


def _combine(values: Sequence[float]) -> float:
    """Geometric mean of per-scenario criteria (inf if any is not a positive finite number)."""
    if not values or not all(0 < x < math.inf for x in values):
        return math.inf
    return math.exp(sum(math.log(x) for x in values) / len(values))


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
    observed, excited : tuple of int or of Dof
        The chosen nodes (transverse w; candidates given as node numbers) or DOFs (candidates
        given as DOF labels), sorted.
    frequency : Frequency
        Lines of the predictions.
    terms : tuple of str
        Term names (``K_w_w``, ``K_w_theta``, ``K_theta_theta``; several joints: ``"front:K_x_x"``, see
        :func:`~jointid.methods.design.predictor.term_names`).
    relative_std : ndarray, shape (F, T)
        Predicted relative error of each term per line, chosen layout: the geometric
        mean over the scenarios (what the plot shows).
    criterion : float
        Geometric mean over scenarios of the weighted geometric mean over terms of the
        median predicted relative error (what the search minimized, without the dominance penalty).
    current_observed, current_excited : tuple of int or None
    current_relative_std : ndarray, shape (F, T), or None
    current_criterion : float or None
    weights : dict
        Term -> weight.
    noise : float
        Relative FRF noise (1-sigma) assumed.
    candidates : tuple of int or of Dof
    search_lines : int
        Lines the search ran on.
    evaluations : int
        Layouts evaluated.
    seconds : float
        Wall time of the search and the final evaluation.
    history : tuple of (step, criterion)
    scenarios : tuple of Scenario
        What was predicted; ``relative_std`` is the geometric mean over them per line and term.
    scenario_relative_std, current_scenario_relative_std : tuple of ndarray, shape (F, T) each
        The prediction per scenario, chosen and current layout.
    ranked : tuple of (criterion, observed, excited)
        The re-ranked layouts (on every line), best first: alternatives to the chosen one.
    checked : tuple of (criterion, observed, excited, medians)
        The layouts checked by Monte Carlo (and last the current one, criterion None):
        per noise model of :data:`MONTE_CARLO_NOISE_MODELS`, the median over seeds of
        the actual median relative error per term.
    monte_carlo : int
        Seeds of that check (0: none).
    targets : dict
        Term -> target median relative error; :meth:`target_report` says which layout reaches it.
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
    scenarios: tuple = field(default=())
    scenario_relative_std: tuple = field(default=())
    current_scenario_relative_std: tuple = field(default=())
    ranked: tuple = field(default=())
    checked: tuple = field(default=())
    monte_carlo: int = 0
    targets: dict = field(default_factory=dict)

    def scenario_medians(self, current: bool = False) -> dict[str, dict[str, float]]:
        """Scenario name -> term -> median over lines of the predicted relative error."""
        rels = self.current_scenario_relative_std if current else self.scenario_relative_std
        return {sc.name: {t: float(v) for t, v in zip(self.terms, np.median(rel, axis=0))}
                for sc, rel in zip(self.scenarios, rels or ())}

    def median(self, current: bool = False) -> dict[str, float]:
        """Per term: the geometric mean over scenarios of the median over lines of the predicted relative error."""
        rels = self.current_scenario_relative_std if current else self.scenario_relative_std
        if not rels:
            rel = self.current_relative_std if current else self.relative_std
            return {} if rel is None else {t: float(v) for t, v in zip(self.terms, np.median(rel, axis=0))}
        with np.errstate(divide="ignore"):
            med = np.exp(np.mean([np.log(np.median(r, axis=0)) for r in rels], axis=0))
        return {t: float(v) for t, v in zip(self.terms, med)}

    def target_report(self) -> list[dict]:
        """Per targeted term: target, and per layout the prediction, the Monte Carlo median and whether it reaches it."""
        return target_report(self)

    def to_dict(self) -> dict:
        """A JSON-ready summary (``design.json``): layouts, medians per term, criterion, search."""

        def num(x):
            return float(x) if x is not None and math.isfinite(x) else None

        def layout(obs, exc, crit, current):
            return {
                "observed": _json_layout(obs), "excited": _json_layout(exc),
                "median_relative_std": {k: num(v) for k, v in self.median(current).items()},
                "criterion": num(crit),
                "scenarios": {name: {k: num(v) for k, v in med.items()} for name, med in self.scenario_medians(current).items()},
            }

        f = self.frequency.hz
        out = {
            "noise": self.noise,
            "band_hz": [float(f[0]), float(f[-1])],
            "lines": int(f.size),
            "weights": dict(self.weights),
            "candidates": _json_layout(self.candidates),
            "chosen": layout(self.observed, self.excited, self.criterion, False),
            "current": None if self.current_observed is None else layout(
                self.current_observed, self.current_excited, self.current_criterion, True),
            "search": {"lines": self.search_lines, "evaluations": self.evaluations, "seconds": round(self.seconds, 3),
                       "steps": [list(h) for h in self.history],
                       "alternatives": [{"observed": _json_layout(o), "excited": _json_layout(e), "criterion": num(c)}
                                        for c, o, e in self.ranked[1:6]]},
            "scenarios": [dataclasses.asdict(sc) | {"name": sc.name} for sc in self.scenarios],
            "targets": self.target_report(),
            "monte_carlo": {
                "seeds": self.monte_carlo, "noise_models": list(MONTE_CARLO_NOISE_MODELS),
                "checked": [{"observed": _json_layout(o), "excited": _json_layout(e), "criterion": None if c is None else num(c),
                             "current": c is None,
                             "median_error": {nm: {t: num(v) for t, v in zip(self.terms, m)}
                                              for nm, m in zip(MONTE_CARLO_NOISE_MODELS, med)}}
                            for c, o, e, med in self.checked],
            },
            "note": "predicted relative error of the default identification per term (median over lines): per "
                    "scenario (FRF noise model; smoothed over frequency as the estimator does; with or without its "
                    "column calibration), and median_relative_std = their geometric mean per line; criterion = "
                    "weighted geometric mean over terms and scenarios, layouts predicted worse than the current one in "
                    "a scenario penalized",
        }
        return out

    def plot(self, axes=None):
        """Predicted relative standard deviation per term vs frequency, chosen and current layouts; returns a Figure."""
        from ...plots.design import plot_layout_design

        return plot_layout_design(self, axes=axes)


def _json_layout(items) -> list:
    """A layout for JSON: node numbers as they are, DOFs as labels (``"12x"``)."""
    return [int(k) if isinstance(k, (int, np.integer)) else str(k) for k in items]


def _candidates(candidates, current):
    """Candidates and current layout, deduplicated: node numbers stay ints, anything else becomes DOFs."""
    cands = list(candidates)
    if all(isinstance(c, (int, np.integer)) and not isinstance(c, bool) for c in cands):
        return tuple(dict.fromkeys(int(c) for c in cands)), current
    cands = tuple(dict.fromkeys(layout_dofs(cands)))
    if current is not None:
        current = (layout_dofs(current[0], "current observed"), layout_dofs(current[1], "current excited"))
    return cands, current


def _check_counts(n_joint: int, n_candidates: int, n_observed: int, n_excited: int, unit: str = "node") -> None:
    """K and L against the joint DOFs and the candidates (``unit``: "node" for beam nodes, "DOF" for DOFs)."""
    for what, k in (("observed", n_observed), ("excited", n_excited)):
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise IdentificationError(f"{what}: expected a number of {unit}s, got {k!r}")
        if k < n_joint:
            raise IdentificationError(
                f"{what}: {k} {unit}{'s' if k != 1 else ''} cannot identify the {n_joint} joint DOFs; choose at least {n_joint}"
            )
        if k > n_candidates:
            raise IdentificationError(
                f"{what}: {k} {unit}s asked for but there are only {n_candidates} candidate {unit}s; choose at most {n_candidates}"
            )


def _search_grid(frequency: Frequency, lines: int) -> Frequency:
    if frequency.hz.size <= lines:
        return frequency
    idx = np.unique(np.round(np.linspace(0, frequency.hz.size - 1, lines)).astype(int))
    return Frequency(frequency.hz[idx])


@single_threaded_blas()  # small batched matrices: BLAS threads only contend (the pool uses the cores)
def design_layout(
    free, joint, joint_dofs, frequency: Frequency, candidates: Sequence, n_observed: int, n_excited: int, *,
    noise: float = 0.01, weights: Mapping[str, float] | None = None, sensors: Sensors | None = None,
    symmetric: bool = True, current: tuple[Sequence, Sequence] | None = None, search_lines: int = 300,
    scenarios: Sequence[Scenario] | None = None, dominate: bool = True, rerank: int = 30,
    monte_carlo: int = 0, monte_carlo_layouts: int = 6, coupling_options=None,
    blocks: Sequence[tuple[str, int]] | None = None, progress: Callable[[str], None] | None = None,
    targets: Mapping[str, float] | None = None,
) -> LayoutDesign:
    """Choose observed and excited nodes that minimize the predicted uncertainty of the joint terms.

    Parameters
    ----------
    free : Structure or FreeModel
        The free structure without accelerometers (``sensors`` adds them); any model with
        ``receptance(frequency, rows, cols)`` and ``dofs``
        (:func:`~jointid.physics.free_model.as_free_model`), e.g. a
        :class:`~jointid.physics.sparse_model.SparseModel`.
    joint : callable
        ``joint(f_hz) -> (F, n, n)``: the (expected) joint stiffness, e.g. a
        :class:`~jointid.physics.structure.ComplexStiffness`; several joints: their
        block-diagonal assembly (:func:`~jointid.physics.jointed_model.assemble_joints`).
    joint_dofs : sequence of Dof or labels
    frequency : Frequency
        The band's lines (> 0 Hz).
    candidates : sequence of int, DOF labels or Dof
        What may be observed or excited: beam nodes (ints, the transverse w; the result
        is then in node numbers) or DOFs of any model (``"12x"``, ``"40z"``; the result
        is then in :class:`Dof`). Accelerometers (``sensors``) need beam nodes.
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
    blocks : sequence of (name, size), optional
        Several joints in ``joint_dofs`` order: the criterion is over each joint's own terms
        (not the terms between joints); term names ``"name:K_x_x"`` (see
        :func:`~jointid.methods.design.predictor.term_names`). A weight named without the
        prefix (``"K_z_z"``) applies to that term of every joint.
    progress : callable, optional
        Called with one line after each step of the search (layouts evaluated, criterion, seconds).
    targets : mapping, optional
        Term -> target median relative error (0.05 = 5 %): reported per layout
        (:meth:`LayoutDesign.target_report`), not searched for (:mod:`.term_goals`).

    Returns
    -------
    LayoutDesign

    Raises
    ------
    IdentificationError
        K or L below the number of joint DOFs or above the candidates, an unknown
        term weight or target, a node that is not in the model.
    """
    t0 = time.perf_counter()
    joint_dofs = tuple(parse_dofs(joint_dofs))
    cands, current = _candidates(candidates, current)
    _check_counts(len(joint_dofs), len(cands), n_observed, n_excited,
                  "node" if all(isinstance(c, int) for c in cands) else "DOF")
    if blocks is not None:
        blocks = joint_blocks(joint_dofs, blocks)
    terms = [t for _, _, t in term_names(joint_dofs, symmetric, blocks)]
    w = term_weights(terms, weights)
    goals = term_targets(terms, targets)
    if isinstance(search_lines, bool) or not (isinstance(search_lines, int) and search_lines >= 8):
        raise IdentificationError(f"search lines: expected an integer >= 8, got {search_lines!r}")
    free = as_free_model(free)  # built once (its modes), used by the search and the final evaluation
    cur_nodes = set(current[0]) | set(current[1]) if current is not None else set()
    grid = _search_grid(frequency, search_lines)
    scenarios = tuple(DEFAULT_SCENARIOS if scenarios is None else scenarios)
    if not scenarios or not all(isinstance(s, Scenario) for s in scenarios):
        raise IdentificationError("scenarios: expected at least one Scenario")
    pred = _Combined(free, joint, joint_dofs, grid, sorted(set(cands) | cur_nodes), noise, sensors, symmetric, scenarios,
                     frequency.hz.size, SEARCH_BASIS, [k for k in range(len(terms)) if w[k] > 0], blocks=blocks)
    seeding = pred.without_calibration()
    cache: dict = {}
    cur_grid = None
    if current is not None and dominate:
        cur_grid = [_criterion(r, w)[0] for r in pred.each(sorted(current[0]), sorted(current[1]))]

    def layout_cost(obs, exc) -> float:
        if len(exc) == len(cands) and len(cands) > n_excited:
            # every candidate excited (the first greedy step): the calibration scenarios are left out,
            # costly with many columns, and no real layout excites them all
            return _criterion(seeding.relative_std(sorted(obs), sorted(exc)), w)[0]
        each = [_criterion(r, w)[0] for r in pred.each(sorted(obs), sorted(exc))]
        c = _combine(each)
        if cur_grid is not None and len(obs) == n_observed and len(exc) == n_excited and c < math.inf:
            # not predicted worse than the current layout in any scenario, else penalized
            c *= math.prod(max(1.0, x / y) ** DOMINANCE_PENALTY for x, y in zip(each, cur_grid))
        return c

    def costs(layouts) -> list[float]:  # the ones not in the cache as one batch on the pool
        keys = [(frozenset(o), frozenset(e)) for o, e in layouts]
        todo = list({k: (tuple(sorted(k[0])), tuple(sorted(k[1]))) for k in keys if k not in cache}.items())
        for (k, _), c in zip(todo, pool.map([v for _, v in todo])):
            cache[k] = c
        return [cache[k] for k in keys]

    def best_of(layouts):  # the first layout of the lowest cost (as min over them in order)
        c = costs(layouts)
        i = min(range(len(layouts)), key=c.__getitem__)
        return layouts[i], c[i]

    n = len(joint_dofs)
    history: list = []

    def say(step: str, value: float) -> None:
        history.append((step, value))
        if progress is not None:
            progress(f"{step}: {len(cache)} layouts evaluated, criterion {value:.4g}, {time.perf_counter() - t0:.1f} s")

    def seed_and_grow(size: int, other: tuple, observed_side: bool) -> tuple:
        def pair(s):
            return (s, other) if observed_side else (other, s)

        layout, _ = best_of([pair(s) for s in _seed_sets(cands, n)])
        chosen = tuple(layout[0] if observed_side else layout[1])
        while len(chosen) < size:
            layout, _ = best_of([pair(chosen + (k,)) for k in cands if k not in chosen])
            chosen = tuple(layout[0] if observed_side else layout[1])
        return tuple(sorted(chosen))

    with LayoutPool(layout_cost, pool_workers(len(cands) ** 2)) as pool:
        obs = seed_and_grow(n_observed, cands, True)
        say("greedy observed", costs([(obs, cands)])[0])
        exc = seed_and_grow(n_excited, obs, False)
        best = costs([(obs, exc)])[0]
        say("greedy excited", best)
        for _ in range(MAX_EXCHANGE_PASSES):
            moves = []
            for side, group in (("observed", obs), ("excited", exc)):
                for out_ in group:
                    for in_ in cands:
                        if in_ in group:
                            continue
                        new = tuple(sorted(set(group) - {out_} | {in_}))
                        moves.append((new, exc) if side == "observed" else (obs, new))
            if not moves:
                break
            (o_new, e_new), c_new = best_of(moves)
            if not c_new < best * (1 - 1e-9):
                break
            obs, exc, best = o_new, e_new, c_new
            say("exchange", best)
    evaluations = len(cache)

    # re-rank the best layouts of the search on every line, with the estimator's own smoother: the
    # search grid samples narrow resonances by luck, which can move the smoothed prediction substantially
    pool = sorted((c, tuple(sorted(o)), tuple(sorted(e))) for (o, e), c in cache.items()
                  if len(o) == n_observed and len(e) == n_excited and c < math.inf)[:rerank]
    active = [k for k in range(len(terms)) if w[k] > 0]
    # the full band on every candidate costs F x D^2: with DOF candidates only the pool's DOFs are computed
    rank_on = set(cands) if all(isinstance(c, int) for c in cands) else {k for _, o, e in pool for k in o + e}
    ranker = _Combined(free, joint, joint_dofs, frequency, sorted(rank_on | cur_nodes), noise, sensors, symmetric,
                       scenarios, terms=active, blocks=blocks)
    full_cur = None

    def rank_each(o, e) -> list[float]:
        return [_criterion(r, w)[0] for r in ranker.each(o, e)]
    items = [(o, e) for _, o, e in pool]
    if current is not None and dominate:
        items.append((tuple(sorted(current[0])), tuple(sorted(current[1]))))
    with LayoutPool(rank_each, pool_workers(len(items))) as workers:
        ranked_each = workers.map(items)
    if current is not None and dominate:
        full_cur = ranked_each.pop()
    reranked = []
    for (_, o, e), each in zip(pool, ranked_each):
        c = _combine(each)
        if full_cur is not None and c < math.inf:
            c *= math.prod(max(1.0, x / y) ** DOMINANCE_PENALTY for x, y in zip(each, full_cur))
        reranked.append((c, o, e))
    if current is not None:
        # a fallback: when no searched layout is predicted better than the current one (a layout of the search),
        # the current one is the design
        cur = (tuple(sorted(set(current[0]))), tuple(sorted(set(current[1]))))
        if (len(cur[0]), len(cur[1])) == (n_observed, n_excited) and set(cur[0]) | set(cur[1]) <= set(cands):
            c_cur = _combine(full_cur if full_cur is not None else [_criterion(r, w)[0] for r in ranker.each(*cur)])
            if c_cur < min(reranked, default=(math.inf,))[0] and all(cur != (o, e) for _, o, e in reranked):
                reranked.append((c_cur, *cur))
    if reranked:
        best_full, obs, exc = min(reranked)
        say("re-rank", best_full)
    checked: tuple = ()
    if monte_carlo and reranked:
        # the estimator itself on synthetic noisy FRFs of the best few (relative noise): a sixth "scenario"
        from .check import monte_carlo_errors

        levels = {sc.noise_model: sc.level for sc in scenarios}  # the level the scenarios give each noise model
        mcs = [ranker.predictor.variant(Scenario(nm, "per-line", False, levels.get(nm))) for nm in MONTE_CARLO_NOISE_MODELS]

        def mc_crit(o, e):
            errs = [monte_carlo_errors(mc, o, e, monte_carlo, coupling_options) for mc in mcs]
            return [_criterion(x, w)[0] for x in errs], tuple(tuple(float(v) for v in np.median(x, axis=0)) for x in errs)

        cur_mc = mc_crit(sorted(current[0]), sorted(current[1])) if current is not None else None
        rows = []
        for _, o, e in sorted(reranked)[:monte_carlo_layouts]:
            c_mc, med = mc_crit(o, e)
            both = [_criterion(r, w)[0] for r in ranker.each(o, e)] + c_mc
            c = _combine(both)
            if full_cur is not None and cur_mc is not None and c < math.inf:
                c *= math.prod(max(1.0, x / y) ** DOMINANCE_PENALTY for x, y in zip(both, full_cur + cur_mc[0]))
            rows.append((c, o, e, med))
        best_mc, obs, exc, _ = min(rows)
        say("monte carlo", best_mc)
        checked = tuple(rows) + ((None, tuple(sorted(current[0])), tuple(sorted(current[1])), cur_mc[1]),) \
            if cur_mc is not None else tuple(rows)

    if set(obs) | set(exc) <= rank_on | cur_nodes:
        final = copy.copy(ranker)  # the re-ranking's receptances hold every chosen and current DOF; every term
        final.terms = None
    else:  # nothing re-ranked (no layout of finite criterion): the search's best
        final = _Combined(free, joint, joint_dofs, frequency, sorted(set(obs) | set(exc) | cur_nodes), noise, sensors,
                          symmetric, scenarios, blocks=blocks)
    each = final.each(obs, exc)
    rel = geometric_mean(each)
    crit = _combine([_criterion(r, w)[0] for r in each])
    cur_rel = cur_crit = cur_each = None
    if current is not None:
        cur_each = final.each(list(current[0]), list(current[1]))
        cur_rel = geometric_mean(cur_each)
        cur_crit = _combine([_criterion(r, w)[0] for r in cur_each])
    return LayoutDesign(
        tuple(obs), tuple(exc), frequency, tuple(terms), rel, crit,
        None if current is None else tuple(current[0]), None if current is None else tuple(current[1]),
        cur_rel, cur_crit, dict(zip(terms, w.tolist())), float(noise), cands, grid.hz.size, evaluations,
        time.perf_counter() - t0, tuple((s, float(c)) for s, c in history),
        scenarios, tuple(each), tuple(cur_each or ()), tuple(sorted(reranked)), checked, int(monte_carlo), goals,
    )
