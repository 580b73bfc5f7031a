"""Atomic file output: write to a temporary file in the target directory, then rename.

A reader never sees a half-written file, and an exception while writing leaves
the previous file (or no file) in place, with no temporary file behind.

The temporary file is created with mode ``0o666`` filtered by the process
umask, like any file ``open(path, "w")`` creates, so the renamed file gets the
user's usual permissions (typically ``0o644``), not the ``0o600`` of
:func:`tempfile.mkstemp`.

For a command's whole output directory (several files that appear together,
a manifest, a lock) use :class:`jointid.io.output_dir.OutputSet`.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path
from typing import Iterator

__all__ = ["atomic_path", "atomic_write_text", "atomic_write_bytes", "create_temp_file"]


def create_temp_file(directory: str | os.PathLike, prefix: str, suffix: str = "") -> Path:
    """Create a new empty file ``directory/prefix<random>suffix`` with umask permissions.

    Parameters
    ----------
    directory : path-like
        Existing directory to create the file in.
    prefix, suffix : str
        Start and end of the file name.

    Returns
    -------
    Path
        The created file (``O_CREAT | O_EXCL``: never an existing one).
    """
    for _ in range(100):
        path = Path(directory) / f"{prefix}{secrets.token_hex(6)}{suffix}"
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the kernel applies the umask
        except FileExistsError:  # pragma: no cover - 48 random bits
            continue
        os.close(fd)
        return path
    raise FileExistsError(f"cannot create a temporary file in {directory}")  # pragma: no cover


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it onto ``path``.

    Parameters
    ----------
    path : path-like
        Final destination. Its directory is created if missing.
    suffix : str, optional
        Suffix of the temporary file (default: that of ``path``, so writers
        that infer a format from the extension, like matplotlib, still work).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp_path = create_temp_file(path.parent, f".{path.name}.", suffix if suffix is not None else path.suffix)
    try:
        yield tmp_path
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
