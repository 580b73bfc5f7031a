"""``report.html`` of ``jointid update`` and ``jointid direct``: findings first, figures, what to trust, inputs.

Built from the command's JSON (``update.json``, ``direct_fit.json``) and the
lines it printed, so the page and the files say the same.
"""

from __future__ import annotations

import datetime
from typing import Sequence

from .html import Section, Table, render_report

__all__ = ["update_report", "direct_report"]


def _num(x, fmt: str = ".4g") -> str:
    return "-" if x is None else f"{x:{fmt}}"


def _figures_section(figures, text: str) -> Section:
    return Section("Figures", "figures", paragraphs=(text,) if figures else ("No figures: the command ran with --no-plots.",),
                   figures=tuple(figures))


def _notes_items(notes: Sequence[str]) -> list[str]:
    return list(notes) or ["The file's records were used as they are: SI units, no record skipped."]


def update_report(report: dict, lines: Sequence[str], figures: Sequence[tuple[str, bytes, str]] = ()) -> str:
    """The page of a model update.

    Parameters
    ----------
    report : dict
        The content of ``update.json`` (``UpdateResult.to_dict()`` plus ``study``, ``frf_file``, ``fitted``).
    lines : sequence of str
        What the command printed (one line per parameter, the residual).
    figures : sequence of (file name, PNG bytes, caption)
    """
    rows = []
    for name, p in report["parameters"].items():
        change = "-" if p["value"] is None else f"{100 * (p['value'] / p['initial'] - 1):+.2f} %"
        rows.append([name, _num(p["value"], ".6g"), _num(p["std"], ".2g"), _num(p["initial"], ".6g"), change, p["unit"],
                     p["status"].replace("_", " ") + (f" ({p['reason']})" if p.get("reason") else "")])
    corr = report["correlation"]
    names = corr["parameters"]
    corr_rows = [[a] + [_num(v, ".2f") for v in row] for a, row in zip(names, corr["matrix"])]
    frf = report["frf"]
    res = report["residual"]
    sections = [
        Section("Findings", "findings", items=list(lines), tables=(
            Table("Parameters", ["parameter", "value", "std error", "initial", "change", "unit", "status"], rows),
        )),
        _figures_section(figures, "Measured FRFs with the initial and the updated model (log magnitude)."),
        Section("What to trust", "trust", items=[
            "A parameter is 'determined' when the FRFs fix it: its standard error is small against its value and it is not "
            "a combination of others. A parameter 'not determined' keeps the study's value in updated_study.toml: the "
            "FRFs say nothing about it, so do not read the fit's number for it.",
            f"The residual (rms |ln(H_model / H_measured)|, a relative error) went from {res['before']:.3g} to {res['after']:.3g}. "
            "After a good update it is close to the FRFs' own noise (a few %); a residual far above it means the model "
            "cannot match these FRFs (wrong structure, a joint still attached, wrong units): do not use the values.",
            "Standard errors are first order (the Jacobian at the optimum) and assume the model's form is right. A correlation "
            "near +-1 between two parameters (table below) means the FRFs fix only their combination.",
            "The figure shows whether the resonances line up after the update; a shifted peak is a model error no parameter "
            "value can remove.",
        ], tables=(Table("Correlation of the fitted parameters", ["", *names], corr_rows),) if names else ()),
        Section("Inputs", "inputs", items=_notes_items(report.get("notes", [])), tables=(Table("Data and fit", ["", "value"], [
            ["FRF file", report["frf_file"]], ["study", report["study"]], ["FRF kind", frf["kind"]],
            ["lines", f"{frf['lines']} ({frf['frequency_hz'][0]:g}-{frf['frequency_hz'][1]:g} Hz)"],
            ["responses", ", ".join(frf["responses"])], ["references", ", ".join(frf["references"])],
            ["coherence weighting", "yes" if frf["coherence_weighted"] else "no (the file has no coherence)"],
            ["fitted", ", ".join(report["fitted"])], ["model evaluations", str(report["evaluations"])],
        ]),)),
    ]
    meta = f"{datetime.datetime.now().isoformat(timespec='seconds')}; study {report['study']}; FRFs {report['frf_file']}"
    return render_report("jointid: free model updated from a free-free test", meta, sections)


