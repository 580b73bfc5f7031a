"""Reading user text files (CSV): UTF-8 decoding and the comma separator, with one-line errors."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import DataError

__all__ = ["read_utf8", "check_separator"]


def read_utf8(path: str | os.PathLike, what: str = "file") -> str:
    """The text of ``path`` decoded as UTF-8 (a byte-order mark is dropped).

    Raises
    ------
    DataError
        The file cannot be read, is UTF-16 (a byte-order mark), or is not UTF-8 (naming the line and the byte).
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise DataError(f"{p}: cannot read the {what} ({exc.strerror or exc})") from None
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise DataError(f"{p} line 1: UTF-16 text (a spreadsheet's 'Unicode text'); save the {what} as UTF-8 (e.g. 'CSV UTF-8')")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise DataError(
            f"{p} line {line}: not UTF-8 text (byte {raw[exc.start]:#04x}); save the {what} as UTF-8 "
            "(e.g. 'CSV UTF-8' in a spreadsheet)"
        ) from None


def check_separator(path: str | os.PathLike, header: list[str], lineno: int = 1) -> None:
    """Refuse a header row that is separated by semicolons or tabs instead of commas.

    Raises
    ------
    DataError
        If the header is one cell holding ``;`` or a tab (a spreadsheet export in a
        locale with decimal commas).
    """
    if len(header) == 1:
        for sep, name in ((";", "semicolons"), ("\t", "tabs")):
            if sep in header[0]:
                raise DataError(
                    f"{path} line {lineno}: the columns are separated by {name}; jointid reads comma-separated "
                    "CSV with '.' as the decimal point: export it so (or replace the separators)"
                )
