"""UFF reading: Fortran D exponents read exactly, tabs and text-mode damage named, mixed kinds with a 0 Hz line."""

from __future__ import annotations

import re

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from jointid.errors import DataError  # noqa: E402
from jointid.io.uff import read_uff_frf  # noqa: E402
from jointid.io.uff_ascii58 import fortran_exponents  # noqa: E402

X = np.arange(1.0, 21.0)  # 1..20 Hz
H = (1.0 + 0.3j) / (100.0 - (2 * np.pi * X) ** 2 * 0.01 + 2j)  # a receptance-like curve, m/N


def _rec(data, x, ref_node=2, num=8, binary=0, spacing=1, odt=None):
    d = pyuff.prepare_58(binary=binary, func_type=4, rsp_node=1, rsp_dir=3, ref_node=ref_node, ref_dir=3,
                         data=np.asarray(data), x=np.asarray(x, dtype=float), abscissa_spacing=spacing,
                         abscissa_spec_data_type=18, ordinate_spec_data_type=num, orddenom_spec_data_type=13)
    return d


def _write(path, sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="add")
    return path


def _to_fortran(data: bytes, lower: bool = False) -> bytes:
    """Every number's exponent written with D (as a Fortran writer does), in all lines."""
    return re.sub(rb"(\d)[eE]([+-]\d)", rb"\1d\2" if lower else rb"\1D\2", data)


# ---------------------------------------------------------------- (a) Fortran D exponents, tabs
@pytest.mark.parametrize("spacing", [1, 0], ids=["even", "uneven"])
@pytest.mark.parametrize("lower", [False, True], ids=["D", "d"])
def test_fortran_d_exponents_read_exactly_as_e(tmp_path, spacing, lower):
    plain = _write(tmp_path / "e.uff", [_rec(H, X, spacing=spacing), _rec(2 * H, X, ref_node=3, spacing=spacing)])
    fortran = tmp_path / "d.uff"
    fortran.write_bytes(_to_fortran(plain.read_bytes(), lower))
    assert b"D+" in fortran.read_bytes().upper() and b"E+" not in fortran.read_bytes().upper()
    with pytest.raises(Exception, match=r"Error when reading data-set\(s\)"):  # what pyuff alone says
        pyuff.UFF(str(fortran)).read_sets(0)
    want, got = read_uff_frf(plain), read_uff_frf(fortran)
    assert np.array_equal(got.frequency.hz, want.frequency.hz) and np.array_equal(got.data, want.data)
    assert got.kind == "receptance" and got.notes == want.notes


def test_fortran_exponents_change_only_numbers_of_record_7_and_the_values(tmp_path):
    path = _write(tmp_path / "e.uff", [_rec(H, X)])
    block = path.read_bytes().replace(b"NONE", b"M3D2", 1)  # an ID line reading like a number with a D exponent
    lines = _to_fortran(block).splitlines(True)
    lines[2] = block.splitlines(True)[2]
    fixed = fortran_exponents(b"".join(lines))
    assert fixed is not None and len(fixed) == len(block)
    assert fixed.splitlines(True)[2].startswith(b"M3D2") and fixed.count(b"D") == 1
    assert fortran_exponents(block) is None  # nothing to change: None


def test_a_tab_that_shifts_the_columns_names_its_line(tmp_path):
    path = _write(tmp_path / "t.uff", [_rec(H, X)])
    lines = path.read_bytes().split(b"\n")
    assert lines[13].startswith(b"   1.00960409588e-02   ")  # line 14: the first value line
    lines[13] = lines[13].replace(b"   ", b"\t")  # a text editor's tabs for runs of spaces
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(DataError) as e:
        read_uff_frf(path)
    assert str(e.value) == (f"record 1 of {path} (dataset 58) cannot be read: line 14 holds a tab character, which shifts "
                            "UFF's fixed-width columns; re-export the file, or replace each tab by the spaces it stands for "
                            "(e.g. `expand` for tab stops every 8 columns)")


# ---------------------------------------------------------------- (b) a binary file copied in text mode
def _with_bytes(prefix: bytes) -> complex:
    """A double whose little-endian bytes start with ``prefix`` (then zeros, exponent of 1.0)."""
    raw = prefix + bytes(6 - len(prefix)) + b"\xf0\x3f"
    return complex(np.frombuffer(raw, "<f8")[0], 0.3)


