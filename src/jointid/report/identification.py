"""``report.html`` of a user's identification (``jointid identify``, ``jointid experiment``).

Built from the command's ``summary.json`` content (so the page and the JSON
say the same), the lines the command printed, the FRF file's notes and the
figures. Findings come first, then each term's figure, a short "what to
trust" section and the inputs.
"""

from __future__ import annotations

import datetime
from typing import Sequence

from .html import Section, Table, render_report

__all__ = ["identification_report", "trust_items"]


def _pct(x, fmt: str = ".2g") -> str:
    return "-" if x is None else f"{100 * x:{fmt}} %"


def _terms_table(caption: str, terms: dict, units: dict) -> Table:
    """One row per independent term (upper triangle; a joint of more than 3 DOFs: the diagonal)."""
    names = list(terms)  # K_{a}_{b}, row-major
    n = int(round(len(names) ** 0.5))
    rows = []
    for idx, name in enumerate(names):
        i, j = divmod(idx, n)
        if j < i or (n > 3 and i != j):
            continue
        t = terms[name]
        eta = t.get("median_loss_factor")
        rows.append([
            name, f"{t['median_magnitude']:.4g}", units.get(name, ""),
            (f"{eta:.3g}" if eta is not None else "Re K <= 0") if i == j else "(coupling)",
            _pct(t.get("median_predicted_relative_std")),
            _pct(t.get("reliable_fraction"), ".0f") if "reliable_fraction" in t else "-",
        ])
    return Table(caption, ["term", "median |K|", "unit", "median loss factor", "predicted error (1 sigma, median)", "lines reliable"], rows)


def _term_verdicts(summary: dict) -> list[str]:
    """One line per independent term: trust it on the whole band, on part of it, or not at all."""
    blocks = [(f"joint {n}: ", j["terms"]) for n, j in summary["joints"].items()] if "joints" in summary else [("", summary["terms"])]
    out = []
    for prefix, terms in blocks:
        names = list(terms)
        n = int(round(len(names) ** 0.5))
        for idx, name in enumerate(names):
            i, j = divmod(idx, n)
            if j < i or (n > 3 and i != j) or "reliable_fraction" not in terms[name]:
                continue
            frac, err = terms[name]["reliable_fraction"], terms[name].get("median_predicted_relative_std")
            e = f", median predicted error {100 * err:.2g} %" if err is not None else ""
            if frac >= 1.0:
                out.append(f"Trust {prefix}{name} over the whole band: reliable on every line{e}.")
            elif frac > 0.0:
                out.append(f"Trust {prefix}{name} only where it is reliable: on {100 * frac:.0f} % of the lines{e}; "
                           "the findings name the bands to leave out.")
            else:
                out.append(f"Do not use {prefix}{name}: these FRFs determine it on no line.")
    return out


def trust_items(summary: dict) -> list[str]:
    """How to read the flags and bands of an identification, with this run's thresholds and a verdict per term."""
    if summary.get("method") == "receptance":
        limit = summary.get("options", {}).get("max_relative_std", 0.1)
        items = [
            f"Reliable means: the predicted relative error (1 sigma) of the term is at most {100 * limit:.0f} % on that line and the "
            "line passes the conditioning and passivity checks. The CSV's reliable_* columns are 1 there and 0 elsewhere; "
            "the figures shade the unreliable lines grey. Do not use a term where it is flagged.",
            "The 90 % band is +-1.645 predicted standard deviations. It covers the random error of the FRFs (its scale is "
            "checked against the residuals, chi^2/dof), not a model error: a wrong free-structure model (modulus, density, "
            "sensor masses) or a biased FRF (leakage, windows, calibration) moves the estimate without widening the band. "
            "Check the model against a free-free test (`jointid update`) before trusting narrow bands.",
            "The line is the smoothed estimate; the grey dots are the per-line estimates before smoothing. Dots far outside the "
            "band on few lines are noise the smoother rejected; a systematic offset of the dots from the line is a misfit "
            "(the findings then say that the structured model does not fit).",
        ]
    else:
        items = [
            "The Hong & Lee method gives no uncertainty: reliable lines are those whose condition numbers and residuals pass "
            "the thresholds in summary.json (reliability_thresholds); there is no band. Use the receptance method "
            "([identification] method = \"receptance\", the default) for per-term bands.",
        ]
    items = _term_verdicts(summary) + items + [
        "The loss factor Im K / Re K is a material loss factor only where the storage stiffness Re K > 0. Where Re K crosses "
        "zero (an internal mode of the joint, or a term dominated by inertia), the figure shows the phase of K in degrees "
        "instead; coupling terms get no loss factor.",
        "Rotations are not measured: rotational and coupling terms come through the model's mode shapes and have wider "
        "bands than translational ones. Each finding above names the band where a term is not identifiable.",
    ]
    return items


