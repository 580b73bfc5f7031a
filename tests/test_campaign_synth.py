"""Synthetic campaign: manifest, truth laws, files that process back to the known stiffness."""

import csv
import math

import numpy as np
import pytest

from jointid.errors import DataError
from jointid.measurement.campaign_synth import MANIFEST_COLUMNS, CampaignTruth, synthesize_campaign
from jointid.measurement.stepsine import process_stepsine, read_stepsine_csv
from jointid.methods.direct.zener_fit import zener_modulus

TEMPS = (0.0, 30.0)
AMPS = (2e-5, 2e-4)


def _rows(manifest):
    with open(manifest, newline="") as fh:
        return list(csv.DictReader(fh))


def test_truth_laws():
    tr = CampaignTruth()
    f = np.logspace(-2, 4, 7)
    # same fractional Zener as the methods layer's (which campaign_synth cannot import)
    assert np.allclose(tr.modulus(f), zener_modulus(f, tr.k0_n_m, tr.kinf_n_m, tr.tau_s, tr.alpha), rtol=1e-14)
    assert tr.log10_shift(tr.reference_temperature_c) == 0.0
    assert tr.log10_shift(30.0) == pytest.approx(-9.0 * 10 / 120)  # WLF at c1 = 9, c2 = 110 K
    assert tr.kraus_factor(0.0) == 1.0
    assert tr.kraus_factor(tr.kraus_critical_amplitude_m) == pytest.approx(0.6 + 0.4 / 2)
    assert tr.kraus_factor(1e3) == pytest.approx(0.6, abs=1e-6)
    k = tr.stiffness(np.array([1.0, 10.0]), 0.0, tr.kraus_critical_amplitude_m)
    assert np.allclose(k, tr.modulus(np.array([1.0, 10.0]) * 100.0) * 0.8, rtol=1e-14)  # log10 aT(0 C) = 2
    assert CampaignTruth(vertical_shift=True).vertical_factor(50.0) == pytest.approx(323.15 / 293.15)
    with pytest.raises(DataError, match="inconsistent parameters"):
        CampaignTruth(kinf_n_m=1.0)


def test_manifest_and_noise_free_files_process_to_the_truth(tmp_path):
    tr = CampaignTruth()
    m = synthesize_campaign(tmp_path, tr, temperatures_c=TEMPS, amplitudes_m=AMPS, noise=0.0, specimens=("S1", "S2"))
    assert m == tmp_path / "manifest.csv"
    rows = _rows(m)
    assert tuple(rows[0]) == MANIFEST_COLUMNS and len(rows) == 2 * 2 * 2
    assert {(r["specimen"], float(r["temperature_c"]), float(r["amplitude_m"])) for r in rows} == {
        (s, t, a) for s in ("S1", "S2") for t in TEMPS for a in AMPS}
    for r in rows:
        res = process_stepsine(read_stepsine_csv(tmp_path / r["file"]), parallel_joints=int(r["parallel_joints"]))
        truth = tr.stiffness(res.frequency_hz, float(r["temperature_c"]), float(r["amplitude_m"]))
        # noise-free: harmonics and settling are fitted/dropped exactly; the file keeps 10 digits
        assert np.max(np.abs(res.stiffness / truth - 1)) < 1e-7


def test_noisy_files_within_the_estimators_error(tmp_path):
    noise = 0.005
    m = synthesize_campaign(tmp_path, temperatures_c=(20.0,), amplitudes_m=(2e-5,), noise=noise, seed=3)
    r = _rows(m)[0]
    res = process_stepsine(read_stepsine_csv(tmp_path / r["file"]), parallel_joints=2)
    truth = CampaignTruth().stiffness(res.frequency_hz, 20.0, 2e-5)
    # least squares of a phasor from N samples with relative noise e on each channel:
    # relative error of F1/X1 ~ 2 e / sqrt(N) (both channels); 6 sigma over 10 lines
    n = res.cycles_used * 32.0
    assert np.all(np.abs(res.stiffness / truth - 1) < 6 * 2 * noise / np.sqrt(n))


def test_files_do_not_depend_on_the_other_tests(tmp_path):
    a = synthesize_campaign(tmp_path / "a", temperatures_c=TEMPS, amplitudes_m=AMPS, seed=5)
    b = synthesize_campaign(tmp_path / "b", temperatures_c=(30.0,), amplitudes_m=(2e-4,), seed=5)
    name = _rows(b)[0]["file"]
    assert (a.parent / name).read_bytes() == (b.parent / name).read_bytes()
    c = synthesize_campaign(tmp_path / "c", temperatures_c=(30.0,), amplitudes_m=(2e-4,), seed=6)
    assert (c.parent / name).read_bytes() != (b.parent / name).read_bytes()


def test_bad_arguments(tmp_path):
    with pytest.raises(DataError, match="must not be empty"):
        synthesize_campaign(tmp_path, temperatures_c=())
    with pytest.raises(DataError, match="two tests map to the file"):
        synthesize_campaign(tmp_path, temperatures_c=(20.0, 20.0), amplitudes_m=(1e-4,))
    assert math.isfinite(CampaignTruth().log10_shift(-50.0))
