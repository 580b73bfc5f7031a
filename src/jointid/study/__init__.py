"""Study files: a study's TOML text validated once, at the door, into frozen section dataclasses.

* :mod:`.parse` -- ``load_study``, ``parse_study`` (every key, unit and physical bound checked);
* :mod:`.sections` -- ``Study`` and its sections (``BeamSpec``, ``MeasurementSpec``, ...);
* :mod:`.structures` -- the free structures a study can name (``[beam]``, ``[structure]`` matrix files)
  and its ``[[joint]]`` list;
* :mod:`.edit` -- writing values into a study's text (``jointid update --write``).
"""

from .parse import *  # noqa: F401,F403 - the public face of study files
from .parse import __all__  # noqa: F401
