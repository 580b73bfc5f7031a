"""Roving-hammer time histories on disk to FRFs: the Python API behind ``jointid frf``.

:func:`read_hits` reads hit files of any of the layouts of
:mod:`jointid.measurement.impact_files` (NumPy ``.npz``, one excited node per file;
long CSV; UFF58 time records) by extension; :func:`frf_from_hits` turns the
records into H1/H2 and coherence with :func:`jointid.measurement.impact.estimate_frfs`
(hit checks, force and exponential windows, window correction) and returns a
:class:`HitsFRF` with the chosen estimator, the rejected hits as a table and
a summary of the averages.

Example::

    from jointid.hits import frf_from_hits
    from jointid.measurement.impact import ImpactOptions

    result = frf_from_hits(["n3.npz", "n9.npz"], ImpactOptions(force_window_s=1e-3, exp_tau_s=0.5))
    result.frf                # FRF (H1), accelerance (m/s^2)/N, (F, responses, excited)
    result.coherence          # (F, responses, excited)
    result.rejected_table()   # columns of rejected_hits.csv

    # UFF time records in g/lbf along -Y at points 1001..: converted to SI and mapped as FRF records are
    result = frf_from_hits("hits.uff", points={1001: 1, 1003: 3}, axis="-Y")
    result.summary()          # first: what was converted and mapped, then averages and data checks
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .errors import DataError
from .frf import FRF
from .measurement.impact import ImpactFRF, ImpactOptions, ImpactRecord, estimate_frfs, rejected_hits_table

__all__ = ["HIT_EXTENSIONS", "HitsFRF", "read_hits", "frf_from_hits"]

#: File extension -> layout of :mod:`jointid.measurement.impact_files`.
HIT_EXTENSIONS: dict[str, str] = {".npz": "npz", ".csv": "csv", ".uff": "uff", ".unv": "uff", ".58": "uff"}


def _read_one(path: Path, points=None, axis: str | None = "+Z", n_nodes: int | None = None) -> tuple[tuple[ImpactRecord, ...], tuple[str, ...]]:
    from .measurement.impact_files import read_impact_csv, read_impact_npz, read_impact_uff

    layout = HIT_EXTENSIONS.get(path.suffix.lower())
    if layout is None:
        raise DataError(
            f"cannot tell the layout of hits file {path} from its extension {path.suffix or '(none)'!r}; "
            f"supported: {', '.join(HIT_EXTENSIONS)} (see jointid.measurement.impact_files)"
        )
    if not path.is_file():
        raise DataError(f"hits file {path} does not exist")
    if layout == "uff":
        return read_impact_uff(path, points=points, axis=axis, n_nodes=n_nodes, with_notes=True)
    if points is not None or axis != "+Z":
        raise DataError(
            f"{path}: a point map and a measurement axis apply to UFF time records only; a .{layout} hits file "
            "names model DOFs itself (\"9w\")"
        )
    return ((read_impact_npz(path),) if layout == "npz" else read_impact_csv(path)), ()


def read_hits(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    n_nodes: int | None = None,
    *,
    points: Mapping[int, int] | None = None,
    axis: str | None = "+Z",
    with_notes: bool = False,
) -> "tuple[ImpactRecord, ...] | tuple[tuple[ImpactRecord, ...], tuple[str, ...]]":
    """Read impact records from hit files, one record per excited DOF, in SI.

    Parameters
    ----------
    paths : path-like or sequence of path-like
        ``.npz`` (one excited node per file), ``.csv`` (long layout) or
        ``.uff``/``.unv``/``.58`` (UFF58 time records); layouts in
        :mod:`jointid.measurement.impact_files`. CSV responses are accelerations.
    n_nodes : int, optional
        Number of beam nodes; a DOF outside ``1..n_nodes`` is an error.
    points : mapping of int to int, optional
        UFF files: file point id -> model node (records at other points are skipped).
    axis : {"+Z", "-Z", "+X", "-X", "+Y", "-Y"} or None
        UFF files: the file's direction that is ``w`` (``None``: 3-D components);
        see :func:`jointid.measurement.impact_files.read_impact_uff`. ``points`` and a
        non-default ``axis`` are refused for ``.npz``/``.csv`` files (they name DOFs).
    with_notes : bool
        Also return the readers' notes (units converted, point map, skipped records).

    Returns
    -------
    tuple of ImpactRecord
        In file order, then in order of appearance within a file.
    (records, notes)
        If ``with_notes``.

    Raises
    ------
    DataError
        A missing file, an unknown extension, a file of the wrong layout (from
        the readers), an excited DOF given in two files, or a node outside the beam.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    if not paths:
        raise DataError("no hits file given; give one or more .npz, .csv or .uff files")
    if n_nodes is not None and not (isinstance(n_nodes, (int, np.integer)) and n_nodes >= 1):
        raise DataError(f"n_nodes must be an integer >= 1, got {n_nodes!r}")
    out: list[ImpactRecord] = []
    notes: list[str] = []
    source: dict = {}
    for p in map(Path, paths):
        recs, file_notes = _read_one(p, points, axis, n_nodes)
        notes.extend(file_notes)
        if not recs:
            raise DataError(f"{p}: no hit in the file (no time samples, or none at the given points/axis); give each "
                            "excited node's hits as time samples of the force and the responses")
        for rec in recs:
            if rec.reference in source:
                raise DataError(
                    f"{p}: excited node {rec.reference} is also in {source[rec.reference]}; "
                    "give each excited node's hits in one file"
                )
            source[rec.reference] = p
            if n_nodes is not None:
                bad = [str(d) for d in (rec.reference, *rec.response_dofs) if not 1 <= d.node <= n_nodes]
                if bad:
                    raise DataError(
                        f"{p}: excited node {rec.reference}: DOF(s) {', '.join(bad)} outside the beam "
                        f"(nodes 1..{n_nodes}); check the node numbers or --n-nodes"
                    )
            out.append(rec)
    return (tuple(out), tuple(notes)) if with_notes else tuple(out)


