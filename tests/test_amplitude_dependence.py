"""Amplitude (Kraus) and preload dependence of the storage stiffness: exact recovery, a noisy step-sine sweep, bad input."""

import csv
import json

import numpy as np
import pytest

from jointid.errors import DataError
from jointid.measurement.campaign_synth import DEFAULT_AMPLITUDES_M, CampaignTruth, synthesize_campaign
from jointid.measurement.stepsine import process_stepsine, read_stepsine_csv
from jointid.methods.direct.amplitude_dependence import (
    fit_kraus,
    fit_kraus_loss,
    fit_preload,
    kraus_loss,
    kraus_storage,
)

TRUTH = CampaignTruth()  # K'inf / K'0 = 0.6, Ac = 0.2 mm, m = 0.6
A = np.asarray(DEFAULT_AMPLITUDES_M)


def test_kraus_exact_values_recovered():
    k = kraus_storage(A, 5e5, 3e5, 2e-4, 0.6)
    assert kraus_storage(2e-4, 5e5, 3e5, 2e-4, 0.6) == pytest.approx(4e5)  # half the drop at Ac
    fit = fit_kraus(A, k)
    assert fit.k0_n_m == pytest.approx(5e5, rel=1e-8) and fit.kinf_n_m == pytest.approx(3e5, rel=1e-8)
    assert fit.critical_amplitude_m == pytest.approx(2e-4, rel=1e-8) and fit.exponent_m == pytest.approx(0.6, rel=1e-8)
    assert fit.identified and fit.residual_rms < 1e-10
    d = json.loads(json.dumps(fit.to_dict(), allow_nan=False))
    assert d["critical_amplitude_m"]["value"] == pytest.approx(2e-4) and d["identified"] is True


def test_kraus_loss_exact_values_recovered():
    storage = fit_kraus(A, kraus_storage(A, 5e5, 3e5, 2e-4, 0.6))
    loss = kraus_loss(A, 2e4, 6e4, 2e-4, 0.6)
    assert kraus_loss(2e-4, 2e4, 6e4, 2e-4, 0.6) == pytest.approx(6e4)  # the peak at Ac
    lf = fit_kraus_loss(A, loss, storage)
    assert lf.kinf_n_m == pytest.approx(2e4, rel=1e-8) and lf.kmax_n_m == pytest.approx(6e4, rel=1e-8)
    assert np.allclose(lf.loss(A), loss, rtol=1e-8)


def test_kraus_sweep_below_the_critical_amplitude_is_not_identified():
    a = np.array([1e-6, 2e-6, 4e-6, 8e-6, 1.6e-5])  # all far below Ac: no second plateau in the data
    rng = np.random.default_rng(0)
    k = kraus_storage(a, 5e5, 3e5, 2e-4, 0.6) * (1 + 1e-3 * rng.standard_normal(a.size))
    fit = fit_kraus(a, k)
    assert not fit.identified and any("not identified" in f or "at bound" in f for f in fit.findings)


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """Step-sine tests at 20 C, 5 amplitudes x 10 lines 1-100 Hz, 0.5 % noise."""
    d = tmp_path_factory.mktemp("sweep")
    m = synthesize_campaign(d, TRUTH, temperatures_c=(20.0,), amplitudes_m=tuple(A), noise=0.005, seed=1)
    with open(m, newline="") as fh:
        rows = list(csv.DictReader(fh))
    res = {float(r["amplitude_m"]): process_stepsine(read_stepsine_csv(d / r["file"]), parallel_joints=2) for r in rows}
    f = res[A[0]].frequency_hz
    return f, np.array([res[a].stiffness for a in A])  # (A, F)


def test_storage_ratio_vs_amplitude_within_2_percent(sweep):
    f, K = sweep
    ratio_true = TRUTH.kraus_factor(A) / TRUTH.kraus_factor(A[0])  # the same at every frequency
    ratio = K.real / K.real[0]
    assert np.max(np.abs(ratio - ratio_true[:, None])) < 0.02
    for i in range(f.size):
        fit = fit_kraus(A, K[:, i].real)
        assert np.max(np.abs(fit.storage(A) / fit.storage(A[0]) - ratio_true)) < 0.02
        assert fit.kinf_n_m / fit.k0_n_m == pytest.approx(TRUTH.kraus_kinf_ratio, rel=0.02)
        assert fit.critical_amplitude_m == pytest.approx(TRUTH.kraus_critical_amplitude_m, rel=0.1)


def test_preload_polynomial():
    p = np.array([0.0, 100.0, 200.0, 300.0, 400.0])
    fit = fit_preload(p, 4e5 + 250.0 * p)
    assert fit.coefficients == pytest.approx([4e5, 250.0], rel=1e-10)
    assert fit.to_dict()["relative_slope_per_n"] == pytest.approx(250.0 / 4e5)
    q = fit_preload(p, 4e5 + 250.0 * p + 0.5 * p**2, degree=2)
    assert q.coefficients == pytest.approx([4e5, 250.0, 0.5], rel=1e-8)
    rng = np.random.default_rng(2)
    slopes, stds = [], []
    for _ in range(400):
        f = fit_preload(p, 4e5 + 250.0 * p + 1e3 * rng.standard_normal(p.size))
        slopes.append(f.coefficients[1])
        stds.append(f.std[1])
    # the reported error of the slope matches its scatter: sigma / sqrt(sum (p - mean p)^2) = 1e3 / sqrt(1e5)
    assert np.std(slopes) == pytest.approx(1e3 / np.sqrt(1e5), rel=0.15)
    assert np.sqrt(np.mean(np.square(stds))) == pytest.approx(1e3 / np.sqrt(1e5), rel=0.15)


def test_bad_input_one_line():
    with pytest.raises(DataError, match="Kraus fit: needs at least 4 distinct amplitudes, got 3"):
        fit_kraus(A[:3], np.ones(3))
    with pytest.raises(DataError, match="Kraus fit: 5 amplitudes but 4 values"):
        fit_kraus(A, np.ones(4))
    with pytest.raises(DataError, match="must be finite and positive"):
        fit_kraus(A, -np.ones(5))
    with pytest.raises(DataError, match="degree 1 needs at least 3 distinct preloads, got 2"):
        fit_preload([0.0, 1.0], [1.0, 2.0])
