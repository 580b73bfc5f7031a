"""A test whose stiffness level differs from its neighbours' by a unit factor: one file recorded in other units.

Tests of one specimen at several temperatures (a campaign's master curve) have stiffness levels that change smoothly
with the temperature. A file whose force was written in kN (or its displacement in mm) under an SI column name has a
level 1000 times too low; the master curve cannot superpose it and, when it is the reference temperature, leaves the
*others* out. :func:`find_unit_slips` names such a test and the factor.

The check, on ``L_i = median ln |K|`` of each test (``T_i`` its temperature):

* the level the others predict at ``T_i``: the least-squares straight line of ``L`` over ``T`` through the others (their
  level when there is one other temperature), ``r_i = L_i - pred_i``;
* the tolerance, from the data: ``tol_i = 3 s d_i``, ``d_i`` the distance from ``T_i`` to the nearest other
  temperature (at least :data:`MIN_DISTANCE_C`) and ``s`` the rms of the others' own leave-one-out residuals (each
  predicted from the rest of the others in the same way) per degree of their own such distance: how far the
  temperature's plausible effect and the scatter of the tests move a level that is right, growing with the distance
  it is predicted over (a temperature far outside the others' is not judged);
* a slip: a unit factor ``u`` (:data:`UNIT_FACTORS`, either way) with ``|r_i - ln u| <= tol_i`` while the test is
  not explained by the temperature (``|r_i| > 2 tol_i``); the factor nearest ``r_i``.

The most significant slip (largest ``|r_i| / tol_i``) is taken out first and the check repeated on the rest, so one
slipped test does not hide or fake another; at least 3 tests are needed (the suspect and two others).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["UnitSlip", "find_unit_slips", "UNIT_FACTORS", "SLIP_TOLERANCE_SIGMAS", "MIN_DISTANCE_C"]

#: Unit factors a file's stiffness may be off by (K_file / K_true, also their inverses), with the probable cause.
UNIT_FACTORS = {
    1e-3: "the force in kN, or the displacement in mm, under an SI column name",
    1e3: "the force in mN, or the displacement in km, under an SI column name",
    1e-6: "the force in MN, or the displacement in um, under an SI column name",
    1e6: "the force in uN, or the displacement in Mm, under an SI column name",
    1e-2: "the displacement in cm under an SI column name",
    1e2: "the force in cN, or the displacement in hm, under an SI column name",
    1 / 9.80665: "the force in kgf under an SI column name",
    9.80665: "the displacement or force scaled by g (9.80665) in the acquisition",
    1 / 4.4482216152605: "the force in lbf under an SI column name",
    4.4482216152605: "the force in N where lbf was expected (the acquisition's calibration)",
    0.0254: "the displacement in inches under an SI column name",
    1 / 0.0254: "the force in N/in or a displacement scaled from inches the wrong way",
    25.4: "the displacement in mm read as inches",
    1 / 25.4: "the displacement in inches read as mm",
}
#: Least distance to the nearest other temperature, deg C, by which the tolerance grows (tests repeated at one
#: temperature, or temperatures within their control's precision).
MIN_DISTANCE_C = 1.0
#: Standard deviations of the others' leave-one-out scatter a level may differ by and still be the temperature's effect.
SLIP_TOLERANCE_SIGMAS = 3.0


@dataclass(frozen=True)
class UnitSlip:
    """A test whose level is a unit factor off its neighbours'.

    Parameters
    ----------
    index : int
        Position of the test in the arguments of :func:`find_unit_slips`.
    factor : float
        The unit factor, ``K_test / K_expected`` (e.g. 0.001).
    ratio : float
        The measured ``K_test / K_expected`` (``exp r``).
    tolerance : float
        ``tol`` of the module docstring, as a factor (``exp tol``; e.g. 1.3 for 30 %).
    cause : str
        The probable cause (:data:`UNIT_FACTORS`).
    """

    index: int
    factor: float
    ratio: float
    tolerance: float
    cause: str


def _predict(t: np.ndarray, level: np.ndarray, at: float) -> tuple[float, float]:
    """The level the tests ``(t, level)`` predict at ``at`` and the distance to the nearest of them, deg C (>= 1)."""
    d = max(float(np.min(np.abs(t - at))), MIN_DISTANCE_C)
    if np.ptp(t) == 0:
        return float(np.mean(level)), d
    a, b = np.polyfit(t, level, 1)
    return float(a * at + b), d


def _loo_scale(t: np.ndarray, level: np.ndarray) -> float:
    """rms of each point's residual against the prediction from the others, per degree of distance to the nearest of
    them (``nan`` with fewer than 2 points), 1/deg C."""
    if t.size < 2:
        return math.nan
    r = []
    for j in range(t.size):
        p, d = _predict(np.delete(t, j), np.delete(level, j), t[j])
        r.append((level[j] - p) / d)
    return float(np.sqrt(np.mean(np.square(r))))


def find_unit_slips(temperature_c, log_level) -> list[UnitSlip]:
    """The tests whose stiffness level is a unit factor off what the others give at their temperature.

    Parameters
    ----------
    temperature_c : array_like, shape (N,)
        Each test's temperature, deg C.
    log_level : array_like, shape (N,)
        Each test's level, ``median ln |K|`` (K in N/m; any common measure of the level, natural log).

    Returns
    -------
    list of UnitSlip
        Most significant first; empty with fewer than 3 tests or none off by a unit factor.
    """
    t = np.asarray(temperature_c, dtype=float).reshape(-1)
    level = np.asarray(log_level, dtype=float).reshape(-1)
    keep = list(np.flatnonzero(np.isfinite(t) & np.isfinite(level)))
    logs = {u: math.log(u) for u in UNIT_FACTORS}
    slips = []
    while len(keep) >= 3:
        best = None
        for i in keep:
            others = np.array([j for j in keep if j != i])
            p, d = _predict(t[others], level[others], t[i])
            r = level[i] - p
            tol = max(SLIP_TOLERANCE_SIGMAS * _loo_scale(t[others], level[others]) * d, 1e-6)  # floor: rounding of ln
            if not (math.isfinite(tol) and abs(r) > 2 * tol):
                continue
            u = min(logs, key=lambda f: abs(r - logs[f]))
            if abs(r - logs[u]) <= tol and (best is None or abs(r) / max(tol, 1e-300) > best[0]):
                best = (abs(r) / max(tol, 1e-300), UnitSlip(int(i), u, math.exp(r), math.exp(tol), UNIT_FACTORS[u]))
        if best is None:
            break
        slips.append(best[1])
        keep.remove(best[1].index)
    return slips
