"""Study 3 -- verification: inverse (Model 3, exact FRFs) against direct (the FE joint model), Material A.

The inverse method identifies the joint from FRFs of the constrained beam; the
direct method gives the joint as the FE elastomer model with the material fitted
to step-sine tests. Both are compared with the true joint for the
translational, coupling and rotational terms on the study grid (1 Hz steps).
"""

from __future__ import annotations

import numpy as np

from ..methods.hong_lee.inverse import identify_joint
from ..physics.synthesis import synthesize_frf
from ..plots.studies import plot_terms
from ..report.html import Table
from .common import SUMMARY_BAND_HZ, Progress, StudyOutput, band_errors, material_joint, percentiles, relative_error, study_beam, terms_of
from .direct_characterization import fitted_joint

__all__ = ["run"]

#: About the CPU seconds of :func:`run` on the benchmark (``jointid reproduce`` starts the longest studies first).
COST = 1.5


def run(config, progress: Progress | None = None, material: str = "A", layout: str = "model_3") -> StudyOutput:
    """Run the verification study on ``config``."""
    progress = progress or Progress()
    progress.total(3)
    f = config.grid
    lay = config.layouts[layout]
    joint = material_joint(config, material)
    truth = terms_of(joint(f.hz))
    beam = study_beam(config)
    frf = synthesize_frf(beam.with_joint(joint), f, [f"{n}w" for n in lay.observed], [f"{n}w" for n in lay.excited], kind="accelerance")
    inverse = terms_of(identify_joint(beam, frf, config.joint_dofs).stiffness)
    progress.update()
    direct = terms_of(fitted_joint(config, material).driving_point_matrix(f.hz, include_cap=False))
    progress.update()
    band = f.mask(*SUMMARY_BAND_HZ)
    rows, data = [], {"frequency_hz": f.hz}
    for term in ("translational", "coupling", "rotational"):
        inv_vs_dir = percentiles(relative_error(inverse[term], direct[term]), band)
        inv_vs_true = percentiles(relative_error(inverse[term], truth[term]), band)
        dir_vs_true = percentiles(relative_error(direct[term], truth[term]), band)
        rows.append([term] + [f"{100 * v:.3g} %" for v in (*inv_vs_dir, *inv_vs_true, *dir_vs_true)])
        for label, k in (("inverse", inverse), ("direct", direct), ("true", truth)):
            data[f"{term}_{label}_real"] = k[term].real
            data[f"{term}_{label}_imag"] = k[term].imag
    fig = plot_terms(f.hz, {"true": truth, "direct (fitted FE joint)": direct, f"inverse ({lay.name}, exact FRFs)": inverse},
                     title=f"Verification, Material {material}: inverse against direct")
    progress.update()
    e = band_errors(inverse["translational"], direct["translational"], f)
    findings = (
        f"With exact FRFs the inverse ({lay.name}) and direct translational stiffness of Material {material} agree to "
        f"{100 * e[0]:.2g}% (median over 100-1000 Hz, worst {100 * float(np.max(relative_error(inverse['translational'][band], direct['translational'][band]))):.2g}%); "
        f"the difference is the direct method's material-fit error, the inverse result matching the true joint to round-off.",
    )
    return StudyOutput(
        name="verification",
        title="Verification: inverse against direct",
        paragraphs=(
            f"Material {material}: the inverse method ({lay.name}, exact FRFs, {f.size} lines) against the direct method (FE joint "
            "model with the material fitted to the step-sine tests) and the true joint. Relative errors |a - b| / |b| over 100-1000 Hz.",
            findings[0],
        ),
        tables=(Table("Median and 90th-percentile relative differences over 100-1000 Hz",
                      ["term", "inverse vs direct, median", "p90", "inverse vs true, median", "p90", "direct vs true, median", "p90"], rows),),
        data={"verification_material_a" if material == "A" else f"verification_material_{material.lower()}": data},
        figures=(("verification", fig, "Translational, coupling and rotational terms: inverse, direct and true (dashed)"),),
        summary=((f"inverse vs direct, Material {material}", *e), (f"inverse vs true, Material {material}", *band_errors(inverse["translational"], truth["translational"], f))),
        findings=findings,
    )
