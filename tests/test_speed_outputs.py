"""The fast paths of the identify outputs give what the plain paths give: CSV text, legend place, tick labels, bands."""

import csv
import io

import numpy as np
import pytest

from jointid.io.tables import _fmt, format_csv


def _plain_csv(columns) -> str:
    """The CSV text a field at a time (the reference of the bulk path)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(list(columns))
    for row in zip(*[np.asarray(c) for c in columns.values()]):
        w.writerow([_fmt(v) for v in row])
    return buf.getvalue()


@pytest.mark.parametrize("columns", [
    {"f": np.linspace(5, 1000, 7), "k": np.array([0.1, -0.0, np.nan, np.inf, -np.inf, 1e-300, 1.7976931348623157e308]),
     "n": np.arange(7), "u": np.arange(7, dtype=np.uint8), "ok": np.arange(7) % 2 == 0, "s": np.float32([0.1] * 7)},
    {"name": ["a,b", 'q"t', "plain"], "x": [1.5, 2.0, 3.0]},  # text columns: the csv module's quoting
    {"a": []},
    {},
    {"a": np.array([0.5, -0.0, np.nan]), "b": np.array([0.5, -0.0, np.nan]), "c": np.array([0.5, 0.0, np.nan]),  # repeated columns
     "d": np.float32([0.5, -0.0, np.nan]), "e": np.array([1, 0, 0]), "f": np.array([True, False, False])},
])
def test_bulk_csv_text_equals_the_per_field_text(columns):
    assert format_csv(columns) == _plain_csv(columns)


def test_bulk_csv_keeps_full_precision_and_bools_as_numbers():
    x = np.random.default_rng(0).standard_normal(1000) * 1e5
    text = format_csv({"x": x, "ok": x > 0})
    back = np.genfromtxt(io.StringIO(text), delimiter=",", names=True)
    assert np.array_equal(back["x"], x)  # shortest round-trip text: the same doubles
    assert np.array_equal(back["ok"], (x > 0).astype(float))


def test_legend_goes_where_the_data_are_not():
    from jointid.plots.fast_axes import place_legend
    from jointid.plots.style import new_figure

    fig, ax = new_figure(1, 1, layout=None)
    f = np.linspace(0.0, 1.0, 20000)
    ax.plot(f, 0.85 + 0.15 * np.sin(40 * f), ".", label="dense dots along the top")
    ax.plot(f, 0.95 + 0 * f, label="a line along the top")
    ax.set_ylim(0, 1)
    leg = place_legend(ax)
    assert leg._loc not in (1, 2, 9)  # upper right, upper left, upper center: over the data


def test_plain_log_tick_labels():
    from jointid.plots.fast_axes import plain_number

    assert [plain_number(v) for v in (1e5, 2e-4, 20.0, 0.5, 1e-3, 1e6, 3e4)] == ["1e5", "2e-4", "20", "0.5", "0.001", "1e6", "30000"]


def test_band_variance_from_the_factor_holds_where_the_quadratic_form_cancels():
    """Gradients orthogonal to the weakest kept direction (a term that does not move along it): ``|W^T g|^2`` keeps
    ``(P eps cond)^2`` relative (the rounding of that direction's singular vector, divided by its singular value,
    squared); ``g^T (W W^T) g`` with the covariance formed loses ``eps cond^2`` and goes below 0 (a band of 0)."""
    from jointid.methods.receptance.structured_bands import covariance_factor

    eps = np.finfo(float).eps
    rng = np.random.default_rng(1)
    N, P = 1800, 6
    U = np.linalg.qr(rng.normal(size=(N, P)))[0]
    V = np.linalg.qr(rng.normal(size=(P, P)))[0]
    for smin in (1e-6, 1e-9, 1e-12):
        s = np.array([1.0, 0.7, 0.4, 0.2, 0.1, smin])
        W, unseen = covariance_factor((U * s) @ V.T)
        assert W.shape == (P, P) and unseen.shape == (P, 0)
        Z = rng.normal(size=(200, P))
        Z -= np.outer(Z @ V[:, -1], V[:, -1])
        exact = np.sum((Z @ V[:, :-1]) ** 2 / s[:-1] ** 2, axis=1)
        rel = np.abs(np.sum((Z @ W) ** 2, axis=1) / exact - 1.0)
        assert rel.max() <= 100 * P * eps + (P * eps / smin) ** 2
        formed = np.einsum("mp,mp->m", Z @ (W @ W.T), Z)
        if smin <= 1e-12:
            assert np.abs(formed / exact - 1.0).max() > 1e3 * rel.max()


def test_ticks_in_view_draw_the_same_png_with_fewer_tick_artists(monkeypatch):
    """Log axes given only their ticks inside the view, their unlabelled minor ticks as one artist
    (fast_axes.ticks_in_view), draw the same bytes with fewer ticks made."""
    from jointid.dofs import Dof
    from jointid.frequency import Frequency
    from jointid.plots import fast_axes
    from jointid.plots.joint_stiffness import plot_joint_stiffness
    from jointid.plots.stiffness_data import JointStiffnessData
    from jointid.io.png import figure_png

    rng = np.random.default_rng(2)
    f = np.linspace(5.0, 1000.0, 400)
    K = np.empty((f.size, 2, 2), complex)
    K[:, 0, 0], K[:, 1, 1] = 1e6 * (1 + 0.1j) * (1 + f / 500), 2e3 * (1 + 0.15j)
    K[:, 0, 1] = K[:, 1, 0] = -3e4 * (1 + 0.05j) * (1 + (f / 300) ** 2)
    std = 0.02 * np.abs(K) * (1 + rng.random(K.shape))
    ok = np.ones(K.shape, bool)
    ok[f > 800, 1, 1] = False
    data = JointStiffnessData(Frequency(f), (Dof(10, "w"), Dof(10, "theta")), K, std, std, ok, 1.4 * std / np.abs(K),
                              K * (1 + 0.05 * rng.standard_normal(K.shape)), {"max_relative_std": 0.1}, "receptance", "test")

    def draw():
        fig = plot_joint_stiffness(data, truth=K * 1.01)
        png = figure_png(fig)
        one = sum(type(a).__name__ == "MinorTicks" for ax in fig.axes for a in ax.artists)
        return png, sum(len(a.majorTicks) + len(a.minorTicks) for ax in fig.axes for a in (ax.xaxis, ax.yaxis)), one

    fast, n_fast, one_artist = draw()
    monkeypatch.setattr(fast_axes, "ticks_in_view", lambda axis: None)
    plain, n_plain, none = draw()
    assert fast == plain
    assert n_fast < n_plain
    assert one_artist >= 5 and none == 0  # every log frequency axis' unlabelled minor ticks drawn as one artist


def test_minor_ticks_as_one_artist_sit_where_matplotlib_puts_its_minor_ticks():
    """The artist's positions are matplotlib's minor tick locations in the view, less the major ones; an axis with
    labelled minor ticks (a short log axis) keeps its Tick objects."""
    from matplotlib.ticker import NullFormatter

    from jointid.plots.fast_axes import minor_ticks_as_one_artist
    from jointid.plots.style import new_figure

    for lo, hi in ((5.0, 1000.0), (0.02, 3e4), (3.0, 40.0)):
        fig, (a, b) = new_figure(1, 2, sharex=False, layout=None)
        for ax in (a, b):
            ax.plot([lo, hi], [1.0, 2.0])
            ax.set_xscale("log")
            ax.set_xlim(lo, hi)
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.grid(True, which="both", alpha=0.3)
        fig.canvas.draw()
        expected = [t for t in b.xaxis.get_minorticklocs() if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        assert minor_ticks_as_one_artist(a.xaxis)
        assert not minor_ticks_as_one_artist(a.xaxis)  # once only
        (artist,) = a.artists
        # the same locator's values (10^k s, one product each): a few ulps apart at most, far inside 1e-12
        assert np.allclose(artist.positions(), expected, rtol=1e-12, atol=0) and len(expected) > 5
        assert not a.xaxis.get_minorticklocs().size  # matplotlib makes no minor Tick for it any more

    fig, ax = new_figure(1, 1, layout=None)
    ax.set_yscale("log")
    ax.set_ylim(2.0, 30.0)
    from jointid.plots.fast_axes import plain_log_ticks

    plain_log_ticks(ax.yaxis)  # a short axis: minor ticks labelled 2 and 5
    assert not ax.artists and not minor_ticks_as_one_artist(ax.yaxis)


def _two_panel_png(convert: bool, style, sharex: bool = False) -> bytes:
    """Two log-log panels (5-1000 on x, 0.3-2000 on y, minor ticks unlabelled), ``style(fig, axes)`` applied before or
    after the conversion as it says; with or without the minor ticks drawn as one artist."""
    from matplotlib.ticker import NullFormatter

    from jointid.plots.fast_axes import minor_ticks_as_one_artist
    from jointid.io.png import figure_png
    from jointid.plots.style import new_figure

    fig, axes = new_figure(1, 2, figsize=(6.0, 3.0), sharex=sharex, layout=None)
    for ax in axes:
        ax.plot([5.0, 1000.0], [0.3, 2000.0], lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(5.0, 1000.0)
        ax.set_ylim(0.3, 2000.0)
        ax.grid(True, which="both", alpha=0.3)
        for a in (ax.xaxis, ax.yaxis):
            a.set_minor_formatter(NullFormatter())
    style(fig, axes, "before")
    if convert:
        for ax in axes[:1] if sharex else axes:  # shared: converting one axes converts its siblings
            minor_ticks_as_one_artist(ax.xaxis)
            minor_ticks_as_one_artist(ax.yaxis)
        if sharex:
            minor_ticks_as_one_artist(axes[1].yaxis)
    style(fig, axes, "after")
    return figure_png(fig, dpi=80)


def _tick_style(fig, axes, when):
    if when == "after":
        axes[0].tick_params(which="minor", direction="in", top=True, right=True, length=5, width=1.2, color="r")
        axes[1].tick_params(which="minor", direction="inout", length=6)


def _grid_style(fig, axes, when):
    if when == "before":
        axes[0].grid(True, which="minor", linestyle=(0, (1, 4)), color="g", linewidth=1.5)
    else:
        axes[1].set_axisbelow(True)
        axes[1].grid(True, which="minor", color="m")


def _axis_off(fig, axes, when):
    if when == "after":
        axes[1].axis("off")


def _scale_changed(fig, axes, when):
    if when == "after":
        axes[0].set_xscale("linear")
        axes[0].set_xlim(5.0, 1000.0)
        axes[1].set_yscale("log")  # a fresh log scale: matplotlib's own minor ticks again (unlabelled here)
        from matplotlib.ticker import NullFormatter

        axes[1].yaxis.set_minor_formatter(NullFormatter())


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


@pytest.mark.parametrize("style", [_tick_style, _grid_style, _axis_off, _scale_changed], ids=["ticks", "grid", "axis-off", "scale"])
def test_minor_ticks_as_one_artist_draw_what_matplotlib_draws(style):
    """What matplotlib's own minor ticks draw: tick direction, length, width, colour and top/right marks, a dash-tuple
    grid and set_axisbelow after the conversion, an axes switched off, a scale changed afterwards.

    Only the order differs: matplotlib draws one axis' major then minor ticks, then the other axis'; the artists
    (children of the axes, at the axis' zorder) draw both axes' minor ticks first. Where lines of different colours
    cross, the blend differs (a few pixels, a few levels); a missing, doubled or misplaced tick or grid line, or
    another style, changes hundreds to thousands of pixels by up to 255 levels."""
    a, b = _pixels(_two_panel_png(True, style)), _pixels(_two_panel_png(False, style))
    d = np.abs(a - b).max(axis=2)
    assert np.count_nonzero(d) <= 1e-3 * d.size and d.max() <= 40


def test_minor_ticks_as_one_artist_on_shared_axes():
    """Converting one of two axes sharing x gives both the artist (they share the minor locator): the same bytes."""
    assert _two_panel_png(True, lambda *a: None, sharex=True) == _two_panel_png(False, lambda *a: None, sharex=True)


def test_a_figure_laid_out_once_has_the_pixels_of_savefig_and_keeps_its_layout_engine():
    """figure_png runs the constrained layout once (savefig runs it at each of its two draws) and draws the pixels
    matplotlib's own savefig draws; the figure keeps its engine and its titles' automatic position afterwards."""
    from matplotlib.image import imread
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    from jointid.io.png import PNG_COMPRESS_LEVEL, figure_png
    from jointid.plots.style import new_figure

    def build():
        fig, axes = new_figure(2, 2, figsize=(7.0, 5.0))
        f = np.linspace(10.0, 1000.0, 400)
        for i, ax in enumerate(axes.flat):
            ax.semilogy(f, 1e3 * (i + 1) * (1 + (f / 300.0) ** 2), label=f"term {i}")
            ax.set_title(f"K_{i} (long title {i})")
            ax.set_ylabel("|K| [N/m]")
            ax.legend()
        fig.suptitle("a constrained figure")
        return fig

    ref = build()
    buf = io.BytesIO()
    ref.savefig(buf, format="png", dpi=120, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    fig = build()
    engine = fig.get_layout_engine()
    calls = []
    run = engine.execute
    engine.execute = lambda f: (calls.append(1), run(f))[1]
    png = figure_png(fig, dpi=120)
    assert len(calls) == 1
    a, b = imread(io.BytesIO(buf.getvalue())), imread(io.BytesIO(png))
    assert a.shape == b.shape and np.array_equal(a, b)
    assert fig.get_layout_engine() is engine and isinstance(engine, ConstrainedLayoutEngine)
    assert all(ax._autotitlepos for ax in fig.axes)
