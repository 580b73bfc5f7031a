"""Figures of an inverse identification: |K_ij| (log), loss factor, condition numbers."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_identification", "TERM_UNITS"]

#: Units of the joint stiffness terms, keyed by (row direction, column direction).
TERM_UNITS = {("w", "w"): "N/m", ("w", "theta"): "N/rad", ("theta", "w"): "N*m/m", ("theta", "theta"): "N*m/rad"}


def plot_identification(result, truth: np.ndarray | None = None):
    """Plot an :class:`~jointid.methods.hong_lee.inverse.InverseResult`.

    A joint of more than 3 DOFs (a 3-D mount) gets the compact figure of
    :func:`jointid.plots.joint_matrix.plot_joint_terms`. Up to 3 DOFs: one
    column per independent joint term (upper triangle): magnitude on a log
    axis; for diagonal terms the loss factor ``Im/Re``, or the phase where
    ``Re K`` crosses zero (:func:`jointid.plots.nvh_axes.loss_or_phase`);
    beneath, the condition numbers (log axis). Unreliable lines are shaded;
    the frequency axis is logarithmic when the band spans a decade.

    Parameters
    ----------
    result : InverseResult
    truth : ndarray, shape (F, n, n), optional
        True joint stiffness, drawn dashed.

    Returns
    -------
    Figure
    """
    from ..terms import dof_term_labels, term_unit
    from .joint_stiffness import draw_loss_or_phase
    from .nvh_axes import robust_log_limits, set_frequency_axis

    f = result.frequency.hz
    dofs = result.joint_dofs
    if len(dofs) > 3:  # a 3-D mount: diagonal terms and the largest couplings in one compact figure
        from .joint_matrix import plot_joint_terms

        return plot_joint_terms(result, truth=truth)
    labels = dof_term_labels(dofs)
    terms = [(i, j) for i in range(len(dofs)) for j in range(i, len(dofs))]
    fig, axes = new_figure(3, len(terms), figsize=(4.2 * len(terms) + 1, 8.0), height_ratios=[2, 1.3, 1.3])
    axes = np.asarray(axes).reshape(3, len(terms))
    bad = ~np.asarray(result.reliable, bool)
    for c, (i, j) in enumerate(terms):
        di, dj = labels[i], labels[j]
        k = result.stiffness[:, i, j]
        ax_m, ax_l, ax_c = axes[:, c]
        ax_m.semilogy(f, np.abs(k), lw=1.0, label="identified", zorder=2)
        if truth is not None:  # the reference on top of the noisy estimate
            ax_m.semilogy(f, np.abs(truth[:, i, j]), "k--", lw=1.0, label="true", zorder=5)
        ax_m.set_title(f"K_{di}_{dj}")
        ax_m.set_ylabel(f"|K_{di}_{dj}| [{term_unit(dofs[i], dofs[j])}]")
        mag = np.abs(k)
        if np.isfinite(mag).any():  # limits from the bulk of the estimate and the truth, not from outlying lines
            core = np.clip(mag, *np.nanpercentile(mag, [2, 98]))
            lim = robust_log_limits(core, None if truth is None else np.abs(truth[:, i, j]))
            if lim is not None:
                ax_m.set_ylim(*lim)
        if i == j:  # a loss factor (or phase) of a diagonal term only; a coupling term's Im/Re means nothing
            draw_loss_or_phase(ax_l, f, k, truth=None if truth is None else truth[:, i, j])
            ax_l.legend(fontsize="x-small")
        else:
            ax_l.axis("off")
        for name in ("cond_A", "cond_B", "cond_H"):
            ax_c.semilogy(f, getattr(result, name), lw=0.9, label=name)
        ax_c.set_ylabel("condition number [-]")
        for ax in (ax_m, ax_l, ax_c):
            set_frequency_axis(ax, f, label=ax is ax_c)
            ax.grid(True, which="both", alpha=0.3)
            if bad.any() and ax.axison:
                ax.fill_between(f, 0, 1, where=bad, transform=ax.get_xaxis_transform(), color="0.85", lw=0, step="mid",
                                label="line unreliable" if ax is ax_m else None)
        if c == 0:
            ax_m.legend(fontsize="small")
            ax_c.legend(fontsize="small", ncol=3)
    fig.suptitle("inverse identification (shaded: lines flagged unreliable)")
    return fig
