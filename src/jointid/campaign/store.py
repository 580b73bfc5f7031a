"""Resumable per-test results: one file per test, written atomically as each test finishes.

Where and why
-------------
``DIR/.jointid-cache/campaign/<k>.json``, ``k`` the test's key
(:func:`task_key`): the SHA-256 of the test file's content, of the study file's
content (``identify``), of the processing options and of the jointid version.
A re-run of the campaign computes only tests whose key has no valid entry: a test
whose file or options changed gets a new key, an unchanged one is reused.

How this fits the output-directory rules (:mod:`jointid.io.output_dir`)
----------------------------------------------------------------------
The campaign's outputs (tables, JSON, report) are one :class:`~jointid.io.output_dir.OutputSet`,
staged and committed together when the campaign ends. The per-test entries cannot
wait for that (a killed run must keep every finished test), so they are written
one by one, each atomically (a new temporary file in the same directory, renamed into
place: an entry is whole or absent; the protocol of :mod:`jointid.io.atomic` with the
fewest system calls, since a store write per test must cost little next to the test), while the run holds the output
directory's lock (``DIR/.jointid.lock``: two campaigns never write the same cache).
They live under ``DIR/.jointid-cache/``: names starting with ``.jointid`` are
reserved for jointid in an output directory (:class:`OutputSet` never writes a user
file there and never lists it), so the cache is jointid's own by its name and
replaces no user file. An entry is only ever added, never rewritten with other
content (its name is the hash of what determines its content), and it carries
the SHA-256 of its payload: an entry that does not verify (edited, foreign) is
ignored, recomputed and replaced. ``rm -r DIR/.jointid-cache`` empties the cache.
"""

from __future__ import annotations

import hashlib
import json
import os
import secrets
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .tasks import ProcessingOptions, TestOutcome

__all__ = ["ResultStore", "task_key", "CACHE_DIR", "STORE_FORMAT"]

#: The cache directory under ``DIR`` (reserved ``.jointid`` name).
CACHE_DIR = ".jointid-cache/campaign"
#: Format tag of an entry; a change of the entry layout or of what the processing gives changes it (old entries are
#: then recomputed; 2: step-sine lines whose stiffness drifts along the block are flagged; 3: unit-suffixed column names
#: such as force_kN are read and converted, which a stored "missing column" failure must not hide; 4: the processing's
#: test-level notes, a drift, in the parameters ``notes``).
STORE_FORMAT = "jointid-campaign-result-4"


def task_key(kind: str, file_sha256: str, options: ProcessingOptions, *, parallel_joints: int, amplitude_m: float,
             study_sha256: str | None = None) -> str:
    """The cache key of a test: SHA-256 of what determines its result.

    Parameters
    ----------
    kind : str
        ``"direct"`` or ``"identify"``.
    file_sha256 : str
        SHA-256 of the data file's content.
    options : ProcessingOptions
    parallel_joints : int
    amplitude_m : float
        Commanded amplitude (it decides ``amplitude_ok``).
    study_sha256 : str, optional
        SHA-256 of the study file's content (``identify``).

    Notes
    -----
    The jointid version is part of the key: an upgrade recomputes everything.
    Manifest columns that do not change the processing (specimen, temperature,
    preload, free columns) are not: they are joined when the tables are built.
    """
    from .. import __version__

    ident = {"format": STORE_FORMAT, "jointid": __version__, "kind": kind, "file": file_sha256, "options": asdict(options)}
    if kind == "direct":
        ident |= {"parallel_joints": int(parallel_joints), "amplitude_m": float(amplitude_m).hex()}
    else:
        ident |= {"study": study_sha256}
    return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()


def _encode_array(a: np.ndarray) -> dict:
    a = np.asarray(a)
    if a.dtype == object or a.dtype.kind in "US":
        return {"dtype": "str", "values": [str(x) for x in a]}
    if a.dtype == bool:
        return {"dtype": "bool", "values": a.tolist()}
    if a.dtype.kind in "iu":
        return {"dtype": "int64", "values": a.astype(np.int64).tolist()}
    return {"dtype": "float64", "values": a.astype(float).tolist()}  # Python floats: repr round-trips exactly


def _decode_array(d: dict) -> np.ndarray:
    dtype = {"str": object, "bool": bool, "int64": np.int64, "float64": float}[d["dtype"]]
    return np.array(d["values"], dtype=dtype)


def _payload_text(payload: dict) -> str:
    return json.dumps(payload, sort_keys=True, separators=(",", ":"))


class ResultStore:
    """The per-test results of a campaign under ``DIR/.jointid-cache/campaign`` (see the module docstring).

    Parameters
    ----------
    directory : path-like
        The campaign's output directory ``DIR`` (the caller holds its lock).
    """

    def __init__(self, directory: str | os.PathLike):
        self.root = Path(directory) / CACHE_DIR

    @classmethod
    def from_root(cls, root: str | os.PathLike) -> "ResultStore":
        """The store whose entries are under ``root`` itself (a worker is given :attr:`root`)."""
        store = cls.__new__(cls)
        store.root = Path(root)
        return store

    def path(self, key: str) -> Path:
        """The entry file of ``key``."""
        return self.root / f"{key}.json"

    def load(self, key: str) -> TestOutcome | None:
        """The stored outcome of ``key``, or None if there is none or it does not verify."""
        try:
            data = json.loads(self.path(key).read_text(encoding="utf-8"))
            payload = data["payload"]
            if data.get("format") != STORE_FORMAT or data.get("key") != key:
                return None
            if data.get("sha256") != hashlib.sha256(_payload_text(payload).encode()).hexdigest():
                return None
            return TestOutcome(
                key=key, ok=bool(payload["ok"]), reason=str(payload["reason"]), cacheable=True,
                lines={k: _decode_array(v) for k, v in payload["lines"].items()},
                parameters=dict(payload["parameters"]), seconds=float(payload["seconds"]),
            )
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def save(self, outcome: TestOutcome) -> bool:
        """Write ``outcome`` atomically if it is a result or a cacheable failure; returns whether it was stored."""
        if not (outcome.ok or outcome.cacheable):
            return False
        payload = {
            "ok": outcome.ok, "reason": outcome.reason, "seconds": outcome.seconds,
            "lines": {k: _encode_array(v) for k, v in outcome.lines.items()},
            "parameters": {k: (v.item() if isinstance(v, np.generic) else v) for k, v in outcome.parameters.items()},
        }
        text = _payload_text(payload)
        head = json.dumps({"format": STORE_FORMAT, "key": outcome.key, "sha256": hashlib.sha256(text.encode()).hexdigest()})
        _write_atomically(self.path(outcome.key), f'{head[:-1]}, "payload": {text}}}\n'.encode())
        return True

    def remove_temporary(self) -> None:
        """Remove temporary files a killed run left (call while holding the output directory's lock)."""
        if self.root.is_dir():
            for tmp in self.root.glob(".*.json.*.tmp"):
                try:
                    tmp.unlink()
                except OSError:
                    pass

    def keys(self) -> set[str]:
        """Keys with an entry file (not verified)."""
        if not self.root.is_dir():
            return set()
        return {p.stem for p in self.root.glob("*.json")}


def _write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` to a new temporary file next to ``path`` (umask permissions), then rename it onto ``path``."""
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except FileNotFoundError:  # first entry (or the cache was removed meanwhile)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
