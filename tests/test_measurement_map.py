"""Real exports: geometry point ids (1001..), the beam measured along -Y, triaxial and coherence records."""

from __future__ import annotations

import csv
import tomllib

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from jointid.cli.main import main  # noqa: E402
from jointid.errors import DataError, StudyError  # noqa: E402
from jointid.io.frf_csv import read_frf_csv, write_frf_csv  # noqa: E402
from jointid.io.frf_files import write_frf  # noqa: E402
from jointid.frf import FRF  # noqa: E402
from jointid.pipeline import identify, read_measured, simulate  # noqa: E402
from jointid.study import load_study, parse_study  # noqa: E402

from test_uff_units import STUDY  # noqa: E402

POINTS = "\n[measurement.points]\n" + "\n".join(f"{1000 + n} = {n}" for n in range(1, 20)) + "\n"
MAPPED = STUDY.replace("excited  = [3, 9, 15]\n", 'excited  = [3, 9, 15]\naxis = "-Y"\n' + POINTS)


def _rec(data, x, rsp, rsp_dir, ref, ref_dir, func_type=4):
    return pyuff.prepare_58(
        binary=1, func_type=func_type, rsp_node=rsp, rsp_dir=rsp_dir, ref_node=ref, ref_dir=ref_dir,
        data=np.array(data), x=np.array(x), abscissa_spacing=0, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=12 if func_type == 4 else 0, orddenom_spec_data_type=13 if func_type == 4 else 0,
        ordinate_axis_units_lab="m/s^2" if func_type == 4 else "NONE", orddenom_axis_units_lab="N" if func_type == 4 else "NONE",
    )


def _export(frf: FRF, coherence: np.ndarray) -> list[dict]:
    """A Testlab-like export: points 1001.., w along -Y (some records +Y, flipped), X/Z channels, coherence, extras."""
    x = frf.frequency.hz
    sets = []
    rng = np.random.default_rng(3)
    for j, r in enumerate(frf.responses):
        for k, c in enumerate(frf.references):
            rsp_dir = -2 if (j + k) % 2 == 0 else 2  # +Y response: the record holds -w
            ref_dir = -2 if k != 1 else 2
            sign = (1 if rsp_dir == -2 else -1) * (1 if ref_dir == -2 else -1)
            sets.append(_rec(sign * frf.data[:, j, k], x, 1000 + r.node, rsp_dir, 1000 + c.node, ref_dir))
            for other in (1, 3):  # triaxial accelerometer: X and Z channels of the same hit
                sets.append(_rec(rng.normal(size=x.size) * (1 + 1j), x, 1000 + r.node, other, 1000 + c.node, ref_dir))
            sets.append(_rec(coherence[:, j, k], x, 1000 + r.node, rsp_dir, 1000 + c.node, ref_dir, func_type=6))
            sets.append(_rec(coherence[:, j, k] * 0.5, x, 1000 + r.node, 1, 1000 + c.node, ref_dir, func_type=6))
    for c in frf.references:  # node 2 is measured but the study does not observe it
        sets.append(_rec(frf.data[:, 0, 0] * 3.0, x, 1002, -2, 1000 + c.node, -2))
    sets.append(_rec(frf.data[:, 0, 0], x, 2001, -2, 1003, -2))  # a point the map does not know
    t = _rec(np.sin(x), x * 1e-3, 1001, -2, 1003, -2, func_type=1)
    t["abscissa_spec_data_type"] = 17
    sets.append(t)
    return sets


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("map")
    (d / "study.toml").write_text(STUDY)
    (d / "mapped.toml").write_text(MAPPED)
    study = load_study(d / "study.toml")
    sim = simulate(study)
    coh = np.random.default_rng(0).uniform(0.5, 1.0, size=sim.frf.shape)
    clean = write_frf(d / "clean.uff", sim.frf, binary=True)
    export = d / "export.uff"
    pyuff.UFF(str(export)).write_sets(_export(sim.frf, coh), mode="add")
    return d, study, load_study(d / "mapped.toml"), clean, export, coh


SKIPPED = "skipped 68 records: 42 in X/Z, 21 coherence, 3 at DOFs not in the study, 1 at points not in the point map, 1 time"


def test_export_with_point_map_and_minus_y_identifies_as_the_clean_file(files):
    d, study, mapped, clean, export, coh = files
    assert mapped.measurement.axis == "-Y" and mapped.measurement.point_map[1019] == 19
    ref = identify(study, read_measured(study, clean))
    measured = read_measured(mapped, export)
    assert measured.notes == (SKIPPED,)
    assert measured.responses == study.measurement.observed_dofs and measured.references == study.measurement.excited_dofs
    np.testing.assert_array_equal(measured.coherence, coh)  # aligned with the kept FRFs
    got = identify(mapped, measured)
    # both files carry the same 12-digit values; measured 2e-9 (receptance method, 5 Hz line)
    assert np.max(np.abs(got.stiffness - ref.stiffness)) <= 1e-8 * np.max(np.abs(ref.stiffness))
    band = measured.band(100.0, 200.0).select(["3w", "1w"], ["9w"])  # coherence follows band and select
    np.testing.assert_array_equal(band.coherence, coh[19:40][:, [1, 0]][:, :, [1]])


