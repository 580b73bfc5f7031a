"""Methods: estimators and fits, one subpackage per family.

The main API, re-exported here (imported on first use)::

    from jointid.methods import InverseOptions, identify_joint, fit_material

* :mod:`.receptance` -- the receptance-coupling estimator (default): ``identify_joint_coupling``,
  ``CouplingOptions``, ``CouplingResult``; per-line fits, FRF variance, column calibration, smoothing,
  the structured joint model;
* :mod:`.hong_lee` -- the paper's method: ``identify_joint``, ``InverseOptions``, ``InverseResult``,
  ``Reliability``; ``pencil_condition``, ``ConditionNumbers``;
* :mod:`.direct` -- fits of direct-test data: ``fit_material``, ``static_estimate``,
  ``complex_modulus_per_line``, ``fit_zener``; ``build_master_curve``, ``fit_wlf``, ``fit_arrhenius``;
  ``fit_kraus``, ``fit_kraus_loss``, ``fit_preload``;
* :mod:`.updating` -- free-model updating: ``update_free_model``, ``UpdateOptions``, ``UpdateResult``,
  ``ModelFamily``, ``ScaledMatrixFamily``;
* :mod:`.design` -- test design: ``design_layout``, ``LayoutDesign``, ``LayoutPredictor``, ``Sensors``;
* shared by the families: :mod:`.estimate` (``JointEstimate``, the one result of every inverse
  estimator, and the estimator registry), :mod:`.frf_screening` (dead data, invisible DOFs),
  :mod:`.fit_statistics` (``ParameterEstimate``), :mod:`.levenberg_marquardt` (``levenberg_marquardt``: MINPACK's
  steps on the normal equations, for least squares of many rows and few parameters), :mod:`.bspline_basis` (the B-spline design
  matrices of the smoothers and the structured model, without importing ``scipy.interpolate``),
  :mod:`.moving_average` (``scipy.ndimage.uniform_filter1d``'s average over lines, without importing ``scipy.ndimage``).

This layer imports :mod:`jointid.measurement`, :mod:`jointid.physics` and the labels, never
the application (study, pipeline, reproduce, report, plots except inside ``plot()`` methods) or
the CLI (checked by ``tests/test_layers.py``).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".receptance.coupling": ("identify_joint_coupling",),
        ".receptance.options": ("CouplingOptions",),
        ".receptance.coupling_result": ("CouplingResult",),
        ".receptance.coupling_lines": ("coupling_per_line", "LineEstimates"),
        ".receptance.smoothing": ("smooth_series", "SmoothedSeries"),
        ".hong_lee.inverse": ("identify_joint", "InverseOptions", "InverseResult", "Reliability"),
        ".hong_lee.condition": ("pencil_condition", "ConditionNumbers"),
        ".direct.material_fit": (
            "fit_material", "MaterialFit", "static_estimate", "StaticEstimate",
            "complex_modulus_per_line", "ComplexModulus", "fit_zener", "ZenerFit",
        ),
        ".fit_statistics": ("ParameterEstimate",),
        ".estimate": ("JointEstimate", "estimate_joint", "ESTIMATORS", "check_layout"),
        ".design.layout": ("design_layout", "LayoutDesign", "LayoutPredictor", "Sensors"),
        ".updating.fit": ("update_free_model", "UpdateOptions", "UpdateResult", "ModelFamily"),
        ".updating.scaled_matrices": ("ScaledMatrixFamily",),
        ".direct.master_curve": ("build_master_curve", "MasterCurve", "TemperatureCurve"),
        ".direct.shift_laws": ("fit_wlf", "fit_arrhenius", "WLFFit", "ArrheniusFit"),
        ".direct.amplitude_dependence": ("fit_kraus", "KrausFit", "fit_kraus_loss", "KrausLossFit", "fit_preload", "PreloadFit"),
    },
    submodules=("receptance", "hong_lee", "direct", "updating", "design", "estimate", "frf_screening", "fit_statistics"),
)
