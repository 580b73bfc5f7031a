"""Methods: the inverse (Hong & Lee) and direct (material fit) identifications, model updating and test design.

The main API, re-exported here (imported on first use)::

    from jointid.methods import InverseOptions, identify_joint, fit_material

* robust inverse method (default) -- :mod:`.coupling`: ``identify_joint_coupling``,
  ``CouplingOptions``, ``CouplingResult``; :mod:`.coupling_lines`, :mod:`.frf_variance`,
  :mod:`.smoothing`;
* inverse method -- :mod:`.inverse`: ``identify_joint``, ``InverseOptions``,
  ``InverseResult``, ``Reliability``, ``check_layout``; :mod:`.condition`:
  ``pencil_condition``, ``ConditionNumbers``;
* direct method -- :mod:`.material_fit`: ``fit_material``,
  ``static_estimate``, ``complex_modulus_per_line``, ``fit_zener`` and their results;
  :mod:`.fit_statistics`: ``ParameterEstimate``;
* test design -- :mod:`.design`: ``design_layout``, ``LayoutDesign``, ``LayoutPredictor``, ``Sensors``
  (where to measure and hit, from the predicted covariance of the default method).
* test campaigns -- :mod:`.master_curve`: ``build_master_curve``, ``MasterCurve``, ``TemperatureCurve``
  (time-temperature superposition); :mod:`.shift_laws`: ``fit_wlf``, ``fit_arrhenius``;
  :mod:`.shift_estimation` (shift between two curves); :mod:`.amplitude_dependence`: ``fit_kraus``,
  ``fit_kraus_loss``, ``fit_preload`` (Payne effect, preload);
* free-structure model updating -- :mod:`.updating`: ``update_free_model``, ``UpdateOptions``,
  ``UpdateResult``, ``ModelFamily``; :mod:`.updating_structure`: ``ScaledMatrixFamily`` (stiffness and
  mass scales and loss factor of a structure's matrices).

The test data these methods take (impact-test FRFs, step-sine K21, the virtual tests) come
from :mod:`jointid.measurement`; the elastomer joint's FE model is
:mod:`jointid.physics.elastomer_joint`.

This layer imports :mod:`jointid.measurement`, :mod:`jointid.physics` and the labels, never
studies, report, plots (except inside ``plot()`` methods) or the CLI (checked by
``tests/test_layers.py``).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".coupling": ("identify_joint_coupling", "CouplingOptions", "CouplingResult"),
        ".coupling_lines": ("coupling_per_line", "LineEstimates"),
        ".smoothing": ("smooth_series", "SmoothedSeries"),
        ".inverse": ("identify_joint", "InverseOptions", "InverseResult", "Reliability", "check_layout"),
        ".condition": ("pencil_condition", "ConditionNumbers"),
        ".material_fit": (
            "fit_material",
            "MaterialFit",
            "static_estimate",
            "StaticEstimate",
            "complex_modulus_per_line",
            "ComplexModulus",
            "fit_zener",
            "ZenerFit",
        ),
        ".fit_statistics": ("ParameterEstimate",),
        ".design": ("design_layout", "LayoutDesign", "LayoutPredictor", "Sensors"),
        ".updating": ("update_free_model", "UpdateOptions", "UpdateResult", "ModelFamily"),
        ".updating_structure": ("ScaledMatrixFamily",),
        ".master_curve": ("build_master_curve", "MasterCurve", "TemperatureCurve"),
        ".shift_laws": ("fit_wlf", "fit_arrhenius", "WLFFit", "ArrheniusFit"),
        ".amplitude_dependence": ("fit_kraus", "KrausFit", "fit_kraus_loss", "KrausLossFit", "fit_preload", "PreloadFit"),
    },
    submodules=(
        "coupling",
        "coupling_lines",
        "frf_variance",
        "smoothing",
        "inverse",
        "condition",
        "estimation",
        "material_fit",
        "material_static",
        "modulus_per_line",
        "zener_fit",
        "fit_statistics",
        "design",
        "updating",
        "updating_structure",
        "master_curve",
        "master_zener",
        "shift_laws",
        "shift_estimation",
        "amplitude_dependence",
    ),
)
