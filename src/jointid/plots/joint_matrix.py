"""Figures of a joint with many DOFs (a 6-DOF mount, 12 x 12 between two parts).

:func:`plot_joint_matrix`: ``|K_ij|`` of every term at a few frequencies;
:func:`plot_joint_terms`: the diagonal terms and the largest couplings over frequency.
"""

from __future__ import annotations

import numpy as np

from ..terms import dof_term_labels, term_unit
from .nvh_axes import loss_or_phase, magnitude_band, robust_log_limits, set_frequency_axis
from .style import new_figure

__all__ = ["plot_joint_matrix", "plot_joint_terms", "largest_couplings"]


def plot_joint_matrix(result, n_frequencies: int = 4, title: str = ""):
    """``|K_ij|`` of every term as an image, one panel per frequency (log colour scale, shared).

    Parameters
    ----------
    result : JointEstimate
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
    """A joint of many DOFs in three panels: diagonal |K|, diagonal loss factor (or phase), largest couplings.

    Each diagonal term ``|K_ii|`` (log scale; unit by DOF: N/m or N*m/rad) with
    its 90 % band; the loss factor ``Im/Re`` of each, or (when some ``Re K_ii``
    crosses zero) the phase of every one; and the
    :func:`largest_couplings` as ``|K_ij| / sqrt(|K_ii| |K_jj|)`` (dimensionless,
    so translations and rotations share an axis). The truth (if given) is dashed
    black. Few axes on purpose: a panel per term of a 12 x 12 joint takes
    seconds to draw.

    Parameters
    ----------
    result : JointEstimate
    truth : ndarray, shape (F, n, n), optional
    couplings : int
        How many couplings to draw.

    Returns
    -------
    Figure
    """
    from ..terms import Z90

    f = result.frequency.hz
    K = result.stiffness
    n = K.shape[1]
    labels = dof_term_labels(result.joint_dofs)
    fig, axes = new_figure(3, 1, figsize=(9.0, 10.0), height_ratios=[2, 1.2, 1.5])
    ax, ax_l, ax_c = axes
    std = result.std_real if result.has_uncertainty else None  # a JointEstimate: NaN where the method gives none
    std_im = result.std_imag
    diag = K[:, range(n), range(n)]
    phase = bool(np.any(diag.real <= 0) or (truth is not None and np.any(truth[:, range(n), range(n)].real <= 0)))
    for i in range(n):
        color = f"C{i % 10}"
        k = K[:, i, i]
        ax.plot(f, np.abs(k), color=color, lw=1.2, label=f"K_{labels[i]}_{labels[i]} [{term_unit(result.joint_dofs[i], result.joint_dofs[i])}]")
        if std is not None:
            lo, hi = magnitude_band(k, std[:, i, i], std_im[:, i, i], Z90)
            ax.fill_between(f, np.clip(lo, np.abs(k) * 1e-3, None), hi, color=color, alpha=0.2, lw=0)
        ax_l.plot(f, loss_or_phase(f, k, force_phase=phase)[0], color=color, lw=1.0)
        if truth is not None:
            t = truth[:, i, i]
            ax.plot(f, np.abs(t), "k--", lw=0.8, label="true" if i == 0 else None)
            ax_l.plot(f, loss_or_phase(f, t, force_phase=phase)[0], "k--", lw=0.8)
    d = np.sqrt(np.abs(K[:, range(n), range(n)]))
    for c, (i, j) in enumerate(largest_couplings(K, couplings)):
        with np.errstate(divide="ignore", invalid="ignore"):
            ax_c.plot(f, np.abs(K[:, i, j]) / (d[:, i] * d[:, j]), color=f"C{c}", lw=1.2, label=f"K_{labels[i]}_{labels[j]}")
            if truth is not None:
                dt = np.sqrt(np.abs(truth[:, range(n), range(n)]))
                ax_c.plot(f, np.abs(truth[:, i, j]) / (dt[:, i] * dt[:, j]), "k--", lw=0.8)
    ax.set_yscale("log")
    lim = robust_log_limits(np.abs(diag), None if truth is None else np.abs(truth[:, range(n), range(n)]))
    if lim is not None:
        ax.set_ylim(*lim)
    ax.set_ylabel("|K_ii| (shaded: 90 % band)")
    ax.legend(fontsize="x-small", ncol=3)
    ax_l.set_ylabel("phase [deg] (Re K crosses 0)" if phase else "loss factor Im/Re [-]")
    ax_c.set_ylabel("|K_ij| / sqrt(|K_ii K_jj|) [-]")
    if ax_c.lines:
        ax_c.legend(fontsize="x-small", ncol=2)
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
        set_frequency_axis(a, f, label=a is ax_c)
    fig.suptitle(f"joint stiffness, {n} DOFs: diagonal terms (90 % bands) and the largest couplings" + ("; dashed: true" if truth is not None else ""))
    return fig
