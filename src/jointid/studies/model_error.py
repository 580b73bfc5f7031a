"""Study 4 -- sensitivity of the identification to errors in the free-beam FE model.

The FRFs come from the true beam (Model 3 layout, Material A joint, exact data);
the identification uses a free-beam model whose loss factor, density or elastic
modulus is scaled. The table gives the median and 90th-percentile relative error
of each joint term over 100-1000 Hz per variant.
"""

from __future__ import annotations

from ..methods.inverse import identify_joint
from ..physics.synthesis import synthesize_frf
from ..plots.studies import plot_terms
from ..report.html import Table
from .common import SUMMARY_BAND_HZ, Progress, StudyOutput, band_errors, material_joint, percentiles, relative_error, study_beam, terms_of

__all__ = ["run", "VARIANTS"]

#: Parameter -> scale factors of the free-beam model.
VARIANTS = {
    "loss_factor": (1 / 3, 2 / 3, 1.0, 4 / 3, 5 / 3),
    "density": (0.98, 0.99, 1.0, 1.01, 1.02),
    "elastic_modulus": (0.98, 0.99, 1.0, 1.01, 1.02),
}
_LABEL = {"loss_factor": "eta", "density": "rho", "elastic_modulus": "E"}


def run(config, progress: Progress | None = None, layout: str = "model_3") -> StudyOutput:
    """Run the model-error study on ``config``; ``layout`` names the coordinate layout used."""
    progress = progress or Progress()
    progress.total(sum(len(v) for v in VARIANTS.values()))
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
    e1 = {t: worst[("elastic_modulus", 1.01, t)] for t in ("translational", "coupling", "rotational")}
    r1 = {t: worst[("density", 1.01, t)] for t in ("translational", "coupling", "rotational")}
    eta = worst[("loss_factor", 5 / 3, "translational")]
    findings = (
        f"A 1% error in the beam's elastic modulus gives a median error of {100 * e1['translational']:.2g}% in the translational, "
        f"{100 * e1['coupling']:.2g}% in the coupling and {100 * e1['rotational']:.2g}% in the rotational term; a 1% density error "
        f"gives {100 * r1['translational']:.2g}%, {100 * r1['coupling']:.2g}% and {100 * r1['rotational']:.2g}%; a beam loss factor "
        f"5/3 too high only {100 * eta:.2g}% in the translational term.",
    )
    header = ["variant"] + [f"{t} {q}" for t in ("translational", "coupling", "rotational") for q in ("median", "p90")]
    return StudyOutput(
        name="model-error",
        title="Sensitivity to free-beam model error",
        paragraphs=(
            f"FRFs of the true beam ({lay.name}, Material A joint, exact data) are identified with free-beam models whose loss factor, "
            "density or elastic modulus is scaled. Errors are relative (|K - K_true| / |K_true|) over 100-1000 Hz.",
            findings[0],
        ),
        tables=(Table("Median and 90th-percentile relative error per variant and term (100-1000 Hz)", header, rows),),
        data=data,
        figures=tuple(figures),
        summary=tuple(summary),
        findings=findings,
    )
