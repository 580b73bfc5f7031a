"""The units check: FRFs scaled by one factor in every excitation column are refused, naming the likely units.

The column calibration (:mod:`jointid.methods.receptance.column_calibration`) estimates
each excitation column's relative error ``eps_j(f)`` (measured = true ``(1 + eps_j)``)
jointly with the joint. Its per-column level ``s_j = median_f |1 + eps_j(f)|`` is the
factor the column's FRFs are off by. A force-channel error differs between columns
(hits, angles, noise) and is small; FRFs read in the wrong units are off by the *same*
factor in every column, usually a unit factor::

    9.80665 (g vs m/s^2), 1000 (mm vs m), 4.44822 (lbf vs N), 0.0254 (in vs m), ...

When the columns agree within :data:`UNITS_COMMON_SPREAD` and their common factor ``s``
is beyond :data:`UNITS_MAX_FACTOR` (or below its inverse), or when they do not agree but
every one is beyond :data:`UNITS_GROSS_FACTOR` on the same side (e.g. 1000-1300 x: a free model with a
dimension in mm typed as m scales the predicted FRFs column by column differently), the FRFs are not identified
as they are: :func:`units_conclusion` states one conclusion, naming the unit factor
``s`` is within :data:`UNITS_MATCH` of when there is one. The joint's terms from such
data would only be as good as a correction of a gross error that the F test cannot tell
from a wrong joint (the calibration absorbs part of the joint's effect), so the
receptance method refuses them (:class:`~jointid.errors.DataError`) unless the user asks
to use them as they are (``CouplingOptions.units_check = False``: a finding, and every
term flagged unreliable).
"""

from __future__ import annotations

import numpy as np

from .column_calibration import ColumnCalibration

__all__ = ["UNIT_FACTORS", "UNITS_MAX_FACTOR", "UNITS_COMMON_SPREAD", "UNITS_GROSS_FACTOR", "UNITS_MATCH", "column_factors", "units_conclusion"]

#: A factor common to every column beyond this (or below 1 / this) is a units problem, not force noise.
UNITS_MAX_FACTOR = 1.5
#: The columns share one factor when their largest and smallest factors are within this ratio.
UNITS_COMMON_SPREAD = 1.2
#: Columns off by different factors, every one beyond this (or below 1 / this): not a force calibration error to correct
#: (a hammer's sensitivity wrong by 1.6-2x per column is corrected; a free model 1000x off is not).
UNITS_GROSS_FACTOR = 5.0
#: A common factor within this ratio of a unit factor is named as that unit.
UNITS_MATCH = 1.1
_G = 9.80665
_LBF = 4.4482216152605
_IN = 0.0254
#: (measured / true factor, what it looks like).
UNIT_FACTORS = (
    (1.0 / _G, "1/9.81", "g/N read as m/s^2/N?"),
    (_G, "9.81", "values in m/s^2/N labelled g, or converted from g twice?"),
    (1e3, "1000", "mm/s^2/N (or mm/N) read as m/s^2/N?"),
    (1e-3, "1/1000", "values in m/s^2/N labelled mm, or per kN read as per N?"),
    (_LBF, "4.45", "per lbf read as per N?"),
    (1.0 / _LBF, "1/4.45", "values per N labelled lbf?"),
    (1.0 / _IN, "39.4", "in/s^2/N read as m/s^2/N?"),
    (_IN, "1/39.4", "values in m/s^2/N labelled in?"),
    (_LBF / _G, "1/2.20", "g/lbf read as m/s^2/N?"),
    (_LBF / _IN, "175", "in/s^2/lbf read as m/s^2/N?"),
)


def column_factors(cal: ColumnCalibration) -> np.ndarray:
    """Each excitation column's level ``s_j = median_f |1 + eps_j(f)|``, shape (e,)."""
    return np.median(np.abs(1.0 + cal.error), axis=0)


def units_conclusion(cal: ColumnCalibration | None) -> str | None:
    """The one line on a common gross factor (module docstring), or None when the columns do not share one.

    Returns
    -------
    str or None
        E.g. "the FRFs look scaled by 1/9.81 in every excitation column (g/N read as m/s^2/N?)".
    """
    if cal is None or not cal.significant:  # a factor the F test cannot tell from noise (or a layout without redundancy for it)
        return None
    s = column_factors(cal)
    if not np.all(np.isfinite(s)) or np.any(s <= 0):
        return None
    if s.max() / s.min() > UNITS_COMMON_SPREAD:  # no common factor; every column grossly off is still no calibration error
        if np.all(s > UNITS_GROSS_FACTOR) or np.all(s < 1.0 / UNITS_GROSS_FACTOR):
            return (f"the FRFs are off by factors {s.min():.4g}-{s.max():.4g} in the excitation columns from what the free "
                    "model predicts (no unit factor, and far beyond a force calibration error): the free model (the study's "
                    "dimensions, material or their units), the FRFs' units, the force sensors' sensitivities or a "
                    "record's sign or direction (its direction code in the file; a beam study's `--axis`, `[measurement] "
                    "axis`) are wrong")
        return None
    common = float(np.exp(np.mean(np.log(s))))
    if 1.0 / UNITS_MAX_FACTOR <= common <= UNITS_MAX_FACTOR:
        return None
    ratios = [abs(np.log(common / u)) for u, _, _ in UNIT_FACTORS]
    best = int(np.argmin(ratios))
    if ratios[best] <= np.log(UNITS_MATCH):
        _, label, why = UNIT_FACTORS[best]
        return f"the FRFs look scaled by {label} in every excitation column ({why})"
    label = f"{common:.3g}" if common >= 1 else f"1/{1 / common:.3g}"
    return f"the FRFs look scaled by {label} in every excitation column (wrong units, or a wrong sensor sensitivity?)"
