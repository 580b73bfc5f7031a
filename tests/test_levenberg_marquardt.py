"""MINPACK's Levenberg-Marquardt on the normal equations against MINPACK itself (``scipy.optimize.leastsq``)."""

import numpy as np
import pytest
from scipy.optimize import leastsq

from jointid.methods.levenberg_marquardt import levenberg_marquardt

T = np.linspace(0.0, 4.0, 200)
TRUE = np.array([2.0, 0.7, 1.0, 0.3, 3.0])


def _model(x):
    return x[0] * np.exp(-x[1] * T) + x[2] * np.exp(-x[3] * T) * np.cos(x[4] * T)


def _jacobian(x):
    e1, e2, c, s = np.exp(-x[1] * T), np.exp(-x[3] * T), np.cos(x[4] * T), np.sin(x[4] * T)
    return np.stack([e1, -x[0] * T * e1, e2 * c, -x[2] * T * e2 * c, -x[2] * T * e2 * s], axis=1)


Y = _model(TRUE) + 0.01 * np.random.default_rng(1).standard_normal(T.size)


def _residual(x):
    return _model(x) - Y


def _normal(x):
    J = _jacobian(x)
    return J.T @ J, J.T @ _residual(x)


@pytest.mark.parametrize("x0", [[1.0, 1.0, 1.0, 1.0, 2.5], [3.0, 0.2, 0.5, 1.0, 3.3], [1.0, 2.0, 2.0, 0.1, 2.0]])
@pytest.mark.parametrize("max_nfev", [4, 200])
def test_the_steps_are_minpacks(x0, max_nfev):
    """The same iterates as MINPACK's lmder (a QR of J) from three starts, stopped early or converged: the
    same evaluation counts and stopping test, and x within the rounding of a few steps (cond(J)^2 eps each)."""
    x0 = np.array(x0)
    ref, _, info, _, ier = leastsq(_residual, x0, Dfun=_jacobian, full_output=True, ftol=1e-6, xtol=1e-8, gtol=1e-8,
                                   maxfev=max_nfev, factor=100.0)
    sol = levenberg_marquardt(_residual, _normal, x0, ftol=1e-6, xtol=1e-8, gtol=1e-8, max_nfev=max_nfev)
    assert (sol.nfev, sol.njev, sol.status) == (info["nfev"], info["njev"], ier)
    cond = np.linalg.cond(_jacobian(ref) / np.linalg.norm(_jacobian(ref), axis=0))
    assert np.abs(sol.x - ref).max() <= 100 * cond ** 2 * np.finfo(float).eps * np.abs(ref).max()
    assert sol.cost == pytest.approx(0.5 * np.sum(_residual(sol.x) ** 2), rel=1e-15)


def test_a_direction_the_residual_does_not_see_is_left_where_it_started():
    """Two parameters that enter only as a sum (a singular J^T J): the fit reaches the least-squares minimum of
    the sum and leaves the unseen difference at its start (the Gauss-Newton step has no part along it)."""
    A = np.stack([np.ones(50), np.linspace(0.0, 1.0, 50)], axis=1)
    y = A @ np.array([1.5, -2.0]) + 0.01 * np.sin(np.arange(50))

    def residual(x):
        return A @ np.array([x[0] + x[1], x[2]]) - y

    def normal(x):
        J = np.stack([A[:, 0], A[:, 0], A[:, 1]], axis=1)
        return J.T @ J, J.T @ residual(x)

    sol = levenberg_marquardt(residual, normal, np.array([0.3, 0.1, 0.0]), ftol=1e-12, xtol=1e-12)
    best = np.linalg.lstsq(A, y, rcond=None)[0]
    assert sol.x[0] + sol.x[1] == pytest.approx(best[0], rel=1e-9) and sol.x[2] == pytest.approx(best[1], rel=1e-9)
    assert sol.x[0] - sol.x[1] == pytest.approx(0.2, abs=1e-9)


def test_a_jacobian_that_is_not_finite_stops_the_fit_where_it_is():
    """NaN in the normal equations (a model evaluated outside its domain): stopped at the last good point, status 9."""
    calls = []

    def normal(x):
        calls.append(x.copy())
        N, g = _normal(x)
        return (N, g) if len(calls) < 3 else (N * np.nan, g)

    sol = levenberg_marquardt(_residual, normal, np.array([1.0, 1.0, 1.0, 1.0, 2.5]), ftol=1e-12, xtol=1e-12)
    assert sol.status == 9 and sol.njev == 3 and np.array_equal(sol.x, calls[-1])
    assert sol.cost == pytest.approx(0.5 * np.sum(_residual(sol.x) ** 2), rel=1e-15)


def test_a_search_that_creeps_is_ended_when_k_steps_lower_the_sum_of_squares_by_less_than_the_stall():
    """``||r||^2 = (1 + 1 / x)^2`` falls towards 1 for ever, ever more slowly (a valley to infinity): with MINPACK's tests off, only
    ``max_nfev`` ends it; ``stall = (k, fall)`` ends it (status 10) at the first successful step where the last k
    steps lowered ``||r||^2`` by less than ``fall``, and not one step before."""
    def residual(x):
        return np.array([1.0 + 1.0 / x[0]])

    points = []

    def normal(x):  # asked at the start and after every successful step
        points.append(x.copy())
        J = np.array([[-1.0 / x[0] ** 2]])
        return J.T @ J, J.T @ residual(x)

    plain = levenberg_marquardt(residual, normal, np.array([1.0]), ftol=0.0, xtol=0.0, max_nfev=60)
    assert plain.status == 5
    points.clear()
    k, fall = 3, 1e-3
    sol = levenberg_marquardt(residual, normal, np.array([1.0]), ftol=0.0, xtol=0.0, max_nfev=60, stall=(k, fall))
    cost = [float(residual(p)[0] ** 2) for p in points] + [2.0 * sol.cost]  # ||r||^2 at each successful point
    assert sol.status == 10 and sol.nfev < 60
    assert cost[-1 - k] - cost[-1] < fall <= cost[-2 - k] - cost[-2]
