"""Cheap replacements for matplotlib's costly automatic layout steps, for figures of many thousand lines.

* :func:`place_legend` -- a legend at the least crowded of matplotlib's ten ``loc="best"``
  places, judged on at most a few hundred points per artist (matplotlib's ``"best"`` hit-tests
  every vertex of every curve at each draw);
* :func:`plain_log_ticks` -- tick labels of a log axis as plain numbers (``20``, ``0.5``, ``1e5``)
  instead of mathtext (``2 x 10^1``), which is parsed per label;
* :func:`fixed_margins` -- subplot margins given in inches, instead of a layout engine that
  measures every tick label before the figure is drawn;
* :func:`ticks_in_view` -- a log axis makes tick artists only for the ticks inside its view
  (matplotlib makes one for every tick of every decade the view touches, then draws the ones inside),
  and its unlabelled minor ticks are drawn as one artist (:func:`minor_ticks_as_one_artist`): matplotlib
  makes a ``Tick`` (two marks, a grid line and two labels) for each, ~1 ms apiece, most of the time of
  drawing a figure of a few log axes.

All of them draw the same information: only where a legend sits and how a tick number is
typeset may differ from matplotlib's automatic choices.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["place_legend", "plain_log_ticks", "plain_number", "fixed_margins", "ticks_in_view", "minor_ticks_as_one_artist"]

#: The points per artist that :func:`place_legend` tests (evenly spaced along the artist's data).
LEGEND_SAMPLE_POINTS = 400

# matplotlib's "best" candidates in its order of preference: (name, x anchor, y anchor) in 0 / 0.5 / 1 of the axes
_PLACES = (
    ("upper right", 1.0, 1.0), ("upper left", 0.0, 1.0), ("lower left", 0.0, 0.0), ("lower right", 1.0, 0.0),
    ("right", 1.0, 0.5), ("center left", 0.0, 0.5), ("center right", 1.0, 0.5), ("lower center", 0.5, 0.0),
    ("upper center", 0.5, 1.0), ("center", 0.5, 0.5),
)


def _axes_points(ax) -> np.ndarray:
    """The data of ``ax``'s lines and collections in axes coordinates (0..1), at most LEGEND_SAMPLE_POINTS each, shape (P, 2)."""
    to_axes = ax.transAxes.inverted()
    pts = []

    def add(xy, transform):
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if xy.shape[0] > LEGEND_SAMPLE_POINTS:
            xy = xy[np.linspace(0, xy.shape[0] - 1, LEGEND_SAMPLE_POINTS).astype(int)]
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if xy.size:
            with np.errstate(all="ignore"):
                pts.append(to_axes.transform(transform.transform(xy)))

    for line in ax.lines:
        add(line.get_xydata(), line.get_transform())
    for coll in ax.collections:
        for path in coll.get_paths():
            add(path.vertices, coll.get_transform())
    return np.concatenate(pts) if pts else np.empty((0, 2))


