"""The jointid FRF CSV layout: exact round trip, kind declaration, bad input naming rows/pairs."""

from __future__ import annotations

import numpy as np
import pytest

from jointid.errors import DataError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.io.frf_csv import read_frf_csv, write_frf_csv


def _frf(kind="accelerance"):
    f = Frequency(np.linspace(5.0, 1000.0, 37))  # awkward step: CSV keeps it exactly
    rng = np.random.default_rng(0)
    data = rng.normal(size=(f.size, 3, 2)) + 1j * rng.normal(size=(f.size, 3, 2))
    return FRF(f, data / 3.0, ["3w", "7theta", "1w"], ["9w", "2w"], kind)


HEAD = "# kind = receptance\nfrequency_hz,response,reference,real,imag\n"


def _csv(tmp_path, text, name="f.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _rows(pairs=(("1w", "2w"), ("1w", "3w")), freqs=(1.0, 2.0)):
    return "".join(f"{f},{r},{c},{f},{-f}\n" for f in freqs for r, c in pairs)


def test_round_trip_is_exact(tmp_path):
    frf = _frf()
    p = write_frf_csv(tmp_path / "a.csv", frf)
    back = read_frf_csv(p, n_nodes=9)
    assert back.kind == "accelerance"
    assert back.responses == frf.responses and back.references == frf.references
    np.testing.assert_array_equal(back.frequency.hz, frf.frequency.hz)
    np.testing.assert_array_equal(back.data, frf.data)
    assert read_frf_csv(p, kind="receptance").kind == "receptance"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["a.csv"]


def test_rows_in_any_order_kind_column_and_bare_nodes(tmp_path):
    text = "frequency_hz,kind,response,reference,real,imag\n"
    text += "2,mobility,1,2,2,-2\n1,mobility,1w,2w,1,-1\n"
    frf = read_frf_csv(_csv(tmp_path, text))
    assert frf.kind == "mobility"
    np.testing.assert_array_equal(frf.frequency.hz, [1.0, 2.0])
    np.testing.assert_array_equal(frf("1w", "2w"), [1 - 1j, 2 - 2j])


def test_kind_must_be_declared_never_guessed(tmp_path):
    with pytest.raises(DataError, match="does not declare the FRF kind"):
        read_frf_csv(_csv(tmp_path, "frequency_hz,response,reference,real,imag\n" + _rows()))
    with pytest.raises(DataError, match="unknown FRF kind 'inertance'"):
        read_frf_csv(_csv(tmp_path, "# kind = inertance\nfrequency_hz,response,reference,real,imag\n" + _rows()))
    text = "# kind = receptance\nfrequency_hz,response,reference,real,imag,kind\n1,1w,2w,1,0,accelerance\n"
    with pytest.raises(DataError, match="contradicts"):
        read_frf_csv(_csv(tmp_path, text))


def test_missing_pair_names_the_pair(tmp_path):
    text = HEAD + _rows(pairs=(("1w", "2w"), ("1w", "3w"), ("4w", "2w")))
    with pytest.raises(DataError, match=r"pair \(response 4w, reference 3w\) is missing"):
        read_frf_csv(_csv(tmp_path, text))


def test_duplicated_row_names_both_rows(tmp_path):
    text = HEAD + _rows() + "2,1w,3w,5,5\n"
    with pytest.raises(DataError, match=r"rows 6 and 7 both give the pair \(response 1w, reference 3w\) at 2 Hz"):
        read_frf_csv(_csv(tmp_path, text))


def test_different_frequency_axes_name_the_pair(tmp_path):
    text = HEAD + _rows() + "3,1w,3w,1,1\n"
    with pytest.raises(DataError, match=r"pair \(response 1w, reference 3w\) is on a different frequency axis.*extra line 3 Hz"):
        read_frf_csv(_csv(tmp_path, text))
    text = HEAD + "1,1w,2w,1,1\n2,1w,2w,1,1\n1,1w,3w,1,1\n2.5,1w,3w,1,1\n"
    with pytest.raises(DataError, match=r"reference 3w\) is on a different frequency axis.*missing line 2 Hz"):
        read_frf_csv(_csv(tmp_path, text))


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_names_the_row(tmp_path, bad):
    text = HEAD + _rows() + f"3,1w,2w,1,{bad}\n"
    with pytest.raises(DataError, match=r"row 7 .*non-finite"):
        read_frf_csv(_csv(tmp_path, text))


def test_node_outside_the_beam_and_bad_cells_name_the_row(tmp_path):
    p = _csv(tmp_path, HEAD + _rows(pairs=(("1w", "2w"), ("12w", "2w"))))
    assert read_frf_csv(p).shape == (2, 2, 1)
    with pytest.raises(DataError, match=r"row 4 of .*f.csv: response 12w is outside the beam \(nodes 1..11\)"):
        read_frf_csv(p, n_nodes=11)
    with pytest.raises(DataError, match=r"row 3 of .*: cannot read the reference DOF '2x'"):
        read_frf_csv(_csv(tmp_path, HEAD + "1,1w,2x,1,1\n"))
    with pytest.raises(DataError, match=r"row 4 of .*: column 'real' holds 'abc'"):
        read_frf_csv(_csv(tmp_path, HEAD + "1,1w,2w,1,1\n2,1w,2w,abc,1\n"))
    with pytest.raises(DataError, match=r"row 3 .* has 4 cells"):
        read_frf_csv(_csv(tmp_path, HEAD + "1,1w,2w,1\n"))
    with pytest.raises(DataError, match="lacks column"):
        read_frf_csv(_csv(tmp_path, "# kind = receptance\nfreq,response,reference,real,imag\n1,1w,2w,1,1\n"))


def test_writer_refuses_non_finite(tmp_path):
    f = Frequency([1.0, 2.0])
    d = np.array([1.0, np.inf]).reshape(2, 1, 1)
    with pytest.raises(DataError, match="not finite at 2 Hz"):
        write_frf_csv(tmp_path / "x.csv", FRF(f, d, ["1w"], ["2w"]))
    assert list(tmp_path.iterdir()) == []


def test_a_directory_given_as_the_frf_file_is_named_as_one(tmp_path):
    from jointid.io.frf_files import read_frf

    with pytest.raises(DataError) as e:
        read_frf(tmp_path)
    assert str(e.value) == f"FRF file {tmp_path} is a directory; give the FRF file in it (e.g. {tmp_path / 'frf.uff'})"
