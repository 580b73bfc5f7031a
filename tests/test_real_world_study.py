"""The real-world study of `jointid reproduce` (issue 26 item 6): its findings on a small grid, its output, its seeding."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from jointid.reproduce import real_world
from jointid.reproduce.config import STUDY_NAMES, load_config
from jointid.reproduce.runner import STUDY_MODULES, study_tasks


@pytest.fixture(scope="module")
def config():
    """The benchmark up to 200 Hz: few lines, one noise realization."""
    return dataclasses.replace(load_config(), stop=200.0, robustness_seeds=1)


@pytest.fixture(scope="module")
def output(config):
    return real_world.run(config)


def _findings(output, case: str) -> str:
    rows = {row[0]: row[2] for row in output.tables[1].rows}
    return rows[real_world.CASES[case]]


def test_registered():
    assert "real-world" in STUDY_NAMES and STUDY_MODULES["real-world"] == "real_world"
    tasks, combine = study_tasks("real-world", load_config())
    assert combine is real_world.combine and len(tasks) == 4  # off, updated, junk (one realization each), the mount


def test_model_check_fires_for_the_off_model_and_not_after_updating(output):
    off, updated = _findings(output, "off"), _findings(output, "updated")
    assert "the free model does not explain these FRFs" in off
    assert any("update it from a free-free test" in f for f in output.findings + output.paragraphs)
    assert "free model does not explain" not in updated


def test_junk_lines_are_left_out(output):
    assert "4 lines at 1-4 Hz left out as junk" in _findings(output, "junk")


def test_table_figure_and_data(output):
    table = output.tables[0]
    cases = {row[0] for row in table.rows}
    assert cases == set(real_world.CASES.values())
    mount = [row for row in table.rows if row[0] == real_world.CASES["mount"]]
    assert [row[1] for row in mount] == ["K_x_x", "K_y_y", "K_z_z", "K_rx_rx", "K_ry_ry", "K_rz_rz"]
    updated = [row for row in table.rows if row[0] == real_world.CASES["updated"]]
    assert all(row[2] == "100 %" for row in updated)  # after updating every line of every term is flagged reliable
    assert output.name == "real-world" and [f[0] for f in output.figures] == ["real_world"]
    assert set(output.data) == {f"real_world_{c}" for c in real_world.CASES}
    assert len(output.findings) == 4 and all(np.isfinite(s[1]) for s in output.summary)


def test_term_figures():
    truth = np.ones((4, 2, 2), complex)
    k = truth.copy()
    k[:, 0, 0] += np.array([0.01, 0.02, 0.5, 0.0])
    std = np.full((4, 2, 2), 0.01)
    reliable = np.ones((4, 2, 2), bool)
    reliable[2, 0, 0] = False
    fig = real_world.term_figures(k, std, std, reliable, truth, [(0, 0), (1, 1)])
    assert fig[0, 0] == 0.75 and fig[0, 1] == pytest.approx(0.01)
    assert fig[0, 2] == pytest.approx(5 / 6)  # real parts 2 of 3 inside +-1.645 sigma, imaginary parts 3 of 3
    assert fig[0, 3] == 0.0 and fig[1].tolist() == [1.0, 0.0, 1.0, 0.0]


def test_seeded_by_config_case_and_realization(config):
    a, b = (real_world.run_case(config, "junk", 0) for _ in range(2))
    assert np.array_equal(a["figures"], b["figures"], equal_nan=True)
    c = real_world.run_case(dataclasses.replace(config, seed=1), "junk", 0)
    assert not np.array_equal(a["columns"]["K_w_w_error"], c["columns"]["K_w_w_error"])


def test_mount_model_is_the_same_bits_after_other_eigensolves():
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    a, _, _ = real_world._mount_model()
    spla.eigsh(sp.diags(np.arange(1.0, 50.0)).tocsc(), k=3, sigma=0.0)  # advances ARPACK's random start
    b, _, _ = real_world._mount_model()
    assert np.array_equal(a.mass.toarray(), b.mass.toarray()) and np.array_equal(a.stiffness.toarray(), b.stiffness.toarray())
