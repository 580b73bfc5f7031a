"""Study 6 -- virtual roving-hammer experiment (Model 3, Materials A and B).

The roving-hammer test of :func:`jointid.pipeline.experiment` (time histories,
noise, H1) is written to UFF58 and read back, then identified exactly as
measured data would be, and compared with the exact-data inverse result and
the true joint. Material B's internal joint mode near 950 Hz is explained by
the joint model's deformed shape at that mode and at 150 Hz.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..physics.synthesis import synthesize_frf
from ..pipeline import constrained_model, experiment, identify
from ..plots.studies import plot_terms
from ..report.html import Table
from ..study import AccelerometerSpec, ExperimentSpec, FrequencySpec, IdentificationSpec, Study
from .common import Progress, StudyOutput, band_errors, config_study, fmt, pct, png, terms_of

__all__ = ["run", "experiment_study", "parts", "combine"]


def experiment_study(config, material: str, layout: str = "model_3") -> Study:
    """The :class:`~jointid.study.Study` of the virtual experiment for ``material``."""
    lay = config.layouts[layout]
    return config_study(
        config, config.joint_node, material, lay.observed, lay.excited,
        FrequencySpec(max(config.start, 5.0), config.stop, config.step), IdentificationSpec(model_accelerometers=True),
        accelerometers=AccelerometerSpec(config.accelerometer_mass, config.accelerometer_rotary_inertia, tuple(lay.observed)),
        experiment=ExperimentSpec(force_noise=config.experiment_noise, response_noise=config.experiment_noise, seed=config.seed,
                                  exponential_window=0.5),
        source=f"virtual experiment, Material {material}",
    )


def _material(config, mat: str) -> dict:
    """One material's virtual test, identification and figure (a task of :func:`parts`)."""
    from ..io.frf_files import read_frf
    from ..io.uff import write_uff_frf

    study = experiment_study(config, mat)
    ex = experiment(study, seed=config.seed, periodic=True)  # periodic: no leakage, no hysteretic precursor
    with tempfile.TemporaryDirectory() as tmp:  # the same path as real data: UFF58 out and back in
        path = write_uff_frf(Path(tmp) / "frf.uff", ex.frf, kind="accelerance", coherence=ex.coherence)
        measured = read_frf(path, n_nodes=study.beam.nodes, coherence=True)
    noisy = identify(study, measured)
    f = noisy.frequency
    exact_frf = synthesize_frf(constrained_model(study), f, study.measurement.observed_dofs, study.measurement.excited_dofs, kind="accelerance")
    exact = identify(study, exact_frf)
    truth = ex.truth
    e_noisy = band_errors(noisy.term("w", "w"), truth[:, 0, 0], f)
    e_exact = band_errors(exact.term("w", "w"), truth[:, 0, 0], f)
    rel = np.abs(noisy.term("w", "w") - truth[:, 0, 0]) / np.abs(truth[:, 0, 0])
    band = f.mask(100, 1000)
    p90 = float(np.percentile(rel[band], 90))
    figure = (
        f"experiment_material_{mat.lower()}",
        png(plot_terms(f.hz, {"true": terms_of(truth), "exact FRFs": terms_of(exact.stiffness), "roving hammer": terms_of(noisy.stiffness)},
                       title=f"Virtual roving-hammer experiment, Material {mat}")),
        f"Material {mat}: joint identified from the virtual roving-hammer test (H1, UFF58 round trip) and from exact FRFs; true joint dashed",
    )
    return {
        "hits": study.experiment.averages,
        "summary": [(f"Material {mat}, roving hammer ({100 * config.experiment_noise:g}% noise)", *e_noisy), (f"Material {mat}, exact FRFs", *e_exact)],
        "row": [f"Material {mat}", str(sum(ex.impact.n_averages)), str(len(ex.impact.rejected)), pct(float(np.mean(ex.coherence > 0.95))),
                pct(e_noisy[0]), pct(p90), fmt(e_noisy[1], 2), pct(e_exact[0])],
        "figure": figure,
        "data": {
            "frequency_hz": f.hz, "true_real": truth[:, 0, 0].real, "true_imag": truth[:, 0, 0].imag,
            "hammer_real": noisy.term("w", "w").real, "hammer_imag": noisy.term("w", "w").imag,
            "exact_real": exact.term("w", "w").real, "exact_imag": exact.term("w", "w").imag,
            "relative_error": rel, "coherence_min": ex.coherence.min(axis=(1, 2)),
        },
        "finding": (
            f"The virtual roving-hammer test of Material {mat} identifies the translational stiffness with a median error of "
            f"{100 * e_noisy[0]:.2g}% (90th percentile {100 * p90:.2g}%) over 100-1000 Hz, against {100 * e_exact[0]:.1g}% from exact FRFs."
        ),
    }


