"""UFF units: labels (g, mm/s^2, in/s^2 over lbf, g/N, ...) and dataset 164, converted exactly to SI or refused."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from jointid.cli.main import main  # noqa: E402
from jointid.errors import DataError  # noqa: E402
from jointid.io.frf_files import write_frf  # noqa: E402
from jointid.io.uff import read_uff_frf  # noqa: E402
from jointid.io.uff_units import G0, INCH, LBF  # noqa: E402
from jointid.io.uff_units import SI as SI_UNITS  # noqa: E402
from jointid.pipeline import identify, read_measured, simulate  # noqa: E402
from jointid.study import load_study  # noqa: E402
from study_texts import beam_study_toml

STUDY = beam_study_toml("growth = 0.5\n", shear_coefficient=False)


def _units(code, length, force, desc="units"):
    return pyuff.prepare_164(units_code=code, units_description=desc, temp_mode=1, length=float(length), force=float(force), temp=1.0, temp_offset=273.15)


def _records(frf, scale=1.0, num_lab=None, den_lab=None, num_type=12, binary=1):
    """Dataset 58 dicts of ``frf`` (accelerance) times ``scale``, +Z, with the given units labels."""
    sets = []
    labels = {}
    if num_lab is not None:
        labels["ordinate_axis_units_lab"] = num_lab
    if den_lab is not None:
        labels["orddenom_axis_units_lab"] = den_lab
    for j, r in enumerate(frf.responses):
        for k, c in enumerate(frf.references):
            sets.append(
                pyuff.prepare_58(
                    binary=binary, func_type=4, rsp_node=r.node, rsp_dir=3, ref_node=c.node, ref_dir=3,
                    data=np.array(frf.data[:, j, k] * scale), x=np.array(frf.frequency.hz), abscissa_spacing=0,
                    abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                    ordinate_spec_data_type=num_type, orddenom_spec_data_type=13, **labels,
                )
            )
    return sets


def _write(path, sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="add")
    return path


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    (d / "study.toml").write_text(STUDY)
    study = load_study(d / "study.toml")
    sim = simulate(study)
    si = write_frf(d / "si.uff", sim.frf, binary=True)
    ref = identify(study, read_measured(study, si))
    assert np.max(np.abs(ref.stiffness - sim.truth) / np.abs(sim.truth)) < 1e-6  # the SI file recovers the joint
    return d, study, sim, ref


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize(
    "name, scale, num_lab, den_lab, units, note",
    [
        ("g", 1 / G0, "g", "N", None, "21 FRF records in g/N (labels) converted to SI: x 9.80665"),
        ("g_over_n", 1 / G0, "g/N", None, None, "21 FRF records in g/N (labels) converted to SI: x 9.80665"),
        ("mm", 1e3, "mm/s^2", "N", None, "21 FRF records in (mm/s^2)/N (labels) converted to SI: x 0.001"),
        ("in_lbf", LBF / INCH, "(in/s2)/lbf", "NONE", None, "21 FRF records in (in/s2)/lbf (labels) converted to SI: x 0.00571014715473"),
        ("kN", 1e3, "m/s^2", "kN", None, "21 FRF records in (m/s^2)/kN (labels) converted to SI: x 0.001"),
        ("164_user_mm", 1e3, None, None, (9, 1000.0, 1.0), "21 FRF records in (0.001 m/s^2)/1 N (dataset 164) converted to SI: x 0.001"),
        ("164_inch", LBF / INCH, None, None, (7, 1 / INCH, 1 / LBF), "21 FRF records in (in/s^2)/lbf (dataset 164) converted to SI: x 0.00571014715473"),
        ("164_mm_labelled", 1.0, "mm/s^2", "mN", (5, 1000.0, 1000.0), None),
        ("164_user_si", 1.0, None, None, (9, 1.0, 1.0), None),
    ],
)
def test_non_si_files_identify_the_same_joint(case, name, scale, num_lab, den_lab, units, note):
    d, study, sim, ref = case
    sets = ([_units(*units)] if units else []) + _records(sim.frf, scale, num_lab, den_lab)
    p = _write(d / f"{name}.uff", sets)
    measured = read_measured(study, p)
    if note is None:
        assert measured.notes == ()
    else:
        assert measured.notes == (f"units: {note}",)
    got = identify(study, measured)
    assert _rel(got.stiffness, ref.stiffness) < 1e-9


def test_g_read_as_si_would_be_wrong(case):
    """The defect this guards against: g/N data taken as (m/s^2)/N give a joint ~G0 times off; the units check refuses them."""
    d, study, sim, ref = case
    p = _write(d / "g_unlabelled.uff", _records(sim.frf, 1 / G0))
    measured = read_measured(study, p)
    assert measured.notes == ("units: 21 FRF records without units labels (and no units dataset 164) read as SI (m/s^2)/N",)
    with pytest.raises(DataError, match=r"^the FRFs look scaled by 1/9\.81 in every excitation column \(g/N read as m/s\^2/N\?\)"):
        identify(study, measured)  # the default method sees one scale error common to every hit column: one conclusion
    plain = dataclasses.replace(study, identification=dataclasses.replace(study.identification, calibration="none", units_check=False))
    used = identify(plain, measured)
    # without the calibration and the check, the one factor common to every column is taken as force noise (a column
    # error the weights then ignore): the joint is not far off, every term is flagged, and the findings say why
    assert not used.reliable_terms.any()
    said = used.findings()
    assert any(f.startswith("the FRFs look scaled by 1/9.81 in every excitation column") and "used as they are" in f for f in said)
    assert any(f.startswith("the excitation columns share a random error line by line (force noise, ~")
               and f.endswith("more than force noise makes: check the units and the hammer's sensitivity per column") for f in said)


X = np.arange(1.0, 21.0)
H = (1.0 + 0.3j) / (100.0 - (2 * np.pi * X) ** 2 * 0.01 + 2j)


def _one(num_lab=None, den_lab=None, num=12, rsp_dir=3, rsp_node=1, x_lab="Hz", x=X):
    labels = {"abscissa_axis_units_lab": x_lab}
    if num_lab is not None:
        labels["ordinate_axis_units_lab"] = num_lab
    if den_lab is not None:
        labels["orddenom_axis_units_lab"] = den_lab
    return pyuff.prepare_58(
        binary=0, func_type=4, rsp_node=rsp_node, rsp_dir=rsp_dir, ref_node=2, ref_dir=3, data=H, x=x,
        abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=num, orddenom_spec_data_type=13, **labels,
    )


@pytest.mark.parametrize(
    "sets, message",
    [
        ([_one("furlong/s^2")], "unknown ordinate units label 'furlong/s^2'; jointid reads g, m/s^2, mm/s^2, in/s^2, m/s, mm/s, in/s, m, mm, in (optionally over N, kN, lbf: 'g/N'); fix the label in the file"),
        ([_one("m/s")], "ordinate units label 'm/s' (velocity) contradicts the ordinate numerator data type 12 (acceleration); fix the label or the data type"),
        ([_one("mm", num=11)], "ordinate units label 'mm' (displacement) contradicts the ordinate numerator data type 11 (velocity); fix the label or the data type"),
        ([_one("N")], "ordinate units label 'N' is a force, but the ordinate numerator data type is 12 (acceleration); fix the label or the data type"),
        ([_one("g", "g")], "ordinate denominator units label 'g' is a motion, but the denominator data type is 13 (excitation force); jointid reads N, kN, mN, lbf, kgf"),
        ([_one("g", "MN")], "ordinate denominator units label 'MN' is an unknown unit, but the denominator data type is 13 (excitation force); jointid reads N, kN, mN, lbf, kgf"),
        ([_one("g/N", "lbf")], "ordinate units label 'g/N' says force in 'N' but the denominator units label says 'lbf'; fix one of them"),
        ([_units(5, 1000.0, 1000.0, "MM"), _one("m/s^2")], "ordinate units label 'm/s^2' (length in m) contradicts the file's units dataset 164 (record 1): MM, mm and mN; fix the label or the units dataset"),
        ([_units(7, 1 / INCH, 1 / LBF, "IN"), _one("in/s^2", "N")], "force units label 'N' contradicts the file's units dataset 164 (record 1): IN, in and lbf; fix the label or the units dataset"),
        ([_one("g", x_lab="s")], "abscissa units label 's' is not a frequency; expected Hz"),
    ],
)
def test_unknown_or_contradictory_labels_name_file_and_record(tmp_path, sets, message):
    p = _write(tmp_path / "bad.uff", sets)
    with pytest.raises(DataError) as e:
        read_uff_frf(p)
    index = len(sets)
    head = f"record {index} of {p} (function type 4, response node 1 dir 3, reference node 2 dir 3): "
    assert str(e.value) == head + message


def test_units_dataset_errors(tmp_path):
    p = _write(tmp_path / "u.uff", [_units(0, 1.0, 1.0, "odd"), _one("g")])
    with pytest.raises(DataError) as e:
        read_uff_frf(p)
    assert str(e.value) == f"record 1 of {p}: units dataset 164 declares units code 0 ('odd'); expected 1 (SI) to 9 (user defined)"
    q = _write(tmp_path / "v.uff", [_units(1, 3.28083989501312334, 0.224808943099710480, "SI"), _one("g")])  # pyuff's docstring example
    with pytest.raises(DataError, match=r"record 1 of .*v.uff: units dataset 164 declares code 1 \(SI: m, N\) but a length factor 3.280839895 \(expected 1\)"):
        read_uff_frf(q)


def test_standard_units_codes_convert_blank_labels(tmp_path):
    for code, length, force, factor in [(2, 1 / 0.3048, 1 / LBF, 0.3048 / LBF), (3, 1.0, 1 / G0, 1 / G0), (6, 100.0, 100.0, 1.0), (8, 1000.0, 1 / G0, 1e-3 / G0)]:
        p = _write(tmp_path / f"c{code}.uff", [_units(code, length, force), _one()])
        np.testing.assert_allclose(read_uff_frf(p)("1w", "2w"), H * factor, rtol=1e-11)


def test_khz_abscissa_and_skipped_records_are_not_decoded(tmp_path):
    p = _write(tmp_path / "k.uff", [_one("g", x_lab="kHz", x=X / 1000.0), _one("furlongs", rsp_dir=1, rsp_node=3, x_lab="kHz", x=X / 1000.0)])
    frf = read_uff_frf(p)  # the X record's unknown label does not matter: it is skipped
    np.testing.assert_allclose(frf.frequency.hz, X, rtol=1e-12)
    np.testing.assert_allclose(frf("1w", "2w"), H * G0, rtol=1e-11)
    assert frf.notes == ("units: 1 FRF record in g/N (labels and default SI) converted to SI: x 9.80665", "skipped 1 record: 1 in X")


def test_cli_unknown_label_and_nan_are_one_line_exit_2(case, capsys):
    d, study, sim, ref = case
    sets = _records(sim.frf, 1.0, "m/s^2", "N", binary=0)
    sets[4]["ordinate_axis_units_lab"] = "m/s^3"
    p = _write(d / "label.uff", sets)
    code = main(["identify", str(d / "study.toml"), "--frf", str(p), "--out", str(d / "out_label"), "--no-plots"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == (
        f"jointid identify: error: record 5 of {p} (function type 4, response node 3 dir 3, reference node 9 dir 3): "
        "unknown ordinate units label 'm/s^3'; jointid reads g, m/s^2, mm/s^2, in/s^2, m/s, mm/s, in/s, m, mm, in "
        "(optionally over N, kN, lbf: 'g/N'); fix the label in the file"
    )
    q = d / "nan.uff"
    text = _write(d / "nan0.uff", _records(sim.frf, 1.0, "m/s^2", "N", binary=0)).read_text()
    token = "%20.11e" % sim.frf.data[7, 0, 0].real
    assert token in text
    q.write_text(text.replace(token, "%20s" % "nan", 1))
    code = main(["identify", str(d / "study.toml"), "--frf", str(q), "--out", str(d / "out_nan"), "--no-plots"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith(f"jointid identify: error: record 1 of {q} (function type 4, response node 1 dir 3")
    assert err.endswith("non-finite value at line 8 (40 Hz)")


def test_cli_prints_the_conversion_line(case, capsys):
    d, study, sim, ref = case
    p = _write(d / "cli_g.uff", _records(sim.frf, 1 / G0, "g", "N"))
    assert main(["identify", str(d / "study.toml"), "--frf", str(p), "--out", str(d / "out_g"), "--no-plots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"{p}: units: 21 FRF records in g/N (labels) converted to SI: x 9.80665"
    assert out[1].startswith("identified 2x2 joint stiffness on 200 lines")


@pytest.mark.parametrize("binary", [0, 1])
def test_real_valued_frf_records_are_refused_naming_the_record(case, binary):
    """Magnitudes only (ordinate data type 4: real, no phase) are no FRF: refused in one line, never read as complex."""
    d, study, sim, _ = case
    sets = _records(sim.frf, binary=binary)
    for s in sets:
        s["data"], s["ord_data_type"] = np.abs(s["data"]), 4
    p = _write(d / f"magnitudes{binary}.uff", sets)
    with pytest.raises(DataError) as err:
        read_measured(study, p)
    assert str(err.value) == (
        f"record 1 of {p} (function type 4, response node {sim.frf.responses[0].node} dir 3, reference node "
        f"{sim.frf.references[0].node} dir 3): real-valued FRF data (ordinate data type 4): an FRF is complex; "
        "export it with real and imaginary parts (data type 5 or 6)")


def _d(num="", den=""):
    return {"ordinate_axis_units_lab": num, "orddenom_axis_units_lab": den}


def test_rotational_records_take_no_length_unit():
    """A rotational response has no length: the inch system converts only its force (rad/s^2 per lbf); an angle label
    converts exactly (deg: pi/180); a moment excitation is force times length; a translation's label on a rotation
    (or the reverse) is refused."""
    from jointid.io.uff_units import UnitSystem, ordinate_units

    inch = UnitSystem("IN", INCH, LBF, "in", "lbf", 1)
    u = ordinate_units(_d(), 12, inch, "r", rotation=True)
    assert u.factor == 1.0 / LBF and u.text == "(rad/s^2)/lbf"
    assert ordinate_units(_d(), 12, inch, "r").factor == INCH / LBF  # the same file's translations
    assert ordinate_units(_d(), 12, inch, "r", moment=True).factor == INCH / (LBF * INCH)
    assert ordinate_units(_d("deg/s^2", "N*m"), 12, SI_UNITS, "r", rotation=True, moment=True).factor == np.pi / 180.0
    assert ordinate_units(_d("rad/s^2/N"), 12, SI_UNITS, "r", rotation=True).factor == 1.0
    for label, rotation, fix in (("g", True, "rad/s^2"), ("mm/s^2", True, "rad/s^2"), ("rad/s^2", False, "m/s^2")):
        with pytest.raises(DataError) as err:
            ordinate_units(_d(label), 12, SI_UNITS, "r", rotation=rotation)
        assert str(err.value) == (f"r: ordinate units label {label!r} is for {'a translation' if rotation else 'a rotation'}, "
                                  f"but the response is {'a rotation' if rotation else 'a translation'}; fix the label (e.g. {fix})")
    with pytest.raises(DataError, match=r"^r: ordinate denominator units label 'N': the excitation is a moment; jointid reads "
                                        r"N\*m, kN\*m, lbf\*in, lbf\*ft$"):
        ordinate_units(_d("rad/s^2", "N"), 12, SI_UNITS, "r", rotation=True, moment=True)


def test_rotational_records_are_written_with_angle_labels_and_read_back(tmp_path):
    from jointid.dofs import parse_dof
    from jointid.frequency import Frequency
    from jointid.frf import FRF

    hz = np.linspace(10.0, 100.0, 10)
    rng = np.random.default_rng(0)
    data = rng.standard_normal((10, 2, 2)) + 1j * rng.standard_normal((10, 2, 2))
    frf = FRF(Frequency(hz), data, (parse_dof("3x"), parse_dof("3rx")), (parse_dof("2y"), parse_dof("2rz")), "accelerance")
    p = write_frf(tmp_path / "rot.uff", frf, binary=True)
    labels = {(s["rsp_dir"], s["ref_dir"]): (s["ordinate_axis_units_lab"].strip(), s["orddenom_axis_units_lab"].strip())
              for s in pyuff.UFF(str(p)).read_sets() if s["type"] == 58}
    assert labels == {(1, 2): ("m/s^2", "N"), (1, 6): ("m/s^2", "N*m"), (4, 2): ("rad/s^2", "N"), (4, 6): ("rad/s^2", "N*m")}
    back = read_uff_frf(p, axis=None)
    assert back.notes == () and np.array_equal(back.data, data)
