"""Figure of the real-world study: a value per case and term as grouped bars."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .style import new_figure

__all__ = ["plot_case_terms"]


def plot_case_terms(groups: Sequence, column: int = 0, *, ylabel: str = "", scale: float = 1.0, log: bool = False,
                    reference: float | None = None, legend: bool = True, ax=None):
    """One bar per case and term, the cases side by side (the real-world study's reliable fractions or errors).

    Parameters
    ----------
    groups : sequence of (case label, term names, values)
        ``values``: shape (terms, k); column ``column`` is drawn. NaN draws no bar.
    column : int
        Column of ``values`` to draw.
    ylabel : str
    scale : float
        Factor on the values (100: fractions as percent).
    log : bool
        Logarithmic value axis.
    reference : float, optional
        A dashed horizontal line at this (scaled) value, e.g. the 90 % a band should cover.
    legend : bool
        The cases' legend, under the axes.
    ax : Axes, optional
        Draw into it (default: a new figure).

    Returns
    -------
    Figure
    """
    if ax is None:
        fig, ax = new_figure(figsize=(8.0, 4.6))
    else:
        fig = ax.figure
    x, ticks, names, colors = 0.0, [], [], []
    for g, (label, terms, values) in enumerate(groups):
        v = scale * np.asarray(values, float)[:, column]
        pos = x + np.arange(len(terms))
        ok = np.isfinite(v) & ((v > 0) if log else True)
        ax.bar(pos[ok], v[ok], width=0.8, color=f"C{g}", label=label)
        ticks.extend(pos)
        names.extend(t.removeprefix("K_") for t in terms)
        colors.extend([f"C{g}"] * len(terms))
        x = pos[-1] + 2.0
    if log:
        ax.set_yscale("log")
    ax.set_xticks(ticks)
    ax.set_xticklabels(names, rotation=90, fontsize="small")
    for tick, c in zip(ax.get_xticklabels(), colors):
        tick.set_color(c)
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    if reference is not None:
        ax.axhline(reference, color="k", ls="--", lw=0.8)
    if legend:
        ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(0.0, -0.27), ncol=2, frameon=False)
    return fig
