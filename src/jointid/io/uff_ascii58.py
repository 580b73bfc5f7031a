"""The values of ASCII dataset 58 records, parsed vectorized with pyuff's field rules.

pyuff (2.5.x) reads an ASCII record's values with one Python ``float()`` per
field, about 0.1 s per 20 000-line complex record; a 7 x 3 test at 20 000 lines
took longer to read than to identify. This module reads a record's header with
pyuff (``read_sets(i, header_only=True)``: ids, nodes, directions, units,
abscissa) and its values with numpy: the data lines are cut into the same
fixed-width fields pyuff cuts them into and converted exactly, as ``float()`` converts
them (correctly rounded), so the values are bit-identical to pyuff's
(``tests/test_io_uff_ascii58.py`` compares them on every layout): a column of ``E``
fields in one layout digit by digit (:func:`_fixed_width_floats`), anything else by
numpy's ``bytes -> float64`` cast.

pyuff's layouts (``ord_data_type``, ``abscissa_spacing``; a line's length
counts its terminator, as pyuff's does):

* 2 or 5 (single precision), any spacing: ``len(line) // 13`` fields of 13
  characters per line (``6E13.5``); blank fields of the last line are skipped;
* 4 or 6 (double), even spacing: ``len(line) // 20`` fields of 20 (``4E20.12``);
* 4, uneven: ``len(line) // 33`` pairs of 13 + 20 characters (``2(E13.5,E20.12)``);
* 6, uneven: three fields of 13, 20, 20 characters (``E13.5,2E20.12``).

Lines of one length are converted at once; anything else (binary records,
lines of differing lengths, a field running into the line end, bytes other
than printable ASCII and the line ends) is left to pyuff itself, so an
irregular file reads exactly as before and a broken one fails with pyuff's
message.

Two damages are found before pyuff reads a record:

* Fortran ``D`` exponents (``1.0D+00``, a Fortran writer's double precision):
  the numbers of record 7 and of an ASCII record's values are read with ``E``
  in their place (:func:`fortran_exponents`): the same numbers, exactly; pyuff
  alone refuses them.
* A binary record damaged by a text-mode transfer (LF made CR LF inside the binary
  data): :func:`crlf_damage` finds it from the byte count its header asks for, and
  :meth:`Uff58Reader.values` raises :class:`UffDamage` instead of reading shifted bytes.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["Uff58Reader", "UffDamage", "unclosed_dataset_line", "fortran_exponents", "crlf_damage", "binary_data_bytes"]

#: Header lines of a dataset 58 block (the leading ``    -1`` included), as pyuff counts them.
_HEADER_LINES = 13
#: The bytes a regular block holds: printable ASCII and line ends (not: line breaks ``str.splitlines`` knows and
#: ``bytes`` does not, NULs an ``S`` cast drops, tabs, non-ASCII).
_REGULAR = bytes(range(0x20, 0x7F)) + b"\r\n"


class _Irregular(Exception):
    """The record is not in a layout this module parses; pyuff reads it."""


class UffDamage(Exception):
    """A record whose bytes are damaged in a known way; the message says how, for "record N of FILE ..."."""


class Uff58Reader:
    """A UFF file read through pyuff, with dataset 58 values parsed vectorized.

    Parameters
    ----------
    path : Path
        The UFF file. ``types`` lists its datasets' type numbers (pyuff's scan).

    Raises
    ------
    Exception
        Whatever pyuff raises on a file it cannot scan (callers wrap it).
    """

    def __init__(self, path: str | Path) -> None:
        import pyuff

        self._uff = pyuff.UFF(str(path))
        self.types = [int(t) for t in self._uff.get_set_types()]
        self._path = Path(path)
        self._bytes: bytes | None = None

    def header(self, i: int) -> dict:
        """Dataset ``i`` (0-based): a 58 record's header only (no ``x``/``data``), any other dataset whole."""
        return self._read(i, header_only=self.types[i] == 58)

    def values(self, i: int, header: dict) -> dict:
        """``header`` (from :meth:`header`) completed with ``x`` and ``data`` exactly as ``pyuff.read_sets(i)`` gives them
        (Fortran ``D`` exponents read as ``E``).

        Raises
        ------
        UffDamage
            A binary record damaged by a text-mode transfer (:func:`crlf_damage`).
        """
        if self.types[i] == 58 and header.get("binary"):
            why = crlf_damage(self.block(i), header)
            if why is not None:
                raise UffDamage(why)
        if self.types[i] != 58 or header.get("binary"):
            return self._read(i)
        try:
            values = _ascii_values(self._block(i), header["ord_data_type"], header["abscissa_spacing"])
        except _Irregular:
            return self._read(i)
        d = dict(header)
        d["x"], d["data"] = _split(values, d)
        return d

    def block(self, i: int) -> bytes:
        """The bytes of dataset ``i`` as they are in the file (from its opening ``    -1`` to its closing one, excluded)."""
        if self._bytes is None:
            self._bytes = self._path.read_bytes()
        start, end = (int(v) for v in self._uff._block_ind[i])
        return self._bytes[start:end + 1]

    def line_of(self, i: int, offset: int) -> int:
        """Line (1-based) of the file at byte ``offset`` of dataset ``i``'s :meth:`block`."""
        start = int(self._uff._block_ind[i][0])
        return self.block(i)[:offset].count(b"\n") + (self._bytes or b"")[:start].count(b"\n") + 1

    def _read(self, i: int, header_only: bool = False) -> dict:
        """pyuff's reading of dataset ``i``, from the block with Fortran exponents as ``E`` when it has any (pyuff
        reads files only: that block alone, in a temporary file)."""
        fixed = fortran_exponents(self.block(i)) if self.types[i] == 58 else None
        if fixed is None:
            return self._uff.read_sets(i, header_only=header_only)
        import pyuff

        fd, name = tempfile.mkstemp(suffix=".uff")
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(fixed + b"    -1\n")
            return pyuff.UFF(name).read_sets(0, header_only=header_only)
        finally:
            os.unlink(name)

    def unclosed_dataset_line(self) -> int | None:
        """Line (1-based) where a dataset opens after the last complete one and is never closed, else None
        (:func:`unclosed_dataset_line`)."""
        if self._bytes is None:
            self._bytes = self._path.read_bytes()
        return unclosed_dataset_line(self._bytes, self._uff._block_ind)

    def _block(self, i: int) -> bytes:
        """:meth:`block`, with Fortran exponents as ``E`` (:func:`fortran_exponents`)."""
        raw = self.block(i)
        fixed = fortran_exponents(raw)
        return raw if fixed is None else fixed


