"""Figures of an inverse identification: |K_ij| (log), loss factor, condition numbers."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_identification", "TERM_UNITS"]

#: Units of the joint stiffness terms, keyed by (row direction, column direction).
TERM_UNITS = {("w", "w"): "N/m", ("w", "theta"): "N/rad", ("theta", "w"): "N*m/m", ("theta", "theta"): "N*m/rad"}


def plot_identification(result, truth: np.ndarray | None = None):
    """Plot an :class:`~jointid.methods.inverse.InverseResult`.

    A joint of more than 3 DOFs (a 3-D mount) gets the compact figure of
    :func:`jointid.plots.joint_matrix.plot_joint_terms`. Up to 3 DOFs: one
    column per independent joint term (upper triangle): magnitude on a log
    axis, loss factor ``Im/Re`` on a linear axis; beneath, the condition numbers
    (log axis). Unreliable lines are shaded.

    Parameters
    ----------
    result : InverseResult
    truth : ndarray, shape (F, n, n), optional
        True joint stiffness, drawn dashed.

    Returns
    -------
    Figure
    """
    from ..methods.inverse import dof_term_labels, term_unit

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
        storage = k.real > 0  # Im/Re is a loss factor only where the storage part is positive
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = np.where(storage, k.imag / k.real, np.nan)
        ax_m.semilogy(f, np.abs(k), lw=1.0, label="identified", zorder=2)
        ax_l.plot(f, eta, lw=1.0, label=f"identified (Re K > 0: {int(storage.sum())}/{f.size} lines)", zorder=2)
        if truth is not None:  # the reference on top of the noisy estimate
            t = truth[:, i, j]
            ax_m.semilogy(f, np.abs(t), "k--", lw=1.0, label="true", zorder=5)
            with np.errstate(divide="ignore", invalid="ignore"):
                ax_l.plot(f, np.where(t.real > 0, t.imag / t.real, np.nan), "k--", lw=1.0, label="true", zorder=5)
        ax_m.set_title(f"K_{di}_{dj}")
        ax_m.set_ylabel(f"|K_{di}_{dj}| [{term_unit(dofs[i], dofs[j])}]")
        ax_l.set_ylabel("loss factor [-] (where Re K > 0)")
        ax_l.legend(fontsize="x-small")
        lo, hi = np.nanpercentile(eta, [5, 95]) if np.isfinite(eta).any() else (0, 1)
        ax_l.set_ylim(min(lo, 0) - 0.05, max(hi, 0.2) + 0.05)
        for name in ("cond_A", "cond_B", "cond_H"):
            ax_c.semilogy(f, getattr(result, name), lw=0.9, label=name)
        ax_c.set_ylabel("condition number [-]")
        ax_c.set_xlabel("frequency [Hz]")
        for ax in (ax_m, ax_l, ax_c):
            ax.grid(True, which="both", alpha=0.3)
            if bad.any():
                ax.fill_between(f, 0, 1, where=bad, transform=ax.get_xaxis_transform(), color="0.85", lw=0, step="mid")
        if c == 0:
            ax_m.legend(fontsize="small")
            ax_c.legend(fontsize="small", ncol=3)
    fig.suptitle("inverse identification (shaded: lines flagged unreliable)")
    return fig
