"""Refits with a block of rows left out or replaced, from the full fit, against factoring the changed problem again."""

from __future__ import annotations

import numpy as np
import pytest

from jointid.methods.receptance.block_refit import LEVERAGE_FLOOR, left_out_rss, replaced_rss

EPS = np.finfo(float).eps


def _problem(seed, F=5, N=40, p=9):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(F, N, p)) + 1j * rng.normal(size=(F, N, p))
    d = rng.normal(size=(F, N)) + 1j * rng.normal(size=(F, N))
    return A, d


def _rss(A, d):
    x = np.linalg.lstsq(A, d, rcond=None)[0]
    return float(np.sum(np.abs(d - A @ x) ** 2))


def _full_fit(A, d):
    Q, _ = np.linalg.qr(A)
    r = d - (Q @ (np.conj(np.swapaxes(Q, 1, 2)) @ d[:, :, None]))[:, :, 0]
    return Q, r


def test_left_out_rows_give_the_residual_of_the_fit_without_them():
    A, d = _problem(0)
    Q, r = _full_fit(A, d)
    rows = np.array([3, 7, 8, 20, 31])
    keep = np.setdiff1d(np.arange(A.shape[1]), rows)
    got = left_out_rss(r, Q, rows)
    for f in range(A.shape[0]):
        want = _rss(A[f, keep], d[f, keep])
        # both backward stable: error ~ N eps ||d||^2 times cond(A)^2 of these well-conditioned random designs (<= 10)
        assert abs(got[f] - want) <= 100 * A.shape[1] * EPS * np.sum(np.abs(d[f]) ** 2), (f, got[f], want)


def test_replaced_rows_give_the_residual_of_the_fit_with_their_new_data_and_weights():
    A, d = _problem(1)
    Q, r = _full_fit(A, d)
    rng = np.random.default_rng(2)
    rows = np.array([0, 5, 6, 39])
    ratio = rng.uniform(0.2, 5.0, size=(A.shape[0], rows.size))  # new weights over old: cond(M) <= 25^2
    d_new = rng.normal(size=ratio.shape) + 1j * rng.normal(size=ratio.shape)
    got = replaced_rss(d, r, Q, rows, d_new, ratio)
    for f in range(A.shape[0]):
        A2, d2 = A[f].copy(), d[f].copy()
        A2[rows] *= ratio[f][:, None]
        d2[rows] = d_new[f]
        want = _rss(A2, d2)
        assert abs(got[f] - want) <= 1e4 * A.shape[1] * EPS * (np.sum(np.abs(d2) ** 2) + np.sum(np.abs(d[f]) ** 2)), f
    # unchanged rows: the full fit's residual
    same = replaced_rss(d, r, Q, rows, d[:, rows], np.ones(ratio.shape))
    np.testing.assert_allclose(same, np.sum(np.abs(r) ** 2, axis=1), rtol=1e3 * A.shape[1] * EPS)


def test_rows_that_alone_determine_a_parameter_leave_an_undetermined_fit():
    A, d = _problem(3, F=2)
    A[:, :, 0] = 0.0
    A[:, [4, 5], 0] = 1.0  # parameter 0 is seen by rows 4 and 5 only
    Q, r = _full_fit(A, d)
    rss = left_out_rss(r, Q, np.array([4, 5]))
    assert np.all(np.isinf(rss))
    assert np.all(np.isfinite(left_out_rss(r, Q, np.array([4]))))  # one of them left: determined (1 - leverage 1/2)
    assert LEVERAGE_FLOOR == pytest.approx(np.sqrt(EPS))
