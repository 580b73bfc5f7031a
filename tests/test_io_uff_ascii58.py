"""The vectorized ASCII dataset 58 reader gives pyuff's values bit for bit, on every layout, and falls back to pyuff."""

from __future__ import annotations

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from jointid.io.uff_ascii58 import Uff58Reader  # noqa: E402


def _record(data, x, spacing, node=1, double=True):
    odt = (6 if double else 5) if np.iscomplexobj(data) else (4 if double else 2)
    return pyuff.prepare_58(
        binary=0, func_type=4, ord_data_type=odt, rsp_node=node, rsp_dir=3, ref_node=2, ref_dir=3, data=np.asarray(data),
        x=np.asarray(x, dtype=float), abscissa_spacing=spacing, abscissa_spec_data_type=18,
        ordinate_spec_data_type=8, orddenom_spec_data_type=13,
    )


def _values(n: int, complex_: bool, seed: int = 0, decades: int = 120) -> np.ndarray:
    """Values over many decades, both signs (fields filled to their width by '-'; 3-digit exponents beyond 1e+-99).

    With ``decades`` 20, every field has the one E layout that is parsed digit by digit
    (:func:`~jointid.io.uff_ascii58._fixed_width_floats`), and some scale beyond 10^+-22, parsed by numpy.
    """
    rng = np.random.default_rng(seed)
    v = rng.standard_normal(n) * 10.0 ** rng.integers(-decades, decades, n)
    if complex_:
        v = v + 1j * rng.standard_normal(n) * 10.0 ** rng.integers(-decades, decades, n)
    return v


def _spy(reader: Uff58Reader) -> list:
    """Record the datasets pyuff itself decodes (not header-only)."""
    calls = []
    read = reader._uff.read_sets

    def spy(i, header_only=False):
        if not header_only:
            calls.append(i)
        return read(i, header_only=header_only)

    reader._uff.read_sets = spy
    return calls


def _assert_same(path, fast_path: bool = True):
    """Every record of ``path`` as Uff58Reader gives it equals pyuff's, key by key, bit for bit."""
    reader = Uff58Reader(path)
    decoded_by_pyuff = _spy(reader)
    ours = [reader.values(i, reader.header(i)) for i in range(len(reader.types))]
    theirs = pyuff.UFF(str(path)).read_sets()
    theirs = theirs if isinstance(theirs, list) else [theirs]
    assert len(ours) == len(theirs)
    for a, b in zip(ours, theirs):
        assert a.keys() == b.keys()
        for k in a:
            if isinstance(b[k], np.ndarray):
                assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
                assert np.array_equal(a[k], b[k]), k  # the same doubles: both are correctly rounded conversions
            else:
                assert a[k] == b[k], k
    assert (decoded_by_pyuff == []) == fast_path


# ordinate data type: 2/4 real single/double, 5/6 complex single/double; spacing 1 even, 0 uneven.
# Sizes leave the last line short (13 values of 4E20.12 is 3 lines + 1 value; 6E13.5 likewise).
@pytest.mark.parametrize("complex_", [False, True])
@pytest.mark.parametrize("double", [False, True])
@pytest.mark.parametrize("spacing", [1, 0])
@pytest.mark.parametrize("n", [2, 13, 24, 101])
@pytest.mark.parametrize("decades", [120, 20])
def test_every_layout_reads_as_pyuff_reads_it(tmp_path, complex_, double, spacing, n, decades):
    x = 5.0 + 0.25 * np.arange(n) if spacing else np.sort(np.random.default_rng(1).uniform(1, 1000, n))
    path = tmp_path / "f.uff"
    records = [_record(_values(n, complex_, 0, decades), x, spacing, 1, double),
               _record(_values(n, complex_, 2, decades), x, spacing, 3, double)]
    pyuff.UFF(str(path)).write_sets(records, mode="add", force_double=double)
    _assert_same(path)


def test_windows_line_ends_read_vectorized_and_identical(tmp_path):
    path = tmp_path / "f.uff"
    pyuff.UFF(str(path)).write_sets([_record(_values(50, True), np.arange(1.0, 51.0), 1)], mode="add")
    path.write_bytes(path.read_bytes().replace(b"\n", b"\r\n"))
    _assert_same(path)


