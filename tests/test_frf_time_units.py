"""``jointid frf`` on UFF58 time records in other units, along another axis, at other point ids.

The same hits are written twice: in SI along +Z at nodes 1..19, and in g (responses) and lbf (force)
along -Y at points 1001.. (some channels recorded along +Y, i.e. sign-flipped). Both files are binary
(IEEE doubles), so the only difference the reader has to undo is one multiplication per sample: each
sample of the converted file is within 2 u (u = 2^-53) of the SI one. The FRF is a ratio of averaged
spectra, linear in each channel, so its relative error per line is that perturbation times the
line's amplification (at most ~1e2 on this record: 12-digit ASCII samples, 5e-12, give 4.5e-10 in
test_cli_frf), i.e. ~1e-13; the FRF files round each value to 12 digits (5e-12) -> bound 1e-10.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointid.benchmark import benchmark_study_path
from jointid.cli.main import main
from jointid.dofs import Dof
from jointid.hits import frf_from_hits
from jointid.measurement.impact_files import read_impact_uff, write_impact_uff
from jointid.io.uff import read_uff_frf
from jointid.io.uff_units import G0, LBF
from jointid.measurement.impact import ImpactRecord

from test_cli_frf import SEED, _small_study, _window_flags  # the small virtual test and its window flags

pyuff = pytest.importorskip("pyuff")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """(study, SI file, g/lbf file along -Y at points 1001..)."""
    from jointid.pipeline import virtual_hits

    study = _small_study()
    records, _ = virtual_hits(study, seed=SEED)
    d = tmp_path_factory.mktemp("units")
    si_ascii = write_impact_uff(d / "si_ascii.uff", records)
    sets = pyuff.UFF(str(si_ascii)).read_sets()
    for s in sets:
        s["binary"] = 1
    si = d / "si.uff"
    pyuff.UFF(str(si)).write_sets(sets, mode="add")
    conv = []
    for s in sets:
        c = dict(s)
        force = s["ordinate_spec_data_type"] == 13
        plus_y = not force and s["rsp_node"] % 2 == 1  # odd nodes recorded along +Y: opposite to the axis
        c["rsp_node"], c["ref_node"] = 1000 + s["rsp_node"], 1000 + s["ref_node"]
        c["rsp_dir"], c["ref_dir"] = (2 if plus_y else -2), -2
        c["data"] = (-1.0 if plus_y else 1.0) * np.asarray(s["data"]) / (LBF if force else G0)
        c["ordinate_axis_units_lab"] = "lbf" if force else "g"
        conv.append(c)
    g = d / "g_minus_y.uff"
    pyuff.UFF(str(g)).write_sets(conv, mode="add")
    return study, si, g, conv, records


POINTS = [f"{1000 + n}={n}" for n in (1, 3, 9, 15)]


def test_time_records_in_g_along_minus_y_at_points_1001_give_the_si_frfs(files, tmp_path, capsys):
    study, si, g, _, _ = files
    flags = _window_flags(study)
    assert main(["frf", str(si), "--out", str(tmp_path / "si"), "--no-plots", *flags]) == 0
    capsys.readouterr()
    assert main(["frf", str(g), "--out", str(tmp_path / "g"), "--no-plots", "--axis=-Y", "--points", *POINTS, *flags]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert f"{g.name}: units: 6 force records in lbf (labels) converted to SI: x 4.4482216152605; " \
           f"18 response records in g (labels) converted to SI: x 9.80665" in printed
    assert f"{g.name}: points 1001, 1003, 1009, 1015 mapped to nodes 1, 3, 9, 15; -Y is w (signals along +Y sign-flipped)" in printed
    a = read_uff_frf(tmp_path / "si" / "frf.uff")
    b = read_uff_frf(tmp_path / "g" / "frf.uff")
    assert a.responses == b.responses and a.references == b.references
    assert np.max(np.abs(b.data - a.data) / np.abs(a.data)) < 1e-10
    # the API, without the 12-digit FRF file: the reader's exact doubles
    ra = frf_from_hits([si]).frf.data
    rb = frf_from_hits([g], points={1000 + n: n for n in (1, 3, 9, 15)}, axis="-Y").frf.data
    assert np.max(np.abs(rb - ra) / np.abs(ra)) < 1e-10
    # without the axis every record is in Y: refused in one line that says what was skipped and what to give
    assert main(["frf", str(g), "--out", str(tmp_path / "none"), "--points", *POINTS]) == 2
    err = capsys.readouterr().err
    assert err == (f"jointid frf: error: {g}: no time record along +Z at a mapped point; skipped 24 records: 24 in Y; "
                   "give the measurement axis (--axis) or the point map (--points)\n")


def test_the_study_gives_axis_and_points(files, tmp_path, capsys):
    study, si, g, _, _ = files
    text = benchmark_study_path().read_text().replace("[measurement]\n", "[measurement]\naxis = \"-Y\"\n", 1)
    text += "\n[measurement.points]\n" + "".join(f"{1000 + n} = {n}\n" for n in range(1, 20))
    p = tmp_path / "study.toml"
    p.write_text(text)
    flags = _window_flags(study)
    assert main(["frf", str(g), "--study", str(p), "--out", str(tmp_path / "s"), "--no-plots", *flags]) == 0
    assert main(["frf", str(si), "--out", str(tmp_path / "si"), "--no-plots", *flags]) == 0
    a, b = read_uff_frf(tmp_path / "si" / "frf.uff"), read_uff_frf(tmp_path / "s" / "frf.uff")
    assert np.max(np.abs(b.data - a.data) / np.abs(a.data)) < 1e-10
    capsys.readouterr()
    assert main(["frf", str(g), "--study", str(p), "--axis=-Y", "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err == ("jointid frf: error: --study gives the axis and the point map ([measurement] axis and "
                                       "[measurement.points]); drop --axis/--points or --study\n")


def test_unknown_or_contradictory_label_is_one_line_naming_the_record(files, tmp_path, capsys):
    _, _, _, conv, _ = files
    bad = [dict(s) for s in conv]
    i = next(k for k, s in enumerate(bad) if s["ordinate_spec_data_type"] == 12 and s["rsp_node"] == 1009)
    bad[i]["ordinate_axis_units_lab"] = "furlong/fortnight^2"
    p = tmp_path / "bad.uff"
    pyuff.UFF(str(p)).write_sets(bad, mode="add")
    s = bad[i]
    assert main(["frf", str(p), "--out", str(tmp_path / "o"), "--axis=-Y", "--points", *POINTS]) == 2
    assert capsys.readouterr().err == (
        f"jointid frf: error: record {i + 1} of {p} (time record, node 1009 dir {s['rsp_dir']}, load case "
        f"{s['load_case_id']}): unknown ordinate units label 'furlong/fortnight^2'; jointid reads g, m/s^2, mm/s^2, "
        "in/s^2, m/s, mm/s, in/s, m, mm, in (and cm, um, ft): fix the label in the file\n")
    bad[i]["ordinate_axis_units_lab"] = "lbf"  # a force on an acceleration record
    p = tmp_path / "bad2.uff"
    pyuff.UFF(str(p)).write_sets(bad, mode="add")
    assert main(["frf", str(p), "--out", str(tmp_path / "o"), "--axis=-Y", "--points", *POINTS]) == 2
    assert "ordinate units label 'lbf' is a force, but the record's data type is 12 (acceleration)" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_dataset_164_units_apply_to_unlabelled_time_records(tmp_path):
    t = np.arange(256) / 1024.0
    force = np.exp(-((t - 0.01) / 0.001) ** 2)[None] * 50.0
    resp = (np.sin(2 * np.pi * 60 * t) * np.exp(-t))[None, None]
    p = write_impact_uff(tmp_path / "hits.uff", [ImpactRecord(force, resp, 1024.0, ["4w"], "9w")])
    sets = pyuff.UFF(str(p)).read_sets()
    for s in sets:  # the same numbers in mm and mN (dataset 164 code 5), no labels
        s["ordinate_axis_units_lab"] = "NONE"
        s["data"] = np.asarray(s["data"]) * 1e3
    units = pyuff.prepare_164(units_code=5, units_description="MM", temp_mode=1, length=1e3, force=1e3, temp=1.0, temp_offset=273.15)
    q = tmp_path / "mm.uff"
    pyuff.UFF(str(q)).write_sets([units] + sets, mode="add")
    (back,), notes = read_impact_uff(q, with_notes=True)
    np.testing.assert_allclose(back.force, force, rtol=1e-10)
    np.testing.assert_allclose(back.responses, resp, rtol=1e-10, atol=1e-13)
    assert notes == ("mm.uff: units: 1 force record in mN (dataset 164) converted to SI: x 0.001; "
                     "1 response record in mm/s^2 (dataset 164) converted to SI: x 0.001",)


def test_points_and_axis_are_refused_for_npz_and_bad_point_maps(files, tmp_path, capsys):
    from jointid.measurement.impact_files import write_impact_npz

    records = files[4]
    f = write_impact_npz(tmp_path / "n3.npz", records[0])
    assert main(["frf", str(f), "--out", str(tmp_path / "o"), "--axis=-Y"]) == 2
    assert capsys.readouterr().err == (f"jointid frf: error: {f}: a point map and a measurement axis apply to UFF time "
                                       "records only; a .npz hits file names model DOFs itself (\"9w\")\n")
    assert main(["frf", str(f), "--out", str(tmp_path / "o"), "--points", "1001=1", "1002=1"]) == 2
    assert capsys.readouterr().err == "jointid frf: error: --points: points 1001 and 1002 both map to node 1; map each node once\n"
    assert main(["frf", str(f), "--out", str(tmp_path / "o"), "--points", "1001"]) == 2
    assert capsys.readouterr().err == "jointid frf: error: --points: expected POINT=NODE with integers >= 1 (e.g. 1001=1), got '1001'\n"


def test_3d_reading_names_the_components_and_flips_negative_codes(files):
    """``axis=None`` (a [structure] study): code -2 is y sign-flipped, +2 is y as recorded."""
    _, si, g, conv, records = files
    pts = {1000 + n: n for n in (1, 3, 9, 15)}
    back = read_impact_uff(g, points=pts, axis=None)
    assert [r.reference for r in back] == [Dof(3, "y"), Dof(9, "y")]
    assert back[0].response_dofs == (Dof(1, "y"), Dof(9, "y"), Dof(15, "y"))
    rec = read_impact_uff(si)[0]
    # force and 9y along -Y: flipped; 1y, 15y along +Y (their data negated in the file): read as recorded, i.e.
    # also the negated SI signal; x / G0 * G0 rounds twice: 2 u
    np.testing.assert_allclose(back[0].force, -rec.force, rtol=4.5e-16)
    np.testing.assert_allclose(back[0].responses, -rec.responses, rtol=4.5e-16)