def direct_report(summary: dict, lines: Sequence[str], figures: Sequence[tuple[str, bytes, str]] = ()) -> str:
    """The page of a direct (step-sine) identification.

    Parameters
    ----------
    summary : dict
        The content of ``direct_fit.json`` (:func:`jointid.cli.direct.direct_summary`).
    lines : sequence of str
        What the command printed (the fit line, warnings).
    figures : sequence of (file name, PNG bytes, caption)
    """
    fit = summary["fit"]
    rows = []
    for name, p in fit["parameters"].items():
        value = p.get("value")
        rows.append([name, _num(value, ".5g"), _num(p.get("std_error"), ".2g"), p.get("unit", ""),
                     str(p.get("status", "")) + (f" (held at {p['held_value']:.5g})" if p.get("held_value") is not None else "")])
    st = summary["static"]
    flagged = summary["flagged_lines_hz"]
    items = list(lines) + [f"warning: {w}" for w in summary.get("warnings", [])]
    if flagged:
        items.append(f"{len(flagged)} line(s) did not reach the commanded amplitude within {100 * summary['tolerance']:.0f} % "
                     f"and are left out of the fit: {', '.join(f'{x:g}' for x in flagged[:12])}{' ...' if len(flagged) > 12 else ''} Hz")
    sections = [
        Section("Findings", "findings", items=items, tables=(
            Table("Fitted elastomer (FE joint model)", ["parameter", "value", "std error", "unit", "status"], rows),
            Table("Static estimate (lowest lines)", ["quantity", "value"], [
                ["stiffness per joint [N/m]", _num(st.get("stiffness_n_m"))],
                ["loss factor", _num(st.get("loss_factor"), ".3g")],
                ["E from k L / A (under-reads) [Pa]", _num(st.get("elastic_modulus_pa"))],
                ["E corrected for the guided stiffness [Pa]", _num(st.get("corrected_elastic_modulus_pa"))],
            ]),
        )),
        _figures_section(figures, "|K21| per joint on a log axis, measured and fitted; below, the loss factor, or the phase "
                                  "when Re K21 crosses zero (past the joint's internal mode)."),
        Section("What to trust", "trust", items=[
            "A parameter's value is given only when its status is 'identified'; a held value is an assumption (e.g. the "
            "density on a band far below the joint's internal mode), and 'not identified' means the data do not fix it.",
            f"The standard errors are first order and assume the constant-modulus model is right; the fit's residual "
            f"({100 * fit['residual_rms']:.2g} % rms) should be close to the measurement noise. A larger residual means the "
            "material is not one constant complex modulus (frequency-dependent: try --zener) or the test is not clean.",
            "Lines flagged for amplitude (red crosses) are measured at another strain than the others; an elastomer's "
            "stiffness depends on amplitude, so they are left out of the fit.",
            "Past the blocked internal mode the storage stiffness Re K21 changes sign: the figure then shows the phase, "
            "a loss factor there would run to +-infinity.",
        ]),
        Section("Inputs", "inputs", tables=(Table("Data", ["", "value"], [
            ["data file", summary["data_file"]], ["joints in parallel", str(summary["parallel_joints"])],
            ["commanded amplitude [m, peak]", f"{summary['commanded_amplitude_m']:.4g} ({summary['commanded_amplitude_source']})"],
            ["lines", f"{summary['lines']} ({summary['band_hz'][0]:g}-{summary['band_hz'][1]:g} Hz)"],
            ["largest force THD", _num(summary.get("max_force_thd"), ".3g")],
            ["elastomer length, diameter [m]", f"{fit.get('length_m', '-')}, {fit.get('diameter_m', '-')}"],
            ["Poisson ratio", str(fit.get("poisson_ratio", "-"))],
        ]),)),
    ]
    meta = f"{datetime.datetime.now().isoformat(timespec='seconds')}; data {summary['data_file']}"
    return render_report("jointid: direct identification of the elastomer", meta, sections)