#: A Fortran double precision exponent: ``D`` (or ``d``) between a number's digits and its exponent's.
_FORTRAN_EXPONENT = re.compile(rb"(?<=[0-9.])[Dd](?=[+-]?[0-9])")


def fortran_exponents(block: bytes) -> bytes | None:
    """A dataset 58 block with the ``D`` exponents of its numbers as ``E``, or None when it has none.

    Only record 7 (the abscissa minimum and increment) and, in an ASCII record, the
    value lines are changed (``1.0D+00`` -> ``1.0E+00``, the same number); the ID and
    label lines and binary values are left as they are. The block keeps its length.

    Parameters
    ----------
    block : bytes
        A dataset's bytes (:meth:`Uff58Reader.block`).
    """
    head = block[:4096].splitlines(True)[:_HEADER_LINES]  # header lines hold at most 80 characters
    if len(head) < _HEADER_LINES:
        return None
    start = sum(len(line) for line in head)
    record7 = _FORTRAN_EXPONENT.sub(b"E", head[8])
    values = None
    if head[1][6:7].lower() != b"b" and (block.find(b"D", start) >= 0 or block.find(b"d", start) >= 0):  # a byte scan
        values = _FORTRAN_EXPONENT.sub(b"E", block[start:])
        values = None if values == block[start:] else values
    if values is None and record7 == head[8]:  # the usual case: no copy of the block
        return None
    return b"".join(head[:8]) + record7 + b"".join(head[9:]) + (block[start:] if values is None else values)


