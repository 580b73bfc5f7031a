"""The manifest of an output directory: which files jointid wrote there, and what each commit of this process did.

``DIR/.jointid-manifest.json`` lists, per command, the files jointid wrote (relative POSIX names)
with the SHA-256 of their content, and the subdirectories it created; :class:`~.output_dir.OutputSet`
replaces or removes only files listed there whose content is unchanged. A manifest that cannot be read
owns nothing, and a name in it that leaves the directory or is reserved is not jointid's
(:func:`read_manifest`): an edited manifest cannot make jointid touch anything outside ``DIR``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from .atomic import atomic_write_text

__all__ = ["MANIFEST_NAME", "manifest_temp_files", "Commit", "commits", "record_commit", "empty_manifest", "read_manifest",
           "write_manifest", "output_key", "valid_name"]

#: Manifest of the files jointid wrote in an output directory.
MANIFEST_NAME = ".jointid-manifest.json"
#: Temporary file of the manifest's atomic write (:func:`~.atomic.atomic_path`: ``.<name>.<12 hex>.json``).
_MANIFEST_TEMP = re.compile(r"^\." + re.escape(MANIFEST_NAME) + r"\.[0-9a-f]{12}\.json$")
_MANIFEST_FORMAT = "jointid-output-manifest"


@dataclass(frozen=True)
class Commit:
    """What one :meth:`OutputSet.commit` did: its directory, command, files and those taken from other commands.

    Attributes
    ----------
    directory : Path
    command : str
    files : tuple of str
        Names written (relative POSIX paths).
    taken_over : dict
        Name -> the command that had written it before (now this command's).
    """

    directory: Path
    command: str
    files: tuple
    taken_over: dict


_COMMITS: list[Commit] = []


def record_commit(commit: Commit) -> None:
    """Record what one commit did (:func:`commits`)."""
    _COMMITS.append(commit)


def commits() -> tuple[Commit, ...]:
    """The commits of this process so far, oldest first."""
    return tuple(_COMMITS)


def empty_manifest() -> dict:
    """A manifest that owns nothing."""
    return {"format": _MANIFEST_FORMAT, "version": 1, "sets": {}, "directories": []}


def read_manifest(directory: Path) -> tuple[dict, bool]:
    """The manifest of ``directory`` and whether there was a readable one; an absent or unreadable one owns nothing
    (the safe reading)."""
    try:
        data = json.loads((directory / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return empty_manifest(), False
    if not isinstance(data, dict) or data.get("format") != _MANIFEST_FORMAT:
        return empty_manifest(), False
    sets = data.get("sets")
    dirs = data.get("directories")
    m = empty_manifest()
    if isinstance(sets, dict):
        for cmd, files in sets.items():
            if isinstance(files, dict):
                m["sets"][str(cmd)] = {str(k): [str(h) for h in v] for k, v in files.items() if isinstance(v, list) and valid_name(k)}
    if isinstance(dirs, list):
        m["directories"] = [str(d) for d in dirs if valid_name(d)]
    return m, True


def valid_name(name) -> bool:
    """A name jointid could have written: relative, inside the directory, not reserved (a manifest edited to list
    ``../x`` or ``/x`` would otherwise make jointid replace or remove files outside ``DIR``)."""
    try:
        return isinstance(name, str) and output_key(name) == name
    except ValueError:
        return False


def write_manifest(directory: Path, manifest: dict) -> None:
    """Write ``manifest`` as ``directory``'s, atomically."""
    atomic_write_text(directory / MANIFEST_NAME, json.dumps(manifest, indent=1, sort_keys=True) + "\n")


def output_key(name: str) -> str:
    """Normalized relative POSIX name; ValueError (a programming error) for anything else."""
    p = PurePosixPath(name)
    if not name or "\\" in name or p.is_absolute() or any(part in ("", ".", "..") for part in p.parts) or p.as_posix() != name.rstrip("/"):
        raise ValueError(f"output name {name!r}: expected a relative path like 'data/x.csv'")
    if p.parts[0].startswith(".jointid"):
        raise ValueError(f"output name {name!r}: names starting with '.jointid' are reserved")
    return p.as_posix()


def manifest_temp_files(directory: Path) -> list[Path]:
    """The manifest's temporary files in ``directory`` (regular files), left by a run killed while writing it."""
    return [p for p in directory.glob("." + MANIFEST_NAME + ".*") if _MANIFEST_TEMP.match(p.name) and p.is_file() and not p.is_symlink()]
