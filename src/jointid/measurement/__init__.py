"""Measurement: test signal processing and the virtual tests that simulate it.

The main API, re-exported here (imported on first use)::

    from jointid.measurement import estimate_frfs, ImpactRecord, process_stepsine, simulate_hits

* impact tests -- :mod:`.impact`: ``estimate_frfs``, ``estimate_frf``, ``check_hits``,
  ``rejected_hits_table`` (hammer and response time histories to H1/H2 and coherence);
  :mod:`.impact_records`: ``ImpactRecord``, ``ImpactOptions``; :mod:`.impact_files`: ``read_impact_npz``/``csv``/``uff``
  and their writers (the hit records' files); :mod:`.impact_checks`:
  ``RejectedHit`` (double hits, overloads); :mod:`.impact_windows` (force and exponential
  windows); :mod:`.sensor_correction`: ``roving_sensor_correction``;
* virtual impact test -- :mod:`.virtual_hammer`: ``simulate_hits``, ``HammerSettings``,
  ``ImpactHits`` (hammer hits on an FE structure, sampled exactly);
* step-sine (direct) test -- :mod:`.stepsine`: ``process_stepsine``, ``read_stepsine_csv``,
  ``write_stepsine_csv``, ``StepSineBlock``, ``StepSineResult`` (time histories to K21(f));
  :mod:`.stepsine_synth`: ``synthesize_stepsine``, ``example_stepsine`` (virtual test);
* synthetic campaign -- :mod:`.campaign_synth`: ``synthesize_campaign``, ``CampaignTruth``
  (step-sine tests over temperature, amplitude and specimen with a known Zener/WLF/Kraus
  truth, and their manifest).

This layer imports the labels and axes (:mod:`jointid.dofs`, :mod:`jointid.frequency`,
:mod:`jointid.frf`, :mod:`jointid.errors`), the file helpers of :mod:`jointid.io` and
:mod:`jointid.physics`; never :mod:`jointid.methods` or anything above
(checked by ``tests/test_layers.py``).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".impact": ("estimate_frfs", "estimate_frf", "ImpactFRF", "check_hits", "rejected_hits_table"),
        ".impact_records": ("ImpactRecord", "ImpactOptions"),
        ".impact_files": ("read_impact_npz", "write_impact_npz", "read_impact_csv", "write_impact_csv", "read_impact_uff", "write_impact_uff"),
        ".impact_checks": ("RejectedHit",),
        ".impact_windows": ("exponential_window", "force_window", "correct_exponential_window"),
        ".sensor_correction": ("roving_sensor_correction",),
        ".virtual_hammer": ("simulate_hits", "HammerSettings", "ImpactHits"),
        ".stepsine": ("process_stepsine", "read_stepsine_csv", "write_stepsine_csv", "StepSineBlock", "StepSineResult"),
        ".stepsine_synth": ("synthesize_stepsine", "example_stepsine"),
        ".campaign_synth": ("synthesize_campaign", "CampaignTruth"),
    },
    submodules=(
        "impact",
        "impact_checks",
        "impact_records",
        "impact_files",
        "impact_windows",
        "sensor_correction",
        "virtual_hammer",
        "stepsine",
        "stepsine_synth",
        "campaign_synth",
    ),
)
