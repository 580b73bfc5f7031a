"""Methods: the inverse (Hong & Lee) and direct (step-sine) identifications and the test data behind them.

The main API, re-exported here (imported on first use)::

    from jointid.methods import InverseOptions, identify_joint, fit_material, process_stepsine

* robust inverse method (default) -- :mod:`.coupling`: ``identify_joint_coupling``,
  ``CouplingOptions``, ``CouplingResult``; :mod:`.coupling_lines`, :mod:`.frf_variance`,
  :mod:`.smoothing`;
* inverse method -- :mod:`.inverse`: ``identify_joint``, ``InverseOptions``,
  ``InverseResult``, ``Reliability``, ``check_layout``; :mod:`.condition`:
  ``pencil_condition``, ``ConditionNumbers``;
* direct method -- :mod:`.stepsine`: ``process_stepsine``, ``read_stepsine_csv``,
  ``write_stepsine_csv``, ``StepSineBlock``, ``StepSineResult``; :mod:`.stepsine_synth`:
  ``synthesize_stepsine``, ``example_stepsine``; :mod:`.joint_model`: ``ElastomerJoint``,
  ``ElastomerMaterial``, ``EndCap``, ``MATERIALS``; :mod:`.material_fit`: ``fit_material``,
  ``static_estimate``, ``complex_modulus_per_line``, ``fit_zener`` and their results;
  :mod:`.fit_statistics`: ``ParameterEstimate``;
* impact tests -- :mod:`.impact`: ``estimate_frfs``, ``estimate_frf``, ``ImpactRecord``,
  ``ImpactOptions``, ``ImpactFRF``, ``RejectedHit``; :mod:`.virtual_hammer`:
  ``simulate_hits``, ``HammerSettings``, ``ImpactHits``; :mod:`.sensor_correction`:
  ``roving_sensor_correction``;
* test design -- :mod:`.design`: ``design_layout``, ``LayoutDesign``, ``LayoutPredictor``, ``Sensors``
  (where to measure and hit, from the predicted covariance of the default method).
* free-structure model updating -- :mod:`.updating`: ``update_free_model``, ``UpdateOptions``,
  ``UpdateResult``.

This layer imports :mod:`jointid.physics` and the labels, never studies, report, plots
(except inside ``plot()`` methods) or the CLI.
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
        ".stepsine": ("process_stepsine", "read_stepsine_csv", "write_stepsine_csv", "StepSineBlock", "StepSineResult"),
        ".stepsine_synth": ("synthesize_stepsine", "example_stepsine"),
        ".joint_model": ("ElastomerJoint", "ElastomerMaterial", "EndCap", "JointModes", "MATERIALS"),
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
        ".impact": ("estimate_frfs", "estimate_frf", "ImpactRecord", "ImpactOptions", "ImpactFRF", "RejectedHit"),
        ".virtual_hammer": ("simulate_hits", "HammerSettings", "ImpactHits"),
        ".sensor_correction": ("roving_sensor_correction",),
        ".design": ("design_layout", "LayoutDesign", "LayoutPredictor", "Sensors"),
        ".updating": ("update_free_model", "UpdateOptions", "UpdateResult"),
    },
    submodules=(
        "coupling",
        "coupling_lines",
        "frf_variance",
        "smoothing",
        "inverse",
        "condition",
        "estimation",
        "stepsine",
        "stepsine_synth",
        "joint_model",
        "material_fit",
        "material_static",
        "modulus_per_line",
        "zener_fit",
        "fit_statistics",
        "impact",
        "impact_checks",
        "impact_records",
        "impact_windows",
        "virtual_hammer",
        "sensor_correction",
        "design",
        "updating",
    ),
)
