"""Figures of the noise-robustness study: |K| with 90 % bands against the truth, error vs noise level."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from matplotlib.ticker import NullFormatter

from ..terms import Z90 as _Z90
from .inverse import TERM_UNITS
from .nvh_axes import set_frequency_axis
from .style import new_figure

__all__ = ["plot_band_examples", "plot_error_vs_noise", "magnitude_band"]

_TERMS = ((0, 0, "w", "w"), (0, 1, "w", "theta"), (1, 1, "theta", "theta"))
_COLORS = {"receptance": "C0", "receptance-raw": "C1", "hong-lee": "C2"}


def magnitude_band(k: np.ndarray, std_real: np.ndarray, std_imag: np.ndarray, z: float = _Z90) -> tuple[np.ndarray, np.ndarray]:
    """First-order ``|K| -+ z sigma_|K|`` with ``sigma_|K| = sqrt((Re K s_re)^2 + (Im K s_im)^2) / |K|``.

    Parameters
    ----------
    k : ndarray, complex, shape (F,)
    std_real, std_imag : ndarray, shape (F,)
        1-sigma standard deviations of the real and imaginary parts.

    Returns
    -------
    lower, upper : ndarray, shape (F,)
        The lower bound is clipped at 1e-3 |K| (log axes).
    """
    mag = np.abs(k)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.hypot(k.real * std_real, k.imag * std_imag) / mag
    return np.maximum(mag - z * s, 1e-3 * mag), mag + z * s


def plot_band_examples(panels: Sequence, methods: Mapping[str, str], title: str | None = None):
    """|K| of each term per joint position: estimates, the 90 % band of those that have one, the truth.

    Parameters
    ----------
    panels : sequence of (label, f_hz, truth, results)
        One row per entry: ``f_hz`` (F,), ``truth`` (F, 2, 2) complex, ``results`` method key -> a
        result with ``stiffness`` (F, 2, 2) and, for a band, ``std_real``/``std_imag``.
    methods : mapping
        Method key -> legend label; the first is drawn on top with its band, the others thin.

    The magnitude axis spans the truth's range widened 5x each way, so a wild estimate does not hide the others.
    """
    rows = len(panels)
    fig, axes = new_figure(rows, 3, figsize=(14.0, 3.4 * rows + 0.8))
    axes = np.asarray(axes).reshape(rows, 3)
    keys = list(methods)
    for r, (label, f, truth, results) in enumerate(panels):
        for c, (i, j, di, dj) in enumerate(_TERMS):
            ax = axes[r, c]
            for z, key in enumerate(keys):
                res = results[key]
                k = res.stiffness[:, i, j]
                color = _COLORS.get(key, f"C{z + 3}")
                top = z == 0
                if top and res.std_real is not None:
                    lo, hi = magnitude_band(k, res.std_real[:, i, j], res.std_imag[:, i, j])
                    ax.fill_between(f, lo, hi, color=color, alpha=0.3, lw=0, zorder=8, label=f"{methods[key]}: 90 % band")
                ax.semilogy(f, np.abs(k), color=color, lw=1.3 if top else 0.6, alpha=1.0 if top else 0.55,
                            zorder=9 if top else 5 - z, label=methods[key])
            t = np.abs(truth[:, i, j])
            ax.semilogy(f, t, "k--", lw=1.1, zorder=10, label="true")
            ax.set_ylim(t.min() / 5.0, t.max() * 5.0)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_title(f"{label}: |K_{di}_{dj}|", fontsize="medium")
            ax.set_ylabel(f"|K_{di}_{dj}| [{TERM_UNITS[(di, dj)]}]")
            set_frequency_axis(ax, f, label=r == rows - 1)
    axes[0, 0].legend(fontsize="x-small")
    if title:
        fig.suptitle(title)
    return fig


def plot_error_vs_noise(levels: Sequence[float], medians: Mapping[str, np.ndarray], methods: Mapping[str, str], terms: Sequence[str]):
    """Median relative error (%) per term vs noise level (%), log axes, one line per method.

    Parameters
    ----------
    levels : sequence of float, shape (L,)
        Relative noise rms.
    medians : mapping
        Method key -> median relative error per case, level and term, shape (cases, L, terms).
        The line is the median over cases, the shaded band their range.
    methods : mapping
        Method key -> legend label.
    terms : sequence of str
        Term labels (one panel each).
    """
    x = 100 * np.asarray(levels, float)
    fig, axes = new_figure(1, len(terms), figsize=(4.4 * len(terms) + 0.5, 4.2), sharex=False)
    axes = np.atleast_1d(axes)
    for t, (ax, term) in enumerate(zip(axes, terms)):
        for z, key in enumerate(methods):
            m = 100 * np.asarray(medians[key])[:, :, t]
            color = _COLORS.get(key, f"C{z + 3}")
            ax.loglog(x, np.median(m, axis=0), "o-", color=color, lw=1.3, ms=4, label=methods[key])
            if m.shape[0] > 1:
                ax.fill_between(x, m.min(axis=0), m.max(axis=0), color=color, alpha=0.12, lw=0)
        ax.set_xticks(x)
        ax.set_xticklabels([f"{v:g}" for v in x])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(term, fontsize="medium")
        ax.set_xlabel("FRF noise, relative rms [%]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("median relative error [%]")
    axes[0].legend(fontsize="x-small")
    return fig
