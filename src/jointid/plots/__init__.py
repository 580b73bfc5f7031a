"""jointid.plots: matplotlib figures (they take and return Figure objects; no pyplot state).

The main API, re-exported here (matplotlib is imported on first use, not by ``import jointid``)::

    from jointid.plots import plot_frf, plot_identification

* :mod:`.frf` -- ``plot_frf``; :mod:`.impact` -- ``plot_impact_frf``;
* :mod:`.inverse` -- ``plot_identification`` (also ``InverseResult.plot()``);
* :mod:`.direct` -- ``plot_direct_stiffness``, ``plot_deformed_shapes``;
* :mod:`.studies` -- ``plot_terms``, ``plot_conditions``;
* :mod:`.design` -- ``plot_layout_design`` (also ``LayoutDesign.plot()``);
* :mod:`.noise_robustness` -- ``plot_band_examples``, ``plot_error_vs_noise``;
* :mod:`.real_world` -- ``plot_case_terms`` (the real-world study);
* :mod:`.joint_stiffness` -- ``plot_joint_stiffness`` (also ``CouplingResult.plot()``);
* :mod:`.campaign` -- temperature curves, master curve, shift factors, amplitude and preload dependence;
* :mod:`.nvh_axes` -- log frequency axes, ``|K|`` bands, loss factor or phase, robust limits;
* :mod:`.style` -- ``new_figure``, ``save_figure`` (PNG bytes: :func:`jointid.io.png.figure_png`).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".frf": ("plot_frf",),
        ".impact": ("plot_impact_frf",),
        ".inverse": ("plot_identification",),
        ".joint_stiffness": ("plot_joint_stiffness",),
        ".direct": ("plot_direct_stiffness", "plot_deformed_shapes"),
        ".studies": ("plot_terms", "plot_conditions"),
        ".design": ("plot_layout_design",),
        ".noise_robustness": ("plot_band_examples", "plot_error_vs_noise"),
        ".real_world": ("plot_case_terms",),
        ".campaign": ("plot_temperature_curves", "plot_master_fit", "plot_shift_factors", "plot_amplitude_dependence",
                      "plot_preload_dependence"),
        ".nvh_axes": ("set_frequency_axis", "loss_or_phase", "magnitude_band"),
        ".style": ("new_figure", "save_figure"),
    },
    submodules=("frf", "campaign", "impact", "inverse", "joint_stiffness", "nvh_axes", "direct", "studies", "design", "noise_robustness", "real_world", "style"),
)
