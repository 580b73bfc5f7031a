"""Study 2 -- conditioning of the coordinate layouts (Models 1, 2, 3).

Condition numbers vs frequency of the three matrices the inverse method
pseudo-inverts or relies on, for each layout, and the identified translational
stiffness of Models 1 and 2 with exact data and with a small measurement noise.
"""

from __future__ import annotations

import numpy as np

from ..methods.hong_lee.inverse import identify_joint
from ..physics.synthesis import synthesize_frf
from ..plots.studies import plot_conditions, plot_terms
from ..report.html import Table
from .common import Progress, StudyOutput, add_noise, band_errors, fmt, layout_table, material_joint, pct, study_beam

__all__ = ["run"]

#: About the CPU seconds of :func:`run` on the benchmark (``jointid reproduce`` starts the longest studies first).
COST = 3.0


def run(config, progress: Progress | None = None) -> StudyOutput:
    """Run the conditioning study on ``config`` (a :class:`~jointid.reproduce.config.ReproduceConfig`)."""
    progress = progress or Progress()
    layouts = list(config.layouts.values())
    progress.total(2 * len(layouts))
    f = config.grid
    beam = study_beam(config)
    joint = material_joint(config, "A")
    article = beam.with_joint(joint)
    truth = joint(f.hz)[:, 0, 0]
    rng = np.random.default_rng(config.seed)
    conds, curves, rows, summary, data = {}, {"true": {"translational": truth}}, [], [], {}
    cond_cols = {"frequency_hz": f.hz}
    for lay in layouts:
        frf = synthesize_frf(article, f, [f"{n}w" for n in lay.observed], [f"{n}w" for n in lay.excited], kind="accelerance")
        exact = identify_joint(beam, frf, config.joint_dofs)
        progress.update()
        noisy = identify_joint(beam, add_noise(frf, config.conditioning_noise, rng), config.joint_dofs)
        progress.update()
        conds[lay.name] = {k: getattr(exact, k) for k in ("cond_A", "cond_B", "cond_H")}
        for k in ("cond_A", "cond_B", "cond_H"):
            cond_cols[f"{k}_{lay.name.replace(' ', '_').lower()}"] = getattr(exact, k)
        e_exact = band_errors(exact.term("w", "w"), truth, f)
        e_noisy = band_errors(noisy.term("w", "w"), truth, f)
        rows.append([
            lay.name, fmt(exact.cond_A.max()), fmt(np.median(exact.cond_A)), fmt(exact.cond_B.max()), fmt(exact.cond_H.max()),
            pct(e_exact[0]), pct(e_noisy[0]), fmt(e_noisy[1], 2), pct(float(np.mean(noisy.reliable))),
        ])
        summary.append((f"{lay.name}, exact data", *e_exact))
        summary.append((f"{lay.name}, {100 * config.conditioning_noise:g}% noise", *e_noisy))
        if len(lay.observed) < 5:  # Models 1 and 2: show the identified stiffness
            curves[f"{lay.name}, exact data"] = {"translational": exact.term("w", "w")}
            curves[f"{lay.name}, {100 * config.conditioning_noise:g}% noise"] = {"translational": noisy.term("w", "w")}
            key = lay.name.replace(" ", "_").lower()
            data[f"conditioning_{key}_translational"] = {
                "frequency_hz": f.hz,
                "true_real": truth.real, "true_imag": truth.imag,
                "exact_real": exact.term("w", "w").real, "exact_imag": exact.term("w", "w").imag,
                "noisy_real": noisy.term("w", "w").real, "noisy_imag": noisy.term("w", "w").imag,
                "cond_A": exact.cond_A, "cond_B": exact.cond_B,
            }
    data["conditioning_condition_numbers"] = cond_cols
    worst = {name: float(c["cond_A"].max()) for name, c in conds.items()}
    names = list(worst)
    findings = []
    if len(names) >= 2:
        findings.append(
            f"The worst estimation condition number falls from {worst[names[0]]:.3g} ({names[0]}) to "
            f"{worst[names[1]]:.3g} ({names[1]})" + (f" and {worst[names[2]]:.3g} ({names[2]})" if len(names) > 2 else "")
            + ": more observed points remove the spikes of cond(Do[nbar, mbar])."
        )
    noisy_err = {r[0]: r[6] for r in rows}
    findings.append(
        "With " + f"{100 * config.conditioning_noise:g}% noise the median translational-stiffness error over 100-1000 Hz is "
        + ", ".join(f"{v} for {k}" for k, v in noisy_err.items()) + "."
    )
    fig_c = plot_conditions(f.hz, conds, "Condition numbers of the inverse method per layout")
    fig_k = plot_terms(f.hz, curves, terms=("translational",), title="Identified translational stiffness, Models 1 and 2 (Material A joint)")
    table = Table(
        "Conditioning and translational-stiffness error (100-1000 Hz medians) per layout",
        ["layout", "max cond_A", "median cond_A", "max cond_B", "max cond_H", "|K_ww| error, exact", "|K_ww| error, noisy", "loss-factor error, noisy", "reliable lines, noisy"],
        rows,
    )
    return StudyOutput(
        name="conditioning",
        title="Conditioning of the coordinate layouts",
        paragraphs=(
            "Each layout identifies the Material A joint at node "
            f"{config.joint_node} from FRFs synthesized on the constrained beam, once exact and once with "
            f"{100 * config.conditioning_noise:g}% complex noise (relative rms, every FRF value). cond_A is the condition number of "
            "the free-beam block Do[nbar, mbar] inverted in the estimation step, cond_B that of the estimated H*[n, e] inverted in the "
            "identification step, cond_H that of the measured H*[m, e]; rotations are scaled by the element length.",
            findings[0] if findings else "",
        ),
        tables=(layout_table(layouts), table),
        data=data,
        figures=(
            ("conditioning_condition_numbers", fig_c, "Condition numbers vs frequency (log axis), one line per layout"),
            ("conditioning_translational", fig_k, "Identified translational stiffness of Models 1 and 2, exact and noisy data, against the true joint (dashed)"),
        ),
        summary=tuple(summary),
        findings=tuple(findings),
    )