def test_cli_identify_with_map_prints_the_skipped_count(files, capsys):
    d, study, mapped, clean, export, coh = files
    assert main(["identify", str(d / "study.toml"), "--frf", str(clean), "--out", str(d / "a"), "--no-plots"]) == 0
    assert main(["identify", str(d / "mapped.toml"), "--frf", str(export), "--out", str(d / "b"), "--no-plots"]) == 0
    out = capsys.readouterr().out.splitlines()
    second = next(i for i, line in enumerate(out) if line.startswith("identified") and i > 0 and out[i - 1].startswith(str(export)))
    assert out[second - 1] == f"{export}: {SKIPPED}"  # printed before the second run's result
    a = list(csv.DictReader(open(d / "a" / "joint_stiffness.csv")))
    b = list(csv.DictReader(open(d / "b" / "joint_stiffness.csv")))
    ka = np.array([[float(r[k]) for k in r if k.startswith("K_") and not k.endswith("_std")] for r in a])
    kb = np.array([[float(r[k]) for k in r if k.startswith("K_") and not k.endswith("_std")] for r in b])
    assert np.max(np.abs(ka - kb) / np.max(np.abs(ka), axis=0)) < 1e-8  # 12-digit files; measured 2e-9


def test_export_without_the_map_is_one_clear_error(files):
    d, study, mapped, clean, export, coh = files
    with pytest.raises(DataError, match=r"skipped 110 records: 67 in X/Y, 42 coherence, 1 time; if the beam was measured along another"):
        read_measured(study, export)  # default axis +Z
    minus_y = parse_study(tomllib.loads(STUDY.replace("excited  = [3, 9, 15]", 'excited  = [3, 9, 15]\naxis = "-Y"')), "y.toml")
    with pytest.raises(DataError, match=r"response node 1001 is outside the beam \(nodes 1..19\); if the file numbers its points otherwise, map them"):
        read_measured(minus_y, export)


def test_csv_reader_takes_the_point_map(tmp_path, files):
    d, study, mapped, clean, export, coh = files
    sim = simulate(study)
    renumbered = FRF(sim.frf.frequency, sim.frf.data, [1000 + r.node for r in sim.frf.responses], [1000 + c.node for c in sim.frf.references], "accelerance")
    p = write_frf_csv(tmp_path / "f.csv", renumbered)
    back = read_frf_csv(p, n_nodes=19, points={1000 + n: n for n in range(1, 20) if n != 19}, responses=["1w", "3w", "6w"])
    assert back.responses == study.measurement.observed_dofs[:3]
    np.testing.assert_array_equal(back.data, sim.frf.data[:, :3])
    assert back.notes == (f"skipped {3 * 200 * 4} rows: {3 * 200 * 3} at DOFs not in the study, {3 * 200} at points not in the point map",)
    got = identify(mapped, read_measured(mapped, p))  # the study's map works on CSV files too
    ref = identify(study, read_measured(study, clean))
    # both files carry the same 12-digit values; measured 2e-9 (receptance method, 5 Hz line)
    assert np.max(np.abs(got.stiffness - ref.stiffness)) <= 1e-8 * np.max(np.abs(ref.stiffness))


@pytest.mark.parametrize(
    "edit, message",
    [
        (("1005 = 5", "1005 = 3"), "[measurement.points]: points 1003 and 1005 both map to node 3; map each node once"),
        (("1009 = 9\n", ""), "[measurement.points]: node 9 is observed or excited but no file point maps to it; add '<point id> = 9'"),
        (("1005 = 5", "p5 = 5"), "[measurement.points]: key 'p5' is not a point id (an integer >= 1)"),
        (("1005 = 5", "1005 = 20"), "[measurement.points].1005: expected a beam node in 1..19, got 20"),
        (('axis = "-Y"', 'axis = "Y"'), "[measurement].axis: expected one of '+X', '-X', '+Y', '-Y', '+Z', '-Z', got 'Y'"),
    ],
)
def test_bad_point_map_names_the_key(edit, message):
    with pytest.raises(StudyError) as e:
        parse_study(tomllib.loads(MAPPED.replace(*edit)), "s.toml")
    assert str(e.value) == f"s.toml: {message}"


def test_unusable_coherence_is_a_note_not_an_error(tmp_path, files):
    d, study, mapped, clean, export, coh = files
    sim = simulate(study)
    bad = coh.copy()
    bad[4, 2, 1] = 1.5  # (pyuff writes NaN as a number)
    sets = [s for s in _export(sim.frf, bad)]
    p = tmp_path / "nan_coherence.uff"
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    measured = read_measured(mapped, p)
    assert measured.coherence is None
    assert measured.notes[0] == SKIPPED
    assert measured.notes[1] == f"coherence not used: {p} holds coherence values outside [0, 1] ({bad.min():.6g}..1.5)"
    got = identify(mapped, measured)
    ref = identify(study, read_measured(study, clean))
    # both files carry the same 12-digit values; measured 2e-9 (receptance method, 5 Hz line)
    assert np.max(np.abs(got.stiffness - ref.stiffness)) <= 1e-8 * np.max(np.abs(ref.stiffness))