@pytest.mark.parametrize("line_feeds", [1, 9])
def test_a_binary_file_copied_in_text_mode_is_named_so(tmp_path, line_feeds):
    data = np.full(X.size, _with_bytes(b"\x01"))  # no byte 10 in these values
    data[:line_feeds] = _with_bytes(b"\n")  # values whose bytes hold a line feed (10)
    assert data.view("<f8").tobytes().count(b"\n") == line_feeds
    path = _write(tmp_path / "b.uff", [_rec(data, X, binary=1), _rec(data, X, ref_node=3, binary=1)])
    good = read_uff_frf(path)
    assert np.array_equal(good("1w", "2w"), data)
    damaged = tmp_path / "copied.uff"
    damaged.write_bytes(path.read_bytes().replace(b"\n", b"\r\n"))  # LF -> CR LF, in the header and in the values
    with pytest.raises(DataError) as e:
        read_uff_frf(damaged)
    assert str(e.value) == (f"record 1 of {damaged} looks damaged by a text-mode transfer (CR LF line ends inserted into "
                            f"binary data: {line_feeds} byte(s) more than its 20 points take, one before each line feed "
                            "byte): copy it again in binary mode")


def test_binary_values_holding_cr_lf_bytes_are_not_damage(tmp_path):
    data = H.copy()
    data[3] = _with_bytes(b"\r\n")  # a CR LF pair that is part of a value
    path = _write(tmp_path / "b.uff", [_rec(data, X, binary=1)])
    assert np.array_equal(read_uff_frf(path)("1w", "2w"), data)
    crlf_header = tmp_path / "crlf.uff"  # text-mode copy of a file whose values hold no line feed: no damage done
    values = np.full(X.size, _with_bytes(b"\x01"))
    assert b"\n" not in values.view("<f8").tobytes()
    clean = _write(tmp_path / "clean.uff", [_rec(values, X, binary=1)])
    crlf_header.write_bytes(clean.read_bytes().replace(b"\n", b"\r\n"))
    assert np.array_equal(read_uff_frf(crlf_header)("1w", "2w"), values)


# ---------------------------------------------------------------- (c) mixed kinds and a 0 Hz line
X0 = np.arange(0.0, 20.0)  # from 0 Hz
H0 = (1.0 + 0.3j) / (100.0 - (2 * np.pi * X0) ** 2 * 0.01 + 2j)
JW0 = 2j * np.pi * X0


def test_mixed_kinds_with_a_0_hz_line_read_as_the_all_accelerance_file(tmp_path):
    mixed = _write(tmp_path / "mixed.uff", [_rec(H0, X0, num=8, binary=1), _rec(H0 * JW0**2, X0, ref_node=3, num=12, binary=1)])
    same = _write(tmp_path / "acc.uff", [_rec(H0 * JW0**2, X0, num=12, binary=1),
                                         _rec(H0 * JW0**2, X0, ref_node=3, num=12, binary=1)])
    got, want = read_uff_frf(mixed), read_uff_frf(same)
    assert got.kind == want.kind == "accelerance"
    assert np.array_equal(got.frequency.hz, X0) and got.data[0].tolist() == [[0j, 0j]]  # 0 Hz: receptance x (j0)^2
    assert np.all(np.abs(got.data - want.data) <= 1e-15 * np.abs(want.data))  # the same values, to rounding
    assert got.notes[1] == ("kind: records of receptance and accelerance read as accelerance (not as the first record's "
                            "receptance: the 0 Hz line of accelerance cannot be converted to receptance)")
    r = got.band(1.0).to("receptance")  # above 0 Hz both records are the receptance H0
    assert np.max(np.abs(r.data[:, 0, :] - H0[1:, None])) <= 1e-12 * np.max(np.abs(H0))
    for path in (mixed, same):  # asked for receptance: refused the same way, naming the file
        with pytest.raises(DataError) as e:
            read_uff_frf(path, kind="receptance")
        assert str(e.value) == (f"{path}: cannot convert accelerance to receptance at 0 Hz (division by zero); "
                                "drop the 0 Hz line first")


def test_mixed_kinds_without_0_hz_keep_the_first_records_kind(tmp_path):
    jw = 2j * np.pi * X
    path = _write(tmp_path / "m.uff", [_rec(H, X, num=8), _rec(H * jw, X, ref_node=3, num=11)])
    frf = read_uff_frf(path)
    assert frf.kind == "receptance" and not any(n.startswith("kind:") for n in frf.notes)
    assert np.max(np.abs(frf("1w", "3w") - H)) <= 1e-12 * np.max(np.abs(H))


def test_mixed_kinds_on_different_axes_name_both_records(tmp_path):
    path = _write(tmp_path / "m.uff", [_rec(H, X, num=8), _rec(H[:10] * (2j * np.pi * X[:10]) ** 2, X[:10], ref_node=3, num=12)])
    with pytest.raises(DataError, match=r"^record 2 \(response 1w, reference 3w\) in .* is on a different frequency axis"):
        read_uff_frf(path)
