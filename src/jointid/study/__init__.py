"""Study files: a study's TOML text validated once, at the door, into frozen section dataclasses.

* :mod:`.parse` -- ``load_study``, ``parse_study`` (every key, unit and physical bound checked);
* :mod:`.sections` -- ``Study`` and its sections (``BeamSpec``, ``MeasurementSpec``, ...);
* :mod:`.structures` -- the free structures a study can name (``[beam]``, ``[structure]`` matrix files)
  and its ``[[joint]]`` list;
* :mod:`.edit` -- writing values into a study's text (``jointid update --write``).
"""

from .parse import MAX_AVERAGES, MAX_LINES, MAX_NODES, MAX_RECORD_SAMPLES, load_study, parse_study
from .sections import (
    AccelerometerSpec, BeamSpec, ExperimentSpec, FrequencySpec, IdentificationSpec, JointModelSpec, JointSpec,
    MeasurementSpec, Study, TruthSpec, UncertaintySpec,
)
from .structures import MatrixStructureSpec

__all__ = [
    "Study", "BeamSpec", "MatrixStructureSpec", "JointSpec", "JointModelSpec", "MeasurementSpec", "AccelerometerSpec",
    "IdentificationSpec", "FrequencySpec", "ExperimentSpec", "TruthSpec", "UncertaintySpec",
    "load_study", "parse_study", "MAX_NODES", "MAX_LINES", "MAX_RECORD_SAMPLES", "MAX_AVERAGES",
]
