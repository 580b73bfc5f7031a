"""The campaign report: one self-contained HTML page (figures embedded) through :mod:`jointid.report`.

Sections: the campaign (tests, computed, reused, failed with their reasons), then per
specimen a summary table (tests, temperatures, amplitudes, preloads, reference
condition, WLF and Arrhenius constants, the fitted modulus and the reduced-frequency
range each temperature covers), K' and loss factor vs frequency at each temperature
as measured and shifted, the master curve with its fit, log aT vs temperature with the
WLF and Arrhenius fits, storage vs amplitude with the Kraus fits and vs preload, and
the findings (what could not be fitted, and why).
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["campaign_report"]


def _g(x, fmt: str = ".4g") -> str:
    if x is None:
        return "-"
    try:
        return "-" if not np.isfinite(x) else f"{x:{fmt}}"
    except TypeError:
        return str(x)


def _pm(d: dict | None, key: str, std_key: str | None = None, scale: float = 1.0) -> str:
    if not d:
        return "-"
    v = d.get(key)
    if isinstance(v, dict):
        v, s = v.get("value"), v.get("std")
    else:
        s = d.get(std_key) if std_key else None
    if v is None:
        return "-"
    return _g(v / scale) + (f" +- {_g(s / scale, '.2g')}" if s is not None else "")


def _anchor(text: str) -> str:
    return "specimen-" + (re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-") or "x")


def _curves(tests, outcomes, amp, pre):
    out = []
    for t in tests:
        o = outcomes[t.row]
        if (t.amplitude_m, t.preload_n) != (amp, pre):
            continue
        ok = np.asarray(o.lines["amplitude_ok"], dtype=bool)
        k = o.lines["stiffness_real"][ok] + 1j * o.lines["stiffness_imag"][ok]
        out.append((t.temperature_c, o.lines["frequency_hz"][ok], k))
    return out


def _summary_table(specimen, tests, a):
    from ..report.html import Table

    d = a.master_curve.to_dict() if a.master_curve is not None else {}
    rows = [
        ("tests processed", str(len(tests))),
        ("temperatures (C)", ", ".join(f"{x:g}" for x in sorted({t.temperature_c for t in tests}))),
        ("amplitudes (m)", ", ".join(f"{x:g}" for x in sorted({t.amplitude_m for t in tests}))),
        ("preloads (N)", ", ".join(f"{x:g}" for x in sorted({t.preload_n for t in tests}))),
        ("master curve at", f"{a.reference_amplitude_m:g} m, {a.reference_preload_n:g} N"),
    ]
    if d:
        wlf, arr, mod = d.get("wlf") or {}, d.get("arrhenius") or {}, d.get("modulus") or {}
        rows += [
            ("reference temperature (C)", _g(d.get("reference_temperature_c"))),
            ("WLF c1", _pm(wlf, "c1", "c1_std")),
            ("WLF c2 (C)", _pm(wlf, "c2", "c2_std")),
            ("Arrhenius Ea (kJ/mol)", _pm(arr, "activation_energy_j_mol", "std", 1e3)),
            ("preferred shift law", str(d.get("preferred_shift_law"))),
            ("modulus", f"{mod.get('model', '-')} (identified: {mod.get('identified')})"),
            ("K0 (N/m)", _pm(mod, "K0_n_m")), ("Kinf (N/m)", _pm(mod, "Kinf_n_m")),
            ("tau (s)", _pm(mod, "tau_s")), ("alpha", _pm(mod, "alpha")),
            ("reduced frequencies (Hz)", f"{_g(mod.get('reduced_frequency_min_hz'))} - {_g(mod.get('reduced_frequency_max_hz'))}"),
            ("not overlapping", ", ".join(f"{n['temperature_c']:g} C" for n in d.get("not_overlapping") or []) or "none"),
        ]
    else:
        rows.append(("master curve", "not built (see the findings)"))
    rows.append(("Kraus fits", str(len(a.kraus))))
    rows.append(("preload fits", str(len(a.preload))))
    cover = Table("Reduced-frequency range covered at each temperature", ("temperature (C)", "log10 aT", "from (Hz)", "to (Hz)"),
                  [(f"{c['temperature_c']:g}", _g(next((s["log10_shift"] for s in d.get("shift_factors") or []
                                                         if s["temperature_c"] == c["temperature_c"]), None)),
                    _g(c["reduced_frequency_min_hz"]), _g(c["reduced_frequency_max_hz"])) for c in d.get("coverage") or []])
    return [Table(f"Specimen {specimen}", ("quantity", "value"), rows)] + ([cover] if d.get("coverage") else [])


def _figures(specimen, tests, outcomes, a):
    from ..plots.campaign import (
        plot_amplitude_dependence,
        plot_master_fit,
        plot_preload_dependence,
        plot_shift_factors,
        plot_temperature_curves,
    )
    from ..io.png import figure_png
    from ..plots.style import new_figure

    slug = _anchor(specimen)[len("specimen-"):]
    figs = []
    curves = _curves(tests, outcomes, a.reference_amplitude_m, a.reference_preload_n)
    mc = a.master_curve
    if curves:
        fig, ax = new_figure(2, 2 if mc is not None else 1, figsize=(11.0 if mc is not None else 6.5, 6.0), sharex=False)
        ax = np.asarray(ax).reshape(2, -1)
        plot_temperature_curves(curves, axes=(ax[0, 0], ax[1, 0]))
        if mc is not None:
            plot_temperature_curves(mc.shifted(), shifted=True, axes=(ax[0, 1], ax[1, 1]))
        figs.append((f"{slug}_temperature_curves", figure_png(fig),
                     f"Specimen {specimen}: K' and loss factor vs frequency at each temperature, as measured"
                     + (" and shifted to the reference temperature" if mc is not None else "")))
    if mc is not None:
        fig, ax = new_figure(2, 2, figsize=(11.0, 6.0), sharex=False, height_ratios=None)
        plot_master_fit(mc, axes=(ax[0, 0], ax[1, 0]))
        gs = ax[0, 1].get_gridspec()
        ax[0, 1].remove()
        ax[1, 1].remove()
        plot_shift_factors(mc, ax=fig.add_subplot(gs[:, 1]))
        figs.append((f"{slug}_master_curve", figure_png(fig),
                     f"Specimen {specimen}: master curve (shifted data, fitted modulus) and log aT vs temperature with WLF and Arrhenius"))
    if a.kraus:
        figs.append((f"{slug}_amplitude", figure_png(plot_amplitude_dependence(a.kraus)),
                     f"Specimen {specimen}: storage and loss stiffness vs achieved amplitude with the Kraus fits (a subset of the groups)"))
    if a.preload:
        figs.append((f"{slug}_preload", figure_png(plot_preload_dependence(a.preload)),
                     f"Specimen {specimen}: storage stiffness vs preload with straight-line fits"))
    return figs


def campaign_report(manifest, outcomes, analysis, summary, *, plots: bool = True) -> tuple[str, dict[str, bytes]]:
    """The HTML report of a campaign and its figures.

    Parameters
    ----------
    manifest : Manifest
    outcomes : mapping of int to TestOutcome
    analysis : mapping of str to SpecimenAnalysis
    summary : dict
        ``campaign.json``.
    plots : bool
        Draw the figures (False: tables and findings only).

    Returns
    -------
    html : str
        Self-contained page (figures as data URIs).
    figures : dict of str to bytes
        ``figures/<name>.png`` -> PNG, the same figures as files.
    """
    from ..report.html import Section, Table, render_report

    failed = Table("Failed tests", ("row", "file", "reason"), [(str(f["row"]), f["file"], f["reason"]) for f in summary["failed"]])
    overview = Section(
        "Campaign", "campaign",
        paragraphs=[f"{summary['tests']} tests in {manifest.path.name}: {summary['computed']} computed in this run, "
                    f"{summary['reused']} reused from a previous run, {len(summary['failed'])} failed. "
                    "Tables: results.parquet/.csv (one row per test and frequency line), tests.parquet/.csv (one row per test); "
                    "master_curve.json; campaign.json."],
        tables=[failed] if summary["failed"] else [],
    )
    sections = [overview]
    figures: dict[str, bytes] = {}
    for specimen, a in analysis.items():
        tests = [t for t in manifest.tests if t.specimen == specimen and t.kind == "direct" and outcomes[t.row].ok]
        figs = _figures(specimen, tests, outcomes, a) if plots else []
        figures.update({f"figures/{name}.png": png for name, png, _ in figs})
        notes = list(a.findings)  # the master curve's own findings among them (campaign.analysis)
        sections.append(Section(f"Specimen {specimen}", _anchor(specimen), paragraphs=notes,
                                tables=_summary_table(specimen, tests, a), figures=tuple(figs)))
    others = [t for t in manifest.tests if t.kind == "identify" and outcomes[t.row].ok]
    if others:
        rows = [(str(t.row), t.value("file"), t.specimen, f"{t.temperature_c:g}", str(outcomes[t.row].parameters.get("lines")),
                 _g(outcomes[t.row].parameters.get("reliable_fraction"), ".0%")) for t in others]
        sections.append(Section("Inverse identifications", "identify",
                                tables=[Table("identify tests (terms per line in results.parquet)",
                                              ("row", "file", "specimen", "temperature (C)", "lines", "reliable"), rows)]))
    html = render_report("jointid test campaign", f"manifest {manifest.path}", sections)
    return html, figures
