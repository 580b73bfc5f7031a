"""Gross errors of a measured FRF set -- a unit factor, a flipped sign, a dead channel -- named by what explains them.

When the FRFs are far from what the free model and any joint can give (the units check of
:mod:`.units_check` refuses them, the column calibration finds a column off by more than
:data:`GROSS_COLUMN_ERROR`, or the model check of :mod:`.model_check` fails), the cause is
more often a slip in the data than in the model: a file in g/N read as m/s^2/N, a hammer hit
from the other side of the structure or a response whose direction code is the opposite of
the sensor's, a disconnected sensor that records noise. Each leaves the per-line coupling fit
with a residual far above the noise, and each has a one-line fix; a column calibration, a
model update or the joint itself would each take up part of it and turn a slip into a wrong
joint. :func:`gross_error` tries each such explanation on an evenly spread subset of at most
:data:`GROSS_LINES` lines and returns the one that explains the data.

Hypotheses (``H`` measured, ``V`` its variance shape; ``H'`` what the hypothesis says the
true FRFs are):

* **units**: ``H' = H / u``, ``V' = V / u^2`` for each unit factor ``u`` of
  :data:`~.units_check.UNIT_FACTORS` (every value off by one factor);
* **signs**: ``H' = diag(s_r) H diag(s_c)`` with ``s = -1`` on the responses, the
  references, or both, along one direction (``x``, ``y``, ``z``, ... of the DOF labels: a
  direction convention reversed), then on one response or one reference;
* **swaps**: two responses, or two references, exchanged (labels, files or cables mixed up), among the
  :data:`SWAP_CANDIDATES` records of each kind whose leaving out (below) lowers the residual most;
* **channels**: one response row or one reference column left out (the rest must still
  have the joint's DOFs and :data:`~.model_check.MIN_REDUNDANCY` residual degrees of freedom);
  when that explains the data best, the record is tried once more kept and divided by each factor
  of :data:`RECORD_FACTORS` (a unit factor, a sensitivity a decade off): one that explains the data
  about as well (within :data:`GROSS_TIE`) is named instead, a more specific fix that keeps the record.

Each is scored by the median over lines of the per-line fit's ``chi2_f``
(:func:`~.model_check.line_residuals`; medians, so that a few junk lines do not decide); a hypothesis
about one or two records (left out, rescaled, exchanged) is refitted from the full fit's factorization
(:mod:`.block_refit`: a 2-mount frame's 45 records, 0.8 s per refactored design, took 45 s).
The data as given score ``chi2_0``. An explanation is taken when its score is at most
``chi2_0 /`` :data:`GROSS_RATIO`; among those within a factor :data:`GROSS_TIE` of the best
score, the first in the order above (a unit factor before a sign, a sign before a swap, a swap
before leaving a channel out: the most specific fix that keeps the data).

Caveats: a free model that is off where one sensor sits (a wrong node, a local mode missed)
makes that sensor's residual large too; leaving it out then "explains" the data, and the
conclusion says that the sensor or the model there is wrong. Two slips at once (a flipped
column in a file in g/N) are not explained (each hypothesis is tried alone); the check that
asked then refuses with its own conclusion.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Sequence

import numpy as np

from ...dofs import parse_dofs
from ...parallel import single_threaded_blas
from .block_refit import left_out_rss, replaced_rss
from .coupling_lines import symmetric_parametrization, whitened_line_design
from .model_check import MIN_REDUNDANCY, design_residual, whitened_residuals
from .units_check import UNIT_FACTORS

__all__ = ["GrossError", "gross_error", "GROSS_LINES", "GROSS_RATIO", "GROSS_TIE", "GROSS_COLUMN_ERROR", "RECORD_FACTORS",
           "SWAP_CANDIDATES", "HYPOTHESES_AT_ONCE"]

#: Most lines the hypotheses are tried on (evenly spread over the band).
GROSS_LINES = 128
#: An explanation is taken when the median residual with it is at most the data's divided by this.
GROSS_RATIO = 20.0
#: Explanations within this factor of the best one's score are equivalent; the first in the module's order is named.
GROSS_TIE = 2.0
#: Hypotheses on the one design scored in one product (memory: 16 x this x lines x m e bytes).
HYPOTHESES_AT_ONCE = 16
#: Records of each kind (responses, excitations) among which exchanged pairs are tried: those whose leaving out lowers
#: the residual most (both records of an exchanged pair are among them).
SWAP_CANDIDATES = 3
#: A column whose calibration factor ``1 + eps`` is off by more than this (median over lines of ``|eps|``) is a gross
#: error, not a force calibration error (a hammer's sensitivity is known to a few per cent).
GROSS_COLUMN_ERROR = 0.5


@dataclass(frozen=True)
class GrossError:
    """An explanation of FRFs far from the free model.

    Attributes
    ----------
    kind : str
        ``"units"``, ``"sign"``, ``"swap"`` or ``"channel"``.
    conclusion : str
        One line: what is wrong and how to fix it (no trailing period).
    ratio : float
        The median residual of the data as given over the one with the explanation.
    """

    kind: str
    conclusion: str
    ratio: float


def _names(dofs, which) -> str:
    return ", ".join(str(dofs[i]) for i in which)


#: The fix named for each kind of explanation.
_FIX = {
    "units": "give the file's units (UFF dataset 164 / unit labels; a CSV file is read in SI units)",
    "sign": "fix the direction code of those records in the FRF file (or the sensor's or the hammer's direction)",
    "swap": "exchange their point or direction labels in the FRF file (or the records' files, or the cables)",
    "response": "fix it, or leave it out of [measurement] observed",
    "reference": "fix it, or leave it out of [measurement] excited",
}


def gross_error(Ymn: np.ndarray, Yne: np.ndarray, Yme: np.ndarray, H: np.ndarray, variance: np.ndarray, symmetric: bool,
                responses: Sequence, references: Sequence) -> GrossError | None:
    """The explanation of FRFs far from the free model (module docstring), or None when none explains them.

    Parameters
    ----------
    Ymn, Yne, Yme : ndarray, shapes (F, m, n), (F, n, e), (F, m, e), complex
        Free receptance blocks (m observed, n joint, e excited DOFs), m/N.
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    variance : ndarray, shape (F, m, e)
        Its variance shape (the weights), (m/N)^2.
    symmetric : bool
    responses, references : sequence of Dof
        The m observed and e excited DOFs, named in the conclusion.
    """
    responses, references = parse_dofs(responses), parse_dofs(references)
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    idx = np.unique(np.round(np.linspace(0, F - 1, min(F, GROSS_LINES))).astype(int))
    Ymn, Yne, Yme, H, V = (np.asarray(a)[idx] for a in (Ymn, Yne, Yme, H, variance))
    dof = m * e - symmetric_parametrization(n, symmetric).shape[1]
    if dof < MIN_REDUNDANCY:
        return None
    # a unit factor scales every weight alike and a sign leaves them: one design for both, only the data change
    with single_threaded_blas():
        sw, _, Q, _ = whitened_line_design(Ymn, Yne, V, symmetric, keep=False)

    def same_design(hypotheses: list) -> list[float]:
        """The score of each ``(H_true, u)`` (weights ``u sw``: ``V / u^2``) on the one design, in blocks of
        :data:`HYPOTHESES_AT_ONCE` as the columns of one product (not one matrix-vector product each)."""
        out = []
        for s in range(0, len(hypotheses), HYPOTHESES_AT_ONCE):
            D = np.stack([(Yme - Ht).reshape(-1, N) * (u * sw) for Ht, u in hypotheses[s:s + HYPOTHESES_AT_ONCE]], axis=2)
            R = whitened_residuals(D, Q)  # (F, m e, h)
            out += [float(v) for v in np.median(np.sum(R.real ** 2 + R.imag ** 2, axis=1) / dof, axis=0)]
        return out

    # a hypothesis about one or two records changes only their rows: refitted from the full fit (block_refit)
    N, p_ = m * e, Q.shape[2]
    d0 = (Yme - H).reshape(-1, N) * sw
    r0 = design_residual(Yme - H, sw, Q)

    def record_rows(axis: int, i: int) -> np.ndarray:  # rows (r, c) -> r e + c of a response (0) or excitation (1)
        return i * e + np.arange(e) if axis == 0 else np.arange(m) * e + i

    def left_out(axis: int, i: int) -> float:
        rows = record_rows(axis, i)
        k = N - rows.size - p_
        return np.inf if k < MIN_REDUNDANCY else float(np.median(left_out_rss(r0, Q, rows) / k))

    def replaced(rows: np.ndarray, H_new: np.ndarray, V_new: np.ndarray) -> float:
        sw_new = 1.0 / np.sqrt(V_new.reshape(-1, N)[:, rows])
        d_new = sw_new * (Yme - H_new).reshape(-1, N)[:, rows]
        return float(np.median(replaced_rss(d0, r0, Q, rows, d_new, sw_new / sw[:, rows]) / dof))

    how = {"units": "divided by it", "sign": "with the sign reversed", "swap": "exchanged back", "channel": "without it"}
    # the data as given, each unit factor and each sign pattern: the same design, scored together
    pending = [((H, 1.0), None)]  # ((H_true, u), (kind, what is wrong, fix))
    for u, label, why in UNIT_FACTORS:
        pending.append(((H / u, u), ("units", f"the FRFs look scaled by {label} in every excitation column ({why})",
                                     _FIX["units"])))

    def flipped(rows, cols) -> tuple:
        s_r, s_c = np.ones(m), np.ones(e)
        s_r[list(rows)], s_c[list(cols)] = -1.0, -1.0
        return H * s_r[:, None] * s_c[None, :], 1.0

    negative = "measured the negative of what the free model predicts"
    for d in dict.fromkeys(x.direction for x in (*responses, *references)):
        rows = [i for i, x in enumerate(responses) if x.direction == d]
        cols = [j for j, x in enumerate(references) if x.direction == d]
        for r_, c_, who in ((rows, [], "responses"), ([], cols, "excitations"), (rows, cols, "responses and excitations")):
            if (r_ or c_) and len(r_) < m and len(c_) < e and len(r_) + len(c_) > 1:  # one record: below
                names = ", ".join(x for x in (_names(responses, r_), _names(references, c_)) if x)
                pending.append((flipped(r_, c_), ("sign", f"the {who} along {d} ({names}) {negative}", _FIX["sign"])))
    for i in range(m):
        pending.append((flipped([i], []), ("sign", f"response {responses[i]} {negative}", _FIX["sign"])))
    for j in range(e):
        pending.append((flipped([], [j]), ("sign", f"the excitation at {references[j]} (column {j + 1}) {negative}",
                                           _FIX["sign"])))
    base, *scores = same_design([h for h, _ in pending])
    if not np.isfinite(base) or base <= 0:
        return None
    tried: list[tuple[float, str, str, str]] = [(sc, *t) for sc, (_, t) in zip(scores, pending[1:])]  # in the module's order

    channels = []  # (score, kind, what, fix, axis, index): one record left out
    for i in range(m if m - 1 >= n else 0):
        channels.append((left_out(0, i), "channel",
                         f"response {responses[i]} does not follow the free model while the others do (a dead, disconnected "
                         "or misplaced sensor, or the model wrong there)", _FIX["response"], 0, i))
    for j in range(e if e - 1 >= n else 0):
        channels.append((left_out(1, j), "channel",
                         f"the excitation at {references[j]} (column {j + 1}) does not follow the free model while the others "
                         "do (a dead force channel, a hit elsewhere, or the model wrong there)", _FIX["reference"], 1, j))

    # two records exchanged: leaving out either lowers the residual, so pairs are tried among the SWAP_CANDIDATES
    # records of each kind whose leaving out lowers it most (a few fits, not m (m - 1) / 2 + e (e - 1) / 2 of them)
    for axis, size in ((0, m), (1, e)):
        ranked = sorted((c for c in channels if c[4] == axis), key=lambda c: c[0])[:SWAP_CANDIDATES]
        for a, b in combinations(sorted(c[5] for c in ranked), 2):
            p = np.arange(size)
            p[[a, b]] = b, a
            rows = np.concatenate([record_rows(axis, a), record_rows(axis, b)])
            if axis == 0:
                tried.append((replaced(rows, H[:, p], V[:, p]), "swap",
                              f"responses {responses[a]} and {responses[b]} look exchanged (each measured what the free model "
                              "predicts at the other)", _FIX["swap"]))
            else:
                tried.append((replaced(rows, H[:, :, p], V[:, :, p]), "swap",
                              f"the excitations at {references[a]} and {references[b]} (columns {a + 1} and {b + 1}) look "
                              "exchanged (each column is what the free model predicts for a hit at the other)", _FIX["swap"]))
    tried += [c[:4] for c in channels]

    best = min(t[0] for t in tried)
    if not best * GROSS_RATIO <= base:
        return None
    score, kind, what, fix = next(t for t in tried if t[0] <= GROSS_TIE * best)
    if kind == "channel":  # the record left out may be one scaled by a unit or sensitivity factor: keep it, rescaled
        axis, index = next(c[4:] for c in channels if c[:4] == (score, kind, what, fix))
        scaled = _scaled_record(lambda s: replaced(record_rows(axis, index), H / s, V / s ** 2), H.shape, axis, index, score)
        if scaled is not None:
            score, kind, (u_label, why) = scaled[0], "units", scaled[1:]
            who = f"response {responses[index]}" if axis == 0 else f"the excitation at {references[index]} (column {index + 1})"
            what = f"{who} looks scaled by {u_label} while the others do not ({why})"
            fix = f"correct that channel's sensitivity or unit label in the FRF file (or leave it out of [measurement] " \
                  f"{'observed' if axis == 0 else 'excited'})"
    ratio = base / score
    return GrossError(kind, f"{what} ({how[kind]}, the per-line fit's residual is {ratio:.2g} times lower): {fix}", ratio)


#: Factors one channel can be off by: the unit factors, and a sensitivity typed a decade off (10 mV/g for 100 mV/g).
RECORD_FACTORS = UNIT_FACTORS + (
    (10.0, "10", "a sensitivity typed 10x too small?"),
    (0.1, "1/10", "a sensitivity typed 10x too large?"),
)


def _scaled_record(score_of, shape, axis: int, index: int, left_out: float):
    """``(score, label, why)`` of the factor of :data:`RECORD_FACTORS` that, dividing record ``index`` (a response row,
    ``axis`` 0, or an excitation column, 1), explains the data about as well as leaving the record out (score within
    :data:`GROSS_TIE` of ``left_out``), the best one; else None. ``score_of(s)``: the score with ``H / s``, ``V / s^2``
    (``s`` broadcast to ``shape`` (F, m, e))."""
    best = None
    for u, label, why in RECORD_FACTORS:
        scale = np.ones(shape[1 + axis])
        scale[index] = u
        score = score_of(scale[None, :, None] if axis == 0 else scale[None, None, :])
        if score <= GROSS_TIE * left_out and (best is None or score < best[0]):
            best = (score, label, why)
    return best
