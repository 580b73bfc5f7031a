"""Figures of the comparative studies: stiffness terms vs frequency, condition numbers, errors."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from .inverse import TERM_UNITS
from .nvh_axes import loss_or_phase, robust_limits, set_frequency_axis
from .style import new_figure

__all__ = ["plot_terms", "plot_conditions"]

_TERM_DIRS = {"translational": ("w", "w"), "coupling": ("w", "theta"), "rotational": ("theta", "theta")}


def plot_terms(
    f_hz: np.ndarray,
    curves: Mapping[str, Mapping[str, np.ndarray]],
    terms: Sequence[str] = ("translational", "coupling", "rotational"),
    title: str | None = None,
    truth_label: str | None = "true",
):
    """|K| (log) and loss factor (or phase) of joint terms, one line per variant (one legend entry each).

    The lower panel of a diagonal term shows the loss factor ``Im/Re``, or the
    phase of K in degrees when the reference curve's ``Re K`` crosses zero
    (:func:`jointid.plots.nvh_axes.loss_or_phase`); coupling terms get none.
    The frequency axis is logarithmic when the band spans a decade.

    Parameters
    ----------
    f_hz : ndarray, shape (F,)
    curves : mapping
        Variant label -> {term name -> complex stiffness (F,)}. The ``truth_label``
        entry, if present, is drawn dashed black.
    terms : sequence of {"translational", "coupling", "rotational"}
    """
    fig, axes = new_figure(2, len(terms), figsize=(4.3 * len(terms) + 1, 6.5), height_ratios=[1.6, 1])
    axes = np.asarray(axes).reshape(2, len(terms))
    for c, term in enumerate(terms):
        di, dj = _TERM_DIRS[term]
        ax_m, ax_l = axes[:, c]
        # one kind per panel, decided by the reference curve (truth, else the first): loss factor, or the
        # phase where Re K crosses zero (the loss factor runs to +-infinity there); limits from the reference
        ref = curves.get(truth_label) or next(iter(curves.values()))
        phase = bool(np.any(ref[term].real <= 0))
        for label, by_term in curves.items():
            k = by_term[term]
            style = dict(color="k", ls="--", lw=1.3) if label == truth_label else dict(lw=1.0)
            ax_m.semilogy(f_hz, np.abs(k), label=label, **style)
            if di == dj:  # a loss factor (or phase) of diagonal terms only
                ax_l.plot(f_hz, loss_or_phase(f_hz, k, force_phase=phase)[0], **style)
        ax_m.set_title(f"{term} K_{di}_{dj}")
        ax_m.set_ylabel(f"|K_{di}_{dj}| [{TERM_UNITS[(di, dj)]}]")
        if di == dj:
            ax_l.set_ylabel("phase [deg] (Re K crosses 0)" if phase else "loss factor [-]")
            lim = robust_limits(loss_or_phase(f_hz, ref[term], force_phase=phase)[0], include=(0.0,))
            if lim is not None:
                ax_l.set_ylim(*lim)
        else:
            ax_l.axis("off")
            ax_m.tick_params(labelbottom=True)  # the shared x axis' labels were on the panel now hidden
        for ax in (ax_m, ax_l):
            set_frequency_axis(ax, f_hz, label=ax is ax_l or di != dj)
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize="small")
    if title:
        fig.suptitle(title)
    return fig


def plot_conditions(f_hz: np.ndarray, conds: Mapping[str, Mapping[str, np.ndarray]], title: str | None = None):
    """Condition numbers (log axis) of the pseudo-inverted matrices, one panel per matrix, one line per layout.

    Parameters
    ----------
    conds : mapping
        Layout label -> {"cond_A": (F,), "cond_B": (F,), "cond_H": (F,)}.
    """
    names = {"cond_A": "cond(Do[nbar, mbar]) (estimation)", "cond_B": "cond(H*[n, e]) (identification)", "cond_H": "cond(H*[m, e]) (measured)"}
    fig, axes = new_figure(3, 1, figsize=(8.5, 8.0))
    for ax, (key, label) in zip(axes, names.items()):
        for layout, c in conds.items():
            ax.semilogy(f_hz, c[key], lw=1.0, label=layout)
        ax.set_ylabel("condition number [-]")
        ax.set_title(label, fontsize="medium")
        ax.grid(True, which="both", alpha=0.3)
        set_frequency_axis(ax, f_hz, label=ax is axes[-1])
    axes[0].legend(fontsize="small")
    if title:
        fig.suptitle(title)
    return fig
