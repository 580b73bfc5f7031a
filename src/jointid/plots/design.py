"""Figure of a test design: predicted relative error per term vs frequency, two layouts."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_layout_design"]


def _nodes(nodes) -> str:
    return ",".join(str(k) for k in nodes)


def plot_layout_design(design, axes=None):
    """Plot a :class:`~jointid.methods.design.LayoutDesign`.

    One panel per term: the predicted relative error of the default identification
    (log scale, %; geometric mean over the design's scenarios) of the chosen layout
    (solid) and of the current layout (dashed), with their medians as horizontal lines.

    Parameters
    ----------
    design : LayoutDesign
    axes : sequence of Axes, optional
        One per term.

    Returns
    -------
    Figure
    """
    f = design.frequency.hz
    T = len(design.terms)
    if axes is None:
        fig, axes = new_figure(1, T, figsize=(4.2 * T + 1, 4.2))
    axes = np.atleast_1d(np.asarray(axes, dtype=object)).ravel()
    fig = axes[0].figure
    chosen = f"chosen: observed {_nodes(design.observed)}; excited {_nodes(design.excited)}"
    rows = [(design.relative_std, chosen, "C0", "-")]
    if design.current_relative_std is not None:
        current = f"current: observed {_nodes(design.current_observed)}; excited {_nodes(design.current_excited)}"
        rows.append((design.current_relative_std, current, "C3", "--"))
    for t, (ax, name) in enumerate(zip(axes, design.terms)):
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
