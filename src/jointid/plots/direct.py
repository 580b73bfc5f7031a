"""Figures of the direct method: measured and fitted K21, and the joint's internal deformed shape."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .style import new_figure

__all__ = ["plot_direct_stiffness", "plot_deformed_shapes"]


def plot_direct_stiffness(result, fit=None, title: str | None = None, points: int = 300) -> Figure:
    """|K21| (log axis) and loss factor vs frequency: measured (markers) and fitted (line).

    Parameters
    ----------
    result : StepSineResult
        Measured stiffness per joint (lines with ``amplitude_ok`` False are
        drawn as red crosses and labelled "flagged").
    fit : MaterialFit, optional
        Fitted joint model; its K21 is drawn as a line over the measured band.
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
    ok = np.asarray(result.amplitude_ok, dtype=bool)
    ax_m.plot(f[ok], result.magnitude[ok], "o", ms=5, color="C0", label="measured")
    ax_e.plot(f[ok], result.loss_factor[ok], "o", ms=5, color="C0", label="measured")
    if (~ok).any():
        lab = f"flagged (amplitude off by > {result.tolerance:.0%})"
        ax_m.plot(f[~ok], result.magnitude[~ok], "x", ms=8, mew=2, color="C3", label=lab)
        ax_e.plot(f[~ok], result.loss_factor[~ok], "x", ms=8, mew=2, color="C3", label=lab)
    if fit is not None:
        ff = np.linspace(f.min(), f.max(), int(points))
        kf = fit.joint.blocked_transfer_stiffness(ff)
        lab = (
            f"FE joint model: E = {fit.elastic_modulus_pa / 1e6:.3g} MPa, "
            f"eta = {fit.loss_factor:.3g}, rho = {fit.density_kg_m3:.4g} kg/m^3"
        )
        ax_m.plot(ff, np.abs(kf), "-", color="C1", label=lab)
        ax_e.plot(ff, kf.imag / kf.real, "-", color="C1", label="FE joint model")
    ax_m.set_yscale("log")
    ax_m.set_ylabel("|K21| per joint (N/m)")
    ax_e.set_ylabel("loss factor (-)")
    ax_e.set_xlabel("frequency (Hz)")
    for ax in (ax_m, ax_e):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="best")
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