def _legend_size(ax, labels: list[str], fontsize: str | float, ncol: int) -> tuple[float, float]:
    """Width and height of a legend of ``labels`` in axes fractions, estimated from the font size (matplotlib's default paddings)."""
    from matplotlib.font_manager import FontProperties

    pt = FontProperties(size=fontsize).get_size_in_points()
    rows = -(-len(labels) // ncol)
    chars = max((len(s) for s in labels), default=0)
    width_pt = ncol * (chars * 0.55 * pt + 2.8 * pt) + 0.8 * pt  # text ~0.55 em a character, handle 2 em + gap 0.8 em
    height_pt = rows * 1.5 * pt + 0.8 * pt  # line pitch: font size + labelspacing 0.5 em
    bbox = ax.get_position()
    w_in, h_in = ax.figure.get_size_inches()
    return width_pt / 72.0 / (bbox.width * w_in), height_pt / 72.0 / (bbox.height * h_in)


def place_legend(ax, fontsize: str | float = "x-small", ncol: int = 1, **kwargs):
    """``ax.legend`` at the least crowded of matplotlib's ``"best"`` places, chosen once from sampled data.

    Counts the points of every line and collection of ``ax`` (evenly spaced
    samples, :data:`LEGEND_SAMPLE_POINTS` per artist) inside the box the legend
    would take at each candidate place, and takes the first place with the
    fewest, as ``loc="best"`` does; the legend is then fixed there, so drawing
    the figure does not test every vertex again. Call it after the axis scales
    and limits are set. Returns the Legend (None when ``ax`` has no labelled artist).
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    pts = _axes_points(ax)
    w, h = _legend_size(ax, labels, fontsize, ncol)
    pad = 0.02
    best, best_count = "upper right", None
    for name, ax_x, ax_y in _PLACES:
        x0 = {0.0: pad, 0.5: 0.5 - w / 2, 1.0: 1 - pad - w}[ax_x]
        y0 = {0.0: pad, 0.5: 0.5 - h / 2, 1.0: 1 - pad - h}[ax_y]
        inside = int(np.count_nonzero((pts[:, 0] >= x0) & (pts[:, 0] <= x0 + w) & (pts[:, 1] >= y0) & (pts[:, 1] <= y0 + h)))
        if best_count is None or inside < best_count:
            best, best_count = name, inside
        if inside == 0:
            break
    return ax.legend(handles, labels, loc=best, fontsize=fontsize, ncol=ncol, **kwargs)


def plain_number(v: float, _pos=None) -> str:
    """A tick value as a plain number: ``%g`` between 1e-3 and 1e5, else ``<mantissa>e<exponent>`` (``2e-4``, ``1e6``)."""
    if v == 0 or not np.isfinite(v):
        return f"{v:g}"
    e = int(np.floor(np.log10(abs(v)) + 1e-9))
    if -3 <= e < 5:
        return f"{v:g}"
    return f"{v / 10.0 ** e:g}e{e}"


def _minor_label(v: float, _pos=None) -> str:
    """Minor-tick labels of a log axis spanning little more than a decade: 2 and 5 of each decade, else none."""
    e = np.floor(np.log10(abs(v)) + 1e-9) if v > 0 else 0
    m = round(v / 10.0 ** e, 6) if v > 0 else 0
    return plain_number(v) if m in (2.0, 5.0) else ""


#: Relative margin (of a tick's value) beyond the view within which :func:`ticks_in_view` keeps a tick: far wider than
#: matplotlib's own test of which ticks to draw (1e-10 of the view in axis coordinates), so every drawn tick is kept.
IN_VIEW_MARGIN = 1e-6


def _in_view(locs: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The tick positions ``locs`` inside the view ``lo..hi`` of a log axis (within :data:`IN_VIEW_MARGIN`)."""
    with np.errstate(invalid="ignore"):
        return locs[(locs >= lo * (1.0 - IN_VIEW_MARGIN)) & (locs <= hi * (1.0 + IN_VIEW_MARGIN))]


def _in_view_locator(base):
    """A Locator giving ``base``'s ticks inside the axis' view (see :func:`ticks_in_view`)."""
    from matplotlib.ticker import Locator

    class InView(Locator):
        def __init__(self, base):
            self.base = base

        def set_axis(self, axis):
            super().set_axis(axis)
            self.base.set_axis(axis)

        def __call__(self):
            return _in_view(np.asarray(self.base()), *sorted(self.axis.get_view_interval()))

        def tick_values(self, vmin, vmax):
            return self.base.tick_values(vmin, vmax)

        def nonsingular(self, v0, v1):
            return self.base.nonsingular(v0, v1)

        def view_limits(self, vmin, vmax):
            return self.base.view_limits(vmin, vmax)

    return InView(base)


def ticks_in_view(axis) -> None:
    """Give a log ``axis`` only the major and minor ticks inside its view (positive limits), so no tick artist is made
    for the ones outside (about half on a log axis of two decades; making them is most of drawing such a figure).

    The figure is the same: matplotlib draws only the ticks inside the view, and a log axis'
    tick labels do not depend on the ticks outside (its formatters read the view limits).
    Call it after the scale is set (setting a scale replaces the locators); a linear axis is left
    as it is (its label format depends on every tick).
    """
    if axis.get_scale() != "log":
        return
    for get, put in ((axis.get_major_locator, axis.set_major_locator), (axis.get_minor_locator, axis.set_minor_locator)):
        loc = get()
        if not hasattr(loc, "base") or type(loc).__name__ != "InView":
            put(_in_view_locator(loc))
    minor_ticks_as_one_artist(axis)


def minor_ticks_as_one_artist(axis) -> bool:
    """Draw a log ``axis``' minor ticks (marks and grid lines, no labels) as one artist per axes; True if done.

    The artist draws, at the minor locator's positions inside the view at draw time (less those of
    major ticks, as matplotlib leaves them out), what matplotlib's minor ``Tick`` objects draw: the
    grid line (when the grid is on for minor ticks), then the marks, each styled as one minor tick of
    the axis (``axis.get_minor_ticks(1)``, copied with ``Line2D.update_from``: ``tick_params``, ``grid``
    and ``set_axisbelow`` settings made before or after this call are followed), nothing where the
    axes' axis is off. The axis' minor locator becomes a ``NullLocator``, for every axes sharing it
    (each gets its artist). Once the axis changes scale or minor locator again, the artist draws
    nothing (matplotlib's own minor ticks, if any, are drawn).

    Only for a log axis whose minor formatter is a ``NullFormatter`` (labelled minor ticks keep their
    ``Tick`` objects: the labels need them); returns False otherwise, and for an axis already converted.
    """
    from matplotlib.ticker import NullFormatter, NullLocator

    if (axis.get_scale() != "log" or not isinstance(axis.get_minor_formatter(), NullFormatter)
            or isinstance(axis.get_minor_locator(), NullLocator)):
        return False
    locator, null = axis.get_minor_locator(), NullLocator()
    axis.set_minor_locator(null)
    name = axis.axis_name
    shared = getattr(axis.axes, f"get_shared_{name}_axes")().get_siblings(axis.axes)
    for ax in shared or [axis.axes]:
        ax.add_artist(_minor_ticks_class()(getattr(ax, f"{name}axis"), locator, null))
    return True


@functools.cache
def _minor_ticks_class():
    """The artist class of :func:`minor_ticks_as_one_artist` (made on first use: matplotlib is imported then)."""
    from matplotlib.artist import Artist
    from matplotlib.lines import Line2D

    class MinorTicks(Artist):
        """An axis' minor tick marks and grid lines, drawn at its former minor locator's positions in the view."""

        def __init__(self, axis, locator, null):
            super().__init__()
            self.axis, self.locator, self.null = axis, locator, null

        @property
        def zorder(self):  # the axis' own, when the axes sorts its children (set_axisbelow changes it)
            return self.axis.get_zorder()

        @zorder.setter
        def zorder(self, value):
            pass

        def positions(self) -> np.ndarray:
            """The minor ticks' positions inside the view, less the major ticks' (data units)."""
            lo, hi = sorted(self.axis.get_view_interval())
            locs = _in_view(np.asarray(self.locator.tick_values(lo, hi), dtype=float), lo, hi)
            major = np.asarray(self.axis.get_majorticklocs(), dtype=float)
            if major.size and locs.size:
                locs = locs[~np.any(np.isclose(locs[:, None], major[None, :], rtol=1e-10, atol=0.0), axis=1)]
            return locs

        def active(self) -> bool:
            """Drawn: visible, the axes' axis on, and the axis still log with the minor locator set at conversion."""
            axis = self.axis
            return bool(self.get_visible() and axis.axes.axison and axis.get_visible() and axis.get_scale() == "log"
                        and axis.get_minor_locator() is self.null)

        def draw(self, renderer):
            if not self.active():
                return
            locs = self.positions()
            if not locs.size:
                return
            x = self.axis.axis_name == "x"
            tick = self.axis.get_minor_ticks(1)[0]  # the style of one minor tick as matplotlib makes it
            g = tick.gridline
            if g.get_visible():  # first: matplotlib draws a tick's grid line before its marks
                along, pos = np.tile([0.0, 1.0, np.nan], locs.size), np.repeat(locs, 3)
                self._draw_like(g, (pos, along) if x else (along, pos), renderer)
            for line, at in ((tick.tick1line, 0.0), (tick.tick2line, 1.0)):
                if line.get_visible():
                    other = np.full(locs.size, at)
                    self._draw_like(line, (locs, other) if x else (other, locs), renderer)
            self.stale = False

        def _draw_like(self, line, xy, renderer):
            """Draw ``xy`` as ``line`` (style, transform, clipping copied) would draw its own data."""
            copy = Line2D(*xy)
            copy.update_from(line)
            copy.set_figure(self.axis.axes.figure)
            copy.draw(renderer)

    return MinorTicks


def plain_log_ticks(axis) -> None:
    """Label a log ``axis`` (``ax.yaxis``/``ax.xaxis``) with plain numbers (:func:`plain_number`), no mathtext.

    Minor ticks are labelled (2 and 5 of a decade) only when the axis spans less than two
    decades, as matplotlib's default does for a short log axis.
    """
    from matplotlib.ticker import FuncFormatter, NullFormatter

    axis.set_major_formatter(FuncFormatter(plain_number))
    lo, hi = sorted(axis.get_view_interval())
    short = lo > 0 and hi / lo < 100.0
    axis.set_minor_formatter(FuncFormatter(_minor_label) if short else NullFormatter())
    ticks_in_view(axis)


def fixed_margins(fig, left: float, right: float, bottom: float, top: float, wspace: float, hspace: float) -> None:
    """Place ``fig``'s subplot grid with margins and gaps given in inches (no layout engine).

    ``left``, ``right``, ``bottom``, ``top``: from the figure's edges to the
    grid; ``wspace``, ``hspace``: between neighbouring axes.
    """
    w, h = fig.get_size_inches()
    gs = fig.axes[0].get_subplotspec().get_gridspec()
    nrows, ncols = gs.get_geometry()
    aw = (w - left - right - (ncols - 1) * wspace) / ncols
    ah = (h - bottom - top - (nrows - 1) * hspace) / nrows
    fig.subplots_adjust(left=left / w, right=1 - right / w, bottom=bottom / h, top=1 - top / h,
                        wspace=wspace / aw if ncols > 1 else 0.2, hspace=hspace / ah if nrows > 1 else 0.2)