def _mode_part(config) -> tuple:
    """``(figure, text)`` of Material B's internal mode, the figure as PNG bytes, or ``(None, "")`` (a task of :func:`parts`)."""
    fig, text = _internal_mode_figure(config)
    return (None if fig is None else png(fig)), text


def _materials(config) -> list[str]:
    return [m for m in ("A", "B") if m in config.materials]


def parts(config) -> list:
    """The study's tasks for :func:`jointid.reproduce.runner.study_tasks`: one per material, one for the joint's mode shapes."""
    return [(_material, (config, mat), 7.0) for mat in _materials(config)] + [(_mode_part, (config,), 0.5)]


def combine(config, results) -> StudyOutput:
    """The study's output from the results of :func:`parts` (in their order)."""
    *materials, (shape_fig, shape_text) = results
    rows, summary, figures, data, findings = [], [], [], {}, []
    hits = None
    for mat, r in zip(_materials(config), materials):
        hits = r["hits"]
        summary += r["summary"]
        rows.append(r["row"])
        figures.append(r["figure"])
        data[f"experiment_material_{mat.lower()}"] = r["data"]
        findings.append(r["finding"])
    if shape_fig is not None:
        figures.append(("experiment_joint_mode_shapes", shape_fig, shape_text))
        findings.append(shape_text)
    table = Table(
        "Virtual roving-hammer experiment: translational stiffness error over 100-1000 Hz",
        ["joint", "hits used", "hits rejected", "lines with coherence > 0.95", "|K_ww| median error", "|K_ww| p90 error", "loss-factor error", "exact-FRF error"],
        rows,
    )
    return StudyOutput(
        name="experiment",
        title="Virtual roving-hammer experiment",
        paragraphs=(
            f"Each excited node is hit {hits} times with a half-sine pulse; force and response noise are "
            f"{100 * config.experiment_noise:g}% (force: of the peak; response: of the record rms). H1 with a force window and a "
            "corrected exponential window gives the accelerances, written to UFF58 with their coherence and read back before "
            "the identification, which models the accelerometers.",
            " ".join(findings),
        ),
        tables=(table,),
        data=data,
        figures=tuple(figures),
        summary=tuple(summary),
        findings=tuple(findings),
    )


def run(config, progress: Progress | None = None) -> StudyOutput:
    """Run the virtual-experiment study on ``config`` in this process."""
    progress = progress or Progress()
    todo = parts(config)
    progress.total(len(todo))
    results = []
    for fn, args, _ in todo:
        results.append(fn(*args))
        progress.update()
    return combine(config, results)


def _internal_mode_figure(config):
    """Figure of Material B's joint deformed shapes at its internal mode and at 150 Hz, or (None, '')."""
    if "B" not in config.materials:
        return None, ""
    from ..plots.direct import plot_deformed_shapes
    from .common import elastomer_joint

    joint = elastomer_joint(config, "B")
    modes = joint.modes(boundary="blocked", count=1)
    f_mode = float(modes.frequency_hz[0])
    fig = plot_deformed_shapes(joint, (150.0, round(f_mode)), title="Material B joint in the blocked test: deflection along the elastomer")
    text = (
        f"Material B's joint has its first blocked internal mode at {f_mode:.0f} Hz (c_s / 2L = {joint.shear_wave_frequency_hz():.0f} Hz): "
        "at 150 Hz the elastomer deflects almost linearly between the caps (quasi-static shear), at the mode it bulges in a half "
        "standing shear wave, so the transmitted force, and the stiffness the beam sees, peaks there."
    )
    return fig, text
