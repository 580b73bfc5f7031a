"""Dead, invisible and degenerate data found before a joint is identified, not identified.

What :func:`screen_measured`, :func:`check_visibility`, :func:`floor_exact_zeros`
and :func:`noise_level_unknown` check, in the order the receptance method
(:func:`jointid.methods.receptance.coupling.identify_joint_coupling`) applies them:

1. **Dead acquisition**: every measured value zero, or the FRFs' median
   magnitude outside ``1e-8 .. 1e8`` times the free model's (e.g. all ~1e-300:
   a dead acquisition or a wrong unit) -> :class:`~jointid.errors.IdentificationError`.
2. **Dead channels**: a response row or excitation column that is zero on every
   line (``max |H| <= DEAD_RELATIVE * max |H|`` of the file), or whose coherence
   has a median below :data:`DEAD_COHERENCE` over the band (it carries no
   coherent signal) is left out, with a finding naming the DOF. If too few
   remain for the joint's DOFs, that is an error naming the dead DOFs.
3. **Invisible joint DOFs** (:func:`check_visibility`): a joint DOF whose free
   receptance to every observed DOF (or from every excited DOF) is zero, e.g. a
   planar model's out-of-plane DOFs measured in plane, or a layout whose
   observed (excited) receptance columns (rows) are linearly dependent on every
   line: the per-line equations cannot determine those terms; an error naming the
   DOFs, before any solve.
4. **Exact zeros** (:func:`floor_exact_zeros`): an FRF value that is exactly 0
   while its row and column are not (a structural zero: in-plane response to an
   out-of-plane force of a planar model) has no relative noise level; its variance
   is floored at ``RELATIVE_FLOOR^2 sqrt(max_row |H|^2 max_col |H|^2)`` per line
   instead of the 1e-308 that would overflow the weights.
5. **Unknown noise level** (:func:`noise_level_unknown`): coherence identically 1
   (one average per excitation, or noise-free data) says nothing about the noise;
   the caller then measures the variance from the residuals of the per-line fit
   (:func:`jointid.methods.receptance.column_calibration.residual_variance`) and says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import IdentificationError

__all__ = ["DEAD_RELATIVE", "DEAD_COHERENCE", "SCALE_LIMIT", "INVISIBLE_RELATIVE", "RANK_RELATIVE", "Screening",
           "screen_measured", "check_visibility", "floor_exact_zeros", "noise_level_unknown"]

#: A row or column whose largest |H| is at most this times the file's largest is dead (zero).
DEAD_RELATIVE = 1e-12
#: A row or column whose median coherence over the band is below this carries no coherent signal.
DEAD_COHERENCE = 0.05
#: Median |H| / median |Y_free| outside ``1/SCALE_LIMIT .. SCALE_LIMIT``: not a measurement of this structure.
SCALE_LIMIT = 1e8
#: A joint DOF whose free receptance column to the observed DOFs is at most this times its driving point is invisible.
INVISIBLE_RELATIVE = 1e-10
#: Smallest singular value / largest of the column-scaled observed (excited) receptance below this: rank deficient.
RANK_RELATIVE = 1e-10
#: Lines sampled for the rank check (a layout property: spread over the band).
RANK_LINES = 24
#: Coherence within this of 1 everywhere is "identically 1".
COHERENCE_ONE = 1e-9
#: Medians (scale, coherence) are taken on at most this many lines, evenly strided over the band.
MEDIAN_LINES = 2048


@dataclass(frozen=True)
class Screening:
    """Which measured rows and columns to keep, and one finding per DOF left out."""

    rows: np.ndarray
    cols: np.ndarray
    findings: tuple[str, ...]


def _median_abs(x: np.ndarray) -> float:
    a = np.abs(x)
    a = a[a > 0]
    return float(np.median(a)) if a.size else 0.0


def screen_measured(H: np.ndarray, coherence: np.ndarray | None, Y: np.ndarray, responses: Sequence, references: Sequence) -> Screening:
    """Find a dead acquisition (error) and dead response rows / excitation columns (left out, one finding each).

    Parameters
    ----------
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    coherence : ndarray, shape (F, m, e), or None
    Y : ndarray, shape (F, m, e), complex
        The free model's receptance between the same DOFs, m/N (the scale a measurement must have).
    responses, references : sequences of Dof
        Labels of the rows and columns.

    Raises
    ------
    IdentificationError
        Every value zero, or the data's scale ``SCALE_LIMIT`` off the model's.
    """
    a = np.abs(H)
    top = float(a.max()) if a.size else 0.0
    if not top > 0:
        raise IdentificationError("every measured FRF is zero on every line (a dead acquisition): nothing to identify; check the "
                                  "acquisition and the file")
    step = max(1, H.shape[0] // MEDIAN_LINES)  # medians on evenly strided lines: the same figure, a fraction of the sorting
    ratio = _median_abs(H[::step]) / max(_median_abs(Y[::step]), np.finfo(float).tiny)
    if not 1.0 / SCALE_LIMIT <= ratio <= SCALE_LIMIT:
        raise IdentificationError(
            f"the measured FRFs are {ratio:.1e} times the free model's (median magnitude): not a measurement of this "
            "structure (a dead acquisition, or FRFs in other units than the file says); check the acquisition and the units"
        )
    dead_row = a.max(axis=(0, 2)) <= DEAD_RELATIVE * top
    dead_col = a.max(axis=(0, 1)) <= DEAD_RELATIVE * top
    findings = [f"response {responses[i]}: its FRFs are zero on every line (a dead channel, or a DOF the excitations do "
                "not move): left out" for i in np.flatnonzero(dead_row)]
    findings += [f"excitation {references[j]}: its FRFs are zero on every line (a dead force channel): left out"
                 for j in np.flatnonzero(dead_col)]
    if coherence is not None:
        g = np.asarray(coherence, dtype=float)[::step]
        quiet_row = (np.median(g, axis=(0, 2)) < DEAD_COHERENCE) & ~dead_row
        quiet_col = (np.median(g, axis=(0, 1)) < DEAD_COHERENCE) & ~dead_col
        findings += [f"response {responses[i]}: median coherence {np.median(g[:, i]):.2g} over the band (no coherent "
                     "signal: a dead or disconnected channel): left out" for i in np.flatnonzero(quiet_row)]
        findings += [f"excitation {references[j]}: median coherence {np.median(g[:, :, j]):.2g} over the band (no "
                     "coherent signal): left out" for j in np.flatnonzero(quiet_col)]
        dead_row |= quiet_row
        dead_col |= quiet_col
    return Screening(np.flatnonzero(~dead_row), np.flatnonzero(~dead_col), tuple(findings))


def _null_dofs(A: np.ndarray, labels: Sequence) -> list[str]:
    """DOFs carrying the right null vector of ``A`` (components above a tenth of the largest)."""
    v = np.abs(np.linalg.svd(A)[2][-1].conj())
    return [str(labels[k]) for k in np.flatnonzero(v >= 0.1 * v.max())]


def check_visibility(Ymn: np.ndarray, Ynn: np.ndarray, Yne: np.ndarray, joint: Sequence, what: str = "") -> None:
    """Refuse, before any solve, joint DOFs the measured FRFs cannot determine (module docstring, 3).

    Parameters
    ----------
    Ymn, Ynn, Yne : ndarray, shapes (F, m, n), (F, n, n), (F, n, e), complex
        The free model's receptance: observed x joint, joint x joint, joint x excited.
    joint : sequence of Dof
        The joint DOFs n.
    what : str
        Prefix of the error (e.g. the joint's name).

    Raises
    ------
    IdentificationError
        One line naming the DOFs: no equation sees them, or the layout is rank deficient in them.
    """
    F, m, n = Ymn.shape
    drive = np.sqrt(np.sum(np.abs(np.diagonal(Ynn, axis1=1, axis2=2)) ** 2, axis=0))  # (n,) driving point scale
    for side, B, axis_, who in (("observed", Ymn, 1, "to every observed DOF"), ("excited", Yne, 2, "from every excited DOF")):
        norm = np.sqrt(np.sum(np.abs(B) ** 2, axis=(0, axis_)))  # (n,)
        blind = norm <= INVISIBLE_RELATIVE * drive
        if blind.any():
            names = ", ".join(str(joint[k]) for k in np.flatnonzero(blind))
            raise IdentificationError(
                f"{what}joint DOF(s) {names}: the free model's receptance {who} is zero, so the FRFs cannot determine "
                f"their terms (e.g. a planar model's out-of-plane DOFs measured in plane); remove them from the joint's "
                f"dofs or measure DOFs that move with them"
            )
        idx = np.unique(np.linspace(0, F - 1, min(F, RANK_LINES)).round().astype(int))
        A = B[idx] / norm[None, None, :] if side == "observed" else np.swapaxes(B[idx], 1, 2) / norm[None, None, :]
        s = np.linalg.svd(A, compute_uv=False)
        if np.all(s[:, -1] <= RANK_RELATIVE * s[:, 0]):
            k = int(np.argmax(s[:, -1] / s[:, 0]))
            names = ", ".join(_null_dofs(A[k], [str(d) for d in joint]))
            raise IdentificationError(
                f"{what}the {side} DOFs cannot tell joint DOFs {names} apart: the free receptance {who} is rank "
                f"deficient in them on every line (smallest/largest singular value <= {RANK_RELATIVE:g}); "
                f"{'observe' if side == 'observed' else 'excite'} DOFs that move them differently, or remove them from the joint"
            )


def floor_exact_zeros(variance: np.ndarray, H: np.ndarray, floor: float) -> np.ndarray:
    """Variance of each value at least ``floor^2 sqrt(max_row |H|^2 max_col |H|^2)`` per line (module docstring, 4)."""
    a2 = H.real ** 2 + H.imag ** 2
    scale = np.sqrt(a2.max(axis=2, keepdims=True) * a2.max(axis=1, keepdims=True))
    return np.maximum(variance, floor ** 2 * scale)


def noise_level_unknown(coherence: np.ndarray | None) -> bool:
    """Coherence given and identically 1 (within :data:`COHERENCE_ONE`): one average, or noise-free data."""
    return coherence is not None and bool(np.all(np.asarray(coherence) >= 1.0 - COHERENCE_ONE))
