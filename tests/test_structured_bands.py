"""The structured fit's parameter covariance: accurate where J^T J is not, and its bands stable to one rounding."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.methods.receptance.structured_bands import parameter_covariance
from jointid.pipeline import identify, simulate

EPS = np.finfo(float).eps


def _orthonormal(rng, n, k):
    return np.linalg.qr(rng.normal(size=(n, k)))[0]


def test_covariance_is_accurate_to_cond_eps_where_the_normal_equations_lose_cond_squared():
    """J = U diag(s) V^T with s = 1 .. 1e-7: (J^T J)^-1 = V diag(1/s^2) V^T exactly; the error bound is
    ~P cond(J) eps relative to the largest entry (a backward-stable QR and SVD), the normal equations' cond^2 eps."""
    rng = np.random.default_rng(3)
    N, P = 400, 5
    s = np.array([1.0, 0.3, 1e-2, 1e-4, 1e-7])
    U, V = _orthonormal(rng, N, P), _orthonormal(rng, P, P)
    J = (U * s) @ V.T
    exact = (V / s ** 2) @ V.T
    cov, unseen = parameter_covariance(J)
    assert unseen.shape == (P, 0)
    cond = s[0] / s[-1]
    scale = np.abs(exact).max()
    assert np.abs(cov - exact).max() <= 10 * P * cond * EPS * scale
    normal = np.linalg.inv(J.T @ J)  # what the fit did before: an error of order cond^2 eps, here ~1e-2
    assert np.abs(normal - exact).max() > 1e3 * np.abs(cov - exact).max()


def test_a_direction_the_data_do_not_determine_is_left_out_and_named():
    """A column that is a combination of two others: one direction below the numerical rank; the covariance
    is the pseudo-inverse of J^T J on the rest, and the left-out direction is orthogonal to what is kept."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(300, 3))
    J = np.column_stack([A, A[:, 0] - 2.0 * A[:, 2]])
    cov, unseen = parameter_covariance(J)
    assert unseen.shape == (4, 1)
    null = np.array([1.0, 0.0, -2.0, -1.0]) / np.sqrt(6.0)
    assert abs(abs(unseen[:, 0] @ null) - 1.0) <= 100 * EPS
    assert np.abs(cov @ null).max() <= 1e3 * EPS * np.abs(cov).max()
    JTJ = J.T @ J
    assert np.allclose(cov @ JTJ @ cov, cov, rtol=0, atol=1e4 * EPS * np.abs(cov).max())  # pseudo-inverse


@pytest.fixture(scope="module")
def beam_case():
    """The benchmark beam at 100-1000 Hz every 3 Hz, 0.3 % noise (seed 7): the Akaike average holds an order
    (one mode, 4 modulus coefficients, no residual term) whose Jacobian has a direction of s_min/s_max ~ 6e-17."""
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0, step=3.0))
    test = simulate(st)
    rng = np.random.default_rng(7)
    noise = (rng.standard_normal(test.frf.shape) + 1j * rng.standard_normal(test.frf.shape)) / np.sqrt(2)
    return st, test.frf, test.frf.data * (1 + 0.003 * noise)


def test_bands_do_not_move_when_the_frfs_change_by_one_rounding(beam_case):
    """Through (J^T J)^-1 the K_ww band moved by up to 9 % for data x (1 + 2.2e-16); from J's singular values
    the change is bounded by the kept directions' cond(J) eps (< 1e-3 here, by the rank cut s > N P eps s_max)."""
    st, frf, data = beam_case
    a, b = (identify(st, FRF(frf.frequency, data * scale, frf.responses, frf.references, frf.kind)) for scale in (1.0, 1.0 + EPS))
    assert a.estimator == b.estimator == "structured"
    assert np.abs(b.std_real / a.std_real - 1.0).max() <= 1e-3
    assert np.abs(b.std_imag / a.std_imag - 1.0).max() <= 1e-3


def test_edge_shapes_and_non_finite_jacobians():
    """Fewer rows than parameters: the missing directions are unseen; a non-finite J: NaN covariance (no band), as
    the fit's values; no parameters: empty."""
    rng = np.random.default_rng(5)
    J = rng.normal(size=(3, 4))
    cov, unseen = parameter_covariance(J)
    assert cov.shape == (4, 4) and unseen.shape == (4, 1)
    assert np.abs(J @ unseen).max() <= 100 * EPS * np.abs(J).max()  # the missing direction: J's null space
    assert np.allclose(cov @ (J.T @ J) @ cov, cov, rtol=0, atol=1e4 * EPS * np.abs(cov).max())  # pseudo-inverse
    J = rng.normal(size=(50, 4))
    J[7, 2] = np.nan
    cov, unseen = parameter_covariance(J)
    assert np.all(np.isnan(cov)) and unseen.shape == (4, 0)
    cov, unseen = parameter_covariance(np.zeros((10, 0)))
    assert cov.shape == (0, 0) and unseen.shape == (0, 0)


def _fit(aic, std, K=1.0 + 0.1j):
    from types import SimpleNamespace

    F = 5
    s = np.full((F, 2, 2), std, float)
    return SimpleNamespace(aic=aic, stiffness=np.full((F, 2, 2), K), std_real=s, std_imag=s)


def test_an_undetermined_fit_is_left_out_of_the_average_even_with_the_lowest_aic():
    """Its infinite band made the degenerate filter's reference infinite: every fit passed, the average's band was
    infinite and the estimate rejected. It is left out first; with every fit undetermined the average keeps them."""
    from jointid.methods.receptance.structured_select import model_average

    fits = {"blind": _fit(0.0, np.inf), "good": _fit(1.0, 0.01), "other": _fit(1.5, 0.012, 1.01 + 0.1j)}
    K, sr, si, w = model_average(fits)
    assert set(w) == {"good", "other"} and np.all(np.isfinite(sr)) and np.all(np.isfinite(si))
    assert abs(w["good"] / w["other"] - np.exp(0.25)) <= 1e-12
    _, sr, _, w = model_average({"blind": _fit(0.0, np.inf), "blind2": _fit(1.0, np.inf)})
    assert set(w) == {"blind", "blind2"} and np.all(np.isinf(sr))


def test_evaluating_a_fit_elsewhere_keeps_its_undetermined_terms_without_a_band(beam_case):
    st, frf, data = beam_case
    res = identify(st, FRF(frf.frequency, data, frf.responses, frf.references, frf.kind))
    fit = res.structured.best
    mask = np.array([[False, True], [True, False]])
    hz = np.linspace(200.0, 800.0, 7)
    moved = dataclasses.replace(fit, undetermined=mask).at(hz)
    assert np.all(np.isinf(moved.std_real[:, mask])) and np.all(np.isinf(moved.std_imag[:, mask]))
    assert np.all(np.isfinite(moved.std_real[:, ~mask])) and np.allclose(moved.std_real[:, ~mask], fit.at(hz).std_real[:, ~mask], rtol=0, atol=0)
