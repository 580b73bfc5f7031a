"""One writer for a command's output directory: :class:`OutputSet`.

Every ``jointid`` command writes its files through an :class:`OutputSet`::

    with OutputSet(args.out, command="identify") as out:   # validates, locks DIR
        result = compute(...)                               # nothing in DIR yet
        out.write_csv("joint_stiffness.csv", result.columns())
        out.write_text("summary.json", text)
        out.write_figure("joint_stiffness.png", fig)
    # leaving the block without an exception commits the set; with one, DIR is as before

What a user can rely on
-----------------------
* ``DIR`` is only ever added to. jointid replaces or removes a file in ``DIR``
  only if it is in jointid's manifest ``DIR/.jointid-manifest.json`` (a file
  jointid wrote) *and* its content is still what jointid wrote (SHA-256). Any
  other file or directory in ``DIR`` is left exactly as it was: ``--out .`` in a
  git checkout leaves ``.git`` and the sources alone.
* If ``DIR`` exists and is not a directory: :class:`OutputError`
  ``"--out DIR is a file; give a directory"`` (exit 2), nothing touched.
* If a file the command would write exists in ``DIR`` but jointid did not write
  it (or it was edited since): :class:`OutputError` naming it, asking to move it
  or choose another ``--out``; nothing written. This is checked as each file is
  produced and again before the first rename.
* ``DIR`` is created if missing, locked and checked writable on entry, *before*
  any computation. A second run into the same ``DIR`` while one is running is
  refused with one line naming ``DIR`` (``fcntl.flock`` on ``DIR/.jointid.lock``;
  the lock file is removed when the run ends).
* Files are produced in a staging directory ``DIR/.jointid-staging-*`` (same
  file system; marked by a file of its own, so that only jointid's staging is
  ever removed) and renamed into place one by one with :func:`os.replace` only
  after *all* of them were produced; an exception before that (a failing
  computation, Ctrl-C, a full disk while staging) leaves ``DIR`` exactly as it
  was (a ``DIR`` this run created is removed again), with no temporary debris.
  SIGTERM and SIGINT unwind the same way under the ``jointid`` command (its
  handlers raise :class:`~jointid.errors.Terminated` / ``KeyboardInterrupt``):
  staging area and lock removed, ``DIR`` as before. A signal that arrives while
  the files are being renamed into place or the staging area is being removed is
  held until that step is done (the set is then complete, or untouched).
  A failure while renaming (a subdirectory made read-only meanwhile) puts the
  previous files back (kept as hard links until the set is complete): the set
  is complete or as before, never half of each.
  Staging left by a killed run (SIGKILL) is removed by the next run into ``DIR``;
  an unmarked one (an older jointid's) only if it holds nothing but files jointid
  writes there, else it is left and named on stderr (:mod:`jointid.io.staging`).
* jointid writes, replaces and removes files only in real directories inside
  ``DIR``: an output whose parent inside ``DIR`` is a symbolic link is refused
  (a link to a directory elsewhere would let it write or delete there), and the
  manifest's names are checked (a name leaving ``DIR`` is not jointid's).
* Files of the same command's previous set that this run does not produce (a
  PNG after ``--no-plots``) are removed, if unchanged. The sets of other
  commands writing into the same ``DIR`` are kept (``jointid simulate --out d``
  then ``jointid identify --frf d/frf.uff --out d`` keeps ``d/frf.uff``); a file
  two commands write belongs to the one that wrote it last.
* Subdirectories (``figures/``, ``data/``) are created as needed; jointid
  removes a subdirectory only if it created it and it is empty.
* Files and directories get the user's umask permissions (like ``open``/``mkdir``).
* What each commit did is recorded in this process (:func:`commits`): the
  ``jointid`` command says so when a stop signal came after its output was
  complete, and names the files it took over from another command.

The manifest survives a crash between renames: before the first rename it lists
both the old and the new content of every file being replaced.

Names are relative POSIX paths (``"figures/a.png"``); names starting with
``.jointid`` are reserved.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import signal
import tempfile
import threading
from pathlib import Path, PurePosixPath
from typing import Callable, Mapping, Sequence

from ..errors import JointIdError
from .atomic import atomic_write_bytes
from .output_manifest import (
    MANIFEST_NAME, Commit, commits, empty_manifest, manifest_temp_files, output_key, read_manifest, record_commit, write_manifest,
)
from .staging import STAGING_MARK, STAGING_PREFIX, clear_stale_staging
from .tables import format_csv

try:  # POSIX; elsewhere runs are not locked against each other
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None

__all__ = ["OutputSet", "OutputError", "Commit", "commits", "MANIFEST_NAME", "LOCK_NAME", "STAGING_PREFIX"]

#: Lock file held (flock) while a run writes into the directory.
LOCK_NAME = ".jointid.lock"
#: The staging area's folder of the files a commit replaces, kept until the set is in place (a reserved name).
_BACKUP_DIR = ".jointid-previous"


class OutputError(JointIdError, OSError):
    """An output directory cannot be used as asked; the message names it and says what to do."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


