"""What a design asks of each joint term: its weight in the criterion and its accuracy target.

A **weight** says how much a term counts in the search's criterion (0: not at all). A
**target** is the median relative error a term must reach (``{"K_rx_rx": 0.05}``: 5 %);
it does not change the search (the weighted geometric-mean criterion is unchanged by
a per-term factor), it states per term whether the chosen and the current layout reach
it: predicted (the median over lines of the predicted relative error, geometric mean
over the scenarios) and, when the design ran its Monte Carlo check, confirmed (the
median over seeds of the actual median relative error, the worse of the noise models).
A layout whose *prediction* misses a target cannot be relied on to reach it; with the
joint spline fit (a mount of 4-6 DOFs) the prediction is the Cramer-Rao bound of the
fit's class (:func:`~jointid.methods.design.estimator.spline_bound`), which no estimator
of that class beats.

With several joints, a name without the ``"joint:"`` prefix sets that term of every joint.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from ...errors import IdentificationError

__all__ = ["term_weights", "term_targets", "target_report"]


def _expand(terms: Sequence[str], name: str, what: str) -> list[str]:
    """The terms a name sets: itself, or (without a joint prefix) that term of every joint."""
    names = [name] if name in terms else [t for t in terms if t.partition(":")[2] == name]
    if not names:
        raise IdentificationError(f"{what}: unknown term {name!r}; expected one of {', '.join(terms)}")
    return names


def term_weights(terms: Sequence[str], weights: Mapping[str, float] | None) -> np.ndarray:
    """Weight per term (default 1), shape (T,), in ``terms`` order.

    Raises
    ------
    IdentificationError
        An unknown term, a weight that is not a number >= 0, every weight 0.
    """
    w = dict.fromkeys(terms, 1.0)
    for name, value in (weights or {}).items():
        names = _expand(terms, name, "weights")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise IdentificationError(f"weights: {name} = {value!r}; expected a number >= 0")
        for t in names:
            w[t] = float(value)
    arr = np.array([w[t] for t in terms])
    if not arr.sum() > 0:
        raise IdentificationError("weights: every term has weight 0; give at least one a positive weight")
    return arr


def term_targets(terms: Sequence[str], targets: Mapping[str, float] | None) -> dict[str, float]:
    """Target median relative error per term named (``0.05`` = 5 %), in ``terms`` order; terms without one are left out.

    Raises
    ------
    IdentificationError
        An unknown term, a target that is not a number in (0, 10].
    """
    out: dict[str, float] = {}
    for name, value in (targets or {}).items():
        names = _expand(terms, name, "targets")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0 < value <= 10):
            raise IdentificationError(f"targets: {name} = {value!r}; expected a relative error > 0 (0.05 = 5 %)")
        for t in names:
            out[t] = float(value)
    return {t: out[t] for t in terms if t in out}


def target_report(design) -> list[dict]:
    """Per targeted term of a :class:`~jointid.methods.design.layout.LayoutDesign`: does each layout reach it?

    Returns
    -------
    list of dict
        ``term``, ``target``, ``chosen`` and ``current`` (each ``predicted``, ``monte_carlo``
        (None: not checked), ``reaches``: the prediction and, when checked, the Monte Carlo
        median at most the target; ``current`` None without a current layout). JSON-ready
        (a prediction that is not finite is None and does not reach).
    """
    if not design.targets:
        return []
    def key(obs, exc):
        return frozenset(map(str, obs)), frozenset(map(str, exc))

    checked = {key(o, e): med for _, o, e, med in design.checked}

    def mc(obs, exc) -> dict[str, float]:
        med = checked.get(key(obs, exc))
        if med is None:
            return {}
        worst = np.max(np.asarray(med, float), axis=0)  # the worse noise model per term
        return dict(zip(design.terms, worst.tolist()))

    layouts = {"chosen": (design.observed, design.excited, design.median(False))}
    if design.current_observed is not None:
        layouts["current"] = (design.current_observed, design.current_excited, design.median(True))
    rows = []
    for term, target in design.targets.items():
        row: dict = {"term": term, "target": target, "current": None}
        for name, (obs, exc, predicted) in layouts.items():
            p = predicted.get(term, math.nan)
            m = mc(obs, exc).get(term)
            reaches = bool(p <= target and (m is None or m <= target))
            row[name] = {"predicted": float(p) if math.isfinite(p) else None,
                         "monte_carlo": None if m is None or not math.isfinite(m) else float(m), "reaches": reaches}
        rows.append(row)
    return rows
