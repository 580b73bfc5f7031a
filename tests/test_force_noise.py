"""Force noise without coherence (jointid.methods.receptance.force_noise): detection, level, honest covariance.

Synthetic per-line coupling problems (random free blocks, a symmetric joint, 7 x 3 FRFs, 2 joint DOFs),
``H_meas = H (1 + n_R) / (1 + n_F[column])`` per line, no coherence: weights ``|H|^2``.
Fixed seeds; the false-positive rate over seeds is printed by ``benchmarks/force_noise.py --force 0``.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointid.methods.receptance.coupling_lines import coupling_per_line
from jointid.methods.receptance.force_noise import FORCE_NOISE_LINES, detect_force_noise

F, M, E, N = 400, 7, 3, 2
P = N * (N + 1) // 2
RESPONSE = 0.01


def problem(seed: int, force: float, response: float = RESPONSE):
    """Free blocks, the measured receptance and the true X (upper triangle) of one synthetic test."""
    rng = np.random.default_rng(seed)

    def cn(*shape):
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    Ymn, Yne, Yme = cn(F, M, N), cn(F, N, E), cn(F, M, E)
    B, D = cn(F, N, N), cn(F, N, N)
    Ynn = B + np.swapaxes(B, 1, 2)
    Du = 3.0 * (D + np.swapaxes(D, 1, 2)) + 5.0 * np.eye(N)
    X = np.linalg.inv(Ynn + np.linalg.inv(Du))
    X = 0.5 * (X + np.swapaxes(X, 1, 2))
    H = Yme - Ymn @ X @ Yne
    Hm = H * (1 + response * cn(F, M, E)) / (1 + force * cn(F, 1, E))
    iu = np.triu_indices(N)
    return Ymn, Yne, Ynn, Yme, Hm, X[:, iu[0], iu[1]]


def mahalanobis(x, cov, truth):
    """Mean over lines of ``(x - truth)^H cov^-1 (x - truth)``: p (here 3) when the covariance is right."""
    d = x - truth
    return float(np.mean(np.real(np.einsum("fi,fij,fj->f", d.conj(), np.linalg.inv(cov), d))))


def test_force_noise_detected_and_its_level_within_the_bound():
    Ymn, Yne, Ynn, Yme, H, _ = problem(1, 0.01)
    fn = detect_force_noise(Ymn, Yne, Yme - H, H, np.abs(H) ** 2)
    assert fn.significant and fn.p_value < 1e-12
    # the level: b from moments over n lines has relative std ~ (1 + a / (b |z|^2)) / sqrt(n), with b |z|^2 / a ~ F - 1;
    # the median over the band's windows is ~1.25 times less efficient than the band's mean; the level sqrt(b) has
    # half b's relative std (1.25 * 1.19 / 40 = 3.7 %; 40 seeds scatter by 3.6 %); 4 sigma
    sigma = 1.25 * (1.0 + 1.0 / (fn.f_statistic - 1.0)) / (2.0 * np.sqrt(F))
    assert np.all(np.abs(fn.level / 0.01 - 1.0) < 4.0 * sigma), (fn.level, sigma)
    # the response noise: a from |m||e| - p - e = 15 degrees of freedom per line over L lines (4 sigma, in the level)
    assert abs(fn.response_level / RESPONSE - 1.0) < 4.0 / (2.0 * np.sqrt(15 * FORCE_NOISE_LINES))
    assert "force noise, ~1" in fn.finding and "per column" in fn.finding


@pytest.mark.parametrize("seed", [2, 3])
def test_only_response_noise_is_not_detected(seed):
    Ymn, Yne, Ynn, Yme, H, _ = problem(seed, 0.0)
    fn = detect_force_noise(Ymn, Yne, Yme - H, H, np.abs(H) ** 2)
    assert not fn.significant
    # F(2 e F, 2 (|m||e| - p - e) F): std ~ sqrt(1 / (e F) + 1 / ((|m||e| - p - e) F)); 4 sigma
    assert abs(fn.f_statistic - 1.0) < 4.0 * np.sqrt(1.0 / (E * F) + 1.0 / ((M * E - P - E) * F))


def test_exact_data_is_not_detected():
    Ymn, Yne, Ynn, Yme, H, _ = problem(4, 0.0, response=0.0)
    fn = detect_force_noise(Ymn, Yne, Yme - H, H, np.abs(H) ** 2)
    assert fn is not None and not fn.significant


def test_no_redundancy_for_the_column_directions():
    Ymn, Yne, Ynn, Yme, H, _ = problem(5, 0.01)
    assert detect_force_noise(Ymn[:, :1], Yne, (Yme - H)[:, :1], H[:, :1], np.abs(H[:, :1]) ** 2) is None


def test_line_estimates_have_an_honest_covariance():
    """With force noise the independent-noise fit's covariance is too small (Mahalanobis mean well above p);
    the generalized least squares with the force noise in the covariance has mean p within 4 sigma
    (a sum of p unit exponentials per line: std sqrt(p / F) of the mean)."""
    Ymn, Yne, Ynn, Yme, H, x_true = problem(6, 0.01)
    v = np.abs(H) ** 2
    fn = detect_force_noise(Ymn, Yne, Yme - H, H, v)
    lines = fn.line_estimates(Ymn, Yne, Ynn, Yme - H, H, v)
    plain = coupling_per_line(Ymn, Yne, Ynn, Yme - H, v)
    bound = 4.0 * np.sqrt(P / F)
    assert abs(mahalanobis(lines.x, lines.x_covariance, x_true) - P) < bound
    assert mahalanobis(plain.x, plain.x_covariance, x_true) - P > bound  # the failure this fixes
    # and the same output as coupling_per_line: Du, its variance, finite
    assert lines.stiffness.shape == plain.stiffness.shape and np.all(np.isfinite(lines.variance))
    assert lines.dof == plain.dof and lines.x_covariance.shape == plain.x_covariance.shape


def test_line_estimates_without_force_noise_are_the_weighted_fit():
    """No column-common variance (b = 0) and one response scale on every line: the generalized fit is the plain
    weighted fit (to round-off; the scale cancels against the residual scale)."""
    Ymn, Yne, Ynn, Yme, H, _ = problem(7, 0.0)
    v = np.abs(H) ** 2
    fn = detect_force_noise(Ymn, Yne, Yme - H, H, v)
    fn0 = type(fn)(np.full(F, 3e-4), np.zeros_like(fn.column_variance), fn.f_statistic, fn.p_value, fn.dof)
    lines = fn0.line_estimates(Ymn, Yne, Ynn, Yme - H, H, v)
    plain = coupling_per_line(Ymn, Yne, Ynn, Yme - H, v)
    # the same least squares by two factorizations: x within 64 eps cond of the design (each line's equilibrated
    # condition number), its variance (squares and a residual scale) within 64 eps cond^2
    cond = float(np.max(plain.condition))
    eps = np.finfo(float).eps
    np.testing.assert_allclose(lines.x, plain.x, rtol=0, atol=64 * eps * cond * np.max(np.abs(plain.x)))
    np.testing.assert_allclose(lines.variance, plain.variance, rtol=64 * eps * cond ** 2)
