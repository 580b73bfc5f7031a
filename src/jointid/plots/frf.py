"""FRF figures: log magnitude and phase vs frequency."""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from .style import new_figure

__all__ = ["plot_frf"]


def plot_frf(frf, pairs: Iterable[tuple] | None = None, axes=None, markers_hz: Sequence[float] = (), title: str | None = None):
    """Plot |FRF| (log axis) and phase (deg) vs frequency (Hz).

    Parameters
    ----------
    frf : FRF
    pairs : iterable of (response, reference), optional
        Which FRFs to draw (default: every pair).
    axes : pair of Axes, optional
        (magnitude, phase) axes to draw into; a new Figure otherwise.
    markers_hz : sequence of float
        Frequencies (Hz) marked with vertical dotted lines (e.g. natural frequencies).
    title : str, optional

    Returns
    -------
    Figure
    """
    if axes is None:
        fig, (ax_m, ax_p) = new_figure(2, 1, height_ratios=[3, 1])
    else:
        ax_m, ax_p = axes
        fig = ax_m.figure
    if pairs is None:
        pairs = [(r, c) for c in frf.references for r in frf.responses]
    f = frf.frequency.hz
    for r, c in pairs:
        h = frf(r, c)
        ax_m.semilogy(f, np.abs(h), lw=1.0, label=f"{r} / {c}")
        ax_p.plot(f, np.degrees(np.angle(h)), lw=0.8)
    for x in markers_hz:
        if f[0] <= x <= f[-1]:
            ax_m.axvline(x, color="0.6", ls=":", lw=0.8)
    ax_m.set_ylabel(f"|{frf.kind}| [{frf.unit()}]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_yticks([-180, -90, 0, 90, 180])
    ax_p.set_xlabel("frequency [Hz]")
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, alpha=0.3)
    if len(list(pairs)) <= 12:
        ax_m.legend(fontsize="small", ncol=2)
    if title:
        ax_m.set_title(title)
    return fig
