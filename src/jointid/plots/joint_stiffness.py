"""Figures of a robust identification: each term's |K| with its 90 % band, loss factor or phase, flags."""

from __future__ import annotations

import numpy as np

from ..terms import Z90 as _Z90
from ..terms import dof_term_labels, term_unit
from .nvh_axes import loss_or_phase, loss_or_phase_std, magnitude_band, robust_limits, robust_log_limits, set_frequency_axis
from .fast_axes import fixed_margins, place_legend, plain_log_ticks
from .stiffness_data import JointStiffnessData
from .style import new_figure

__all__ = ["plot_joint_stiffness", "joint_stiffness_figure", "draw_term_magnitude", "draw_loss_or_phase", "JointStiffnessData"]

_UNRELIABLE = dict(color="0.88", lw=0, step="mid", zorder=0)


def _shade(ax, f, bad, label: bool) -> None:
    """Grey background on the lines where the term is unreliable (one legend entry)."""
    if bad.any():
        ax.fill_between(f, 0, 1, where=bad, transform=ax.get_xaxis_transform(), label="term unreliable" if label else None, **_UNRELIABLE)


def draw_term_magnitude(ax, f, k, std_real, std_imag, per_line=None, truth=None, bad=None, unit: str = "", name: str = "K"):
    """``|K|`` on a log axis with its 90 % band, the per-line estimates as faint dots, the truth dashed.

    The y limits cover the estimate, its band (at most a decade beyond the
    estimate) and the truth, not the scatter of the per-line estimates.
    Every artist has a legend entry.
    """
    mag = np.abs(k)
    lo, hi = magnitude_band(k, std_real, std_imag, _Z90)
    floor = mag / 1e3
    if per_line is not None:
        ax.plot(f, np.abs(per_line), ".", ms=1.5, color="0.45", alpha=0.35, zorder=1, label="per-line estimate (not smoothed)")
    ax.fill_between(f, np.maximum(lo, floor), hi, color="C0", alpha=0.3, lw=0, zorder=2, label="90 % band")
    ax.plot(f, mag, color="C0", lw=1.4, zorder=3, label="estimate")
    if truth is not None:
        ax.plot(f, np.abs(truth), "k--", lw=1.0, zorder=5, label="true")
    if bad is not None:
        _shade(ax, f, bad, label=True)
    ax.set_yscale("log")
    lim = robust_log_limits(mag, None if truth is None else np.abs(truth), band=(lo, hi))
    if lim is not None:
        ax.set_ylim(*lim)
    ax.set_ylabel(f"|{name}| [{unit}]")
    ax.grid(True, which="both", alpha=0.3)


def draw_loss_or_phase(ax, f, k, std_real=None, std_imag=None, truth=None, bad=None) -> str:
    """The loss factor of a diagonal term (or its phase where ``Re K`` crosses zero) with its 90 % band.

    Returns ``"loss factor"`` or ``"phase"`` (:func:`jointid.plots.nvh_axes.loss_or_phase`).
    """
    force = bool(np.any(k.real <= 0) or (truth is not None and np.any(truth.real <= 0)))
    val, kind = loss_or_phase(f, k, force_phase=force)
    parts = [val]
    if std_real is not None:
        s = _Z90 * loss_or_phase_std(k, std_real, std_imag, kind)
        width = np.nanmedian(np.abs(val)) + 1e-12 if np.isfinite(val).any() else 1.0
        s = np.minimum(s, 3 * width)  # a band wider than the curve's scale says nothing more: clip for the axis
        ax.fill_between(f, val - s, val + s, color="C2", alpha=0.3, lw=0, zorder=2, label="90 % band")
        parts += [val - s, val + s]
    ax.plot(f, val, color="C2", lw=1.3, zorder=3, label="estimate")
    if truth is not None:
        t, _ = loss_or_phase(f, truth, force_phase=kind == "phase")
        ax.plot(f, t, "k--", lw=1.0, zorder=5, label="true")
        parts.append(t)
    if bad is not None:
        _shade(ax, f, bad, label=True)
    lim = robust_limits(*parts, include=(0.0,))
    if lim is not None:
        ax.set_ylim(*lim)
    ax.set_ylabel("phase [deg]" if kind == "phase" else "loss factor [-]")
    ax.grid(True, which="both", alpha=0.3)
    return kind


def joint_stiffness_figure(n_dofs: int):
    """The empty figure :func:`plot_joint_stiffness` draws a joint of ``n_dofs`` (<= 3) DOFs into: ``(fig, axes)``,
    axes shape (2, independent terms), fixed margins (no layout engine: the figure of 20 000 lines draws in a
    fraction of the time). Made ahead by the figure worker while the identification runs."""
    terms = n_dofs * (n_dofs + 1) // 2
    fig, axes = new_figure(2, terms, figsize=(4.6 * terms + 0.6, 7.0), height_ratios=[1.6, 1], sharex=False, layout=None)
    fixed_margins(fig, left=0.8, right=0.15, bottom=0.55, top=0.6, wspace=0.9, hspace=0.45)
    return fig, axes


