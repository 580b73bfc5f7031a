"""Figure of a test design: predicted relative error per term vs frequency, two layouts."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_layout_design"]


def _nodes(nodes) -> str:
    return ",".join(str(k) for k in nodes)


#: Most panels of the figure: with more terms (6-DOF mounts), the weighted ones, then only the diagonal ones.
MAX_PANELS = 12


def _diagonal(name: str) -> bool:
    """``K_a_a`` (also ``"front:K_a_a"``): a diagonal term."""
    _, a, b = name.rpartition(":")[2].split("_", 2)
    return a == b


def _shown_terms(design) -> list[int]:
    """Indices of the terms to plot: all, or (more than :data:`MAX_PANELS`) the weighted ones, then the diagonal ones."""
    terms = list(range(len(design.terms)))
    if len(terms) > MAX_PANELS:
        terms = [t for t in terms if design.weights.get(design.terms[t], 1) > 0] or terms
    if len(terms) > MAX_PANELS:
        terms = [t for t in terms if _diagonal(design.terms[t])] or terms
    return terms


def plot_layout_design(design, axes=None):
    """Plot a :class:`~jointid.methods.design.layout.LayoutDesign`.

    One panel per term (more than :data:`MAX_PANELS`: the weighted ones, then only the
    diagonal ones; ``design.json`` has every term): the predicted relative error of the default identification
    (log scale, %; geometric mean over the design's scenarios) of the chosen layout
    (solid) and of the current layout (dashed), with their medians as horizontal lines.

    Parameters
    ----------
    design : LayoutDesign
    axes : sequence of Axes, optional
        One per shown term.

    Returns
    -------
    Figure
    """
    f = design.frequency.hz
    shown = _shown_terms(design)
    T = len(shown)
    if axes is None:
        cols = min(T, 6)
        rows = -(-T // cols)
        fig, axes = new_figure(rows, cols, figsize=(4.2 * cols + 1, 4.2 * rows))
    axes = np.atleast_1d(np.asarray(axes, dtype=object)).ravel()
    fig = axes[0].figure
    for ax in axes[T:]:
        ax.set_visible(False)
    chosen = f"chosen: observed {_nodes(design.observed)}; excited {_nodes(design.excited)}"
    rows = [(design.relative_std, chosen, "C0", "-")]
    if design.current_relative_std is not None:
        current = f"current: observed {_nodes(design.current_observed)}; excited {_nodes(design.current_excited)}"
        rows.append((design.current_relative_std, current, "C3", "--"))
    for ax, t in zip(axes, shown):
        name = design.terms[t]
        for rel, label, color, ls in rows:
            y = 100 * rel[:, t]
            ax.semilogy(f, np.where(np.isfinite(y), y, np.nan), ls, color=color, lw=1.0, label=label)
            med = np.median(y)
            if np.isfinite(med):
                ax.axhline(med, color=color, ls=":", lw=1.0)
        ax.set_title(f"{name} (weight {design.weights.get(name, 1):g})")
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel(f"predicted relative error (%), {100 * design.noise:g} % FRF noise")
    axes[0].legend(loc="upper left", fontsize=7)
    return fig
