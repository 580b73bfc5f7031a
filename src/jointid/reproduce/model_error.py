"""Study 4 -- sensitivity of the identification to errors in the free-beam FE model.

The FRFs come from the true beam (Model 3 layout, Material A joint, exact data);
the identification uses a free-beam model whose loss factor, density or elastic
modulus is scaled. The table gives the median and 90th-percentile relative error
of each joint term over 100-1000 Hz per variant.

Then the remedy: a nominal model 2 % off in E and 1 % off in density is
updated from a virtual free-free test of the true free beam (same layout,
1 % complex noise, :func:`jointid.methods.updating.fit.update_free_model`), and
the joint is identified with the nominal and with the updated model: the error
per term before and after updating, side by side (second table).
"""

from __future__ import annotations

import numpy as np

from ..methods.hong_lee.inverse import identify_joint
from ..methods.updating.fit import update_free_model
from ..physics.synthesis import synthesize_frf
from ..plots.studies import plot_terms
from ..report.html import Table
from .common import (
    SUMMARY_BAND_HZ, Progress, StudyOutput, add_noise, band_errors, material_joint, percentiles, relative_error, study_beam, terms_of,
)

__all__ = ["run", "VARIANTS", "NOMINAL_ERROR", "FREE_TEST_NOISE", "updating_comparison"]

#: About the CPU seconds of :func:`run` on the benchmark (``jointid reproduce`` starts the longest studies first).
COST = 8.0

#: Parameter -> scale factors of the free-beam model.
VARIANTS = {
    "loss_factor": (1 / 3, 2 / 3, 1.0, 4 / 3, 5 / 3),
    "density": (0.98, 0.99, 1.0, 1.01, 1.02),
    "elastic_modulus": (0.98, 0.99, 1.0, 1.01, 1.02),
}
_LABEL = {"loss_factor": "eta", "density": "rho", "elastic_modulus": "E"}
#: The nominal model of the updating comparison: parameter -> factor on the true value.
NOMINAL_ERROR = {"elastic_modulus": 1.02, "density": 0.99}
#: Relative complex noise rms of the virtual free-free test.
FREE_TEST_NOISE = 0.01


def updating_comparison(config, frf, truth, layout, band):
    """Identify with the nominal model (:data:`NOMINAL_ERROR`) and with it updated from a virtual free-free test.

    Returns ``(rows, summary, columns, result)``: table rows (model, E and rho
    error, median error per term), summary lines, CSV columns, the
    :class:`~jointid.methods.updating.fit.UpdateResult`.
    """
    from ..physics.synthesis import synthesize_frf as synth

    f = config.grid
    beam = config.beam
    names = ("elastic_modulus", "density", "loss_factor")
    true_values = {k: float(getattr(beam, k)) for k in names}
    nominal = {k: v * NOMINAL_ERROR.get(k, 1.0) for k, v in true_values.items()}

    def build(values):
        return study_beam(config, {k: values[k] / true_values[k] for k in names})

    dofs = ([f"{n}w" for n in layout.observed], [f"{n}w" for n in layout.excited])
    free = synth(study_beam(config), f[f.hz > 0], *dofs, kind="accelerance")
    free = add_noise(free, FREE_TEST_NOISE, np.random.default_rng(config.seed))
    result = update_free_model(build, nominal, free)
    rows, summary, cols = [], [], {"frequency_hz": f.hz}
    for label, values in (("nominal (E x 1.02, rho x 0.99)", nominal), ("updated from free-free test", result.values)):
        r = identify_joint(build(values), frf, config.joint_dofs)
        terms = terms_of(r.stiffness)
        row = [label] + [f"{100 * (values[k] / true_values[k] - 1):+.3g} %" for k in names]
        for term, k in terms.items():
            med, _ = percentiles(relative_error(k, truth[term]), band)
            row.append(f"{100 * med:.3g} %")
            key = "nominal" if label.startswith("nominal") else "updated"
            cols[f"{term}_{key}_real"] = k.real
            cols[f"{term}_{key}_imag"] = k.imag
        rows.append(row)
        summary.append((f"model {label}", *band_errors(terms["translational"], truth["translational"], f)))
    return rows, summary, cols, result


