"""A matplotlib figure as PNG bytes, laid out once: the one place jointid renders its figures.

``Figure.savefig`` on a figure with a layout engine (matplotlib's ``"constrained"``) draws the
figure twice -- once without rendering, to lay it out, then again -- and each draw runs the
engine, which measures every tick label of every axes (twice per run). :func:`figure_png` runs
the engine once, at the dpi of the PNG, detaches it for the one drawing ``savefig`` then does,
and attaches it again: the same positions, so the same pixels (measured on the model-error
study's figures: identical). With the change below, ``jointid reproduce --only
conditioning,model-error`` took 0.91 of the time (4 interleaved runs).

An axes title's automatic height (matplotlib moves a title above top tick labels or a top
axis) asks every axes of the row for its tick labels' extents at each draw. jointid's figures
have neither, so the search is switched off for the drawing: titles stay at ``y = 1``, where the
search puts them when nothing is above the axes.

Only a duck-typed ``Figure`` is used here (no matplotlib import): the lowest layer may render
what the figure modules built.
"""

from __future__ import annotations

import io
from contextlib import contextmanager

__all__ = ["figure_png", "laid_out_once", "PNG_COMPRESS_LEVEL"]

#: zlib level of the PNGs written here (the pixels do not depend on it). Measured on ``joint_stiffness.png`` of
#: 19 901 lines (1380 x 840 px): level 6 (PIL's default) 0.053 s, 315 kB; 3: 0.036 s, 303 kB (a third faster, and
#: smaller: the line-art's filtered rows compress as well at the lower level).
PNG_COMPRESS_LEVEL = 3


@contextmanager
def laid_out_once(fig, dpi: float):
    """Within the block, ``fig`` is laid out for ``dpi`` and draws without running its layout engine again.

    The engine (if any) runs once with the figure at ``dpi`` and is detached; titles keep ``y = 1``
    (module docstring). Both are restored on exit; the axes keep their laid-out positions, as after
    any ``savefig``.
    """
    engine = fig.get_layout_engine()
    autotitle = [(ax, getattr(ax, "_autotitlepos", None)) for ax in fig.axes]
    try:
        for ax, auto in autotitle:
            if auto:
                ax._autotitlepos = False
        if engine is not None:
            own_dpi = fig.dpi
            fig.set_dpi(dpi)
            try:
                engine.execute(fig)
            finally:
                fig.set_dpi(own_dpi)
            fig.set_layout_engine(None)
        yield fig
    finally:
        for ax, auto in autotitle:
            if auto:
                ax._autotitlepos = auto
        if engine is not None:
            fig.set_layout_engine(engine)


def figure_png(fig, dpi: float = 120) -> bytes:
    """``fig`` (a matplotlib ``Figure``) as PNG bytes at ``dpi``, laid out once (:func:`laid_out_once`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    dpi : float
        Pixels per inch of the PNG.
    """
    buf = io.BytesIO()
    with laid_out_once(fig, dpi):
        fig.savefig(buf, format="png", dpi=dpi, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return buf.getvalue()
