"""Impact-test figures: FRF magnitude with the coherence beneath."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_impact_frf"]


def plot_impact_frf(impact, estimator: str = "h1", kind: str | None = None, axes=None, title: str | None = None):
    """Plot |H1| or |H2| (log axis) and the coherence (0..1) vs frequency (Hz).

    Parameters
    ----------
    impact : ImpactFRF
        From :func:`jointid.measurement.impact.estimate_frfs` (or ``HitsFRF.impact``).
    estimator : {"h1", "h2"}
    kind : {"accelerance", "mobility", "receptance"}, optional
        Kind to draw (converted exactly; default: the records' kind). Lines at
        0 Hz cannot be converted to a lower kind.
    axes : pair of Axes, optional
        (magnitude, coherence) axes to draw into; a new Figure otherwise.
    title : str, optional

    Returns
    -------
    Figure
    """
    if axes is None:
        fig, (ax_m, ax_c) = new_figure(2, 1, height_ratios=[3, 1])
    else:
        ax_m, ax_c = axes
        fig = ax_m.figure
    frf = impact.to_frf(estimator)
    if kind is not None:
        frf = frf.to(kind)
    f = frf.frequency.hz
    for c, ref in enumerate(frf.references):
        for r, resp in enumerate(frf.responses):
            (line,) = ax_m.semilogy(f, np.abs(frf.data[:, r, c]), lw=1.0, label=f"{resp} / {ref}")
            ax_c.plot(f, impact.coherence[:, r, c], lw=0.8, color=line.get_color())
    ax_m.set_ylabel(f"|{estimator.upper()}| {frf.kind} [{frf.unit()}]")
    ax_c.set_ylabel("coherence")
    ax_c.set_ylim(0.0, 1.05)
    ax_c.set_xlabel("frequency [Hz]")
    ax_m.grid(True, which="both", alpha=0.3)
    ax_c.grid(True, alpha=0.3)
    if frf.data.shape[1] * frf.data.shape[2] <= 12:
        ax_m.legend(fontsize="small", ncol=2)
    ax_m.set_title(title or f"{estimator.upper()} from {sum(impact.n_averages)} hit(s), {len(impact.rejected)} rejected")
    return fig