def run(config, progress: Progress | None = None, layout: str = "model_3") -> StudyOutput:
    """Run the model-error study on ``config``; ``layout`` names the coordinate layout used."""
    progress = progress or Progress()
    progress.total(sum(len(v) for v in VARIANTS.values()) + 1)
    f = config.grid
    lay = config.layouts[layout]
    joint = material_joint(config, "A")
    truth = terms_of(joint(f.hz))
    frf = synthesize_frf(study_beam(config).with_joint(joint), f, [f"{n}w" for n in lay.observed], [f"{n}w" for n in lay.excited], kind="accelerance")
    band = f.mask(*SUMMARY_BAND_HZ)
    rows, summary, figures, data = [], [], [], {}
    worst = {}
    for param, scales in VARIANTS.items():
        curves = {"true": truth}
        cols = {"frequency_hz": f.hz}
        for s in scales:
            model = study_beam(config, {param: s})
            r = identify_joint(model, frf, config.joint_dofs)
            progress.update()
            label = f"{_LABEL[param]} x {s:.3g}"
            terms = terms_of(r.stiffness)
            curves[label] = terms
            row = [label]
            for term, k in terms.items():
                med, p90 = percentiles(relative_error(k, truth[term]), band)
                row += [f"{100 * med:.3g} %", f"{100 * p90:.3g} %"]
                worst[(param, s, term)] = med
                cols[f"{term}_x{s:.4g}_real"] = k.real
                cols[f"{term}_x{s:.4g}_imag"] = k.imag
            rows.append(row)
            if s != 1.0:
                summary.append((f"model {label}", *band_errors(terms["translational"], truth["translational"], f)))
        data[f"model_error_{param}"] = cols
        figures.append((
            f"model_error_{param}",
            plot_terms(f.hz, curves, title=f"Identified joint terms with the free-beam {param.replace('_', ' ')} scaled"),
            f"Identified translational, coupling and rotational terms for free-beam models with {param.replace('_', ' ')} scaled; true joint dashed",
        ))
    up_rows, up_summary, up_cols, up = updating_comparison(config, frf, truth, lay, band)
    progress.update()
    summary.extend(up_summary)
    data["model_error_updating"] = up_cols
    held = [p.name for p in up.parameters if not p.identified]
    e1 = {t: worst[("elastic_modulus", 1.01, t)] for t in ("translational", "coupling", "rotational")}
    r1 = {t: worst[("density", 1.01, t)] for t in ("translational", "coupling", "rotational")}
    eta = worst[("loss_factor", 5 / 3, "translational")]
    findings = (
        f"A 1% error in the beam's elastic modulus gives a median error of {100 * e1['translational']:.2g}% in the translational, "
        f"{100 * e1['coupling']:.2g}% in the coupling and {100 * e1['rotational']:.2g}% in the rotational term; a 1% density error "
        f"gives {100 * r1['translational']:.2g}%, {100 * r1['coupling']:.2g}% and {100 * r1['rotational']:.2g}%; a beam loss factor "
        f"5/3 too high only {100 * eta:.2g}% in the translational term.",
        f"Updated from a virtual free-free test ({100 * FREE_TEST_NOISE:g}% noise), a model 2% off in E and 1% off in density "
        f"identifies the rotational term to {up_rows[1][6]} instead of {up_rows[0][6]} (median)"
        + (f"; {', '.join(held)} not determined by the free-free test on this grid (kept at the nominal value)." if held else "."),
    )
    header = ["variant"] + [f"{t} {q}" for t in ("translational", "coupling", "rotational") for q in ("median", "p90")]
    return StudyOutput(
        name="model-error",
        title="Sensitivity to free-beam model error",
        paragraphs=(
            f"FRFs of the true beam ({lay.name}, Material A joint, exact data) are identified with free-beam models whose loss factor, "
            "density or elastic modulus is scaled. Errors are relative (|K - K_true| / |K_true|) over 100-1000 Hz.",
            findings[0],
            findings[1],
        ),
        tables=(
            Table("Median and 90th-percentile relative error per variant and term (100-1000 Hz)", header, rows),
            Table(
                "Before and after updating the free beam from a virtual free-free test: parameter error and median "
                "relative error per term (100-1000 Hz)",
                ["model", "E error", "rho error", "eta error", "translational", "coupling", "rotational"],
                up_rows,
            ),
        ),
        data=data,
        figures=tuple(figures),
        summary=tuple(summary),
        findings=findings,
    )
