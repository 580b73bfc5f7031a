"""Impact-test figures: FRF magnitude with the coherence beneath, one column per excitation."""

from __future__ import annotations

import numpy as np

from .style import new_figure

__all__ = ["plot_impact_frf", "MAX_EXCITATION_PANELS"]

#: At most this many excitation columns get a panel each; beyond, one panel of the driving points (or first responses).
MAX_EXCITATION_PANELS = 4


def plot_impact_frf(impact, estimator: str = "h1", kind: str | None = None, axes=None, title: str | None = None):
    """Plot |H1| or |H2| (log axis) and the coherence (0..1) vs frequency (Hz), grouped by excitation.

    Up to :data:`MAX_EXCITATION_PANELS` excited DOFs: one column of panels per
    excitation, each curve labelled by its response DOF (the legend lists
    them; the same response has the same colour in every column). More
    excitations: one column with one curve per excitation (its driving point
    when measured, else its first response), labelled ``response / reference``.

    Parameters
    ----------
    impact : ImpactFRF
        From :func:`jointid.measurement.impact.estimate_frfs` (or ``HitsFRF.impact``).
    estimator : {"h1", "h2"}
    kind : {"accelerance", "mobility", "receptance"}, optional
        Kind to draw (converted exactly; default: the records' kind). Lines at
        0 Hz cannot be converted to a lower kind.
    axes : array of Axes, shape (2, columns), optional
        (magnitude, coherence) rows to draw into (one column per group); a new Figure otherwise.
    title : str, optional

    Returns
    -------
    Figure
    """
    frf = impact.to_frf(estimator)
    if kind is not None:
        frf = frf.to(kind)
    f = frf.frequency.hz
    refs, resps = list(frf.references), list(frf.responses)
    if len(refs) <= MAX_EXCITATION_PANELS:
        groups = [(f"excitation at {ref}", [(resps.index(r), c, f"response {r}") for r in resps]) for c, ref in enumerate(refs)]
    else:
        pick = [(resps.index(ref) if ref in resps else 0, c) for c, ref in enumerate(refs)]
        groups = [("one FRF per excitation", [(r, c, f"{resps[r]} / {refs[c]}") for r, c in pick])]
    if axes is None:
        fig, axes = new_figure(2, len(groups), height_ratios=[3, 1], figsize=(max(8.0, 4.6 * len(groups)), 6.0))
    else:
        fig = np.asarray(axes).flat[0].figure
    axes = np.asarray(axes).reshape(2, len(groups))
    for g, (heading, curves) in enumerate(groups):
        ax_m, ax_c = axes[:, g]
        for k, (r, c, label) in enumerate(curves):
            color = f"C{(r if len(groups) > 1 or len(refs) <= MAX_EXCITATION_PANELS else k) % 10}"
            ax_m.semilogy(f, np.abs(frf.data[:, r, c]), lw=1.0, color=color, label=label)
            ax_c.plot(f, impact.coherence[:, r, c], lw=0.8, color=color)
        ax_m.set_title(heading, fontsize="medium")
        ax_m.set_ylabel(f"|{estimator.upper()}| {frf.kind} [{frf.unit()}]")
        ax_c.set_ylabel("coherence")
        ax_c.set_ylim(0.0, 1.05)
        ax_c.set_xlabel("frequency [Hz]")
        ax_m.grid(True, which="both", alpha=0.3)
        ax_c.grid(True, alpha=0.3)
        ax_m.legend(fontsize="x-small", ncol=1 + len(curves) // 8, loc="best")
    fig.suptitle(title or f"{estimator.upper()} from {sum(impact.n_averages)} hit(s), {len(impact.rejected)} rejected; "
                 "coherence beneath (same colours)")
    return fig
