"""``jointid campaign --scheduler``: the same tests on a dask.distributed cluster give the local results.

Runs in ``make test`` (dask is in the ``test`` extra); skipped, with the reason, only when
dask.distributed is not installed.
"""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest

from campaign_data import small_campaign
from jointid.cli.main import main

distributed = pytest.importorskip("dask.distributed", reason="dask.distributed is not installed (pip install 'jointid[dask]')")

pytestmark = pytest.mark.dask


def test_local_cluster_equals_local_run(tmp_path, capsys):
    manifest = small_campaign(tmp_path / "data", temperatures=(10.0, 20.0, 30.0), amplitudes=(2e-5,))
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "local"), "--workers", "2", "--no-plots"]) == 0
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as cluster:
        rc = main(["campaign", str(manifest), "--out", str(tmp_path / "dask"), "--scheduler", cluster.scheduler_address,
                   "--no-plots"])
    assert rc == 0
    assert f"to compute on the Dask cluster at {cluster.scheduler_address}" in capsys.readouterr().out
    summary = json.loads((tmp_path / "dask" / "campaign.json").read_text())
    assert (summary["tests"], summary["computed"], summary["failed"]) == (3, 3, [])
    for name in ("results.parquet", "tests.parquet"):
        local = pq.read_table(tmp_path / "local" / name)
        dask = pq.read_table(tmp_path / "dask" / name)
        assert local.column_names == dask.column_names and local.num_rows == dask.num_rows
        for col in local.column_names:
            a, b = local[col].to_numpy(zero_copy_only=False), dask[col].to_numpy(zero_copy_only=False)
            if a.dtype.kind == "f":
                np.testing.assert_allclose(b, a, rtol=1e-9, atol=0, equal_nan=True, err_msg=f"{name}: {col}")
            else:
                assert list(a) == list(b), f"{name}: {col}"
    master = [json.loads((tmp_path / d / "master_curve.json").read_text()) for d in ("local", "dask")]
    assert master[0] == master[1]


def test_unreachable_scheduler_is_one_line_exit_2(tmp_path, capsys):
    manifest = small_campaign(tmp_path / "data", temperatures=(20.0,), amplitudes=(2e-5,), extra=False)
    assert main(["campaign", str(manifest), "--out", str(tmp_path / "o"), "--scheduler", "nonsense://x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jointid campaign: error: --scheduler nonsense://x: cannot connect to the Dask scheduler")
    assert not (tmp_path / "o" / "results.parquet").exists()
