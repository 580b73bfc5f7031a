"""Shared figure helpers: a Figure without pyplot state, atomic PNG saving."""

from __future__ import annotations

import os
from pathlib import Path

from matplotlib.figure import Figure

from ..io.atomic import atomic_write_bytes
from ..io.png import figure_png

__all__ = ["new_figure", "save_figure"]


def new_figure(rows: int = 1, cols: int = 1, height_ratios=None, figsize=(8.0, 6.0), sharex: bool = True,
               layout: str | None = "constrained"):
    """A Figure with a grid of axes (no pyplot, safe in threads and headless runs).

    ``layout``: matplotlib's layout engine (``"constrained"``), or None for
    margins set by the caller (:func:`jointid.plots.fast_axes.fixed_margins`):
    the constrained layout measures every tick label before the figure is drawn.

    Returns
    -------
    fig : Figure
    axes : ndarray of Axes, shape (rows, cols) squeezed
    """
    fig = Figure(figsize=figsize, layout=layout)
    axes = fig.subplots(rows, cols, sharex=sharex, squeeze=False, gridspec_kw={"height_ratios": height_ratios} if height_ratios else None)
    return fig, axes.squeeze() if axes.size > 1 else axes[0, 0]


def save_figure(fig: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Save ``fig`` as PNG at ``path`` atomically (umask permissions), laid out once
    (:func:`jointid.io.png.figure_png`); returns the path.

    For a command's outputs use :meth:`jointid.io.output_dir.OutputSet.write_figure`.
    """
    atomic_write_bytes(path, figure_png(fig, dpi=dpi))
    return Path(path)
