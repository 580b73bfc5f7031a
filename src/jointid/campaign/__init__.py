"""jointid.campaign: many tests, conditions and specimens in one run (``jointid campaign``).

The main API, re-exported here (imported on first use)::

    from jointid.campaign import run_campaign, read_manifest

* :mod:`.manifest` -- ``read_manifest``, ``Manifest``, ``CampaignTest`` (one row per test, validated);
* :mod:`.tasks` -- ``run_test``, ``TestTask``, ``TestOutcome``, ``ProcessingOptions`` (one test -> result);
* :mod:`.store` -- ``ResultStore``, ``task_key`` (resumable per-test results under ``DIR/.jointid-cache``);
* :mod:`.runner` -- ``execute_tasks`` (process pool or Dask cluster, progress);
* :mod:`.analysis` -- ``analyze_specimens`` (master curves, Kraus and preload fits per specimen);
* :mod:`.tables` -- ``results_table``, ``tests_table`` (pyarrow tables);
* :mod:`.report` -- ``campaign_report`` (the HTML page);
* :mod:`.driver` -- ``run_campaign``, ``CampaignOptions``, ``CampaignResult``.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".manifest": ("read_manifest", "Manifest", "CampaignTest"),
        ".tasks": ("run_test", "TestTask", "TestOutcome", "ProcessingOptions"),
        ".store": ("ResultStore", "task_key"),
        ".runner": ("execute_tasks",),
        ".analysis": ("analyze_specimens", "SpecimenAnalysis"),
        ".tables": ("results_table", "tests_table"),
        ".report": ("campaign_report",),
        ".driver": ("run_campaign", "CampaignOptions", "CampaignResult"),
    },
    submodules=("manifest", "tasks", "store", "runner", "analysis", "tables", "report", "driver"),
)
