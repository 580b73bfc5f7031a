"""``kind = identify`` rows: an inverse test in a campaign is exactly ``jointid.identify`` on its study and FRF file."""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq

from campaign_data import manifest_rows, small_campaign, write_manifest
from jointid.benchmark import benchmark_study_path
from jointid.cli.main import main


def test_identify_row_gives_the_pipeline_result_per_term(tmp_path):
    from jointid.pipeline import identify, read_measured
    from jointid.study import load_study

    manifest = small_campaign(tmp_path / "data", temperatures=(20.0,), amplitudes=(2e-5,), extra=False)
    text = benchmark_study_path().read_text().replace("step = 1.0", "step = 5.0")  # 200 lines: a quick identification
    study_path = tmp_path / "data" / "study.toml"
    study_path.write_text(text)
    assert main(["simulate", str(study_path), "--out", str(tmp_path / "data" / "rig")]) == 0
    rows = manifest_rows(manifest)
    for r in rows:
        r.update(kind="direct", study="")
    rows.append({**rows[0], "file": "rig/frf.uff", "specimen": "mount-A", "amplitude_m": "", "preload_n": "", "kind": "identify",
                 "study": "study.toml"})
    write_manifest(manifest, rows)
    out = tmp_path / "out"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    assert json.loads((out / "campaign.json").read_text())["failed"] == []
    df = pq.read_table(out / "results.parquet").to_pandas()
    inv = df[df["kind"] == "identify"]
    assert set(inv["term"]) == {"K_w_w", "K_w_theta", "K_theta_w", "K_theta_theta"}
    assert inv["amplitude_m"].isna().all() and inv["amplitude_ok"].isna().all()
    from jointid.parallel import single_threaded_blas

    study = load_study(study_path)
    with single_threaded_blas():  # as the campaign runs its tests: the same arithmetic, so the same bits on any BLAS
        expected = identify(study, read_measured(study, tmp_path / "data" / "rig" / "frf.uff"))
    kww = inv[inv["term"] == "K_w_w"].sort_values("frequency_hz")
    np.testing.assert_array_equal(kww["frequency_hz"], expected.frequency.hz)
    np.testing.assert_array_equal(kww["stiffness_real"] + 1j * kww["stiffness_imag"], expected.stiffness[:, 0, 0])
    np.testing.assert_array_equal(kww["stiffness_real_std"], expected.std_real[:, 0, 0])
    np.testing.assert_array_equal(kww["reliable"], expected.reliable_terms[:, 0, 0])
    tests = pq.read_table(out / "tests.parquet").to_pandas()
    assert tests.iloc[-1]["method"] == "receptance" and tests.iloc[-1]["lines"] == expected.frequency.hz.size
