"""A labelled frequency-response container: frequency axis, response/reference DOFs, kind.

Arrays are shaped ``(frequency, responses, references)``. Kinds and units
(for a translational response and a force reference):

=============  ==============================  ===========
kind           definition                       unit
=============  ==============================  ===========
receptance     H = X / F                        m/N
mobility       Y = V / F = j w H                (m/s)/N
accelerance    A = a / F = -w^2 H               (m/s^2)/N
=============  ==============================  ===========

Conversions are exact; converting mobility or accelerance to receptance is
undefined at 0 Hz and raises :class:`~jointid.errors.FrequencyError`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterable

import numpy as np

from .dofs import Dof, dof_indices, parse_dof, parse_dofs
from .errors import DataError, FrequencyError
from .frequency import Frequency

__all__ = ["FRF", "KINDS", "kind_factor", "LEAKAGE_MARK", "MARK_PREFIX"]

KINDS: tuple[str, ...] = ("receptance", "mobility", "accelerance")
_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}


def kind_factor(omega: np.ndarray, from_kind: str, to_kind: str) -> np.ndarray:
    """Factor ``(j w)^(p_to - p_from)`` that converts FRFs of ``from_kind`` to ``to_kind``, shape (F,)."""
    for k in (from_kind, to_kind):
        if k not in _POWER:
            raise DataError(f"unknown FRF kind {k!r}; expected one of {KINDS}")
    p = _POWER[to_kind] - _POWER[from_kind]
    jw = 1j * np.asarray(omega, dtype=float)
    if p < 0 and np.any(jw == 0):
        raise FrequencyError(
            f"cannot convert {from_kind} to {to_kind} at 0 Hz (division by zero); drop the 0 Hz line first"
        )
    return jw ** float(p) if p else np.ones_like(jw)


#: ID line 4 of the records that ``jointid frf`` marks (every mark starts with :data:`MARK_PREFIX`).
MARK_PREFIX = "jointid frf:"
#: The mark of a record whose response still rang at the record's end when ``jointid frf`` estimated it (leakage).
LEAKAGE_MARK = "jointid frf: leakage (the response still rings at the record's end)"


@dataclass(frozen=True, eq=False)
class FRF:
    """Frequency response functions between labelled DOFs.

    Parameters
    ----------
    frequency : Frequency
        Frequency axis (Hz), F lines.
    data : ndarray, shape (F, r, c), complex
        FRF values in the units of ``kind``.
    responses : tuple of Dof, length r
        Response DOFs (rows).
    references : tuple of Dof, length c
        Reference (excitation) DOFs (columns).
    kind : {"receptance", "mobility", "accelerance"}
    coherence : ndarray, shape (F, r, c), real, optional
        Ordinary coherence of each FRF in [0, 1], aligned with ``data``
        (``None``: not measured). Kept by :meth:`to`, :meth:`select` and
        :meth:`band`.
    notes : tuple of str
        How the data were read, one line each (unit conversions, skipped
        records); empty when there is nothing to say.
    marks : tuple of (Dof, Dof, str)
        Processing marks the file carried per record, ``(response, reference, text)``
        (e.g. ``jointid frf``'s leakage mark, :data:`LEAKAGE_MARK`); only
        pairs of this FRF; kept by :meth:`to`, :meth:`select` and :meth:`band`.
    """

    frequency: Frequency
    data: np.ndarray
    responses: tuple[Dof, ...]
    references: tuple[Dof, ...]
    kind: str = "receptance"
    coherence: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    marks: tuple[tuple[Dof, Dof, str], ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.frequency, Frequency):
            object.__setattr__(self, "frequency", Frequency(self.frequency))
        object.__setattr__(self, "responses", parse_dofs(self.responses))
        object.__setattr__(self, "references", parse_dofs(self.references))
        data = np.array(self.data, dtype=complex)
        shape = (self.frequency.size, len(self.responses), len(self.references))
        if data.shape != shape:
            raise DataError(f"FRF data has shape {data.shape}, expected (frequency, responses, references) = {shape}")
        if self.kind not in KINDS:
            raise DataError(f"unknown FRF kind {self.kind!r}; expected one of {KINDS}")
        for what, dofs in (("response", self.responses), ("reference", self.references)):
            if len(set(dofs)) != len(dofs):
                raise DataError(f"duplicated {what} DOF in FRF labels {[str(d) for d in dofs]}")
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        if self.coherence is not None:
            coh = np.array(self.coherence)
            if coh.shape != shape:
                raise DataError(f"FRF coherence has shape {coh.shape}, expected the data's shape {shape}")
            if np.iscomplexobj(coh) or not np.all(np.isfinite(coh)) or np.any(coh < 0) or np.any(coh > 1):
                raise DataError("FRF coherence must be real, finite and within [0, 1]")
            coh = coh.astype(float)
            coh.setflags(write=False)
            object.__setattr__(self, "coherence", coh)
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))
        marks = tuple((parse_dof(r), parse_dof(c), str(t)) for r, c, t in self.marks)
        if any(r not in self.responses or c not in self.references for r, c, _ in marks):
            raise DataError("FRF marks name a pair that is not among its responses and references")
        object.__setattr__(self, "marks", marks)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(F, r, c)."""
        return self.data.shape  # type: ignore[return-value]

    def to(self, kind: str) -> "FRF":
        """The same FRFs converted exactly to ``kind`` (receptance, mobility, accelerance)."""
        if kind == self.kind:
            return self
        factor = kind_factor(self.frequency.omega, self.kind, kind)
        return replace(self, data=self.data * factor[:, None, None], kind=kind)

    def select(self, responses: Iterable | None = None, references: Iterable | None = None) -> "FRF":
        """Sub-matrix by DOF labels (``None`` keeps all), in the order asked."""
        ri = list(range(len(self.responses))) if responses is None else dof_indices(self.responses, responses, "FRF responses")
        ci = list(range(len(self.references))) if references is None else dof_indices(self.references, references, "FRF references")
        kept_r, kept_c = {self.responses[i] for i in ri}, {self.references[i] for i in ci}
        return FRF(
            self.frequency,
            self.data[:, ri][:, :, ci],
            tuple(self.responses[i] for i in ri),
            tuple(self.references[i] for i in ci),
            self.kind,
            None if self.coherence is None else self.coherence[:, ri][:, :, ci],
            self.notes,
            tuple((r, c, t) for r, c, t in self.marks if r in kept_r and c in kept_c),
        )

    def band(self, start_hz: float | None = None, stop_hz: float | None = None) -> "FRF":
        """The lines in ``[start_hz, stop_hz]`` (either bound optional)."""
        m = self.frequency.mask(start_hz, stop_hz)
        if not m.any():
            raise FrequencyError(
                f"no FRF line in {start_hz}..{stop_hz} Hz (data cover {self.frequency.hz[0]:g}..{self.frequency.hz[-1]:g} Hz)"
            )
        coh = None if self.coherence is None else self.coherence[m]
        return replace(self, frequency=self.frequency[m], data=self.data[m], coherence=coh)

    def __call__(self, response, reference) -> np.ndarray:
        """One FRF vs frequency, shape (F,), by labels, e.g. ``frf("3w", "9w")``."""
        i = dof_indices(self.responses, [parse_dof(response)], "FRF responses")[0]
        j = dof_indices(self.references, [parse_dof(reference)], "FRF references")[0]
        return self.data[:, i, j]

    def unit(self, response: Dof | None = None, reference: Dof | None = None) -> str:
        """Unit string of the FRF between ``response`` and ``reference`` (default: first of each)."""
        r = response or self.responses[0]
        c = reference or self.references[0]
        base = r.unit
        num = {"receptance": base, "mobility": f"({base}/s)", "accelerance": f"({base}/s^2)"}[self.kind]
        return f"{num}/{c.force_unit}"

    def plot(self, pairs: Iterable[tuple] | None = None, ax=None):
        """Magnitude (log) and phase of FRFs; returns the matplotlib Figure. See :func:`jointid.plots.frf.plot_frf`."""
        from .plots.frf import plot_frf

        return plot_frf(self, pairs=pairs, axes=ax)
