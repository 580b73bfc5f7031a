"""Study 5 -- accelerometer mass loading.

The free-free driving-point receptance with one accelerometer (at the driving
point) and with seven (Model 3's observed nodes), each with mass and rotary
inertia; and the identification of the joint from FRFs of the loaded beam with
and without the accelerometers in the free-beam model.
"""

from __future__ import annotations

import numpy as np

from ..methods.hong_lee.inverse import identify_joint
from ..physics.modes import natural_modes
from ..physics.synthesis import synthesize_frf
from ..plots.studies import plot_terms
from ..report.html import Table
from .common import Progress, StudyOutput, band_errors, fmt, material_joint, pct, study_beam, terms_of

__all__ = ["run"]

#: About the CPU seconds of :func:`run` on the benchmark (``jointid reproduce`` starts the longest studies first).
COST = 3.0


def run(config, progress: Progress | None = None, layout: str = "model_3") -> StudyOutput:
    """Run the accelerometer-mass study on ``config``."""
    progress = progress or Progress()
    progress.total(4)
    f = config.grid
    lay = config.layouts[layout]
    ma, ja = config.accelerometer_mass, config.accelerometer_rotary_inertia
    beam = study_beam(config)
    drive = lay.excited[0]
    one = beam.with_masses([drive], ma, ja)
    seven = beam.with_masses(lay.observed, ma, ja)
    dp = [f"{drive}w"]
    h1 = synthesize_frf(one, f, dp, dp)
    h7 = synthesize_frf(seven, f, dp, dp)
    progress.update()
    modes = {label: natural_modes(s).frequencies_hz for label, s in (("none", beam), ("1", one), ("7", seven))}
    elastic = {k: v[v > 1e-3][:5] for k, v in modes.items()}
    diff_db = 20 * np.log10(np.abs(h7.data[:, 0, 0]) / np.abs(h1.data[:, 0, 0]))

    joint = material_joint(config, "A")
    truth = terms_of(joint(f.hz))
    frf = synthesize_frf(seven.with_joint(joint), f, [f"{n}w" for n in lay.observed], [f"{n}w" for n in lay.excited], kind="accelerance")
    without = identify_joint(beam, frf, config.joint_dofs)
    progress.update()
    with_ = identify_joint(seven, frf, config.joint_dofs)
    progress.update()
    e_without = band_errors(without.term("w", "w"), truth["translational"], f)
    e_with = band_errors(with_.term("w", "w"), truth["translational"], f)

    fig_h = _receptance_figure(f.hz, h1.data[:, 0, 0], h7.data[:, 0, 0], diff_db, drive, len(lay.observed), ma, ja)
    fig_k = plot_terms(
        f.hz,
        {"true": truth, "masses not in model": terms_of(without.stiffness), "masses in model": terms_of(with_.stiffness)},
        title=f"Identification from the beam loaded by {len(lay.observed)} accelerometers",
    )
    progress.update()
    table_f = Table(
        f"Free-free natural frequencies (Hz) with accelerometers of {1e3 * ma:g} g and {ja:g} kg*m^2",
        ["mode", "no sensor", f"1 sensor (node {drive})", f"{len(lay.observed)} sensors", "shift 1 -> 7"],
        [[str(i + 1), fmt(a, 5), fmt(b, 5), fmt(c, 5), f"{100 * (c / b - 1):.2f} %"]
         for i, (a, b, c) in enumerate(zip(elastic["none"], elastic["1"], elastic["7"]))],
    )
    table_e = Table(
        "Translational stiffness error over 100-1000 Hz (medians)",
        ["free-beam model", "|K_ww| error", "loss-factor error"],
        [["accelerometers not modelled", pct(e_without[0]), fmt(e_without[1], 2)], ["accelerometers modelled", pct(e_with[0]), fmt(e_with[1], 2)]],
    )
    shift = 100 * (elastic["7"][0] / elastic["1"][0] - 1)
    findings = (
        f"Seven {1e3 * ma:g} g accelerometers lower the first free-free mode by {abs(shift):.2g}% against one; left out of the "
        f"free-beam model they raise the median translational-stiffness error to {100 * e_without[0]:.3g}%, modelled it is "
        f"{100 * e_with[0]:.2g}%.",
    )
    return StudyOutput(
        name="accelerometers",
        title="Accelerometer mass loading",
        paragraphs=(
            f"Accelerometers of {1e3 * ma:g} g with rotary inertia {ja:g} kg*m^2: one at the driving point (node {drive}) against "
            f"seven at the {lay.name} observed nodes. The loaded constrained beam (Material A joint) is then identified with "
            "and without the sensors in the free-beam model Do.",
            findings[0],
        ),
        tables=(table_f, table_e),
        data={
            "accelerometers_receptance": {
                "frequency_hz": f.hz, "one_real": h1.data[:, 0, 0].real, "one_imag": h1.data[:, 0, 0].imag,
                "seven_real": h7.data[:, 0, 0].real, "seven_imag": h7.data[:, 0, 0].imag, "difference_db": diff_db,
            },
            "accelerometers_identification": {
                "frequency_hz": f.hz,
                "true_real": truth["translational"].real, "true_imag": truth["translational"].imag,
                "without_real": without.term("w", "w").real, "without_imag": without.term("w", "w").imag,
                "with_real": with_.term("w", "w").real, "with_imag": with_.term("w", "w").imag,
            },
        },
        figures=(
            ("accelerometers_receptance", fig_h, "Free-free driving-point receptance with 1 and 7 accelerometers, and their difference"),
            ("accelerometers_identification", fig_k, "Identified joint terms with and without the accelerometer masses in the model; true joint dashed"),
        ),
        summary=(("accelerometers not modelled", *e_without), ("accelerometers modelled", *e_with)),
        findings=findings,
    )


def _receptance_figure(f, h1, h7, diff_db, drive, n7, ma, ja):
    from ..plots.style import new_figure

    fig, (ax, ax_d) = new_figure(2, 1, height_ratios=[2, 1], figsize=(8.5, 6.5))
    ax.semilogy(f, np.abs(h1), lw=1.0, label=f"1 accelerometer (node {drive})")
    ax.semilogy(f, np.abs(h7), lw=1.0, label=f"{n7} accelerometers")
    ax.set_ylabel(f"|H_{drive}w,{drive}w| [m/N]")
    ax.set_title(f"Free-free driving-point receptance, sensors {1e3 * ma:g} g, {ja:g} kg*m^2")
    ax.legend(fontsize="small")
    ax_d.plot(f, diff_db, lw=1.0, color="C3")
    ax_d.set_ylabel("|H7| / |H1| [dB]")
    ax_d.set_xlabel("frequency [Hz]")
    for a in (ax, ax_d):
        a.grid(True, which="both", alpha=0.3)
    return fig
