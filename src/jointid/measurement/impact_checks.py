"""Hit quality checks of impact tests: double hits and overloads.

Per hit, on the raw force and response:

* *double hit*: the main pulse is the run of samples around the force peak
  with ``|f| > double_hit_fraction * max|f|``; any other sample above that
  threshold (before or after the main pulse) means a second impact;
* *overload*: a sample with ``|x| >= overload_fraction * clip`` when a
  clipping level is given (``force_clip_n``, ``response_clip``), or a flat
  top: ``flat_top_samples`` consecutive samples at the channel's ``max|x|``
  (what a saturated ADC or amplifier produces); and then any other hit of the record whose
  ``max|x|`` on that channel is the level the flat tops sit at (within 1e-9; a hit above it shows
  that the channel does not clip there): the channel's clipping level, learned from the flat tops,
  reached by a hit clipped for fewer samples; or the level that at least half the hits (and two)
  peak at exactly, which independent hits do not by chance (a blind
  test's accelerometer clipped for 2 samples on one hit of five was averaged in, and ``identify``
  then blamed the excitation column).

Bad hits are dropped from the averages by
:func:`jointid.measurement.impact.estimate_frfs` and listed, with every finding
(:class:`HitProblem`: check, channel, value and threshold), in
``ImpactFRF.rejected``; :func:`rejected_hits_table` turns them into columns.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

from ..dofs import Dof
from .impact_records import ImpactOptions, ImpactRecord, where_hit

__all__ = ["HitProblem", "RejectedHit", "REJECTED_COLUMNS", "check_hits", "main_pulse", "rejected_hits_table"]


_UNITS = {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}


class HitProblem(NamedTuple):
    """One finding of :func:`check_hits` on one channel of one hit.

    Attributes
    ----------
    check : str
        ``"double_hit"``, ``"overload"`` (a clipping level reached) or ``"flat_top"``.
    channel : str
        ``"force"`` or the response DOF label (``"3w"``).
    value, threshold : float
        What was measured and the limit it reached, in ``unit``: the second
        pulse's peak as a fraction of the main peak (double hit), the channel's
        ``max|x|`` and ``overload_fraction * clip`` (overload), the longest run
        of samples at the channel's maximum and ``flat_top_samples`` (flat top).
    unit : str
        ``"fraction of peak"``, ``"N"``, the response unit (``"m/s^2"``) or ``"samples"``.
    time_s : float
        Where: the second pulse's peak, the first overloaded sample, the start
        of the flat top, s from the record's start.
    message : str
        The finding in words, with what to do.
    """

    check: str
    channel: str
    value: float
    threshold: float
    unit: str
    time_s: float
    message: str


class RejectedHit(NamedTuple):
    """A hit left out of the averages: excited DOF, hit index (0-based), the reason and the findings."""

    reference: Dof
    hit: int
    reason: str
    problems: tuple[HitProblem, ...] = ()


def main_pulse(force: np.ndarray, fraction: float):
    """The main force pulse of each hit.

    Parameters
    ----------
    force : ndarray, shape (n_hits, n_samples)
        Hammer force, N.
    fraction : float
        Threshold as a fraction of each hit's peak ``|force|``.

    Returns
    -------
    peak, start, end : ndarray of int, shape (n_hits,)
        Index of the peak and of the main pulse's first sample above the
        threshold (inclusive) and of the first sample after it (exclusive).
    above : ndarray of bool, shape (n_hits, n_samples)
        Samples above the threshold.
    """
    a = np.abs(force)
    n = a.shape[-1]
    peak = np.argmax(a, axis=-1)
    thr = fraction * a[np.arange(a.shape[0]), peak]
    above = a > thr[:, None]
    idx = np.arange(n)
    below = ~above
    end = np.where(below & (idx > peak[:, None]), idx, n).min(axis=1)
    start = np.where(below & (idx < peak[:, None]), idx, -1).max(axis=1) + 1
    return peak, start, end, above


def _at_max(x: np.ndarray) -> np.ndarray:
    a = np.abs(x)
    m = a.max(axis=-1, keepdims=True)
    return (a >= m * (1.0 - 1e-9)) & (m > 0)


def _flat_top(x: np.ndarray, n_flat: int) -> np.ndarray:
    """True where ``n_flat`` consecutive samples sit at the channel's max |x| (> 0); shape x.shape[:-1]."""
    at = _at_max(x)
    if at.shape[-1] < n_flat:
        return np.zeros(at.shape[:-1], dtype=bool)
    runs = np.lib.stride_tricks.sliding_window_view(at, n_flat, axis=-1).all(axis=-1)
    return runs.any(axis=-1)


