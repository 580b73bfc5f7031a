"""Figures of a test campaign: temperature curves (raw and shifted), master curve, shift factors, amplitude and preload.

Each function draws on the axes it is given (``ax=``, or a new figure) and returns the figure.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import NullFormatter

from .style import new_figure

__all__ = ["plot_temperature_curves", "plot_master_fit", "plot_shift_factors", "plot_amplitude_dependence",
           "plot_preload_dependence"]

#: Gas constant, J/(mol K).
_R = 8.314462618


def _colors(n: int):
    from matplotlib import colormaps

    cmap = colormaps["plasma"]  # cold (dark blue) to warm (orange); stops before the pale yellow end
    return [cmap(x) for x in (np.linspace(0.0, 0.85, n) if n > 1 else [0.0])]


def plot_temperature_curves(curves, *, shifted: bool = False, axes=None):
    """Storage stiffness K' (log) and loss factor vs frequency, one colour per temperature.

    Parameters
    ----------
    curves : sequence of (float, ndarray (F,), ndarray (F,) complex)
        ``(temperature_c, frequency_hz, stiffness)``; for ``shifted`` the frequency is the reduced one.
    shifted : bool
        Label the x axis as reduced frequency ``f aT``.
    axes : pair of Axes, optional
        Storage and loss-factor axes (default: a new figure with both).
    """
    if axes is None:
        fig, axes = new_figure(2, 1, figsize=(6.5, 5.5))
    ax_k, ax_e = axes
    order = sorted(range(len(curves)), key=lambda i: curves[i][0])
    for c, i in zip(_colors(len(order)), order):
        temp, f, k = curves[i]
        k = np.asarray(k, dtype=complex)
        ax_k.loglog(f, k.real, "o-", ms=3, lw=0.8, color=c, label=f"{temp:g} C")
        ax_e.semilogx(f, k.imag / k.real, "o-", ms=3, lw=0.8, color=c)
    ax_k.set_ylabel("K' (N/m)")
    ax_e.set_ylabel("loss factor")
    ax_e.set_xlabel("reduced frequency f aT (Hz)" if shifted else "frequency (Hz)")
    ax_k.legend(fontsize=7, ncol=2)
    ax_k.set_title("shifted to the reference temperature" if shifted else "as measured")
    return ax_k.figure


def plot_master_fit(master, *, axes=None, points: int = 200):
    """The master curve: shifted data and the fitted modulus vs reduced frequency (K' and loss factor).

    Parameters
    ----------
    master : MasterCurve
        :class:`jointid.methods.direct.master_curve.MasterCurve` (``shifted()``, ``stiffness(f)``, ``to_dict()``).
    axes : pair of Axes, optional
    points : int
        Points of the fitted curve.
    """
    if axes is None:
        fig, axes = new_figure(2, 1, figsize=(6.5, 5.5))
    ax_k, ax_e = axes
    shifted = master.shifted()
    fr = np.concatenate([s[1] for s in shifted])
    for c, (temp, f, k) in zip(_colors(len(shifted)), sorted(shifted, key=lambda s: s[0])):
        k = np.asarray(k, dtype=complex)
        ax_k.loglog(f, k.real, "o", ms=3, color=c, label=f"{temp:g} C")
        ax_e.semilogx(f, k.imag / k.real, "o", ms=3, color=c)
    grid = np.geomspace(fr.min(), fr.max(), points)
    model = master.to_dict().get("modulus") or {}
    try:
        fit = np.asarray(master.stiffness(grid), dtype=complex)
    except Exception:  # noqa: BLE001 - no fitted modulus: data only
        fit = None
    if fit is not None and np.all(np.isfinite(fit)):
        label = f"{model.get('model', 'fit')} at {master.to_dict().get('reference_temperature_c', float('nan')):g} C"
        ax_k.loglog(grid, fit.real, "k-", lw=1.5, label=label)
        ax_e.semilogx(grid, fit.imag / fit.real, "k-", lw=1.5)
        band = getattr(master, "stiffness_band", None)
        if callable(band):
            lo, hi = band(grid)
            ax_k.fill_between(grid, np.real(lo), np.real(hi), color="0.6", alpha=0.3, lw=0, label="fit band")
    ax_k.set_ylabel("K' (N/m)")
    ax_e.set_ylabel("loss factor")
    ax_e.set_xlabel("reduced frequency f aT (Hz)")
    ax_k.legend(fontsize=7, ncol=2)
    ax_k.set_title("master curve")
    return ax_k.figure


def plot_shift_factors(master, *, ax=None):
    """log10 aT vs temperature: the shifts estimated from the data (2-sigma bars), the WLF and Arrhenius fits.

    WLF: ``log10 aT = -c1 (T - Tr) / (c2 + T - Tr)``; Arrhenius:
    ``log10 aT = Ea / (R ln 10) (1/T - 1/Tr)`` with T in kelvin.
    """
    if ax is None:
        fig, ax = new_figure(1, 1, figsize=(6.0, 4.0))
    d = master.to_dict()
    sf = d.get("shift_factors") or []
    t = np.array([s["temperature_c"] for s in sf], dtype=float)
    y = np.array([s["log10_shift"] for s in sf], dtype=float)
    e = np.array([s.get("std") or 0.0 for s in sf], dtype=float)
    ax.errorbar(t, y, yerr=2 * e, fmt="ko", ms=4, capsize=3, label="from the data (2 sigma)")
    tr = float(d["reference_temperature_c"])
    if t.size:
        grid = np.linspace(t.min() - 5, t.max() + 5, 200)
        wlf = d.get("wlf") or {}
        if wlf.get("c1") is not None and wlf.get("c2") is not None:
            c1, c2 = wlf["c1"], wlf["c2"]
            g = grid[c2 + grid - tr > 0]
            ax.plot(g, -c1 * (g - tr) / (c2 + g - tr), "b-", label=f"WLF c1 = {c1:.3g}, c2 = {c2:.3g} C")
        arr = d.get("arrhenius") or {}
        ea = arr.get("activation_energy_j_mol")
        if ea is not None:
            ax.plot(grid, ea / (_R * np.log(10)) * (1 / (grid + 273.15) - 1 / (tr + 273.15)), "r--",
                    label=f"Arrhenius Ea = {ea / 1e3:.3g} kJ/mol")
    for n in d.get("not_overlapping") or []:
        ax.axvline(n["temperature_c"], color="0.7", ls=":", lw=1)
    ax.set_xlabel("temperature (C)")
    ax.set_ylabel("log10 aT")
    ax.set_title(f"shift factors (reference {tr:g} C; preferred law: {d.get('preferred_shift_law')})")
    ax.legend(fontsize=7)
    return ax.figure


def _dependence(entries, x_key: str, ax, xlabel: str, logx: bool, max_curves: int):
    picks = list(entries)
    if len(picks) > max_curves:  # a readable subset: evenly over the list (temperatures x frequencies)
        picks = [picks[i] for i in np.linspace(0, len(picks) - 1, max_curves).round().astype(int)]
    for c, e in zip(_colors(len(picks)), picks):
        x = np.asarray(e[x_key], dtype=float)
        ax.plot(x, e["storage_n_m"], "o", ms=4, color=c)
        grid = np.geomspace(x.min(), x.max(), 100) if logx else np.linspace(x.min(), x.max(), 100)
        other = "preload_n" if x_key == "amplitude_m" else "amplitude_m"
        ax.plot(grid, e["fit"].storage(grid), "-", color=c, lw=1,
                label=f"{e['temperature_c']:g} C, {e['frequency_hz']:g} Hz, {other.split('_')[0]} {e[other]:g}")
    if logx:
        ax.set_xscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("K' (N/m)")
    ax.legend(fontsize=6, ncol=2)
    return ax.figure


def plot_amplitude_dependence(entries, *, axes=None, max_curves: int = 8):
    """Storage K' and loss K'' stiffness vs achieved amplitude (Payne effect) with the Kraus fits.

    Parameters
    ----------
    entries : sequence of dict
        ``temperature_c``, ``preload_n``, ``frequency_hz``, ``amplitude_m`` (A,), ``storage_n_m`` (A,),
        ``fit`` (KrausFit); optional ``loss_n_m`` (A,) and ``loss_fit`` (KrausLossFit or None).
    axes : pair of Axes, optional
        K' and K'' axes (default: a new figure with both).
    max_curves : int
        At most this many groups are drawn (evenly chosen).
    """
    if axes is None:
        fig, axes = new_figure(2, 1, figsize=(6.5, 6.5))
    ax_k, ax_l = axes
    fig = _dependence(entries, "amplitude_m", ax_k, "amplitude (m, peak)", True, max_curves)
    ax_k.set_title("storage and loss stiffness vs amplitude, Kraus fits")
    picks = list(entries)
    if len(picks) > max_curves:
        picks = [picks[i] for i in np.linspace(0, len(picks) - 1, max_curves).round().astype(int)]
    for c, e in zip(_colors(len(picks)), picks):
        if e.get("loss_n_m") is None:
            continue
        x = np.asarray(e["amplitude_m"], dtype=float)
        ax_l.plot(x, e["loss_n_m"], "o", ms=4, color=c)
        if e.get("loss_fit") is not None:
            grid = np.geomspace(x.min(), x.max(), 100)
            ax_l.plot(grid, e["loss_fit"].loss(grid), "-", color=c, lw=1)
    ax_l.set_xscale("log")
    for ax in (ax_k, ax_l):
        ax.xaxis.set_minor_formatter(NullFormatter())  # short ranges: no crowded minor labels
    ax_k.set_xlabel("")
    ax_l.set_xlabel("amplitude (m, peak)")
    ax_l.set_ylabel("K'' (N/m)")
    return fig


def plot_preload_dependence(entries, *, ax=None, max_curves: int = 8):
    """Storage stiffness vs preload with the straight-line fits (``entries`` as for amplitude, with ``preload_n``)."""
    if ax is None:
        fig, ax = new_figure(1, 1, figsize=(6.5, 4.5))
    fig = _dependence(entries, "preload_n", ax, "preload (N)", False, max_curves)
    ax.set_title("storage stiffness vs preload")
    return fig
