"""The campaign report and the amplitude table: figures embedded, Kraus fits where 4+ amplitudes were tested."""

from __future__ import annotations

import base64
import re

import numpy as np
import pyarrow.parquet as pq

from campaign_data import manifest_rows, write_manifest
from jointid.cli.main import main


def test_report_figures_and_amplitude_table(tmp_path):
    from jointid.measurement.campaign_synth import CampaignTruth, synthesize_campaign

    amplitudes = (2e-5, 6e-5, 2e-4, 6e-4)
    manifest = synthesize_campaign(tmp_path / "data", temperatures_c=(10.0, 20.0, 30.0), amplitudes_m=amplitudes,
                                   frequencies_hz=(1.0, 10.0, 100.0), cycles=6.37, seed=3)
    # all four amplitudes at 20 C only; the other temperatures at the smallest amplitude (the master curve's)
    rows = [r for r in manifest_rows(manifest) if float(r["temperature_c"]) == 20.0 or float(r["amplitude_m"]) == 2e-5]
    write_manifest(manifest, rows)
    out = tmp_path / "out"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1"]) == 0
    html = (out / "report.html").read_text()
    assert "http://" not in html and "https://" not in html  # self-contained
    images = re.findall(r"src='data:image/png;base64,([^']+)'", html)
    names = sorted(p.name for p in (out / "figures").glob("*.png"))
    assert names == ["S1_amplitude.png", "S1_master_curve.png", "S1_temperature_curves.png"]
    assert sorted(base64.b64decode(i) for i in images) == sorted((out / "figures" / n).read_bytes() for n in names)
    for text in ("Specimen S1", "WLF c1", "Arrhenius Ea (kJ/mol)", "Reduced-frequency range covered at each temperature"):
        assert text in html
    amp = pq.read_table(out / "amplitude.parquet").to_pandas()
    assert list(amp["frequency_hz"]) == [1.0, 10.0, 100.0] and (amp["temperature_c"] == 20.0).all()
    assert (amp["amplitudes"] == 4).all()
    assert {"k0_n_m", "k0_n_m_std", "critical_amplitude_m", "loss_kmax_n_m", "loss_kmax_n_m_std"} <= set(amp.columns)
    # the Kraus storage law of the truth: K'(A) / K'(A_min) at 20 C, the same ratio at every frequency
    truth = CampaignTruth()
    g = np.array([truth.kraus_factor(a) for a in amplitudes])
    results = pq.read_table(out / "results.parquet").to_pandas()
    at20 = results[(results["temperature_c"] == 20.0) & (results["frequency_hz"] == 10.0)].sort_values("amplitude_m")
    np.testing.assert_allclose(at20["stiffness_real"] / at20["stiffness_real"].iloc[0], (g / g[0]).real, rtol=0.02)
    assert not (out / "preload.parquet").exists()  # one preload: no preload fits
