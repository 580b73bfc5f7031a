"""jointid.plots: matplotlib figures (they take and return Figure objects; no pyplot state).

The main API, re-exported here (matplotlib is imported on first use, not by ``import jointid``)::

    from jointid.plots import plot_frf, plot_identification

* :mod:`.frf` -- ``plot_frf``; :mod:`.impact` -- ``plot_impact_frf``;
* :mod:`.inverse` -- ``plot_identification`` (also ``InverseResult.plot()``);
* :mod:`.direct` -- ``plot_direct_stiffness``, ``plot_deformed_shapes``;
* :mod:`.studies` -- ``plot_terms``, ``plot_conditions``;
* :mod:`.design` -- ``plot_layout_design`` (also ``LayoutDesign.plot()``);
* :mod:`.noise_robustness` -- ``plot_band_examples``, ``plot_error_vs_noise``;
* :mod:`.joint_stiffness` -- ``plot_joint_stiffness`` (also ``CouplingResult.plot()``);
* :mod:`.nvh_axes` -- log frequency axes, ``|K|`` bands, loss factor or phase, robust limits;
* :mod:`.style` -- ``new_figure``, ``save_figure``, ``figure_png``.
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
        ".nvh_axes": ("set_frequency_axis", "loss_or_phase", "magnitude_band"),
        ".style": ("new_figure", "save_figure", "figure_png"),
    },
    submodules=("frf", "impact", "inverse", "joint_stiffness", "nvh_axes", "direct", "studies", "design", "noise_robustness", "style"),
)