def binary_data_bytes(header: dict) -> int | None:
    """The bytes of a binary dataset 58 record's values as its header describes them (as pyuff reads them), or None.

    ``num_pts`` values, complex ones (ordinate data type 5, 6) as two numbers, with the
    abscissa values of an uneven axis; 4 bytes a number in single precision (2, 5), 8 in double (4, 6).
    """
    n, odt, spacing = header.get("num_pts"), header.get("ord_data_type"), header.get("abscissa_spacing")
    if not isinstance(n, int) or odt not in (2, 4, 5, 6) or spacing not in (0, 1):
        return None
    per_point = (2 if odt in (5, 6) else 1) + (1 if spacing == 0 else 0)
    return n * per_point * (4 if odt in (2, 5) else 8)


def _fits(data: bytes, expected: int) -> bool:
    """``data`` is ``expected`` bytes, or those and a line end before the closing ``    -1`` (some writers put one)."""
    return len(data) == expected or (len(data) > expected and data[expected:] in (b"\n", b"\r\n", b"\r"))


def crlf_damage(block: bytes, header: dict) -> str | None:
    """What damaged a binary dataset 58 record by a text-mode transfer, or None (not that damage).

    A text-mode copy writes each line feed (byte 10) as CR LF, also the line feeds
    that are bytes of the binary values: the record then holds one byte more per such
    byte, and exactly the bytes its header asks for once each CR LF is taken back to LF.
    A record whose byte count is off in another way is left to the other checks.

    Parameters
    ----------
    block : bytes
        The dataset's bytes (:meth:`Uff58Reader.block`).
    header : dict
        Its header (``num_pts``, ``ord_data_type``, ``abscissa_spacing``).
    """
    expected = binary_data_bytes(header)
    lines = block.splitlines(True)
    if expected is None or len(lines) < _HEADER_LINES:
        return None
    data = block[sum(len(line) for line in lines[:_HEADER_LINES]):]
    if _fits(data, expected) or not _fits(data.replace(b"\r\n", b"\n"), expected):
        return None
    extra = len(data) - len(data.replace(b"\r\n", b"\n"))
    return (f"looks damaged by a text-mode transfer (CR LF line ends inserted into binary data: {extra} byte(s) more than "
            f"its {header['num_pts']} points take, one before each line feed byte): copy it again in binary mode")


#: A dataset delimiter: a line that reads exactly ``    -1`` (CR LF or LF; padded, pyuff does not see it either).
_DELIMITER = re.compile(rb"(?m)^    -1\r?$")


#: What may follow a file's last dataset besides one lone ``-1``: white space, NUL padding, a DOS end-of-file mark (^Z).
_TRAILER = b" \t\r\n\v\f\x00\x1a"


def unclosed_dataset_line(data: bytes, block_ind) -> int | None:
    """Line (1-based) where something starts after the last complete dataset (a dataset never closed), else None.

    pyuff lists only the datasets closed by a second ``    -1`` and ignores the rest, so a file cut
    short (an interrupted copy or export) reads as a shorter, valid file. ``block_ind`` is pyuff's
    ``(start, end)`` byte index per listed dataset, ``end`` just before its closing ``    -1``
    (on a line of its own after ASCII values, right after the bytes of a binary dataset). After
    that closing delimiter only white space, NUL bytes or a ^Z may follow, or one lone ``-1`` (it opens nothing); with
    no dataset listed, a delimiter line with anything after it is a dataset never closed (a file
    with no delimiter at all is not a UFF file: the caller says so). A cut within the first 12
    bytes of a dataset leaves only those (blanks, ``    -1``) and reads as the shorter file.

    Parameters
    ----------
    data : bytes
        The whole file.
    block_ind : array_like, shape (datasets, 2)
        pyuff's ``UFF._block_ind``.
    """
    if len(block_ind):
        start = int(block_ind[-1][1]) + 1
        close = data.find(b"    -1", start, start + 8)
        after = close + 6 if close >= 0 else start
        rest = data[after:]
        if rest.strip(_TRAILER) in (b"", b"-1"):
            return None
        return data.count(b"\n", 0, after + len(rest) - len(rest.lstrip(_TRAILER))) + 1
    m = _DELIMITER.search(data)
    if m is None or not data[m.end():].strip(_TRAILER):
        return None
    return data.count(b"\n", 0, m.start()) + 1


