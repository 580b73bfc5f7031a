"""Test design: where to measure and hit, from the predicted covariance of the default estimator.

* :mod:`.layout` -- ``design_layout``, ``LayoutDesign``, ``Sensors``;
* :mod:`.predictor` -- ``LayoutPredictor`` (+ :mod:`.estimator`, :mod:`.check`, :mod:`.pool`);
* :mod:`.term_goals` -- per-term weights and accuracy targets.
"""

from ..._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {".layout": ("design_layout", "LayoutDesign", "LayoutPredictor", "Sensors"),
     ".term_goals": ("term_weights", "term_targets", "target_report")},
    submodules=("layout", "predictor", "estimator", "check", "pool", "term_goals"),
)
