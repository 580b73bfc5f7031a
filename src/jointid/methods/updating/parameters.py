"""The names of the parameters model updating can fit, and their check (pure Python: no numpy, no scipy).

One place for the names the command line lists in ``jointid update --help`` and
validates in ``--parameters`` before anything heavy is imported, and that
:mod:`jointid.methods.updating.fit` fits. Each entry: name -> (unit, bounds as ratios
of the initial value, label).
"""

from __future__ import annotations

from typing import Mapping, Sequence

from ...errors import ModelError

__all__ = [
    "PARAMETERS", "DEFAULT_PARAMETERS", "STRUCTURE_PARAMETERS", "DEFAULT_STRUCTURE_PARAMETERS",
    "DEFAULT_MAX_EVALUATIONS", "check_parameter_names",
]

#: Parameters of a beam that can be updated: name -> (unit, bounds as ratios of the initial value, label).
PARAMETERS: dict[str, tuple[str, tuple[float, float], str]] = {
    "elastic_modulus": ("Pa", (0.2, 5.0), "E"),
    "density": ("kg/m^3", (0.2, 5.0), "density"),
    "loss_factor": ("-", (0.01, 100.0), "loss factor"),
    "shear_coefficient": ("-", (0.2, 5.0), "shear coefficient"),
    "accelerometers.mass": ("kg", (0.1, 10.0), "accelerometer mass"),
    "accelerometers.rotary_inertia": ("kg*m^2", (0.01, 100.0), "accelerometer rotary inertia"),
}
#: What ``jointid update`` fits by default.
DEFAULT_PARAMETERS = ("elastic_modulus", "density", "loss_factor")
#: Parameters of a free structure given by matrices (``[structure]`` study): ``alpha K (1 + j eta) - w^2 beta M``
#: (see :mod:`jointid.methods.updating.scaled_matrices`).
STRUCTURE_PARAMETERS: dict[str, tuple[str, tuple[float, float], str]] = {
    "stiffness_scale": ("-", (0.2, 5.0), "stiffness scale"),
    "mass_scale": ("-", (0.2, 5.0), "mass scale"),
    "loss_factor": ("-", (0.01, 100.0), "loss factor"),
}
#: What ``jointid update`` fits by default on a ``[structure]`` study.
DEFAULT_STRUCTURE_PARAMETERS = ("stiffness_scale", "mass_scale", "loss_factor")
#: Model evaluations allowed to the least-squares fit by default (``UpdateOptions.max_evaluations``).
DEFAULT_MAX_EVALUATIONS = 100


def check_parameter_names(names: Sequence[str], prefix: str = "", known: Mapping[str, object] | None = None) -> None:
    """Raise :class:`ModelError` (one line, starting with ``prefix``) for no, an unknown or a repeated name.

    ``known``: the names allowed (default :data:`PARAMETERS`, the beam's; :data:`STRUCTURE_PARAMETERS` for a structure).
    """
    known = PARAMETERS if known is None else known
    listed = ", ".join(known)
    if not names:
        raise ModelError(f"{prefix}give at least one of {listed}")
    for n in names:
        if n not in known:
            raise ModelError(f"{prefix}unknown parameter {n!r}; expected any of {listed}")
    if len(set(names)) != len(names):
        raise ModelError(f"{prefix}{', '.join(names)!r} names a parameter twice")