def _split(values: np.ndarray, d: dict) -> tuple[np.ndarray, np.ndarray]:
    """Abscissa and ordinate of a record's values, with pyuff's expressions (``_extract58``)."""
    odt, spacing = d["ord_data_type"], d["abscissa_spacing"]
    if odt in (2, 4):
        if spacing == 0:
            return values[:-1:2].copy(), values[1::2].copy()
        return d["abscissa_min"] + np.arange(len(values)) * d["abscissa_inc"], values.copy()
    if spacing == 0:
        return values[:-2:3].copy(), values[1:-1:3] + 1.0j * values[2::3]
    n_val = len(values) / 2
    return d["abscissa_min"] + np.arange(n_val) * d["abscissa_inc"], values[0:-1:2] + 1.0j * values[1::2]


def _fields(odt: int, spacing: int, length: int) -> list[tuple[int, int]]:
    """(start, width) of the fields pyuff reads from a line of ``length`` characters (terminator included)."""
    if odt in (2, 5):
        return [(13 * i, 13) for i in range(length // 13)]
    if odt in (4, 6) and spacing == 1:
        return [(20 * i, 20) for i in range(length // 20)]
    if odt == 4 and spacing == 0:
        return [f for i in range(length // 33) for f in ((33 * i, 13), (33 * i + 13, 20))]
    if odt == 6 and spacing == 0:
        return [(0, 13), (13, 20), (33, 20)]
    raise _Irregular


#: Powers of ten exact in float64 (10^22 is the largest): a decimal of at most 15 digits scaled by one of them
#: is rounded once, as ``strtod`` rounds it.
_EXACT_TENS = 10.0 ** np.arange(23)


def _fixed_width_floats(chars: np.ndarray) -> np.ndarray:
    """The numbers of one fixed-width column of ASCII characters, shape (lines, width) uint8, as float64.

    A column of Fortran ``E`` fields -- right-aligned ``[-]d.ddd...E+dd`` with one layout on every line, as
    UFF writers (and jointid) write them -- is read digit by digit: the mantissa's ``p <= 15`` digits form an
    integer ``m`` (exact in float64) and the value is ``m * 10^k`` or ``m / 10^-k`` with ``|k| <= 22``, one
    correctly rounded operation on two exact numbers (Clinger's fast path): the float ``strtod`` gives, bit for
    bit (tested against numpy's parser). Measured on 800 000 values: 1.6x (E20.12) to 3x (E13.5) faster than
    numpy's ``astype`` from bytes; the benchmark's 17 MB UFF (19 901 lines, 7 x 3) is read in 0.29-0.36 s instead
    of 0.42-0.51 s (a fresh process's first read, 5 interleaved runs).
    Anything else (other layouts, longer mantissas, values whose scale is beyond ``10^+-22``) is parsed by
    numpy's ``astype``.

    Raises
    ------
    _Irregular
        A field that is not a number.
    """
    lines, width = chars.shape
    fast = _e_format_floats(chars) if lines else None
    if fast is not None:
        values, parsed = fast
        if parsed.all():
            return values
        rest = ~parsed
        values[rest] = _numpy_floats(chars[rest])
        return values
    return _numpy_floats(chars)


def _numpy_floats(chars: np.ndarray) -> np.ndarray:
    width = chars.shape[1]
    text = np.ascontiguousarray(chars).view(f"S{width}")[:, 0]
    try:
        return text.astype(np.float64)
    except ValueError:
        raise _Irregular from None


def _e_format_floats(chars: np.ndarray, block: int = 1 << 15):
    """``(values, parsed)`` of a column in one ``[-]d.ddd...E+dd`` layout (:func:`_fixed_width_floats`), else None.

    The mantissa is a product of its digits with the powers of ten, in float64: every partial sum is an integer
    below ``10^15 < 2^53``, so exact in any order. Done by blocks of ``block`` lines (kept in cache).
    """
    width = chars.shape[1]
    dot = bytes(chars[0]).find(b".")
    decimals = width - 5 - dot
    if dot < 1 or decimals < 0 or decimals > 14:
        return None
    digit_cols = np.r_[dot - 1, dot + 1:width - 4]
    tens = 10.0 ** np.arange(decimals, -1, -1)
    lines = chars.shape[0]
    values, parsed = np.empty(lines), np.empty(lines, bool)
    for a in range(0, lines, block):
        c = chars[a:a + block]
        digits = c[:, digit_cols] - np.uint8(48)  # wraps below '0': one test for both ends
        e_digits = c[:, width - 2:] - np.uint8(48)
        sign, e_sign = c[:, dot - 1 - 1] if dot > 1 else None, c[:, width - 3]
        ok = ((c[:, dot] == 46) & ((c[:, width - 4] | 32) == 101) & ((e_sign == 43) | (e_sign == 45))
              & np.all(digits <= 9, axis=1) & np.all(e_digits <= 9, axis=1))
        if dot > 1:  # blanks, then at most one minus sign just before the first digit
            ok &= ((sign == 32) | (sign == 45)) & np.all(c[:, :dot - 2] == 32, axis=1)
        if not ok.all():
            return None
        exponent = e_digits[:, 0].astype(np.int64) * 10 + e_digits[:, 1]
        k = np.where(e_sign == 45, -exponent, exponent) - decimals
        scale = _EXACT_TENS[np.minimum(np.abs(k), 22)]
        m = digits @ tens
        v = np.where(k >= 0, m * scale, m / scale)
        values[a:a + block] = np.where(sign == 45, -v, v) if dot > 1 else v
        parsed[a:a + block] = np.abs(k) <= 22
    return values, parsed


def _ascii_values(block: bytes, odt: int, spacing: int) -> np.ndarray:
    """Every value of an ASCII 58 block, in file order (float64).

    The lines are found from the positions of the line feeds (``\\n`` or ``\\r\\n``, the
    terminators ``splitlines`` keeps): the data lines but the last must all have one
    length, so they form one (lines, length) character array.
    """
    if odt not in (2, 4, 5, 6) or block.translate(None, _REGULAR):  # anything left is irregular
        raise _Irregular
    chars = np.frombuffer(block, dtype=np.uint8)
    nl = np.flatnonzero(chars == 10)
    cr = np.flatnonzero(chars == 13)
    if nl.size < _HEADER_LINES or (cr.size and (cr[-1] + 1 >= chars.size or np.any(chars[cr + 1] != 10))):
        raise _Irregular  # a lone CR is a line break to pyuff's str.splitlines
    bounds = np.concatenate([[nl[_HEADER_LINES - 1] + 1], nl[_HEADER_LINES:] + 1])  # starts of the data lines, then ends
    if bounds[-1] < chars.size:  # an unterminated last line
        bounds = np.append(bounds, chars.size)
    if bounds.size < 2:
        raise _Irregular
    last = block[bounds[-2]:bounds[-1]]
    parts = []
    if bounds.size > 2:
        lengths = np.diff(bounds[:-1])
        length = int(lengths[0])
        if np.any(lengths != length):
            raise _Irregular
        body = chars[bounds[0]:bounds[-2]].reshape(-1, length)
        ends = body[:, -2:]
        term = 2 if ends[0, 0] == 13 else 1
        if np.any((ends[:, 0] == 13) != (term == 2)):
            raise _Irregular
        fields = _fields(odt, spacing, length)
        if not fields or fields[-1][0] + fields[-1][1] > length - term:
            raise _Irregular
        columns = []
        for start, width in fields:
            columns.append(_fixed_width_floats(body[:, start:start + width]))
        parts.append(np.stack(columns, axis=1).reshape(-1))
    text = last.decode("ascii")
    skip_blank = odt in (2, 5)
    try:
        tail = [float(text[s:s + w]) for s, w in _fields(odt, spacing, len(text)) if not (skip_blank and text[s:s + w] == " " * 13)]
    except ValueError:
        raise _Irregular from None
    parts.append(np.asarray(tail, dtype=np.float64))
    return np.concatenate(parts)