def _longest_run(x: np.ndarray) -> tuple[int, int]:
    """Length and start index of the longest run of samples of 1-D ``x`` at its max |x|."""
    at = np.concatenate([[False], _at_max(x), [False]]).astype(np.int8)
    d = np.diff(at)
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    k = int(np.argmax(ends - starts))
    return int(ends[k] - starts[k]), int(starts[k])


def check_hits(record: ImpactRecord, options: ImpactOptions | None = None) -> tuple[RejectedHit, ...]:
    """Double-hit and overload checks of every hit of ``record``.

    Parameters
    ----------
    record : ImpactRecord
        Hits at one excited node.
    options : ImpactOptions, optional
        Uses ``double_hit_fraction``, ``force_clip_n``, ``response_clip``,
        ``overload_fraction`` and ``flat_top_samples``.

    Returns
    -------
    tuple of RejectedHit
        One entry per bad hit: all findings' messages joined by ``"; "`` in
        ``reason``, and each finding in ``problems``.
    """
    o = options or ImpactOptions()
    fs = record.sample_rate_hz
    F, R = record.force, record.responses
    runit = _UNITS[record.kind]
    peak, start, end, above = main_pulse(F, o.double_hit_fraction)
    idx = np.arange(F.shape[1])
    outside = above & ((idx < start[:, None]) | (idx >= end[:, None]))
    found: list[list[HitProblem]] = [[] for _ in range(F.shape[0])]
    pk = np.abs(F[np.arange(F.shape[0]), peak])
    for i in np.flatnonzero(outside.any(axis=1)):
        j = int(np.flatnonzero(outside[i])[0])
        k = j + int(np.argmax(np.abs(F[i, j:]) * outside[i, j:]))
        ratio = abs(F[i, k]) / pk[i]
        found[i].append(HitProblem(
            "double_hit", "force", float(ratio), o.double_hit_fraction, "fraction of peak", k / fs,
            f"double hit: a second force pulse at t = {k / fs:.4g} s reaches {ratio:.0%} of the "
            f"peak (main pulse at t = {peak[i] / fs:.4g} s, threshold {o.double_hit_fraction:.0%}); repeat the hit",
        ))
    if o.force_clip_n is not None:
        lim = o.overload_fraction * o.force_clip_n
        for i in np.flatnonzero(np.abs(F).max(axis=1) >= lim):
            top = float(np.abs(F[i]).max())
            found[i].append(HitProblem(
                "overload", "force", top, lim, "N", int(np.argmax(np.abs(F[i]) >= lim)) / fs,
                f"overload: force reaches {top:.4g} N, >= {o.overload_fraction:.0%} of the "
                f"clipping level {o.force_clip_n:g} N; hit softer or raise the range",
            ))
    if o.response_clip is not None:
        lim = o.overload_fraction * o.response_clip
        over = np.abs(R).max(axis=2) >= lim
        for i, c in zip(*np.nonzero(over)):
            top = float(np.abs(R[i, c]).max())
            found[i].append(HitProblem(
                "overload", str(record.response_dofs[c]), top, lim, runit, int(np.argmax(np.abs(R[i, c]) >= lim)) / fs,
                f"overload: response channel {record.response_dofs[c]} reaches {top:.4g}, "
                f">= {o.overload_fraction:.0%} of the clipping level {o.response_clip:g}; hit softer or raise the range",
            ))
    if o.flat_top_samples:
        n_flat = o.flat_top_samples
        for i in np.flatnonzero(_flat_top(F, n_flat)):
            run, at = _longest_run(F[i])
            found[i].append(HitProblem(
                "flat_top", "force", float(run), float(n_flat), "samples", at / fs,
                f"overload: the force has a flat top ({n_flat}+ consecutive samples at its maximum "
                f"{np.abs(F[i]).max():.4g} N): the channel saturated; hit softer or raise the range",
            ))
        flat_r = _flat_top(R, n_flat)
        for i, c in zip(*np.nonzero(flat_r)):
            run, at = _longest_run(R[i, c])
            found[i].append(HitProblem(
                "flat_top", str(record.response_dofs[c]), float(run), float(n_flat), "samples", at / fs,
                f"overload: response channel {record.response_dofs[c]} has a flat top ({n_flat}+ "
                f"consecutive samples at its maximum {np.abs(R[i, c]).max():.4g}): the channel saturated; "
                "hit softer or raise the range",
            ))
        # the clipping level the flat tops show, reached by other hits for fewer samples
        for name, x, flat, unit in (("the force", F[:, None, :], _flat_top(F, n_flat)[:, None], "N"), (None, R, flat_r, runit)):
            top = np.abs(x).max(axis=-1)  # (H, C)
            for c in range(top.shape[1]):
                same = np.abs(top[:, c][:, None] - top[:, c][None, :]) <= 1e-9 * top[:, c][None, :]  # (H, H) equal peaks
                # a peak level half the hits share exactly (not 0: a dead channel is the dead-channel check's)
                shared = (same.sum(axis=1) >= max(2, -(-top.shape[0] // 2))) & (top[:, c] > 0)
                if not (flat[:, c].any() or shared.any()):
                    continue
                level = float(np.min(top[flat[:, c] | shared, c]))
                at_level = np.abs(top[:, c] - level) <= 1e-9 * level  # above it: the channel does not clip there
                why = ("the level at which it has a flat top in other hits" if flat[:, c].any() else
                       f"the level {int(at_level.sum())} of the {top.shape[0]} hits peak at exactly (independent hits do not)")
                for i in np.flatnonzero(~flat[:, c] & at_level):
                    what = name or f"response channel {record.response_dofs[c]}"
                    found[i].append(HitProblem(
                        "flat_top", "force" if name else str(record.response_dofs[c]), float(top[i, c]), level, unit,
                        int(np.argmax(np.abs(x[i, c]) >= level * (1.0 - 1e-9))) / fs,
                        f"overload: {what} reaches {top[i, c]:.4g}, {why} (its clipping level): the channel saturated; "
                        "hit softer or raise the range",
                    ))
    return tuple(
        RejectedHit(record.reference, i, f"{where_hit(record.reference, i)}: " + "; ".join(p.message for p in ps), tuple(ps))
        for i, ps in enumerate(found)
        if ps
    )


#: Columns of :func:`rejected_hits_table`, in order.
REJECTED_COLUMNS = ("excited_dof", "hit", "check", "channel", "value", "threshold", "unit", "time_s", "reason")


def rejected_hits_table(rejected: Sequence[RejectedHit]) -> dict[str, list]:
    """The rejected hits as table columns, one row per finding (a hit may have several).

    Parameters
    ----------
    rejected : sequence of RejectedHit
        E.g. ``ImpactFRF.rejected``.

    Returns
    -------
    dict of str to list
        Columns :data:`REJECTED_COLUMNS`: ``excited_dof`` (label), ``hit``
        (0-based index of the hit within its excited node, in file order),
        ``check``, ``channel``, ``value``, ``threshold``, ``unit``, ``time_s``
        (see :class:`HitProblem`) and ``reason`` (the finding in words). A
        hit without findings (built by hand) gives one row with its
        ``reason``, ``check`` ``"other"`` and NaN numbers.
    """
    cols: dict[str, list] = {k: [] for k in REJECTED_COLUMNS}
    for r in rejected:
        problems = r.problems or (HitProblem("other", "", float("nan"), float("nan"), "", float("nan"), r.reason),)
        for p in problems:
            for k, v in zip(REJECTED_COLUMNS, (str(r.reference), int(r.hit), p.check, p.channel, p.value,
                                               p.threshold, p.unit, p.time_s, p.message)):
                cols[k].append(v)
    return cols
