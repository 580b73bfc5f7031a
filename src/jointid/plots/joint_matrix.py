"""Figures of a joint with many DOFs (a 6-DOF mount, 12 x 12 between two parts).

:func:`plot_joint_matrix`: ``|K_ij|`` of every term at a few frequencies;
:func:`plot_joint_terms`: the diagonal terms and the largest couplings over frequency.
"""

from __future__ import annotations

import numpy as np

from ..methods.inverse import dof_term_labels, term_unit
from .style import new_figure

__all__ = ["plot_joint_matrix", "plot_joint_terms", "largest_couplings"]


def plot_joint_matrix(result, n_frequencies: int = 4, title: str = ""):
    """``|K_ij|`` of every term as an image, one panel per frequency (log colour scale, shared).

    Parameters
    ----------
    result : CouplingResult or InverseResult
        Anything with ``frequency``, ``joint_dofs`` and ``stiffness`` (F, n, n).
    n_frequencies : int
        Panels, at lines spread evenly over the band (first and last included).
    title : str
        Prefix of the figure title (e.g. the joint's name).

    Returns
    -------
    Figure
    """
    from matplotlib.colors import LogNorm

    f = result.frequency.hz
    K = np.abs(result.stiffness)
    labels = dof_term_labels(result.joint_dofs)
    lines = np.unique(np.linspace(0, f.size - 1, min(n_frequencies, f.size)).round().astype(int))
    n = K.shape[1]
    fig, axes = new_figure(1, lines.size, figsize=(3.2 * lines.size + 1.5, 3.4 + 0.12 * n), sharex=False)
    axes = np.atleast_1d(axes)
    positive = K[lines][K[lines] > 0]
    vmax = float(positive.max()) if positive.size else 1.0
    vmin = max(float(positive.min()) if positive.size else vmax * 1e-6, vmax * 1e-8)
    norm = LogNorm(vmin=vmin, vmax=vmax)
    for ax, i in zip(axes, lines):
        im = ax.imshow(np.clip(K[i], vmin, None), norm=norm, cmap="viridis")
        ax.set_title(f"{f[i]:g} Hz")
        ax.set_xticks(range(n), labels, rotation=90, fontsize="x-small")
        ax.set_yticks(range(n), labels, fontsize="x-small")
    fig.colorbar(im, ax=list(axes), label="|K_ij| (SI: N/m, N/rad, N*m/rad)")
    fig.suptitle((f"{title}: " if title else "") + "joint matrix, |K_ij| of every term")
    return fig


def largest_couplings(stiffness: np.ndarray, count: int = 4) -> list[tuple[int, int]]:
    """The ``count`` off-diagonal terms (i < j) with the largest ``max_f |K_ij| / sqrt(|K_ii| |K_jj|)``, largest first.

    Terms below 1e-6 of that scale (zero up to round-off) are left out.
    """
    n = stiffness.shape[1]
    mag = np.abs(stiffness)
    d = np.sqrt(mag[:, range(n), range(n)])
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.nan_to_num(np.max(mag / (d[:, :, None] * d[:, None, :]), axis=0))
    off = sorted(((i, j) for i in range(n) for j in range(i + 1, n)), key=lambda t: -rel[t])
    return [t for t in off[:count] if rel[t] > 1e-6]


def plot_joint_terms(result, truth: np.ndarray | None = None, couplings: int = 4):
    """A joint of many DOFs in three panels: diagonal storage stiffness, diagonal loss factor, largest couplings.

    Each diagonal term ``Re K_ii`` (log scale; unit by DOF: N/m or N*m/rad) with
    its 90 % band; the loss factor ``Im/Re`` of each; and the
    :func:`largest_couplings` as ``|K_ij| / sqrt(|K_ii| |K_jj|)`` (dimensionless,
    so translations and rotations share an axis). The truth (if given) is dashed
    black. Few axes on purpose: a panel per term of a 12 x 12 joint takes
    seconds to draw.

    Parameters
    ----------
    result : CouplingResult (or anything with ``frequency``, ``joint_dofs``, ``stiffness``)
    truth : ndarray, shape (F, n, n), optional
    couplings : int
        How many couplings to draw.

    Returns
    -------
    Figure
    """
    from ..methods.coupling import Z90

    f = result.frequency.hz
    K = result.stiffness
    n = K.shape[1]
    labels = dof_term_labels(result.joint_dofs)
    fig, axes = new_figure(3, 1, figsize=(9.0, 10.0), height_ratios=[2, 1.2, 1.5])
    ax, ax_l, ax_c = axes
    std = getattr(result, "std_real", None)
    for i in range(n):
        color = f"C{i % 10}"
        k = K[:, i, i]
        ax.plot(f, k.real, color=color, lw=1.2, label=f"K_{labels[i]}_{labels[i]} [{term_unit(result.joint_dofs[i], result.joint_dofs[i])}]")
        if std is not None:
            sr = std[:, i, i]
            ax.fill_between(f, np.clip(k.real - Z90 * sr, k.real * 1e-3, None), k.real + Z90 * sr, color=color, alpha=0.2, lw=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            ax_l.plot(f, np.where(k.real > 0, k.imag / k.real, np.nan), color=color, lw=1.0)
        if truth is not None:
            t = truth[:, i, i]
            ax.plot(f, t.real, "k--", lw=0.8)
            with np.errstate(divide="ignore", invalid="ignore"):
                ax_l.plot(f, np.where(t.real > 0, t.imag / t.real, np.nan), "k--", lw=0.8)
    d = np.sqrt(np.abs(K[:, range(n), range(n)]))
    for c, (i, j) in enumerate(largest_couplings(K, couplings)):
        with np.errstate(divide="ignore", invalid="ignore"):
            ax_c.plot(f, np.abs(K[:, i, j]) / (d[:, i] * d[:, j]), color=f"C{c}", lw=1.2, label=f"K_{labels[i]}_{labels[j]}")
            if truth is not None:
                dt = np.sqrt(np.abs(truth[:, range(n), range(n)]))
                ax_c.plot(f, np.abs(truth[:, i, j]) / (dt[:, i] * dt[:, j]), "k--", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("Re K_ii (storage)")
    ax.legend(fontsize="x-small", ncol=3)
    ax_l.set_ylabel("loss factor Im/Re [-]")
    ax_c.set_ylabel("|K_ij| / sqrt(|K_ii K_jj|) [-]")
    ax_c.set_xlabel("frequency [Hz]")
    if ax_c.lines:
        ax_c.legend(fontsize="x-small", ncol=2)
    for a in axes:
        a.grid(True, alpha=0.3)
    fig.suptitle(f"joint stiffness, {n} DOFs: diagonal terms (90 % bands) and the largest couplings" + ("; dashed: true" if truth is not None else ""))
    return fig
