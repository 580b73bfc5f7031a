"""Figures of the direct method: measured and fitted K21, and the joint's internal deformed shape."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .nvh_axes import loss_or_phase, set_frequency_axis
from .style import new_figure

__all__ = ["plot_direct_stiffness", "plot_deformed_shapes"]


def _fit_label(fit) -> str:
    """Legend text of the fitted model: identified values, held ones marked, none that is not identified."""
    parts = []
    for p, scale, unit, fmt in zip(fit.parameters, (1e6, 1.0, 1.0), ("MPa", "", "kg/m^3"), (".3g", ".3g", ".4g")):
        name = {"elastic_modulus_pa": "E", "loss_factor": "eta", "density_kg_m3": "rho"}.get(p.name, p.title)
        u = f" {unit}" if unit else ""
        if p.identified:
            parts.append(f"{name} = {p.value / scale:{fmt}}{u}")
        elif p.held:
            parts.append(f"{name} held at {p.value / scale:{fmt}}{u}")
        else:
            parts.append(f"{name} not identified")
    return "FE joint model: " + ", ".join(parts)


def plot_direct_stiffness(result, fit=None, title: str | None = None, points: int = 300) -> Figure:
    """|K21| (log axis) and loss factor (or phase) vs frequency: measured (markers) and fitted (line).

    The frequency axis is logarithmic when the band spans a decade or more
    (:func:`jointid.plots.nvh_axes.set_frequency_axis`).

    The lower panel shows the loss factor ``Im K21 / Re K21`` while the
    storage stiffness ``Re K21`` stays positive over the band. Past the
    joint's internal mode ``Re K21`` changes sign and the loss factor runs to
    +-infinity, so the panel then shows the phase of K21 in degrees instead
    (``atan(eta)`` below the mode), as the y label and title say.

    Parameters
    ----------
    result : StepSineResult
        Measured stiffness per joint (lines with ``amplitude_ok`` False are
        drawn as red crosses and labelled "flagged").
    fit : MaterialFit, optional
        Fitted joint model; its K21 is drawn as a line over the measured band,
        above the markers. The legend gives only identified parameters'
        values (held ones are marked "held").
    title : str, optional
        Figure title.
    points : int
        Points of the fitted curve.

    Returns
    -------
    Figure
    """
    fig, (ax_m, ax_e) = new_figure(2, 1, figsize=(7.5, 6.0))
    f = result.frequency_hz
    k = np.asarray(result.stiffness, dtype=complex)
    ok = np.asarray(result.amplitude_ok, dtype=bool)
    kf = ff = None
    if fit is not None:
        ff = np.linspace(f.min(), f.max(), int(points))
        kf = fit.joint.blocked_transfer_stiffness(ff)
    use_phase = bool(np.any(k.real <= 0) or (kf is not None and np.any(kf.real <= 0)))

    def lower(freq, z):
        """Loss factor, or the phase in degrees unwrapped along frequency (:func:`.nvh_axes.loss_or_phase`)."""
        return loss_or_phase(freq, z, force_phase=use_phase)[0]

    low = lower(f, k)
    ax_m.plot(f[ok], np.abs(k[ok]), "o", ms=5, color="C0", label="measured", zorder=2)
    ax_e.plot(f[ok], low[ok], "o", ms=5, color="C0", label="measured", zorder=2)
    if (~ok).any():
        lab = f"flagged (amplitude off by > {result.tolerance:.0%})"
        ax_m.plot(f[~ok], np.abs(k[~ok]), "x", ms=8, mew=2, color="C3", label=lab, zorder=2)
        ax_e.plot(f[~ok], low[~ok], "x", ms=8, mew=2, color="C3", label=lab, zorder=2)
    if kf is not None:
        ax_m.plot(ff, np.abs(kf), "-", color="C1", lw=2, label=_fit_label(fit), zorder=3)
        ax_e.plot(ff, lower(ff, kf), "-", color="C1", lw=2, label="FE joint model", zorder=3)
    ax_m.set_yscale("log")
    ax_m.set_ylabel("|K21| per joint (N/m)")
    if use_phase:
        ax_e.set_ylabel("phase of K21 (deg)")
        ax_e.set_title("phase shown: Re K21 changes sign in the band (internal mode), the loss factor would run to +-infinity", fontsize=8)
    else:
        ax_e.set_ylabel("loss factor (-)")
    for ax in (ax_m, ax_e):
        set_frequency_axis(ax, f, label=False, pad=0.03)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    ax_e.set_xlabel("frequency (Hz)")
    ax_m.set_title(title or f"Direct method: blocked transfer stiffness ({result.parallel_joints} joints in parallel, per joint)")
    return fig


def plot_deformed_shapes(joint, frequencies_hz: Sequence[float] = (150.0, 950.0), title: str | None = None) -> Figure:
    """Deflection along the elastomer in the direct test (per unit imposed displacement) at a few frequencies.

    Parameters
    ----------
    joint : ElastomerJoint
        Joint model.
    frequencies_hz : sequence of float
        Frequencies, Hz (e.g. below and at the blocked internal mode).
    title : str, optional
        Figure title.

    Returns
    -------
    Figure
    """
    fig, ax = new_figure(1, 1, figsize=(6.5, 4.5))
    for i, fr in enumerate(frequencies_hz):
        x, w = joint.deformed_shape(float(fr))
        ax.plot(x * 1e3, w.real, "-", color=f"C{i}", label=f"{fr:g} Hz, real part")
        ax.plot(x * 1e3, w.imag, "--", color=f"C{i}", label=f"{fr:g} Hz, imaginary part")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("position from the driven end (mm)")
    ax.set_ylabel("w / imposed displacement (-)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or "Elastomer deflection in the direct test (driven end left, blocked end right)")
    return fig
