"""Staging folders of an output directory left by a stopped run: which ones jointid removes.

:class:`~jointid.io.output_dir.OutputSet` produces its files in ``DIR/.jointid-staging-*``
(:func:`tempfile.mkdtemp`: the prefix and 8 characters of ``[a-z0-9_]``) and marks it with
a file ``.jointid-staging``. A run killed before it removed its staging folder leaves it;
the next run into ``DIR`` (holding ``DIR``'s lock) removes it with :func:`clear_stale_staging`:

* a marked folder: the whole folder (only jointid puts the mark there);
* an unmarked folder (a jointid older than the mark wrote none), only if its name is
  exactly a staging folder's and it holds nothing but regular files jointid could have
  written there -- names listed in ``DIR``'s manifest, or one of :data:`KNOWN_OUTPUT_NAMES`
  -- and directories; then exactly those files are removed, and the directories if they
  are empty afterwards (a file put there meanwhile stays). Otherwise it is left, and
  one line on stderr (once per folder and process) names it and says what to do;
* any other folder whose name starts with ``.jointid-staging-`` is not a staging folder: left, silently.

A user's file is never removed: a symbolic link, a special file or an unknown name
inside an unmarked folder leaves the whole folder in place.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import sys
from pathlib import Path, PurePosixPath
from typing import Iterable

__all__ = ["STAGING_PREFIX", "STAGING_MARK", "KNOWN_OUTPUT_NAMES", "clear_stale_staging", "unknown_entry"]

#: Prefix of the staging directory inside the output directory.
STAGING_PREFIX = ".jointid-staging-"
#: The file that marks a staging directory as jointid's (a marked one is removed whole as a stopped run's).
STAGING_MARK = ".jointid-staging"
#: The exact name of a staging directory (:func:`tempfile.mkdtemp` with :data:`STAGING_PREFIX`).
_STAGING_NAME = re.compile(r"^" + re.escape(STAGING_PREFIX) + r"[a-z0-9_]{8}$")
#: Output names the ``jointid`` commands always use (relative POSIX names); names made per run (a joint's
#: CSV, ``figures/<name>.png``) are recognized through the manifest only.
KNOWN_OUTPUT_NAMES = frozenset({
    "campaign.json", "design.json", "design.png", "direct_fit.json", "direct_stiffness.csv", "direct_stiffness.png",
    "experiment_errors.csv", "free_frf.uff", "frf.png", "frf.uff", "joint_stiffness.csv", "joint_stiffness.png",
    "master_curve.json", "modes.csv", "modes_frf.png", "rejected_hits.csv", "report.html", "summary.json",
    "update.json", "update.png", "updated_study.toml",
})

_reported: set[str] = set()


def unknown_entry(folder: Path, names: Iterable[str]) -> tuple[str | None, list[str], list[str]]:
    """The first entry of ``folder`` that is not a regular file of one of ``names`` nor a directory, or None.

    Parameters
    ----------
    folder : Path
        An unmarked staging folder.
    names : iterable of str
        Relative POSIX names jointid could have written (an output staged at ``folder / name``).

    Returns
    -------
    tuple
        (the first other entry, relative POSIX name, or None; the files found, relative, in
        walk order; the directories found, relative, outermost first). An entry that cannot be read
        counts as another entry.
    """
    allowed = set(names)
    files: list[str] = []
    dirs: list[str] = []
    todo = [PurePosixPath()]
    while todo:
        rel = todo.pop()
        try:
            entries = sorted(os.scandir(folder / rel), key=lambda e: e.name)
        except OSError:
            return (rel.as_posix() if rel.parts else "."), files, dirs
        for e in entries:
            name = (rel / e.name).as_posix()
            try:
                if e.is_symlink():
                    return name, files, dirs
                if e.is_dir(follow_symlinks=False):
                    dirs.append(name)
                    todo.append(rel / e.name)
                elif e.is_file(follow_symlinks=False) and name in allowed:
                    files.append(name)
                else:
                    return name, files, dirs
            except OSError:
                return name, files, dirs
    return None, files, dirs


def clear_stale_staging(directory: Path, owned: Iterable[str], command: str) -> list[Path]:
    """Remove the staging folders stopped runs left in ``directory`` (module docstring); the caller holds its lock.

    Parameters
    ----------
    directory : Path
        The output directory.
    owned : iterable of str
        Every name ``directory``'s manifest lists (any command's).
    command : str
        The running command, for the note on an unmarked folder that is left (``"identify"``).

    Returns
    -------
    list of Path
        The folders removed.
    """
    removed = []
    allowed = set(owned) | KNOWN_OUTPUT_NAMES
    for old in sorted(directory.glob(STAGING_PREFIX + "*")):
        if not old.is_dir() or old.is_symlink():
            continue
        if (old / STAGING_MARK).is_file():
            shutil.rmtree(old, ignore_errors=True)
            removed.append(old)
            continue
        if not _STAGING_NAME.match(old.name):
            continue
        other, files, dirs = unknown_entry(old, allowed)
        if other is None:
            with contextlib.suppress(OSError):
                for name in files:
                    os.unlink(old / name)
                for name in reversed(dirs):
                    os.rmdir(old / name)
                os.rmdir(old)
                removed.append(old)
            continue
        if str(old) not in _reported:
            _reported.add(str(old))
            who = " ".join(["jointid"] + command.split()[:1])
            print(f"{who}: note: left {old}: it is named like the staging folder of a stopped run "
                  f"of an older jointid, but holds {other}, which jointid does not write there; look inside, then move or "
                  "remove it yourself", file=sys.stderr)
    return removed