@pytest.mark.parametrize("edit", ["shorter line", "longer line", "tab"])
def test_irregular_lines_are_left_to_pyuff(tmp_path, edit):
    path = tmp_path / "f.uff"
    pyuff.UFF(str(path)).write_sets([_record(_values(40, True), np.arange(1.0, 41.0), 1)], mode="add")
    lines = path.read_bytes().split(b"\n")
    k = 14  # the second value line of the record (13 header lines after its "-1"), 80 characters
    assert len(lines[k]) == 80
    lines[k] = {"shorter line": lines[k][1:], "longer line": lines[k] + b"  ", "tab": b"\t" + lines[k][1:]}[edit]
    path.write_bytes(b"\n".join(lines))
    _assert_same(path, fast_path=False)  # pyuff reads these lines (the same numbers); so does the fallback


@pytest.mark.parametrize("decades", [120, 20])
def test_a_broken_value_fails_as_in_pyuff(tmp_path, decades):
    path = tmp_path / "f.uff"
    pyuff.UFF(str(path)).write_sets([_record(_values(40, True, 0, decades), np.arange(1.0, 41.0), 1)], mode="add")
    data = path.read_bytes()
    i = data.index(b"e+", 1500)  # in a value, past the header
    path.write_bytes(data[:i] + b"x" + data[i + 1:])
    with pytest.raises(Exception, match="reading data-set"):
        pyuff.UFF(str(path)).read_sets()
    reader = Uff58Reader(path)
    with pytest.raises(Exception, match="reading data-set"):
        reader.values(0, reader.header(0))


def test_binary_records_are_read_by_pyuff(tmp_path):
    path = tmp_path / "f.uff"
    rec = _record(_values(30, True), np.arange(1.0, 31.0), 1)
    rec["binary"] = 1
    pyuff.UFF(str(path)).write_sets([rec], mode="add")
    _assert_same(path, fast_path=False)


@pytest.mark.parametrize("fmt", ["%20.12e", "%13.5e", "%13.6E", "%25.14e", "%12.5e"])
def test_e_fields_parsed_digit_by_digit_are_the_floats_numpy_parses(fmt):
    """Each field's float is one correctly rounded operation on exact numbers (mantissa < 2^53, 10^|k| <= 10^22):
    the correctly rounded conversion numpy's parser makes, bit for bit; scales beyond 10^+-22 go to numpy itself."""
    from jointid.io.uff_ascii58 import _e_format_floats, _fixed_width_floats

    rng = np.random.default_rng(4)
    v = rng.standard_normal(5000) * 10.0 ** rng.integers(-40, 40, 5000)
    v[:6] = [0.0, -0.0, 1.0, -1.0, 9.999999999999999e22, 1e-22]
    width = int(fmt[1:].split(".")[0])
    chars = np.frombuffer("".join(fmt % x for x in v).encode(), np.uint8).reshape(-1, width)
    expect = np.ascontiguousarray(chars).view(f"S{width}")[:, 0].astype(np.float64)
    values, parsed = _e_format_floats(chars, block=777)  # several blocks, the last one short
    assert parsed.any() and not parsed.all()  # both ways taken
    assert np.array_equal(values[parsed].view(np.int64), expect[parsed].view(np.int64))
    assert np.array_equal(_fixed_width_floats(chars).view(np.int64), expect.view(np.int64))  # -0.0 included


def test_a_column_of_another_layout_is_parsed_by_numpy():
    """A 3-digit exponent, a plus sign or a field not in E form: not the one layout, so numpy parses the column."""
    from jointid.io.uff_ascii58 import _e_format_floats, _fixed_width_floats

    for fields in ([b" 1.50000e+00", b" 2.5000e-120", b" 1.00000e+00"], [b" 1.50000e+00", b"+2.50000e+00"],
                   [b" 1.50000e+00", b"      2.5000"]):
        chars = np.frombuffer(b"".join(f.rjust(12) for f in fields), np.uint8).reshape(-1, 12)
        assert _e_format_floats(chars) is None
        assert np.array_equal(_fixed_width_floats(chars), np.ascontiguousarray(chars).view("S12")[:, 0].astype(float))