def _inputs(summary: dict, notes: Sequence[str]) -> Section:
    f0, f1 = summary["frequency_hz"]
    rows = [
        ["FRF file", summary["frf_file"]],
        ["study", summary["study"]],
        ["method", summary["method"]],
        ["lines used", f"{summary['lines']} ({f0:g}-{f1:g} Hz, the study's [frequency] band on the file's grid)"],
        ["joint DOFs", ", ".join(summary["joint_dofs"])],
        ["observed (responses)", ", ".join(summary["observed"])],
        ["excited (references)", ", ".join(summary["excited"])],
    ]
    for key, value in sorted(summary.get("options", {}).items()):
        rows.append([f"option {key}", str(value)])
    items = list(notes) or ["The file's records were used as they are: SI units, no record skipped."]
    return Section(
        "Inputs", "inputs",
        paragraphs=("What the file held and what was converted or skipped on reading it:",),
        items=items, tables=(Table("Layout and options", ["", "value"], rows),),
    )


def identification_report(summary: dict, lines: Sequence[str], notes: Sequence[str] = (),
                          figures: Sequence[tuple[str, bytes, str]] = (), title: str | None = None) -> str:
    """The self-contained HTML page of an identification.

    Parameters
    ----------
    summary : dict
        The content of ``summary.json`` (:func:`jointid.cli.identify.summary`).
    lines : sequence of str
        What the command printed (summary line, estimator, one line per term, findings).
    notes : sequence of str
        The FRF file's notes: units converted, records skipped (``FRF.notes``).
    figures : sequence of (file name, PNG bytes, caption)
        Embedded as base64 PNG; an empty sequence (``--no-plots``) is said in the page.
    title : str, optional

    Returns
    -------
    str
        HTML with no external reference (opens offline).
    """
    findings = list(summary.get("findings", []))
    items = list(lines)
    if not findings:
        items.append("No finding: every term is identifiable on every line of the band." if summary.get("method") == "receptance"
                     else "The Hong & Lee method reports no per-term findings; see the reliable column.")
    tables = []
    if "joints" in summary:
        for name, joint in summary["joints"].items():
            tables.append(_terms_table(f"joint {name}: per term", joint["terms"], joint["units"]))
    else:
        tables.append(_terms_table("Per term", summary["terms"], summary["units"]))
    sections = [
        Section("Findings", "findings", items=items, tables=tuple(tables)),
        Section(
            "Terms", "terms",
            paragraphs=("Each term's |K| on a log axis with its 90 % band; below, the loss factor of the diagonal terms "
                        "(or their phase where Re K crosses zero).",) if figures else
                       ("No figures: the command ran with --no-plots.",),
            figures=tuple(figures),
        ),
        Section("What to trust", "trust", items=trust_items(summary)),
        _inputs(summary, notes),
    ]
    meta = f"{datetime.datetime.now().isoformat(timespec='seconds')}; study {summary['study']}; FRFs {summary['frf_file']}"
    return render_report(title or "jointid: identified joint stiffness", meta, sections)
