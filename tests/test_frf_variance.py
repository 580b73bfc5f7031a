"""FRF variance from coherence, and its split into a column-common (force) and a per-value (response) part."""

import dataclasses

import numpy as np
import pytest

from jointid.benchmark import benchmark_study
from jointid.methods.receptance.frf_variance import (
    COHERENCE_SMOOTHING_LINES,
    SPLIT_MIN_FRACTION,
    column_noise_fraction,
    frf_variance,
    smooth_coherence_variance,
)
from jointid.pipeline import experiment


def _layout(seed, F=60, m=7, e=3, a_level=1e-3):
    """Exact coherences of the split's model: q = a_j + s_r t_j / |H_rj|^2, constant over frequency."""
    rng = np.random.default_rng(seed)
    a = a_level * rng.uniform(0.5, 2.0, e)
    s = 1e-3 * rng.uniform(0.2, 5.0, m)
    t = rng.uniform(0.5, 2.0, e)
    M = rng.uniform(0.05, 20.0, (m, e))
    b = s[:, None] * t[None, :] / M
    q = np.broadcast_to(a[None, :] + b, (F, m, e))
    H = np.broadcast_to(np.sqrt(M) * np.exp(1j * rng.uniform(0, 6, (m, e))), (F, m, e))
    return np.array(H), 1.0 / (1.0 + q), b / (a[None, :] + b)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_split_recovers_the_column_common_part_of_exact_coherences(seed):
    H, g2, truth = _layout(seed)
    frac = column_noise_fraction(H, g2)
    assert frac.shape == H.shape
    truth = np.maximum(truth, SPLIT_MIN_FRACTION)
    assert np.max(np.abs(frac[0] - truth) / truth) < 0.02, (frac[0], truth)


def test_without_force_noise_nothing_is_taken_as_column_common():
    H, g2, _ = _layout(3, a_level=0.0)
    frac = column_noise_fraction(H, g2)
    assert np.min(frac) > 0.99


@pytest.mark.parametrize("m, e", [(2, 3), (7, 1), (3, 2)])
def test_a_layout_that_cannot_separate_the_parts_is_not_split(m, e):
    H, g2, _ = _layout(4, m=m, e=e)
    assert np.all(column_noise_fraction(H, g2) == 1.0)


def test_split_of_a_virtual_hammer_test_matches_its_force_and_response_noise():
    """Coherence of 1 % force + 1 % response noise, split, against the coherences of each noise alone (same hits)."""
    st = benchmark_study()
    st = dataclasses.replace(st, frequency=dataclasses.replace(st.frequency, start=100.0, stop=1000.0))

    def q(**noise):
        ex = experiment(dataclasses.replace(st, experiment=dataclasses.replace(st.experiment, **noise)), seed=0, periodic=True)
        frf = ex.frf.band(100, 1000)
        return frf, frf_variance(np.ones(frf.data.shape), frf.coherence, "coherence")[0]  # smoothed (1 - g^2) / g^2

    both, _ = q()
    _, qa = q(response_noise=0.0)  # smoothed (1 - g^2) / g^2 of the force noise alone
    _, qb = q(force_noise=0.0)
    frac = column_noise_fraction(both.data, both.coherence)
    truth = np.maximum(qb / (qa + qb), SPLIT_MIN_FRACTION)
    ratio = frac / truth
    # measured: median 1.0, 80 % of values within 0.75-1.7
    assert 0.85 < np.median(ratio) < 1.2, np.median(ratio)
    assert np.mean((ratio > 0.5) & (ratio < 2.0)) > 0.8


def _dense_split(logq, logM, m, e, iterations=30):
    """The split's Levenberg-Marquardt written out: full Jacobian (F, m e, 2e - 1 + m), per-line solve; (fractions, cost)."""
    from jointid.methods.receptance.frf_variance import RELATIVE_FLOOR, _cholesky_solve

    F = logq.shape[0]
    q, M = np.exp(logq).reshape(F, m, e), np.exp(logM).reshape(F, m, e)
    rows, cols = np.divmod(np.arange(m * e), e)
    Sa = np.zeros((m * e, e)); Sa[np.arange(m * e), cols] = 1
    Ss = np.zeros((m * e, m)); Ss[np.arange(m * e), rows] = 1
    St = Sa[:, 1:]
    theta = np.concatenate([np.log(0.5 * q.min(axis=1)), np.log(np.median(q * M, axis=2)), np.zeros((F, e - 1))], axis=1)

    def parts(th):
        la, lb = th[:, :e] @ Sa.T, th[:, e:e + m] @ Ss.T + th[:, e + m:] @ St.T - logM
        return la, lb, np.logaddexp(la, lb)

    def cost(th):
        return np.sum((logq - parts(th)[2]) ** 2, axis=1)

    lam, c = np.full(F, 1e-2), cost(theta)
    for _ in range(iterations):
        la, lb, lmod = parts(theta)
        wa, wb = np.exp(la - lmod), np.exp(lb - lmod)
        J = np.concatenate([wa[:, :, None] * Sa, wb[:, :, None] * Ss, wb[:, :, None] * St], axis=2)
        JJ, g = np.einsum("fri,frj->fij", J, J), np.einsum("fri,fr->fi", J, logq - lmod)
        D = np.einsum("fkk->fk", JJ) + 1e-12
        A = JJ + lam[:, None, None] * D[:, :, None] * np.eye(JJ.shape[1])
        # lam falls to ~1e-17 after 30 improvements: A is then singular to round-off on lines whose cost is flat
        # along some direction (LU raises LinAlgError there on some BLAS kernels); the module's Cholesky clamps such
        # a pivot, and the reference solves with it too: what is compared is how the normal equations are formed
        trial = theta + _cholesky_solve(A, g)
        trial[:, :e] = np.maximum(trial[:, :e], np.log(RELATIVE_FLOOR**2))
        ct = cost(trial)
        better = ct < c
        theta, c = np.where(better[:, None], trial, theta), np.where(better, ct, c)
        lam = np.where(better, lam / 3.0, lam * 4.0)
    la, lb, lmod = parts(theta)
    return np.exp(lb - lmod), c


