"""Read (and write) FRF files by extension: UFF dataset 58 or the jointid CSV layout."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, Mapping

from ..errors import DataError
from ..frf import FRF
from .frf_csv import read_frf_csv, write_frf_csv
from .uff import read_uff_frf, write_uff_frf

__all__ = ["read_frf", "write_frf", "UFF_EXTENSIONS", "CSV_EXTENSIONS", "MAX_FRF_MAGNITUDE", "check_frf_magnitudes"]

UFF_EXTENSIONS: tuple[str, ...] = (".uff", ".unv", ".58")
CSV_EXTENSIONS: tuple[str, ...] = (".csv",)
#: Largest FRF magnitude accepted after conversion to SI, any kind ((m/s^2)/N, rad/(N*m), ...): far above any
#: measured structure (a 1 mg point at a resonance of Q = 1e3 is ~1e9 (m/s^2)/N) and far below where squares
#: and products of FRFs overflow (|H|^4 < 1e60).
MAX_FRF_MAGNITUDE = 1e15


def _format(path: Path) -> str:
    if path.is_dir():
        raise DataError(f"FRF file {path} is a directory; give the FRF file in it (e.g. {path / 'frf.uff'})")
    ext = path.suffix.lower()
    if ext in UFF_EXTENSIONS:
        return "uff"
    if ext in CSV_EXTENSIONS:
        return "csv"
    raise DataError(
        f"cannot tell the format of FRF file {path} from its extension {ext or '(none)'!r}; "
        f"supported: {', '.join(UFF_EXTENSIONS)} (UFF dataset 58, ASCII or binary) and "
        f"{', '.join(CSV_EXTENSIONS)} (jointid FRF CSV)"
    )


def read_frf(
    path: str | os.PathLike,
    n_nodes: int | None = None,
    kind: str | None = None,
    *,
    points: Mapping[int, int] | None = None,
    axis: str = "+Z",
    responses: Iterable | None = None,
    references: Iterable | None = None,
    coherence: bool = False,
) -> FRF:
    """Read an FRF file: ``.uff``/``.unv``/``.58`` → :func:`~jointid.io.uff.read_uff_frf`,
    ``.csv`` → :func:`~jointid.io.frf_csv.read_frf_csv`. Values come back in SI.

    Parameters
    ----------
    path : path-like
    n_nodes : int, optional
        Number of beam nodes; DOFs outside ``1..n_nodes`` are an error.
    kind : str, optional
        Convert exactly to this kind (default: the file's own kind).
    points : mapping of int to int, optional
        File point id -> model node; points it does not list are skipped.
        Default: the file's point ids are node numbers.
    axis : {"+Z", "-Z", "+X", "-X", "+Y", "-Y"}
        UFF only: the file's direction that is the model's ``w`` (the
        opposite one is sign-flipped, others are skipped). CSV files name
        the model's DOFs (``3w``): the axis does not apply to them.
    responses, references : iterables of DOF labels, optional
        Keep only FRFs between these model DOFs (others are skipped, not read).
    coherence : bool
        UFF only: also read the coherence records of the kept FRFs into
        ``FRF.coherence`` (``None`` if the file has none).

    Returns
    -------
    FRF
        ``notes`` holds one line per unit conversion / skipped records / unused coherence.

    Raises
    ------
    DataError
        Unsupported extension (the message lists the supported ones), or
        invalid content (see the readers).
    """
    path = Path(path)
    if _format(path) == "uff":
        frf = read_uff_frf(  # type: ignore[assignment]
            path, n_nodes=n_nodes, kind=kind, points=points, axis=axis,
            responses=responses, references=references, coherence=coherence, attach=True,
        )
    else:
        frf = read_frf_csv(path, n_nodes=n_nodes, kind=kind, points=points, responses=responses, references=references)
    check_frf_magnitudes(frf, path)
    return frf


def check_frf_magnitudes(frf: FRF, source: str | os.PathLike) -> None:
    """Refuse FRF values that are not finite or above :data:`MAX_FRF_MAGNITUDE` (in SI).

    Parameters
    ----------
    frf : FRF
        Values in SI units of its kind (after any unit conversion), shape (F, r, c).
    source : path-like
        The file, for the message.

    Raises
    ------
    DataError
        One line naming the file, the (response, reference) pair, the line and the value.
    """
    import numpy as np

    with np.errstate(over="ignore", invalid="ignore"):
        mag = np.abs(frf.data)
    bad = ~(mag <= MAX_FRF_MAGNITUDE)  # NaN compares False: caught too
    if not bad.any():
        return
    f, i, j = (int(x[0]) for x in np.nonzero(bad))
    value = frf.data[f, i, j]
    pair = f"FRF ({frf.responses[i]}, {frf.references[j]})"
    at = f"at {frf.frequency.hz[f]:g} Hz ({int(bad.sum())} value(s) in the file)"
    if not np.isfinite(value):
        raise DataError(f"{source}: {pair} is not finite (NaN or inf) {at}: not a measured FRF; check the file")
    limit = f"{MAX_FRF_MAGNITUDE:.0e}".replace("e+", "e")
    raise DataError(
        f"{source}: {pair} has magnitude {abs(value):.3g} {frf.unit(frf.responses[i], frf.references[j])} {at}, "
        f"above {limit} in SI after unit conversion: "
        "not a measured FRF; check the file's units and scaling"
    )


def write_frf(path: str | os.PathLike, frf: FRF, kind: str | None = None, **uff_options) -> Path:
    """Write an FRF file by extension (atomically).

    UFF files are written as ``kind`` (default accelerance, like a test);
    ``uff_options`` go to :func:`~jointid.io.uff.write_uff_frf` (``binary``,
    ``coherence``, ``description``, ``marks``). CSV files are written in ``kind``
    (default: the FRF's own kind).
    """
    path = Path(path)
    if _format(path) == "uff":
        return write_uff_frf(path, frf, kind=kind or "accelerance", **uff_options)
    if uff_options:
        raise DataError(f"options {sorted(uff_options)} apply to UFF files only, not to {path}")
    return write_frf_csv(path, frf.to(kind) if kind else frf)
