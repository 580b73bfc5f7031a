"""The structured estimate's membership test: a joint outside the class is rejected with its finding, one inside is kept.

Small synthetic per-line estimates (a 2-DOF joint of the class: one internal mode, constant
modulus; 200 lines, 0.5 % noise per term, fixed seeds). Figures over many seeds on the beam
are in benchmarks/out_of_class.py.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from jointid.methods.receptance.structured_membership import MAX_WHITENESS_Z, fitting_bias, lag_correlation
from jointid.methods.receptance.structured_model import StructuredModel, pack, structured_stiffness
from jointid.methods.receptance.structured_select import MAX_CHI2_PER_DOF, polish_best, structured_estimate

HZ = np.linspace(100.0, 1000.0, 200)


def _joint(extra_loss_ww: float = 0.0) -> np.ndarray:
    """A joint of the class; ``extra_loss_ww``: K_ww alone gets ``+ j eta (f / 1 kHz) Re K_ww`` (its own damping law)."""
    S = (np.sqrt(2e5), np.sqrt(60.0))
    model = StructuredModel(2, 1, 1, False, S, 1000.0, (HZ[0], HZ[-1]))
    theta = pack([1.0, 0.05, 0.8], [0.02, 0.0, 0.05], [], [[0.3, 0.2, np.log(0.5)]], [1.0 + 0.12j])
    D = structured_stiffness(theta, HZ, model) * np.outer(S, S)
    D[:, 0, 0] += 1j * extra_loss_ww * D[:, 0, 0].real * HZ / 1000.0
    return D


def _lines(D: np.ndarray, seed: int, noise: float = 0.005):
    """Per-line estimates with independent circular noise of relative rms ``noise`` per term (``Ynn = 0``: ``x = Du``)."""
    rng = np.random.default_rng(seed)
    iu = np.triu_indices(2)
    x0 = D[:, iu[0], iu[1]]
    sd = noise * np.abs(x0)
    x = x0 + sd * (rng.standard_normal(x0.shape) + 1j * rng.standard_normal(x0.shape)) / np.sqrt(2)
    K = np.empty_like(D)
    V = np.empty(D.shape)
    K[:, iu[0], iu[1]] = K[:, iu[1], iu[0]] = x
    V[:, iu[0], iu[1]] = V[:, iu[1], iu[0]] = sd ** 2
    cov = np.zeros((HZ.size, 3, 3), complex)
    cov[:, range(3), range(3)] = sd ** 2
    return SimpleNamespace(stiffness=K, variance=V, x=x, x_covariance=cov, Ynn=np.zeros((HZ.size, 2, 2), complex))


@pytest.fixture(scope="module")
def outside():
    lines = _lines(_joint(extra_loss_ww=0.02), seed=0)
    return lines, structured_estimate(HZ, lines)


def test_fitting_bias_is_the_expected_lag_product_of_least_squares_residuals():
    """Residuals of a least-squares fit of white noise: the mean lag-1 product over 4000 draws is -sum_f H[f, f+1]."""
    rng = np.random.default_rng(0)
    F = 60
    f = np.linspace(0.0, 1.0, F)
    J = np.stack([np.ones(F), f, f ** 2, np.cos(3 * f)], axis=1)  # smooth regressors
    H = J @ np.linalg.pinv(J)
    e = rng.standard_normal((4000, F))
    r = e - e @ H.T
    products = np.sum(r[:, 1:] * r[:, :-1], axis=1)
    expected = fitting_bias(J, 1)
    # the mean of 4000 draws: standard error sqrt(var / 4000), var about F
    assert abs(products.mean() - expected) < 4 * products.std() / np.sqrt(4000)
    assert expected < -0.5  # anti-correlated, by much more than the tolerance: the test can fail
    assert np.isclose(lag_correlation(np.r_[1.0, 1.0, 1.0, 1.0]), 0.75)


def test_a_joint_in_the_class_is_accepted():
    est = structured_estimate(HZ, _lines(_joint(), seed=0))
    assert est.accepted and est.finding == ""
    # under the model z is about N(0, 1): 3 sigma
    assert abs(est.membership.z) < 3.0
    assert "residual whiteness Z" in est.describe() and est.best.model.label in est.describe()


def test_a_joint_outside_the_class_is_rejected_by_whiteness_where_chi2_alone_accepts(outside):
    _, est = outside
    assert est.best.chi2_per_dof <= MAX_CHI2_PER_DOF  # chi^2/dof alone would have accepted it
    assert not est.accepted
    # repeatable across seeds: z has unit spread, so a margin of 5 keeps the decision for any seed of these data
    assert est.membership.z > MAX_WHITENESS_Z + 5.0
    assert est.membership.worst_term() == 0  # the missed shape is on K_ww
    text = est.finding
    assert text.startswith(f"the structured joint model ({est.best.model.label}; chi^2/dof {est.best.chi2_per_dof:.2f}) misses the shape")
    assert f"whiteness Z {est.membership.z:.1f} > {MAX_WHITENESS_Z}, most in term (0, 0)" in text
    assert text.endswith("each term smoothed on its own instead")


def test_a_rejected_estimate_has_the_lowest_chi2_either_path_reaches(outside):
    """The rejection was decided after the second path: refitting again finds no better fit of the chosen order."""
    lines, est = outside
    best = min((f for f in est.fits.values() if np.isfinite(f.aic)), key=lambda f: f.aic)
    again = polish_best(HZ, lines, est.fits)
    order = best.model.order
    # least_squares stops when chi^2 moves by less than ftol = 1e-6 relative: a fit of this order no lower than that
    assert again[order].chi2 >= best.chi2 * (1 - 1e-5)
