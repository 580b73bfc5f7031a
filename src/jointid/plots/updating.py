"""Model-updating figure: measured FRFs with the initial and the updated model."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .style import new_figure

__all__ = ["plot_update"]


def plot_update(measured, initial, updated, pairs: Sequence[tuple] | None = None, max_panels: int = 4):
    """|FRF| (log) of the measured FRFs, the initial model and the updated model, one panel per FRF.

    Parameters
    ----------
    measured, initial, updated : FRF
        Same lines, DOFs and kind.
    pairs : sequence of (response, reference), optional
        FRFs to draw; default: the driving points first, then others, at most ``max_panels``.
    """
    if pairs is None:
        drive = [(r, c) for c in measured.references for r in measured.responses if r == c]
        other = [(r, c) for c in measured.references for r in measured.responses if r != c]
        pairs = (drive + other)[:max_panels]
    pairs = list(pairs)
    fig, axes = new_figure(len(pairs), 1, figsize=(8.0, 2.4 * len(pairs) + 0.6))
    axes = np.atleast_1d(axes)
    f = measured.frequency.hz
    for ax, (r, c) in zip(axes, pairs):
        ax.semilogy(f, np.abs(measured(r, c)), color="0.55", lw=1.6, label="measured")
        ax.semilogy(f, np.abs(initial(r, c)), color="tab:red", lw=0.9, ls="--", label="initial model")
        ax.semilogy(f, np.abs(updated(r, c)), color="tab:blue", lw=0.9, label="updated model")
        ax.set_ylabel(f"|{r} / {c}|\n[{measured.unit()}]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize="small", ncol=3)
    axes[0].set_title(f"Free-free {measured.kind}: measured, initial and updated model")
    axes[-1].set_xlabel("frequency [Hz]")
    return fig
