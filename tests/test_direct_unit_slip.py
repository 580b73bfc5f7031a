"""A test whose stiffness is a unit factor off its neighbours' (one file in kN among SI files): named with the factor
and the fix, left out of the master curve alone (black-box finding of 2026-11-28)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from campaign_data import small_campaign
from jointid.cli.main import main
from jointid.methods.direct.unit_slip import find_unit_slips

T = np.array([5.0, 15.0, 25.0, 35.0])


def _levels(scatter=0.0, seed=0):
    """ln |K| of a material stiffening as it cools (curved in T, as WLF makes it), with a scatter between tests."""
    return 15.0 - 0.05 * (T - 5.0) + 4e-4 * (T - 5.0) ** 2 + scatter * np.random.default_rng(seed).standard_normal(T.size)


@pytest.mark.parametrize("index, factor", [(1, 1e-3), (2, 1 / 9.80665), (0, 1e3), (3, 0.0254)])
def test_a_unit_factor_off_the_trend_is_named(index, factor):
    level = _levels(0.01)
    level[index] += math.log(factor)
    (slip,) = find_unit_slips(T, level)
    assert slip.index == index and slip.factor == factor
    assert abs(math.log(slip.ratio / factor)) <= math.log(slip.tolerance)


def test_no_slip_on_a_smooth_trend_a_non_unit_factor_or_a_far_temperature():
    assert find_unit_slips(T, _levels(0.01)) == []
    level = _levels(0.01)
    level[1] += math.log(3.0)  # 3x: no unit's factor (the overlap check of the master curve says what it can)
    assert find_unit_slips(T, level) == []
    # a temperature typed in K: its level is predicted over 263 C, beyond what the others' scatter can judge
    assert find_unit_slips(np.array([5.0, 15.0, 35.0, 298.15]), _levels(0.01) + np.array([0, 0, 0, math.log(1e-6)])) == []
    assert find_unit_slips(T[:2], _levels()[:2]) == []  # one other test: nothing to predict with


def test_the_tolerance_follows_the_scatter_of_the_other_tests():
    """The same 1/9.81 level is named among tests that scatter by 0.01 in ln |K| and not among tests that scatter by
    0.5 (it is then within the temperature's plausible effect as the others show it; tolerance x/ 6.5); a 1/1000 one is
    named in both."""
    slip_981 = np.array([0, math.log(1 / 9.80665), 0, 0])
    slip_1e3 = np.array([0, math.log(1e-3), 0, 0])
    assert [s.factor for s in find_unit_slips(T, _levels(0.01) + slip_981)] == [1 / 9.80665]
    level = _levels(0.5, seed=1)
    assert find_unit_slips(T, level + slip_981) == []
    (slip,) = find_unit_slips(T, level + slip_1e3)
    assert slip.index == 1 and slip.factor == 1e-3 and slip.tolerance == pytest.approx(6.53, abs=0.01)


def test_campaign_names_the_file_in_kn_and_superposes_the_others(tmp_path, capsys):
    manifest = small_campaign(tmp_path / "d", temperatures=(10.0, 15.0, 20.0, 25.0), amplitudes=(2e-5,), extra=False)
    with manifest.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    name = rows[1]["file"]
    path = tmp_path / "d" / name
    lines = list(csv.reader(path.open(newline="")))
    j = lines[0].index("force_n")
    for r in lines[1:]:
        r[j] = repr(float(r[j]) / 1e3)  # the force written in kN under force_n
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(lines)
    out = tmp_path / "o"
    assert main(["campaign", str(manifest), "--out", str(out), "--workers", "1", "--no-plots"]) == 0
    findings = json.loads((out / "campaign.json").read_text())["findings"]
    slip = [f for f in findings if "unit factor" in f]
    assert len(slip) == 1 and slip[0].startswith(f"specimen S1: row 2 (15 C, {name}): its stiffness is 0.001")
    assert slip[0].endswith(" x what the other tests give at 15 C, the unit factor 0.001 (within their scatter, x/ "
                            + slip[0].split("x/ ")[1].split(")")[0] + "): probably the force in kN, or the displacement in mm, "
                            "under an SI column name; left out of the master curve; name that file's columns with their units "
                            "(force_kN, displacement_mm: converted exactly) or convert it (--column/--scale apply to every "
                            "file of the campaign)")
    master = json.loads((out / "master_curve.json").read_text())["specimens"]["S1"]
    assert [s["temperature_c"] for s in master["shift_factors"]] == [10.0, 20.0, 25.0]  # only that test left out
    assert "3 of 4 temperatures superposed" in capsys.readouterr().out
    with open(out / "tests.csv", newline="") as fh:
        warnings = {int(r["manifest_row"]): r["warning"] for r in csv.DictReader(fh)}
    assert warnings == {1: "", 2: slip[0].removeprefix(f"specimen S1: row 2 (15 C, {name}): "), 3: "", 4: ""}