_DEFERRED_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGINT") if hasattr(signal, name))


@contextlib.contextmanager
def _signals_held():
    """SIGTERM/SIGINT arriving inside the block are handled when it ends (main thread; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    saved = {}
    for s in _DEFERRED_SIGNALS:
        with contextlib.suppress(ValueError, OSError):
            saved[s] = signal.signal(s, lambda signum, frame: pending.append(signum))
    try:
        yield
    finally:
        for s, h in saved.items():
            signal.signal(s, h)
        if pending:
            h = saved.get(pending[0])
            if callable(h):
                h(pending[0], None)
            elif h == signal.SIG_DFL:
                signal.raise_signal(pending[0])


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _real_path(directory: Path, key: str) -> bool:
    """Every parent of ``key`` inside ``directory`` that exists is a real directory (no symbolic link on the way)."""
    parts = PurePosixPath(key).parts
    for i in range(1, len(parts)):
        sub = directory.joinpath(*parts[:i])
        if os.path.islink(sub) or (os.path.lexists(sub) and not sub.is_dir()):
            return False
    return True


def _makedirs(path: Path) -> list[Path]:
    """``mkdir -p path``; returns the directories it created, outermost first."""
    missing = []
    p = path
    while not p.exists() and not p.is_symlink():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    created = []
    try:
        for d in reversed(missing):
            os.mkdir(d)  # mode 0o777 filtered by the umask
            created.append(d)
    except OSError:  # e.g. a name too long for the file system: the parents made so far go again
        for d in reversed(created):
            with contextlib.suppress(OSError):
                os.rmdir(d)
        raise
    return created


class OutputSet:
    """The files one command writes into an output directory, committed together.

    Parameters
    ----------
    directory : path-like
        The ``--out`` directory; created (with missing parents) on :meth:`open`.
    command : str
        Name of the command (``"identify"``, ``"reproduce"``, ...): the manifest
        keeps one set of files per command, and a run removes stale files of
        its own command's previous set only.

    Notes
    -----
    Use it as a context manager (``with OutputSet(out, "identify") as o:``):
    entering opens (validate, create, lock, stage), leaving without an
    exception commits, leaving with one discards everything. ``open``,
    ``commit`` and ``close`` are also public for callers that cannot use
    ``with``. Not thread-safe: one OutputSet per run.
    """

    def __init__(self, directory: str | os.PathLike, command: str):
        self.directory = Path(directory)
        self.command = str(command)
        self._staging: Path | None = None
        self._lock_fd: int | None = None
        self._created: list[Path] = []
        self._manifest = empty_manifest()
        self._files: dict[str, Path] = {}
        self._committed = False
        self._manifest_found = False
        self._manifest_unreadable = False
        self._manifest_bytes: bytes | None = None

    # ------------------------------------------------------------ lifecycle
    def __enter__(self) -> "OutputSet":
        return self.open()

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            try:
                self.commit()
            finally:
                self.close()
        else:
            self.close()

    def open(self) -> "OutputSet":
        """Validate ``directory`` (a directory, writable, not in use), create it if missing, lock it.

        Raises
        ------
        OutputError
            ``--out DIR is a file; give a directory``, not creatable or not
            writable, or in use by another jointid run. Nothing is changed then.
        """
        d = self.directory
        if self._staging is not None:
            raise RuntimeError("OutputSet is already open")
        try:
            if d.is_symlink() and not d.exists():
                raise OutputError(f"--out {d} is a symbolic link to {os.readlink(d)}, which does not exist; create that "
                                  "directory or give another --out")
            if d.exists() and not d.is_dir():
                raise OutputError(f"--out {d} is a file; give a directory")
            self._created = _makedirs(d)
        except OSError as exc:
            if isinstance(exc, OutputError):
                raise
            raise OutputError(f"--out {d}: cannot create the directory: {exc.strerror or exc}; give another --out") from exc
        try:
            self._lock()
            self._manifest_bytes = (d / MANIFEST_NAME).read_bytes() if (d / MANIFEST_NAME).is_file() else None
            self._manifest, readable = read_manifest(d)
            self._manifest_found = readable
            self._manifest_unreadable = not readable and os.path.lexists(d / MANIFEST_NAME)
            owned = {k for files in self._manifest["sets"].values() for k in files}
            clear_stale_staging(d, owned, self.command)  # left by a killed run; we hold the lock
            for old in manifest_temp_files(d):  # the manifest's temporary file of a killed run
                with contextlib.suppress(OSError):
                    old.unlink()
            try:
                self._staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=d))
                (self._staging / STAGING_MARK).touch()
            except OSError as exc:
                raise OutputError(f"--out {d} is not writable: {exc.strerror or exc}") from exc
        except BaseException:
            self._release(failed=True)
            raise
        return self

    def close(self) -> None:
        """Discard what was staged and not committed, unlock; a ``DIR`` created by a failed run is removed."""
        self._release(failed=not self._committed)

    def _lock(self) -> None:
        path = self.directory / LOCK_NAME
        while True:
            if os.path.islink(path):
                raise OutputError(f"{path} is a symbolic link (jointid's lock file name); remove it and run again")
            try:
                fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
            except OSError as exc:
                raise OutputError(f"--out {self.directory} is not writable: {exc.strerror or exc}") from exc
            if fcntl is None:  # pragma: no cover
                self._lock_fd = fd
                return
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise OutputError(
                    f"--out {self.directory} is being written by another jointid run; wait for it to finish or choose another --out"
                ) from None
            # the previous holder removes the lock file before it unlocks: make sure we locked the file that is there now
            try:
                same = os.path.samestat(os.stat(path), os.fstat(fd))
            except FileNotFoundError:
                same = False
            if same:
                self._lock_fd = fd
                return
            os.close(fd)

    def _release(self, failed: bool) -> None:
        with _signals_held():
            self._release_now(failed)

    def _release_now(self, failed: bool) -> None:
        if self._staging is not None:
            shutil.rmtree(self._staging, ignore_errors=True)
            self._staging = None
        if self._lock_fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.directory / LOCK_NAME)  # while still locked (see _lock)
            os.close(self._lock_fd)
            self._lock_fd = None
        if failed:
            for d in reversed(self._created):  # a DIR this run created goes again, if empty
                with contextlib.suppress(OSError):
                    os.rmdir(d)
        self._created = []

    # ------------------------------------------------------------ writing
    def path(self, name: str) -> Path:
        """Final path of output ``name`` in the directory (for messages; it exists after commit)."""
        return self.directory / output_key(name)

    def staged(self, name: str) -> Path:
        """Staged file of output ``name``, already written in this set (to read it back before commit)."""
        key = output_key(name)
        if key not in self._files:
            raise KeyError(f"{name!r} was not written in this output set")
        return self._files[key]

    @property
    def names(self) -> tuple[str, ...]:
        """Names written so far, in order."""
        return tuple(self._files)

    def check(self, *names: str) -> None:
        """Refuse now, before anything is computed, if writing any of ``names`` would replace a file
        jointid did not write (or one edited since): the same one-line :class:`OutputError` a
        ``write_*`` of that name raises. Nothing is staged.
        """
        if self._staging is None:
            raise RuntimeError("OutputSet is not open (use it in a with block)")
        for name in names:
            self._check_target(output_key(name))

    def write_bytes(self, name: str, data: bytes) -> Path:
        """Stage ``data`` as output ``name``; returns its final path."""
        return self.write_file(name, lambda p: p.write_bytes(data))

    def write_text(self, name: str, text: str) -> Path:
        """Stage ``text`` (UTF-8) as output ``name``; returns its final path."""
        return self.write_file(name, lambda p: p.write_text(text, encoding="utf-8"))

    def write_csv(self, name: str, columns: Mapping[str, Sequence]) -> Path:
        """Stage equal-length ``columns`` as CSV (:func:`jointid.io.tables.format_csv`); returns the final path."""
        text = format_csv(columns)
        return self.write_text(name, text)

    def write_figure(self, name: str, fig, dpi: int = 120) -> Path:
        """Stage matplotlib ``fig`` as a PNG (:func:`~jointid.io.png.figure_png`); returns the final path."""
        from .png import figure_png

        return self.write_bytes(name, figure_png(fig, dpi=dpi))

    def write_file(self, name: str, writer: Callable[[Path], object]) -> Path:
        """Stage output ``name`` with ``writer(path)``, which must create the file at ``path``.

        For writers that take a path (``write_uff_frf``, ``np.savez``...). An
        ``OSError`` while staging is reported naming the final path, never
        the staging one. Returns the final path.
        """
        if self._staging is None:
            raise RuntimeError("OutputSet is not open (use it in a with block)")
        key = output_key(name)
        if key in self._files:
            raise ValueError(f"output {key!r} written twice in one output set")
        self._check_target(key)
        staged = self._staging / key
        final = self.directory / key
        try:
            staged.parent.mkdir(parents=True, exist_ok=True)
            writer(staged)
        except OSError as exc:
            raise OutputError(f"cannot write {final}: {exc.strerror or exc}") from exc
        if not staged.is_file():
            raise RuntimeError(f"the writer of {key!r} produced no file")
        self._files[key] = staged
        return final

    # ------------------------------------------------------------ commit
    def _owner(self, key: str) -> tuple[str, list[str]] | None:
        """(command, hashes) of the manifest entry of ``key``, or None if jointid does not own it."""
        for cmd, files in self._manifest["sets"].items():
            if key in files:
                return cmd, files[key]
        return None

    def _check_target(self, key: str) -> None:
        """Refuse if writing ``key`` would replace something jointid did not write."""
        d = self.directory
        parts = PurePosixPath(key).parts
        for i in range(1, len(parts)):
            sub = d.joinpath(*parts[:i])
            if os.path.islink(sub):
                raise OutputError(f"{sub} is a symbolic link and jointid would write {d / key} through it (jointid writes only "
                                  "into real directories of --out); replace it by a directory or choose another --out")
            if os.path.lexists(sub) and not sub.is_dir():
                raise OutputError(f"{sub} is not a directory and jointid would write {d / key}; move it or choose another --out")
        target = d / key
        if not os.path.lexists(target):
            return
        owner = self._owner(key)
        if target.is_symlink() or not target.is_file() or owner is None:
            if not target.is_symlink() and target.is_file() and self._manifest_unreadable:
                raise OutputError(f"{target} exists, and jointid's record of the files it wrote ({d / MANIFEST_NAME}) cannot "
                                  "be read; move the file away or choose another --out")
            raise OutputError(f"{target} exists and was not written by jointid; move it or choose another --out")
        if _sha256(target) not in owner[1]:
            raise OutputError(f"{target} was changed after jointid wrote it; move it or choose another --out")

    def commit(self) -> tuple[Path, ...]:
        """Rename every staged file into place, remove this command's stale files, update the manifest.

        Returns the final paths written. Raises :class:`OutputError` if a target became a file jointid did
        not write meanwhile (nothing renamed), if renaming failed (the previous files put back), or if the
        set is in place but its tidying or final manifest failed (the commit is complete and recorded).
        """
        if self._staging is None:
            raise RuntimeError("OutputSet is not open")
        d = self.directory
        for key in self._files:  # again: a user may have put a file there while we computed
            self._check_target(key)
        new = {key: _sha256(staged) for key, staged in self._files.items()}
        sets = {cmd: dict(files) for cmd, files in self._manifest["sets"].items()}
        previous = sets.pop(self.command, {})
        taken = {k: cmd for cmd, files in sets.items() for k in files if k in new and os.path.lexists(d / k)}
        for cmd in sets:  # a file this run writes now belongs to this command
            sets[cmd] = {k: v for k, v in sets[cmd].items() if k not in new}
        dirs = sorted(set(self._manifest["directories"]) | self._new_directories())
        with _signals_held():  # a stop signal now is raised once the set is complete (and recorded as such)
            self._place_files(new, sets, previous, dirs)
            self._committed = True
            record_commit(Commit(d, self.command, tuple(self._files), taken))
            self._tidy(new, sets, previous, dirs)
        return tuple(d / key for key in self._files)

    def _new_directories(self) -> set:
        """The subdirectories (relative names) this set needs that are not there yet."""
        out = set()
        for key in self._files:
            parent = PurePosixPath(key).parent
            for i in range(1, len(parent.parts) + 1):
                sub = PurePosixPath(*parent.parts[:i]).as_posix()
                if not (self.directory / sub).is_dir():
                    out.add(sub)
        return out

    def _place_files(self, new: dict, sets: dict, previous: dict, dirs: list) -> None:
        """Steps 1-3 of a commit: the transition manifest, the directories, every file renamed into place (undone on
        failure: :meth:`_undo`)."""
        d = self.directory
        placed: list[str] = []  # renamed into place, in order
        backups: dict[str, Path] = {}  # the previous file of a placed one, hard-linked in the staging area
        made: list[Path] = []  # subdirectories created here
        transition_written = False
        try:
            # 1. a manifest valid whatever happens next: old and new content of each file, the directories to be made
            transition = dict(previous)
            for key, h in new.items():
                old = self._owner(key)
                transition[key] = [h] + (old[1] if old else [])
            write_manifest(d, {**empty_manifest(), "sets": {**sets, self.command: transition}, "directories": dirs})
            transition_written = True
            # 2. the directories, each checked writable before the first rename
            for key in self._files:
                parent = PurePosixPath(key).parent
                for i in range(1, len(parent.parts) + 1):
                    sub = d / PurePosixPath(*parent.parts[:i])
                    if not sub.is_dir():
                        os.mkdir(sub)
                        made.append(sub)
                where = d / parent
                if not os.access(where, os.W_OK | os.X_OK):
                    raise OutputError(f"cannot write into {where}: permission denied; make it writable or choose another --out")
            # 3. every file renamed into place, the one it replaces kept until all are
            for key, staged in self._files.items():
                target = d / key
                if os.path.lexists(target):
                    keep = self._staging / _BACKUP_DIR / key
                    keep.parent.mkdir(parents=True, exist_ok=True)
                    try:
                        os.link(target, keep, follow_symlinks=False)
                    except OSError:  # a file system without hard links
                        shutil.copy2(target, keep, follow_symlinks=False)
                    backups[key] = keep
                os.replace(staged, target)
                placed.append(key)
        except OSError as exc:
            undone = self._undo(placed, backups, made, transition_written)
            kept = "" if undone else self._keep_backups()
            if isinstance(exc, OutputError) and undone:
                raise
            why = str(exc) if isinstance(exc, OutputError) else f"cannot write into --out {d}: {exc.strerror or exc} ({exc.filename or d})"
            raise OutputError(why.removesuffix("; make it writable or choose another --out") + "; "
                              + ("the previous files are back" if undone else f"some previous files could not be put back{kept}")
                              + "; fix that and run again") from exc

    def _tidy(self, new: dict, sets: dict, previous: dict, dirs: list) -> None:
        """Steps 4-6 of a commit, once the set is in place: this command's stale files, empty directories, the final
        manifest. A stale file that cannot be removed stays listed as this command's."""
        d = self.directory
        try:
            stale_kept = {}
            for key, hashes in previous.items():
                if key in new:
                    continue
                target = d / key
                try:
                    if _real_path(d, key) and target.is_file() and not target.is_symlink() and _sha256(target) in hashes:
                        target.unlink()
                except OSError:
                    stale_kept[key] = hashes
            kept = []
            owned = set(new) | set(stale_kept) | {k for files in sets.values() for k in files}
            for sub in sorted(set(dirs), key=lambda s: -len(PurePosixPath(s).parts)):
                p = d / sub
                with contextlib.suppress(OSError):
                    if not _real_path(d, sub + "/x") or not p.is_dir() or p.is_symlink():
                        continue
                    if not any(k.startswith(sub + "/") for k in owned):
                        p.rmdir()  # only if empty
                if os.path.isdir(p) and not os.path.islink(p):
                    kept.append(sub)
            final = {**{k: list(v) for k, v in stale_kept.items()}, **{k: [h] for k, h in new.items()}}
            write_manifest(d, {**empty_manifest(), "sets": {**sets, self.command: final}, "directories": sorted(kept)})
        except OSError as exc:  # the files are in place; the transition manifest (old and new contents) still holds
            raise OutputError(f"the output in --out {d} is complete but its record {d / MANIFEST_NAME} could not be "
                              f"updated: {exc.strerror or exc}") from exc

    def _keep_backups(self) -> str:
        """Move the staging area's previous files out of it (the staging area is removed on close) to
        ``DIR/.jointid-previous-<random>``, which jointid never removes; ``" (kept in ...)"``, or "" without any."""
        src = self._staging / _BACKUP_DIR
        if not src.is_dir():
            return ""
        try:
            dst = Path(tempfile.mkdtemp(prefix=_BACKUP_DIR + "-", dir=self.directory))
            os.replace(src, dst / "files")
        except OSError:
            return ""
        return f" (they are kept in {dst / 'files'})"

    def _undo(self, placed: list, backups: dict, made: list, transition_written: bool) -> bool:
        """Put the previous files back over the ones placed, remove the new ones and the directories made; the manifest
        as it was (unless a file could not be put back: then the transition manifest, which lists both contents, stays).
        True if every file was put back."""
        ok = True
        for key in reversed(placed):
            target = self.directory / key
            try:
                if key in backups:
                    os.replace(backups[key], target)
                else:
                    target.unlink()
            except OSError:
                ok = False
        for sub in reversed(made):
            with contextlib.suppress(OSError):
                sub.rmdir()
        if ok and transition_written:
            try:
                if self._manifest_bytes is None:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(self.directory / MANIFEST_NAME)
                else:
                    atomic_write_bytes(self.directory / MANIFEST_NAME, self._manifest_bytes)
            except OSError:
                ok = False
        return ok