@dataclass(frozen=True, eq=False)
class HitsFRF:
    """FRFs estimated from hit files, with the estimator chosen for output.

    Attributes
    ----------
    impact : ImpactFRF
        H1, H2, coherence, averages per excited node, rejected hits, window notes.
    estimator : str
        ``"h1"`` or ``"h2"``: the one :attr:`frf` returns.
    input_notes : tuple of str
        What the readers did: units converted to SI, point map and axis, skipped records.
    """

    impact: ImpactFRF
    estimator: str = "h1"
    input_notes: tuple[str, ...] = ()

    @property
    def frf(self) -> FRF:
        """The chosen estimate, in the records' kind, shape (F, responses, excited)."""
        return self.impact.to_frf(self.estimator)

    @property
    def coherence(self) -> np.ndarray:
        """Ordinary coherence, real, shape (F, responses, excited)."""
        return self.impact.coherence

    def rejected_table(self) -> dict[str, list]:
        """Rejected hits, one row per finding (see :func:`jointid.measurement.impact.rejected_hits_table`)."""
        return rejected_hits_table(self.impact.rejected)

    def summary(self) -> list[str]:
        """The input notes, one line per excited node (accepted / total hits), then window and data notes."""
        imp = self.impact
        n_rej: dict = {}
        for r in imp.rejected:
            n_rej[r.reference] = n_rej.get(r.reference, 0) + 1
        lines = list(self.input_notes) + [
            f"excited node {ref}: {n} average(s) ({n + n_rej.get(ref, 0)} hit(s), {n_rej.get(ref, 0)} rejected)"
            for ref, n in zip(imp.references, imp.n_averages)
        ]
        f = imp.frequency.hz
        lines.append(
            f"{self.estimator.upper()} {imp.kind}: {len(imp.responses)} response(s) x {len(imp.references)} "
            f"excited node(s), {f.size} lines {f[0]:g}-{f[-1]:g} Hz"
        )
        for m in imp.window_modes:
            lines.append(
                f"exponential window corrected at {m.frequency_hz:.4g} Hz: loss factor "
                f"{m.loss_factor_windowed:.4g} (windowed) -> {m.loss_factor:.4g}"
            )
        lines.extend(imp.notes)
        return lines


def frf_from_hits(
    hits: str | os.PathLike | Sequence[str | os.PathLike] | Sequence[ImpactRecord],
    options: ImpactOptions | None = None,
    estimator: str = "h1",
    n_nodes: int | None = None,
    *,
    points: Mapping[int, int] | None = None,
    axis: str | None = "+Z",
) -> HitsFRF:
    """H1 or H2 and coherence from roving-hammer hits (files or records).

    Parameters
    ----------
    hits : path-like, sequence of path-like, or sequence of ImpactRecord
        Hit files (read with :func:`read_hits`) or records, one per excited node.
    options : ImpactOptions, optional
        Windows, hit checks, band, FFT length. When ``band_hz`` is None the
        band is the first line above 0 Hz up to the Nyquist frequency (the
        0 Hz line of a hammer test carries no FRF information and cannot be
        converted to receptance or mobility).
    estimator : {"h1", "h2"}
        Which estimate :attr:`HitsFRF.frf` returns (both are computed).
    n_nodes : int, optional
        Number of beam nodes (files only); DOFs outside ``1..n_nodes`` are an error.
    points, axis :
        UFF files: point map and measurement axis (:func:`read_hits`).

    Returns
    -------
    HitsFRF

    Raises
    ------
    DataError
        Bad files or records, every hit of an excited node rejected, bad options.
    """
    if estimator not in ("h1", "h2"):
        raise DataError(f"estimator must be 'h1' or 'h2', got {estimator!r}")
    hits = [hits] if isinstance(hits, (str, os.PathLike)) else list(hits)
    if hits and all(isinstance(h, ImpactRecord) for h in hits):
        records, notes = tuple(hits), ()
    else:
        records, notes = read_hits(hits, n_nodes=n_nodes, points=points, axis=axis, with_notes=True)
    o = options or ImpactOptions()
    if o.band_hz is None:
        r0 = records[0]
        n_fft = r0.n_samples if o.n_fft is None else int(o.n_fft)
        o = dataclasses.replace(o, band_hz=(r0.sample_rate_hz / n_fft, r0.sample_rate_hz / 2))
    return HitsFRF(estimate_frfs(records, o), estimator, tuple(notes))