def test_the_structured_split_is_the_dense_levenberg_marquardt():
    """The split's normal equations formed from row and column sums and solved through the Schur complement of
    the diagonal response block equal the dense Jacobian's: the same iterates up to rounding (relative
    ~cond eps per step). Both stop after the same 30 iterations, so rounding differences persist only along
    directions the cost hardly determines, where they move a fraction by far less than the split's own error
    (a factor ~1.5, module docstring); bound: 1e-6 on fractions in [0, 1] (measured 1e-8).
    """
    from jointid.methods.receptance.frf_variance import _split

    rng = np.random.default_rng(0)
    F, m, e = 600, 7, 3
    H = (rng.standard_normal((F, m, e)) + 1j * rng.standard_normal((F, m, e))) * np.exp(rng.uniform(-3, 3, (1, m, e)))
    q = (1e-3 * rng.uniform(1, 2, e)[None, None, :] + 1e-3 * rng.uniform(1, 2, m)[None, :, None] / np.abs(H) ** 2)
    q = q * rng.chisquare(10, size=q.shape) / 10  # the scatter of an estimated coherence
    logq, logM = np.log(q).reshape(F, m * e), np.log(np.abs(H) ** 2).reshape(F, m * e)
    dense, _ = _dense_split(logq, logM, m, e)
    frac = _split(logq, logM, m, e)
    assert np.quantile(dense, 0.1) < 0.5 < np.quantile(dense, 0.9)  # both parts present: not a trivial split
    assert np.max(np.abs(frac - dense)) < 1e-6


def test_a_constant_coherence_carries_no_split_and_raises_no_warning():
    """q the same for every value of a line: column and response noise cannot be told apart, the whole variance is kept."""
    import warnings

    from jointid.methods.receptance.frf_variance import column_noise_fraction

    rng = np.random.default_rng(0)
    H = (rng.standard_normal((40, 7, 3)) + 1j * rng.standard_normal((40, 7, 3))) * 10.0 ** rng.uniform(-3, 1, (40, 7, 3))
    for g2 in (0.2, 0.9):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            frac = column_noise_fraction(H, np.full(H.shape, g2))
        assert np.array_equal(frac, np.ones(H.shape))


def _resonant_magnitude(F: int = 800) -> np.ndarray:
    """|H|^2 of three lightly damped modes (peaks and antiresonances far narrower than the smoothing window), (F, 2, 2)."""
    hz = np.linspace(5.0, 1000.0, F)
    poles = np.array([120.0, 410.0, 760.0])
    H = np.zeros((F, 2, 2), complex)
    for k, p in enumerate(poles):
        shape = np.array([[1.0, (-1) ** k], [(-1) ** k, 1.0 + k]])
        H += shape / (p**2 - hz[:, None, None] ** 2 + 0.004j * p * hz[:, None, None])
    return np.abs(H) ** 2


def test_a_relative_error_keeps_its_variance_through_resonances():
    """Constant q (force noise, constant SNR): the smoothed variance is q |H|^2 on every line, peaks included.

    Averaging q |H|^2 over the window instead makes the peak's variance the window's mean (too small by
    orders of magnitude). Tolerance: the running sums of the window means accumulate over the F lines, and the
    slope's cancellation ``mean(x x) - mean(x)^2`` multiplies that by ``|x|``: ``F eps max|log |H|^2|^2``."""
    mag2 = _resonant_magnitude()
    q = np.full(mag2.shape, 2.5e-5)
    var = smooth_coherence_variance(q, mag2)
    bound = mag2.shape[0] * np.finfo(float).eps * np.abs(np.log(mag2)).max() ** 2
    np.testing.assert_allclose(var, q * mag2, rtol=bound, atol=0)
    assert COHERENCE_SMOOTHING_LINES > 1


def test_a_noise_floor_gives_the_floor_over_the_force_spectrum():
    """q = c / |H|^2 (a response noise floor c): the smoothed variance is c on every line (slope -1; bound as above)."""
    mag2 = _resonant_magnitude()
    c = 3e-12
    var = smooth_coherence_variance(c / mag2, mag2)
    bound = mag2.shape[0] * np.finfo(float).eps * np.abs(np.log(mag2)).max() ** 2
    np.testing.assert_allclose(var, np.full(mag2.shape, c), rtol=bound, atol=0)


def test_noisy_coherence_of_a_relative_error_is_averaged_not_followed():
    """q scattering by a factor ~2 around a constant (a coherence from few averages): the smoothed q is
    within the window mean's scatter of the truth on every line, far nearer than the raw q."""
    rng = np.random.default_rng(3)
    mag2 = _resonant_magnitude()
    q0 = 1e-4
    q = q0 * rng.chisquare(10, mag2.shape) / 10  # chi^2 with 10 dof: relative std 0.45
    ratio = smooth_coherence_variance(q, mag2) / (q0 * mag2)
    raw = np.log(q / q0)
    # log of chi^2_10 / 10: std 0.47, mean -0.10 (the log-mean's bias, common to every line); a mean over
    # 41 lines with a fitted slope: std ~0.47 sqrt(2 / 41) ~ 0.15 at most; the raw q's scatter is 3x that
    assert np.abs(np.log(ratio)).max() < 1.0  # within a factor e on every line, edges (a one-sided window) included
    assert np.std(np.log(ratio)) < 0.5 * np.std(raw)