def plot_joint_stiffness(result, truth: np.ndarray | None = None, axes=None, prepared=None):
    """Plot a :class:`~jointid.methods.receptance.coupling.CouplingResult` as an NVH engineer reads it.

    A joint of more than 3 DOFs (a 3-D mount) gets the compact figure of
    :func:`jointid.plots.joint_matrix.plot_joint_terms` instead. Up to 3 DOFs
    (the beam's joint): one column per independent term (upper triangle).
    Top: ``|K|`` on a log axis with its 90 % band (+-1.645 sigma, first order),
    the per-line estimates as faint dots; lines where the term is unreliable are
    shaded. Bottom, diagonal terms only: the loss factor ``Im/Re`` with its band,
    or the phase of K in degrees when ``Re K`` crosses zero in the band (a loss
    factor would run to +-infinity there); under the first coupling term, the
    predicted relative error (1 sigma) of every term against the reliability
    threshold. Axes are scaled to the estimate and its band, not to the per-line
    scatter; the frequency axis is logarithmic when the band spans a decade.
    The truth (if given) is drawn black, dashed, on top. Every artist has a
    legend entry.

    Parameters
    ----------
    result : JointEstimate or JointStiffnessData
    truth : ndarray, shape (F, n, n), optional
    axes : array of Axes, shape (2, n_terms), optional
    prepared : tuple, optional
        ``(fig, axes)`` of :func:`joint_stiffness_figure`, unused, made ahead: drawn into as into the figure made
        here (the same figure); one of another size is not used.

    Returns
    -------
    Figure
    """
    f = result.frequency.hz
    dofs = result.joint_dofs
    if len(dofs) > 3 and axes is None:
        from .joint_matrix import plot_joint_terms

        return plot_joint_terms(result, truth=truth)
    labels = dof_term_labels(dofs)
    lines = result.line_estimates()  # the per-line estimates behind a smoothed result (None: it is per line)
    terms = [(i, j) for i in range(len(dofs)) for j in range(i, len(dofs))]
    own = axes is None
    if own:
        ready = prepared is not None and np.size(prepared[1]) == 2 * len(terms)
        fig, axes = prepared if ready else joint_stiffness_figure(len(dofs))
    else:
        fig = np.asarray(axes).flat[0].figure
    axes = np.asarray(axes).reshape(2, len(terms))
    error_panel_drawn = False
    for c, (i, j) in enumerate(terms):
        name = f"K_{labels[i]}_{labels[j]}"
        k, sr, si = result.stiffness[:, i, j], result.std_real[:, i, j], result.std_imag[:, i, j]
        t = None if truth is None else truth[:, i, j]
        bad = ~result.reliable_terms[:, i, j]
        ax, ax_l = axes[:, c]
        draw_term_magnitude(ax, f, k, sr, si, per_line=None if lines is None else lines[:, i, j], truth=t, bad=bad,
                            unit=term_unit(dofs[i], dofs[j]), name=name)
        ax.set_title(f"{name} ({100 * (~bad).mean():.0f} % of lines reliable)", y=1.0)  # y given: no search for top tick labels
        if i == j:
            kind = draw_loss_or_phase(ax_l, f, k, sr, si, truth=t, bad=bad)
            ax_l.set_title(f"{name}: " + ("loss factor Im K / Re K" if kind == "loss factor" else
                           "phase (Re K crosses 0: no loss factor there)"), fontsize="small", y=1.0)
        elif not error_panel_drawn:
            _draw_predicted_errors(ax_l, result, labels)
            error_panel_drawn = True
        else:
            ax_l.axis("off")
        for a in (ax, ax_l):
            set_frequency_axis(a, f, label=a is ax_l)
            if a.axison:
                if a.get_yscale() == "log":
                    plain_log_ticks(a.yaxis)
                place_legend(a, ncol=2 if a is ax_l and i != j else 1)
        if own:
            ax.tick_params(labelbottom=False)  # the frequency is labelled under the bottom row
    o = result.options_summary()
    how = "".join(f", {k}: {o[k]}" for k in ("weighting",) if k in o)
    fig.suptitle(f"joint stiffness ({result.method}, estimator: {result.estimator}{how}); shaded: term unreliable")
    return fig


def _draw_predicted_errors(ax, result, labels) -> None:
    """Predicted relative error (1 sigma) of each independent term, log axis, with the reliability threshold."""
    f = result.frequency.hz
    rel = result.relative_std
    n = len(labels)
    for c, (i, j) in enumerate((i, j) for i in range(n) for j in range(i, n)):
        ax.plot(f, rel[:, i, j], lw=1.0, color=f"C{c}", label=f"K_{labels[i]}_{labels[j]}")
    threshold = result.options_summary().get("max_relative_std")
    if threshold is not None:
        ax.axhline(threshold, color="C3", ls=":", lw=1.2, label=f"threshold {threshold:g}")
    ax.set_yscale("log")
    finite = rel[np.isfinite(rel) & (rel > 0)]
    if finite.size:
        ax.set_ylim(max(np.percentile(finite, 1) / 2, 1e-6), max(np.percentile(finite, 99) * 2, 2 * (threshold or 0.0)))
    else:
        ax.text(0.5, 0.5, "no per-term uncertainty from this method", transform=ax.transAxes, ha="center", va="center")
    ax.set_ylabel("predicted relative error (1 sigma)")
    ax.set_title("predicted error of each term; above the threshold: unreliable", fontsize="small", y=1.0)
    ax.grid(True, which="both", alpha=0.3)
