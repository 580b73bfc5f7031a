"""UFF dataset 58 FRF files: round trips, kind from ordinate characteristics, -Z flips, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from jointid.errors import DataError  # noqa: E402
from jointid.frequency import Frequency  # noqa: E402
from jointid.frf import FRF  # noqa: E402
from jointid.io.frf_files import read_frf, write_frf  # noqa: E402
from jointid.io.uff import read_uff_frf, write_uff_frf  # noqa: E402

RESP = ("3w", "7w", "1w")
REFS = ("9w", "2w")


def _frf(kind: str = "receptance", f: Frequency | None = None, seed: int = 0) -> FRF:
    f = f or Frequency.from_range(5.0, 60.0, 0.5)
    rng = np.random.default_rng(seed)
    data = (rng.normal(size=(f.size, 3, 2)) + 1j * rng.normal(size=(f.size, 3, 2))) * 1e-4
    return FRF(f, data, RESP, REFS, kind)


def _rec(data, x, rsp_node=1, ref_node=2, rsp_dir=3, ref_dir=3, num=8, den=13, func_type=4, binary=0, spacing=1):
    return pyuff.prepare_58(
        binary=binary,
        func_type=func_type,
        rsp_node=rsp_node,
        rsp_dir=rsp_dir,
        ref_node=ref_node,
        ref_dir=ref_dir,
        data=np.asarray(data),
        x=np.asarray(x, dtype=float),
        abscissa_spacing=spacing,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=num,
        orddenom_spec_data_type=den,
    )


def _write(path, sets):
    pyuff.UFF(str(path)).write_sets(list(sets), mode="add")
    return path


X = np.arange(1.0, 21.0)  # 1..20 Hz, exactly representable in the 13.5e header
H = (1.0 + 0.3j) / (100.0 - (2 * np.pi * X) ** 2 * 0.01 + 2j)  # a receptance-like curve


def _rel(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b))


# ---------------------------------------------------------------- truncated files
@pytest.mark.parametrize("binary", [False, True])
def test_a_file_cut_inside_a_dataset_is_refused_naming_the_line(tmp_path, binary):
    """pyuff lists only closed datasets: a file cut inside the 4th record would read as 3 records (a missing pair,
    blamed on the study). It is refused as truncated, with the line where the unclosed dataset opens."""
    p = write_uff_frf(tmp_path / "whole.uff", _frf(), binary=binary)
    data = p.read_bytes()
    opening = [int(start) for start, _ in pyuff.UFF(str(p))._block_ind]  # where each dataset's "    -1" line starts
    assert len(opening) == 7 and all(data[k:k + 7] == b"    -1\n" for k in opening)  # units (164) and six FRF records
    cut = tmp_path / "cut.uff"
    cut.write_bytes(data[:opening[4] + 200])  # the 5th dataset (the 4th FRF record) opened, 200 bytes of it
    line = data.count(b"\n", 0, opening[4]) + 1
    with pytest.raises(DataError) as err:
        read_uff_frf(cut)
    assert str(err.value) == (f"{cut} ends inside a dataset (from line {line} on, after 4 dataset(s), the text is not closed by a "
                              "'    -1' line): the file is truncated or damaged (an interrupted copy or export?); copy or export it again")
    first = tmp_path / "first.uff"
    first.write_bytes(data[:opening[0] + 100])  # not one dataset closed
    with pytest.raises(DataError, match=r"first.uff ends inside a dataset \(from line 1 on, after 0 dataset\(s\),"):
        read_uff_frf(first)


def test_a_whole_file_and_a_lone_delimiter_at_its_end_are_not_truncated(tmp_path):
    p = write_uff_frf(tmp_path / "whole.uff", _frf())
    assert read_uff_frf(p).data.shape[1:] == (3, 2)
    p.write_bytes(p.read_bytes() + b"    -1\n")  # opens nothing
    assert read_uff_frf(p).data.shape[1:] == (3, 2)


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("trailer", [b"\x1a", b"\r\n\x1a", b"\x00" * 64, b"    -1\n\x1a"], ids=["ctrl-z", "crlf-ctrl-z", "nul-padding", "delimiter-ctrl-z"])
def test_a_dos_end_of_file_mark_or_nul_padding_is_not_a_truncation(tmp_path, binary, trailer):
    p = write_uff_frf(tmp_path / "whole.uff", _frf(), binary=binary)
    whole = read_uff_frf(p).data
    p.write_bytes(p.read_bytes() + trailer)
    assert np.array_equal(read_uff_frf(p).data, whole)


@pytest.mark.parametrize("binary", [False, True])
def test_a_dataset_cut_in_the_middle_of_a_file_is_refused(tmp_path, binary):
    """An interrupted part of a joined export: the 5th of 7 datasets cut after 200 bytes, the rest of the file after it."""
    p = write_uff_frf(tmp_path / "whole.uff", _frf(), binary=binary)
    data = p.read_bytes()
    opening = [int(start) for start, _ in pyuff.UFF(str(p))._block_ind]
    cut = tmp_path / "mid.uff"
    cut.write_bytes(data[:opening[4] + 200] + data[opening[5]:])
    with pytest.raises(DataError, match=r"mid.uff ends inside a dataset \(from line \d+ on, after \d dataset\(s\), the text is not "
                                        r"closed by a '    -1' line\): the file is truncated or damaged"):
        read_uff_frf(cut)


# ---------------------------------------------------------------- round trips
@pytest.mark.parametrize("kind", ["accelerance", "mobility", "receptance"])
def test_ascii_round_trip(tmp_path, kind):
    frf = _frf()
    p = write_uff_frf(tmp_path / "a.uff", frf, kind=kind)
    back = read_uff_frf(p, n_nodes=10)
    assert back.kind == kind
    assert [str(d) for d in back.responses] == list(RESP)
    assert [str(d) for d in back.references] == list(REFS)
    assert back.frequency == frf.frequency
    assert _rel(back.to("receptance").data, frf.data) < 1e-10  # %20.11e: 12 significant digits
    assert _rel(read_uff_frf(p, kind="receptance").data, frf.data) < 1e-10


def test_binary_round_trip_is_exact_and_carries_coherence(tmp_path):
    frf = _frf("accelerance")
    coh = np.random.default_rng(1).uniform(size=frf.shape)
    p = write_uff_frf(tmp_path / "b.uff", frf, coherence=coh, binary=True)
    assert b"58b" in p.read_bytes()
    back, c = read_uff_frf(p, coherence=True)
    np.testing.assert_array_equal(back.data, frf.data)
    np.testing.assert_array_equal(back.frequency.hz, frf.frequency.hz)
    np.testing.assert_array_equal(c, coh)
    assert read_uff_frf(p).kind == "accelerance"  # coherence records are skipped by default


def test_ascii_coherence_round_trip_and_absent_coherence(tmp_path):
    frf = _frf()
    coh = np.random.default_rng(2).uniform(size=frf.shape)
    back, c = read_uff_frf(write_uff_frf(tmp_path / "c.uff", frf, coherence=coh), coherence=True)
    assert np.max(np.abs(c - coh)) < 1e-11
    _, none = read_uff_frf(write_uff_frf(tmp_path / "d.uff", frf), coherence=True)
    assert none is None


def test_binary_file_written_directly_by_pyuff(tmp_path):
    """A binary 58 file from pyuff itself (not our writer), with a -Z reference."""
    p = _write(tmp_path / "raw.uff", [_rec(H, X, rsp_node=4, ref_node=5, ref_dir=-3, num=12, binary=1)])
    frf = read_uff_frf(p)
    assert frf.kind == "accelerance" and frf.shape == (X.size, 1, 1)
    np.testing.assert_array_equal(frf("4w", "5w"), -H)


def test_uneven_grid_binary_exact_ascii_refused(tmp_path):
    f = Frequency(np.linspace(5.0, 1000.0, 4097))  # step 0.2428...: not 6-digit representable
    frf = _frf(f=f)
    with pytest.raises(DataError, match="binary=True"):
        write_uff_frf(tmp_path / "a.uff", frf, binary=False)
    assert not (tmp_path / "a.uff").exists()
    auto = read_uff_frf(write_uff_frf(tmp_path / "auto.uff", frf))  # default: binary where ASCII is not exact
    np.testing.assert_array_equal(auto.frequency.hz, f.hz)
    back = read_uff_frf(write_uff_frf(tmp_path / "b.uff", frf, binary=True))
    np.testing.assert_array_equal(back.frequency.hz, f.hz)
    np.testing.assert_allclose(back.to("receptance").data, frf.data, rtol=1e-12, atol=0)


def test_write_replaces_existing_file_atomically(tmp_path):
    p = tmp_path / "x.uff"
    write_uff_frf(p, _frf(seed=1), binary=True)
    write_uff_frf(p, _frf(seed=2), binary=True)  # pyuff's binary 'overwrite' would truncate; we add to a fresh file
    np.testing.assert_array_equal(read_uff_frf(p, kind="receptance").data, _frf(seed=2).to("accelerance").to("receptance").data)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["x.uff"]


def test_writer_refuses_what_it_cannot_write(tmp_path):
    f = Frequency.from_range(5.0, 10.0, 1.0)
    rot = FRF(f, np.ones((f.size, 1, 1)), ["3theta"], ["9w"], "receptance")
    with pytest.raises(DataError, match="3theta"):
        write_uff_frf(tmp_path / "r.uff", rot)
    d = np.ones((f.size, 1, 1), complex)
    d[2, 0, 0] = np.nan
    with pytest.raises(DataError, match="not finite"):  # pyuff would silently write 0
        write_uff_frf(tmp_path / "n.uff", FRF(f, d, ["3w"], ["9w"], "accelerance"))
    with pytest.raises(DataError, match="coherence"):
        write_uff_frf(tmp_path / "c.uff", FRF(f, np.ones((f.size, 1, 1)), ["3w"], ["9w"]), coherence=np.ones((2, 1, 1)))
    assert list(tmp_path.iterdir()) == []


def test_record_marks_are_written_to_id_line_4_and_only_the_leakage_mark_becomes_a_note(tmp_path):
    from jointid.io.uff import LEAKAGE_MARK

    p = tmp_path / "m.uff"
    write_uff_frf(p, _frf(), binary=True, marks={("7w", "2w"): LEAKAGE_MARK})
    frf = read_uff_frf(p, kind="receptance")
    assert frf.notes == (
        "1 record(s) marked by jointid frf as leaking (the response still rang at the record's end: 7w/2w): their FRFs are "
        "biased near the lightly damped modes, so a free model that does not fit these FRFs there may be this, not the "
        "model; process the hits again with longer records or an exponential window (--exp-tau-ms) before updating the model",)
    np.testing.assert_array_equal(frf.data, read_uff_frf(_written(tmp_path / "plain.uff"), kind="receptance").data)
    assert read_uff_frf(tmp_path / "plain.uff", kind="receptance").notes == ()
    # the FRF keeps the mark on its pair (what the model check names), through select and band
    assert [(str(r), str(c), t) for r, c, t in frf.marks] == [("7w", "2w", LEAKAGE_MARK)]
    assert frf.select(["7w"], ["2w"]).band(stop_hz=frf.frequency.hz[3]).marks == frf.marks
    assert frf.select(["7w"], [str(c) for c in frf.references if str(c) != "2w"]).marks == ()
    with pytest.raises(DataError, match="^FRF marks name a pair that is not among its responses and references$"):
        dataclasses.replace(frf, marks=(("5theta", "2w", LEAKAGE_MARK),))
    write_uff_frf(tmp_path / "other.uff", _frf(), binary=True, marks={("7w", "2w"): "measured on a Monday"})
    other = read_uff_frf(tmp_path / "other.uff", kind="receptance")
    assert other.notes == () and other.marks == ()  # not jointid's mark: nothing said, nothing kept
    with pytest.raises(DataError, match="^UFF ID lines hold at most 80 characters; shorten the record marks$"):
        write_uff_frf(tmp_path / "long.uff", _frf(), marks={("7w", "2w"): "x" * 81})


def _written(path):
    write_uff_frf(path, _frf(), binary=True)
    return path


# ------------------------------------------------- kind and direction decoding
@pytest.mark.parametrize("code, power", [(8, 0), (11, 1), (12, 2)])
def test_kind_from_ordinate_numerator(tmp_path, code, power):
    jw = 2j * np.pi * X
    p = _write(tmp_path / "k.uff", [_rec(H * jw**power, X, num=code)])
    frf = read_uff_frf(p)
    assert frf.kind == {8: "receptance", 11: "mobility", 12: "accelerance"}[code]
    assert _rel(frf.to("receptance")("1w", "2w"), H) < 1e-10


def test_mixed_kinds_are_converted_to_the_first(tmp_path):
    jw = 2j * np.pi * X
    p = _write(
        tmp_path / "m.uff",
        [_rec(H * jw**2, X, ref_node=2, num=12), _rec(H * jw, X, ref_node=3, num=11), _rec(H, X, ref_node=4, num=8)],
    )
    frf = read_uff_frf(p).to("receptance")
    for ref in ("2w", "3w", "4w"):
        assert _rel(frf("1w", ref), H) < 1e-10


@pytest.mark.parametrize("rsp_dir, ref_dir, sign", [(3, 3, 1), (-3, 3, -1), (3, -3, -1), (-3, -3, 1)])
def test_minus_z_records_are_sign_flipped(tmp_path, rsp_dir, ref_dir, sign):
    p = _write(tmp_path / "z.uff", [_rec(H, X, rsp_dir=rsp_dir, ref_dir=ref_dir)])
    assert _rel(read_uff_frf(p)("1w", "2w"), sign * H) < 1e-10


def test_time_records_units_and_other_datasets_are_skipped(tmp_path):
    units = pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0, temp_offset=273.15)
    time = _rec(np.sin(X), X * 1e-3, func_type=1, rsp_dir=1, num=12, den=0)
    time["abscissa_spec_data_type"] = 17
    p = _write(tmp_path / "t.uff", [units, time, _rec(H, X)])
    frf = read_uff_frf(p)
    assert frf.shape == (X.size, 1, 1)
    assert frf.notes == ("skipped 1 record: 1 time",)  # blank labels under an SI dataset 164: nothing to say
    q = _write(tmp_path / "q.uff", [_rec(H, X)])
    assert read_uff_frf(q).notes == (
        "units: 1 FRF record without units labels (and no units dataset 164) read as SI m/N",
    )


# ------------------------------------------------------------------ bad input
def test_missing_pair_names_the_pair(tmp_path):
    p = _write(tmp_path / "m.uff", [_rec(H, X, 1, 2), _rec(H, X, 1, 3), _rec(H, X, 4, 2)])
    with pytest.raises(DataError, match=r"pair \(response 4w, reference 3w\) is missing"):
        read_uff_frf(p)


@pytest.mark.parametrize("second_dir", [3, -3])
def test_duplicated_pair_names_the_record(tmp_path, second_dir):
    p = _write(tmp_path / "d.uff", [_rec(H, X), _rec(H, X, 1, 3), _rec(H, X, rsp_dir=second_dir)])
    with pytest.raises(DataError, match=r"record 3 .*duplicates .*\(1w, 2w\).*record 1"):
        read_uff_frf(p)


@pytest.mark.parametrize("x2", [X + 0.5, X * 2.0, X[:-1]], ids=["min", "increment", "points"])
def test_different_frequency_axes_name_the_record(tmp_path, x2):
    p = _write(tmp_path / "f.uff", [_rec(H, X, 1, 2), _rec(H[: x2.size], x2, 1, 3)])
    with pytest.raises(DataError, match=r"record 2 .*different frequency axis"):
        read_uff_frf(p)


def test_nan_value_names_the_record(tmp_path):
    data = H.copy()
    data[3] = 0.25
    p = _write(tmp_path / "n.uff", [_rec(H, X, 1, 2), _rec(data, X, 1, 3)])
    text = p.read_text()
    token = "%20.11e" % 0.25
    assert text.count(token) == 1
    p.write_text(text.replace(token, "%20s" % "nan"))
    with pytest.raises(DataError, match=r"record 2 of .*n\.uff \(.*\): non-finite value at line 4 \(4 Hz\)"):
        read_uff_frf(p)


def test_node_outside_the_beam_names_the_record(tmp_path):
    p = _write(tmp_path / "o.uff", [_rec(H, X, 1, 2), _rec(H, X, 1, 12)])
    assert read_uff_frf(p).shape == (X.size, 1, 2)  # fine without n_nodes
    with pytest.raises(DataError, match=r"record 2 of .*o\.uff .*reference node 12 is outside the beam \(nodes 1..11\)"):
        read_uff_frf(p, n_nodes=11)


@pytest.mark.parametrize(
    "rsp_dir, ref_dir, letters", [(1, 3, "X"), (3, 2, "Y"), (5, 3, "RY"), (3, -6, "RZ"), (0, 3, "scalar"), (2, -1, "X/Y")]
)
def test_other_directions_are_skipped_and_counted(tmp_path, rsp_dir, ref_dir, letters):
    p = _write(tmp_path / "x.uff", [_rec(H, X, 1, 2), _rec(H, X, 3, 2, rsp_dir=rsp_dir, ref_dir=ref_dir)])
    frf = read_uff_frf(p)
    assert frf.shape == (X.size, 1, 1)
    assert frf.notes[-1] == f"skipped 1 record: 1 in {letters}"


def test_no_record_along_the_axis_says_what_was_skipped(tmp_path):
    p = _write(tmp_path / "y.uff", [_rec(H, X, 1, 2, rsp_dir=2, ref_dir=2), _rec(H, X, 3, 2, rsp_dir=-2, ref_dir=2)])
    with pytest.raises(DataError) as e:
        read_uff_frf(p)
    assert str(e.value) == (
        f"{p} holds no FRF record to read (UFF dataset 58, function type 4, along Z); skipped 2 records: 2 in Y; "
        "if the beam was measured along another direction, give that axis (the study's [measurement].axis)"
    )
    assert read_uff_frf(p, axis="+Y").shape == (X.size, 2, 1)


@pytest.mark.parametrize("num, den", [(0, 13), (1, 13), (12, 0), (12, 9), (13, 8)])
def test_unknown_characteristics_name_the_record(tmp_path, num, den):
    p = _write(tmp_path / "u.uff", [_rec(H, X, 1, 2), _rec(H, X, 1, 3, num=num, den=den)])
    with pytest.raises(DataError, match=r"record 2 .*cannot tell the FRF kind"):
        read_uff_frf(p)


def test_contradictory_units_dataset_no_frf_and_missing_file(tmp_path):
    units = pyuff.prepare_164(units_code=2, units_description="BG", temp_mode=1, length=3.28, force=0.2248, temp=1.8, temp_offset=459.67)
    p = _write(tmp_path / "bg.uff", [units, _rec(H, X)])
    with pytest.raises(DataError, match=r"record 1 of .*bg.uff: units dataset 164 declares code 2 \(BG: ft, lbf\) but a length factor 3.28"):
        read_uff_frf(p)
    q = _write(tmp_path / "t.uff", [_rec(H.real, X, func_type=1)])
    with pytest.raises(DataError, match=r"no FRF record to read .*; skipped 1 record: 1 time"):
        read_uff_frf(q)
    with pytest.raises(DataError, match="does not exist"):
        read_uff_frf(tmp_path / "nope.uff")


# ------------------------------------------------------------------- dispatch
def test_read_frf_dispatches_on_extension(tmp_path):
    frf = _frf()
    for name in ("a.uff", "a.unv", "a.58", "A.UFF"):
        back = read_frf(write_frf(tmp_path / name, frf), n_nodes=9)
        assert back.kind == "accelerance" and _rel(back.to("receptance").data, frf.data) < 1e-10
    back = read_frf(write_frf(tmp_path / "a.csv", frf))
    np.testing.assert_array_equal(back.data, frf.data)
    with pytest.raises(DataError, match=r"\.uff, \.unv, \.58 .* \.csv"):
        read_frf(tmp_path / "a.txt")


def test_a_file_without_any_uff_dataset_says_what_delimits_them(tmp_path):
    """Separator lines with trailing spaces (another program's export): pyuff sees no dataset; the error says why."""
    from jointid.benchmark import benchmark_study
    from jointid.pipeline import simulate

    frf = simulate(benchmark_study()).frf
    good = write_uff_frf(tmp_path / "good.uff", frf, binary=False)
    bad = tmp_path / "trailing.uff"
    bad.write_text("".join(line.rstrip("\n") + ("   \n" if line.strip() == "-1" else "\n")
                           for line in good.read_text().splitlines(keepends=True)))
    with pytest.raises(DataError) as err:
        read_uff_frf(bad)
    assert str(err.value) == (
        f"{bad} holds no FRF record to read (UFF dataset 58, function type 4, along Z); no UFF dataset was "
        "found in it at all: datasets are delimited by lines that read exactly '    -1' (six characters: check for "
        "trailing spaces, tabs or another file format)")


@pytest.mark.parametrize("binary", [False, True])
def test_every_cut_past_a_datasets_first_line_is_found(tmp_path, binary):
    """Cut k bytes into the 4th FRF record (its opening '    -1' line, then its header): refused for k = 5 (a
    partial delimiter) and every k >= 12; k = 0-4 and 6-11 leave blanks or a lone '-1', which a whole file may end
    with too (read as the 3 records before, whose pairs are then missing)."""
    p = write_uff_frf(tmp_path / "whole.uff", _frf(), binary=binary)
    data = p.read_bytes()
    start = int(pyuff.UFF(str(p))._block_ind[4][0])
    line = data.count(b"\n", 0, start) + 1
    cut = tmp_path / "cut.uff"
    for k in [5, *range(12, 400, 7)]:
        cut.write_bytes(data[:start + k])
        with pytest.raises(DataError, match=rf"ends inside a dataset \(from line {line} on, after 4 dataset\(s\),"):
            read_uff_frf(cut)
    for k in [*range(0, 5), *range(6, 12)]:
        cut.write_bytes(data[:start + k])
        with pytest.raises(DataError, match="pair .* is missing"):
            read_uff_frf(cut)


@pytest.mark.parametrize("binary", [0, 1])
def test_the_writer_writes_the_bytes_pyuff_writes_without_its_quadratic_reindex(tmp_path, binary):
    """``write_uff_datasets`` skips pyuff's re-read of the file after each dataset, nothing else."""
    from jointid.io.uff import write_uff_datasets

    sets = [pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0,
                              temp_offset=273.15)]
    sets += [_rec(H * (k + 1), X, rsp_node=k + 1, binary=binary) for k in range(4)]
    ours, theirs = tmp_path / "ours.uff", tmp_path / "theirs.uff"
    ours.touch()
    write_uff_datasets(ours, [dict(s) for s in sets], ours)
    _write(theirs, [dict(s) for s in sets])
    assert ours.read_bytes() == theirs.read_bytes()
    back = pyuff.UFF(str(ours))
    assert list(back.get_set_types()) == [164, 58, 58, 58, 58]
    np.testing.assert_array_equal(read_uff_frf(ours)("3w", "2w"), 3 * H if binary else read_uff_frf(theirs)("3w", "2w"))
