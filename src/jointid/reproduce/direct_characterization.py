"""Study 1 -- direct characterization of Materials A and B on the elastomer test system.

Synthetic step-sine tests (25-600 Hz every 25 Hz, 0.05 mm peak-to-peak, two
joints in double shear, noise, settling ramp, force harmonics) of the FE joint
model with the material's true parameters are processed like machine data;
the static stiffness gives G = kL/A and E = 2G(1 + nu); a least-squares fit of
E, eta and rho reproduces K21; the fitted joint model is then extended to the
inverse band (1 Hz steps to the grid's stop frequency).
"""

from __future__ import annotations

import numpy as np

from ..methods.direct.material_fit import fit_material, static_estimate
from ..measurement.stepsine import process_stepsine
from ..measurement.stepsine_synth import synthesize_stepsine
from ..plots.direct import plot_direct_stiffness
from ..plots.studies import plot_terms
from ..report.html import Table
from .common import Progress, StudyOutput, band_errors, elastomer_joint, fmt, pct, terms_of

__all__ = ["run", "characterize", "fitted_joint"]

#: About the CPU seconds of :func:`run` on the benchmark (``jointid reproduce`` starts the longest studies first).
COST = 4.0


def run(config, progress: Progress | None = None) -> StudyOutput:
    """Run the direct characterization on ``config``."""
    progress = progress or Progress()
    materials = list(config.materials)
    progress.total(2 * len(materials))
    f_test = np.arange(config.direct_start, config.direct_stop + 1e-9, config.direct_step)
    f = config.grid
    rows, figures, data, summary, findings = [], [], {}, [], []
    for name in materials:
        true, result, static, fit = characterize(config, name)
        progress.update()
        m = config.materials[name]
        rows.append([
            f"Material {name}", fmt(m.elastic_modulus / 1e6, 4), fmt(m.loss_factor, 3), fmt(m.density, 4),
            fmt(static.shear_modulus_pa / 1e6, 4), fmt(static.elastic_modulus_pa / 1e6, 4), fmt(static.corrected_elastic_modulus_pa / 1e6, 4),
            *(_fitted(p, scale) for p, scale in zip(fit.parameters, (1e6, 1.0, 1.0))),
            pct(max(abs(fit.elastic_modulus_pa / m.elastic_modulus - 1), abs(fit.loss_factor / m.loss_factor - 1), abs(fit.density_kg_m3 / m.density - 1))),
            str(int(np.sum(~result.amplitude_ok))),
        ])
        figures.append((f"direct_material_{name.lower()}", plot_direct_stiffness(result, fit, title=f"Material {name}: K21 per joint, measured and fitted"),
                        f"Material {name}: step-sine K21 per joint (markers) and the fitted FE joint model (line)"))
        data[f"direct_material_{name.lower()}"] = result.columns()
        # the fitted joint model as the inverse experiment's joint, over the inverse band
        K_fit = fit.joint.driving_point_matrix(f.hz, include_cap=False)
        K_true = true.driving_point_matrix(f.hz, include_cap=False)
        K21_fit = fit.joint.blocked_transfer_stiffness(f.hz)
        data[f"direct_model_material_{name.lower()}"] = {
            "frequency_hz": f.hz, "K21_real": K21_fit.real, "K21_imag": K21_fit.imag,
            "K_w_w_real": K_fit[:, 0, 0].real, "K_w_w_imag": K_fit[:, 0, 0].imag,
            "K_w_theta_real": K_fit[:, 0, 1].real, "K_w_theta_imag": K_fit[:, 0, 1].imag,
            "K_theta_theta_real": K_fit[:, 1, 1].real, "K_theta_theta_imag": K_fit[:, 1, 1].imag,
        }
        figures.append((f"direct_model_material_{name.lower()}", plot_terms(f.hz, {"true": terms_of(K_true), "fitted FE joint": terms_of(K_fit)},
                        title=f"Material {name}: joint driving-point matrix from the direct method"),
                        f"Material {name}: the 2x2 driving-point stiffness of the joint (far end fixed) with the fitted material, to {f.hz[-1]:g} Hz; true dashed"))
        summary.append((f"Material {name}, fitted FE joint", *band_errors(K_fit[:, 0, 0], K_true[:, 0, 0], f)))
        findings.append(
            f"The direct method recovers Material {name}'s E, loss factor and density within "
            f"{rows[-1][10]}; G = kL/A from the static stiffness reads {static.shear_modulus_pa / 1e6:.3g} MPa, "
            f"{100 * (1 - static.shear_modulus_pa / (true.elastic_modulus / (2 * (1 + true.poisson_ratio)))):.0f}% below the true G because the short cylinder also bends."
        )
        progress.update()
    table = Table(
        "Material parameters: true, from the static stiffness (G = kL/A, E = 2G(1 + nu)), and fitted to K21 over the test band",
        ["material", "E true [MPa]", "eta true", "rho true [kg/m^3]", "G static [MPa]", "E static [MPa]", "E static, bending-corrected [MPa]",
         "E fit [MPa]", "eta fit", "rho fit [kg/m^3]", "worst fit error", "lines off amplitude"],
        rows,
    )
    return StudyOutput(
        name="direct",
        title="Direct characterization (elastomer test system)",
        paragraphs=(
            f"Step-sine tests at {f_test[0]:g}-{f_test[-1]:g} Hz every {config.direct_step:g} Hz, {1e3 * config.direct_amplitude_pp:g} mm "
            f"peak-to-peak, {config.parallel_joints} joints in parallel (double shear), synthesized from the FE joint model with 0.5% noise "
            "on both channels, a 3-cycle settling ramp and a 3rd harmonic in the force, processed per block (transient dropped, "
            "least-squares fundamental over whole cycles). The fitted material feeds the FE joint model that the inverse method is "
            "compared with.",
            " ".join(findings),
        ),
        tables=(table,),
        data=data,
        figures=tuple(figures),
        summary=tuple(summary),
        findings=tuple(findings),
    )


def _fitted(p, scale: float) -> str:
    """A fitted parameter for the table: the value if identified, else its status (never a held value as a result)."""
    if p.identified:
        return fmt(p.value / scale, 4)
    return f"held at {fmt(p.value / scale, 4)}" if p.held else "not identified"


def characterize(config, material: str):
    """The direct method on ``material``'s synthetic step-sine test.

    Returns
    -------
    true : ElastomerJoint
        The joint the test was synthesized from (caps excluded).
    result : StepSineResult
        K21 per joint and the test's flags.
    static : StaticEstimate
        G = kL/A and E = 2G(1 + nu) from the lowest lines.
    fit : MaterialFit
        E, eta, rho fitted to K21; ``fit.joint`` is the FE joint with them.
    """
    true = elastomer_joint(config, material)
    f_test = np.arange(config.direct_start, config.direct_stop + 1e-9, config.direct_step)
    amplitude = config.direct_amplitude_pp / 2
    blocks = synthesize_stepsine(f_test, true.blocked_transfer_stiffness, amplitude_m=amplitude,
                                 parallel_joints=config.parallel_joints, seed=config.seed + list(config.materials).index(material))
    result = process_stepsine(blocks, parallel_joints=config.parallel_joints, commanded_amplitude_m=amplitude)
    static = static_estimate(result.frequency_hz, result.stiffness)
    fit = fit_material(result.frequency_hz, result.stiffness, joint=true.with_material(static.elastic_modulus_pa, 0.1, 1000.0))
    return true, result, static, fit


def fitted_joint(config, material: str):
    """The FE joint (caps excluded) with ``material`` fitted to its synthetic step-sine test (the direct method's result)."""
    return characterize(config, material)[3].joint
