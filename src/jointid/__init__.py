"""jointid: identify the frequency-dependent dynamic stiffness of elastomeric joints.

The public face: the main classes and functions of every layer, re-exported here and
imported on first use (``import jointid`` itself loads neither numpy nor matplotlib)::

    import jointid

    study = jointid.benchmark_study()              # or jointid.load_study("study.toml")
    test = jointid.simulate(study)                 # exact FRFs of the study's [joint.model]
    result = jointid.identify(study, test.frf)     # InverseResult: 2x2 K per line
    result.term("w", "w")

Layers, bottom-up (a lower one never imports a higher one): labels and axes
(:class:`Dof`, :class:`Frequency`, :class:`FRF`, errors) -> :mod:`jointid.physics` ->
:mod:`jointid.measurement` -> :mod:`jointid.methods` -> :mod:`jointid.reproduce` and :mod:`jointid.report` ->
:mod:`jointid.cli`; :mod:`jointid.io` holds the file formats of those objects,
:mod:`jointid.plots` their figures, and ``study``, ``pipeline``, ``hits`` translate study
and hit files into API calls. Each subpackage re-exports its own main API the same way;
the subpackages are reachable as attributes (``jointid.physics.natural_modes``).
"""

from ._lazy import attach

__version__ = "0.1.0"

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        # labels, axes, errors
        ".dofs": ("Dof", "parse_dof", "parse_dofs"),
        ".frequency": ("Frequency",),
        ".frf": ("FRF",),
        ".errors": (
            "JointIdError",
            "ModelError",
            "FrequencyError",
            "DofError",
            "StudyError",
            "DataError",
            "IdentificationError",
        ),
        # physics
        ".physics.structure": ("Structure", "ComplexStiffness", "build_beam"),
        ".physics.joints": ("parametric_joint",),
        ".physics.modes": ("Modes", "natural_modes"),
        ".physics.synthesis": ("synthesize_frf",),
        ".physics.elastomer_joint": ("ElastomerJoint",),
        ".physics.elastomer_material": ("ElastomerMaterial", "MATERIALS"),
        # measurement: impact and step-sine test processing, virtual tests
        ".measurement.stepsine": ("process_stepsine", "read_stepsine_csv", "StepSineResult"),
        ".measurement.stepsine_synth": ("synthesize_stepsine", "example_stepsine"),
        ".measurement.campaign_synth": ("synthesize_campaign", "CampaignTruth"),
        ".measurement.impact": ("estimate_frfs", "ImpactRecord", "ImpactOptions", "ImpactFRF"),
        ".measurement.virtual_hammer": ("simulate_hits", "HammerSettings"),
        # methods: inverse, direct
        ".methods.hong_lee.inverse": ("identify_joint", "InverseOptions", "InverseResult"),
        ".methods.receptance.coupling": ("identify_joint_coupling",),
        ".methods.receptance.options": ("CouplingOptions",),
        ".methods.receptance.coupling_result": ("CouplingResult",),
        ".methods.direct.material_fit": ("fit_material", "MaterialFit", "static_estimate", "fit_zener"),
        ".methods.direct.master_curve": ("build_master_curve", "MasterCurve", "TemperatureCurve"),
        ".methods.direct.amplitude_dependence": ("fit_kraus", "KrausFit"),
        # files
        ".io.frf_files": ("read_frf", "write_frf"),
        ".io.output_dir": ("OutputSet",),
        # study files, the built-in benchmark, study -> API, hit files -> FRFs
        ".study": ("Study", "load_study", "parse_study"),
        ".benchmark": ("benchmark_study", "benchmark_study_path"),
        ".pipeline": ("simulate", "identify", "experiment", "VirtualTest", "free_model", "true_joint"),
        ".hits": ("frf_from_hits", "read_hits", "HitsFRF"),
        # the reproduce studies
        ".reproduce.runner": ("run_reproduce",),
        ".reproduce.config": ("load_config",),
        # test campaigns: many tests in one run
        ".campaign.driver": ("run_campaign", "CampaignOptions"),
        ".campaign.manifest": ("read_manifest",),
    },
    submodules=(
        "physics",
        "measurement",
        "methods",
        "io",
        "plots",
        "reproduce",
        "campaign",
        "report",
        "cli",
        "dofs",
        "frequency",
        "frf",
        "errors",
        "study",
        "benchmark",
        "pipeline",
        "hits",
        "parallel",
    ),
)
