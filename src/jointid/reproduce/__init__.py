"""jointid.reproduce: the comparative studies of ``jointid reproduce``, one module per study.

The main API, re-exported here (imported on first use)::

    from jointid.reproduce import load_config, run_reproduce
    run_reproduce(load_config(None), "results", only=["verification"])

* :mod:`.runner` -- ``run_reproduce``, ``ReproduceResult``, ``StudyFailed``, ``parse_only``;
* :mod:`.config` -- ``load_config``, ``ReproduceConfig``, ``STUDY_NAMES``;
* :mod:`.common` -- ``StudyOutput``, ``Progress`` (what each study's ``run(config, progress)`` returns and reports).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".runner": ("run_reproduce", "ReproduceResult", "StudyFailed", "parse_only"),
        ".config": ("load_config", "ReproduceConfig", "STUDY_NAMES"),
        ".common": ("StudyOutput", "Progress"),
    },
    submodules=(
        "runner",
        "config",
        "common",
        "direct_characterization",
        "conditioning",
        "verification",
        "model_error",
        "accelerometers",
        "virtual_experiment",
        "noise_robustness",
        "real_world",
    ),
)
