"""jointid.plots: matplotlib figures (they take and return Figure objects; no pyplot state).

The main API, re-exported here (matplotlib is imported on first use, not by ``import jointid``)::

    from jointid.plots import plot_frf, plot_identification

* :mod:`.frf` -- ``plot_frf``; :mod:`.impact` -- ``plot_impact_frf``;
* :mod:`.inverse` -- ``plot_identification`` (also ``InverseResult.plot()``);
* :mod:`.direct` -- ``plot_direct_stiffness``, ``plot_deformed_shapes``;
* :mod:`.studies` -- ``plot_terms``, ``plot_conditions``;
* :mod:`.design` -- ``plot_layout_design`` (also ``LayoutDesign.plot()``);
* :mod:`.noise_robustness` -- ``plot_band_examples``, ``plot_error_vs_noise``;
* :mod:`.style` -- ``new_figure``, ``save_figure``.
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
        ".style": ("new_figure", "save_figure"),
    },
    submodules=("frf", "impact", "inverse", "joint_stiffness", "direct", "studies", "design", "noise_robustness", "style"),
)
