"""Figures of a robust identification: each term with its 90 % band, loss factor or phase, flags."""

from __future__ import annotations

import numpy as np

from ..methods.coupling import Z90 as _Z90
from ..methods.inverse import dof_term_labels, term_unit
from .style import new_figure

__all__ = ["plot_joint_stiffness"]


def plot_joint_stiffness(result, truth: np.ndarray | None = None, axes=None):
    """Plot a :class:`~jointid.methods.coupling.CouplingResult`.

    A joint of more than 3 DOFs (a 3-D mount) gets the compact figure of
    :func:`jointid.plots.joint_matrix.plot_joint_terms` instead (diagonal terms
    and the largest couplings); below, up to 3 DOFs (the beam's joint):
    one column per independent term (upper triangle). Top: the real and
    imaginary parts with their 90 % bands (+-1.645 sigma) and the per-line
    estimates as faint dots; lines where the term is unreliable are shaded.
    Bottom: the loss factor ``Im/Re`` on the lines where the storage part is
    positive (elsewhere it is not a loss factor and is not drawn; the title says
    how many lines). The truth (if given) is drawn black, dashed, on top.

    Parameters
    ----------
    result : CouplingResult
    truth : ndarray, shape (F, n, n), optional
    axes : array of Axes, shape (2, n_terms), optional

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
    terms = [(i, j) for i in range(len(dofs)) for j in range(i, len(dofs))]
    if axes is None:
        fig, axes = new_figure(2, len(terms), figsize=(4.4 * len(terms) + 1, 6.5), height_ratios=[2, 1.2])
    else:
        fig = np.asarray(axes).flat[0].figure
    axes = np.asarray(axes).reshape(2, len(terms))
    for c, (i, j) in enumerate(terms):
        di, dj = labels[i], labels[j]
        k, sr, si = result.stiffness[:, i, j], result.std_real[:, i, j], result.std_imag[:, i, j]
        ax, ax_l = axes[:, c]
        for part, val, sd, color in (("Re", k.real, sr, "C0"), ("Im", k.imag, si, "C1")):
            ax.plot(f, getattr(result.per_line[:, i, j], "real" if part == "Re" else "imag"), ".", ms=1.5, color=color, alpha=0.25, zorder=1)
            ax.fill_between(f, val - _Z90 * sd, val + _Z90 * sd, color=color, alpha=0.25, lw=0, zorder=2, label=f"{part}: 90 % band")
            ax.plot(f, val, color=color, lw=1.2, zorder=3, label=f"{part} K_{di}_{dj}")
        storage = k.real > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            eta = np.where(storage, k.imag / k.real, np.nan)
        ax_l.plot(f, eta, color="C2", lw=1.2, zorder=3, label="identified")
        if truth is not None:
            t = truth[:, i, j]
            ax.plot(f, t.real, "k--", lw=1.0, zorder=5, label="true")
            ax.plot(f, t.imag, "k--", lw=1.0, zorder=5)
            with np.errstate(divide="ignore", invalid="ignore"):
                ax_l.plot(f, np.where(t.real > 0, t.imag / t.real, np.nan), "k--", lw=1.0, zorder=5, label="true")
        bad = ~result.reliable_terms[:, i, j]
        for a in (ax, ax_l):
            a.grid(True, alpha=0.3)
            if bad.any():
                a.fill_between(f, 0, 1, where=bad, transform=a.get_xaxis_transform(), color="0.88", lw=0, step="mid", zorder=0)
        ax.set_title(f"K_{di}_{dj} ({100 * (~bad).mean():.0f} % of lines reliable)")
        ax.set_ylabel(f"K_{di}_{dj} [{term_unit(dofs[i], dofs[j])}]")
        ax_l.set_ylabel("loss factor [-]")
        ax_l.set_title(f"loss factor where Re K > 0 ({int(storage.sum())} of {f.size} lines)", fontsize="small")
        ax_l.set_xlabel("frequency [Hz]")
        finite = eta[np.isfinite(eta)]
        if finite.size:
            lo, hi = np.percentile(finite, [2, 98])
            ax_l.set_ylim(min(lo, 0.0) - 0.05, max(hi, 0.2) + 0.05)
        if c == 0:
            ax.legend(fontsize="x-small", ncol=2)
    fig.suptitle(f"joint stiffness ({result.method}, weighting: {result.weighting}); shaded: term unreliable")
    return fig
