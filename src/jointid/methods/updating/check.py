"""Does an updated free model fit its FRFs? The check ``jointid update`` makes before reporting parameters.

A least-squares fit always returns values. Whether they mean anything depends on
whether the model *can* explain the data: FRFs of the jointed structure, of
another structure, or with wrong units leave a residual far above the data's
noise (or resonances the model does not have) however the parameters move.
Then no parameter is reported as determined.

Noise level
-----------
The residual of the fit is ``r_k = ln(H_model / H_measured)`` per FRF value
(complex: log-magnitude and wrapped phase). The measurement noise is white
from line to line, a model misfit is smooth in frequency: the noise level is
estimated from the second differences along frequency,

    sigma = median |r_{k+1} - 2 r_k + r_{k-1}| / sqrt(6)

(for white noise the second difference has ``sqrt(6)`` times its standard
deviation, so this is the median ``|r|`` the noise alone would leave; the median
makes it robust to the few lines where a sharp resonance the model misses
dominates, and a smooth misfit hardly changes it). The fit is rejected when

    median |r| > max(MISFIT_FLOOR, min(NOISE_FACTOR * sigma, MISFIT_CEILING))

i.e. a typical value is off by more than :data:`MISFIT_FLOOR` (10 %) *and* by
far more than the noise explains, or by more than :data:`MISFIT_CEILING` (50 %)
whatever the noise estimate says (on a coarse frequency grid a misfit is not
smooth from line to line and inflates ``sigma``; data whose noise alone leaves
half the values 50 % off carry no parameter anyway). An updated model fitted to
its own free-free test leaves ``median |r|`` of the order of ``sigma``; FRFs of
the jointed structure leave it above :data:`MISFIT_FLOOR` and many times
``sigma`` (``tests/test_update.py`` checks both cases).

Resonances
----------
The measured peaks are matched to the updated model's natural frequencies
(:func:`~jointid.methods.updating.resonances.frequency_scale`, the update's stage 1): a
scale more than :data:`MAX_FREQUENCY_SHIFT` away from 1 means the resonances
are left misaligned.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import DataError

__all__ = ["MISFIT_FLOOR", "MISFIT_CEILING", "NOISE_FACTOR", "MAX_FREQUENCY_SHIFT", "noise_level", "judge_update_fit",
           "unit_factor_of", "refuse_unit_factor"]

#: Median relative misfit |ln(H_model / H_measured)| above which a fit can be rejected.
MISFIT_FLOOR = 0.1
#: Median relative misfit above which a fit is rejected whatever the noise level.
MISFIT_CEILING = 0.5
#: Rejected only if the median misfit is also this many times the noise level (or above MISFIT_CEILING).
NOISE_FACTOR = 4.0
#: Largest relative shift of the matched resonances (measured / updated model) accepted.
MAX_FREQUENCY_SHIFT = 0.02


def noise_level(residual: np.ndarray) -> float:
    """Line-to-line noise of a complex residual ``(F, r, c)``: ``median |second difference| / sqrt(6)``."""
    r = np.asarray(residual)
    if r.shape[0] < 3:
        return math.inf
    d2 = r[2:] - 2.0 * r[1:-1] + r[:-2]
    return float(np.median(np.abs(d2)) / math.sqrt(6.0))


def judge_update_fit(residual: np.ndarray, measured, model_hz: np.ndarray | None, described: str,
                     initial: np.ndarray | None = None) -> str | None:
    """The finding when an updated model does not fit its FRFs, else None.

    Parameters
    ----------
    residual : ndarray, shape (F, r, c), complex
        ``ln(H_model / H_measured)`` of the updated model, phase wrapped to (-pi, pi].
    measured : FRF
        The data (for the resonance check).
    model_hz : ndarray or None
        The updated model's natural frequencies (Hz); None skips the resonance check.
    described : str
        What the FRFs should be a test of ("this beam with these sensors").
    initial : ndarray, shape (F, r, c), complex, optional
        The same residual of the initial model: FRFs off by a unit factor leave it at ``-ln u`` on every value
        when the initial model is right (the update, pulled by the factor, may scatter it); named when so
        (:func:`unit_factor_of`).

    Returns
    -------
    str or None
        ``"these FRFs do not look like a free-free test of the study's structure (<described>): ..."``.

    Raises
    ------
    DataError
        The FRFs are off by one unit factor as a whole (:func:`unit_factor_of`): bad input, named with the factor.
    """
    from .resonances import frequency_scale

    misfit = float(np.median(np.abs(residual)))
    sigma = noise_level(residual)
    head = f"these FRFs do not look like a free-free test of the study's structure ({described}): "
    if _rejected(misfit, sigma):
        factor = next((f for f in (unit_factor_of(r, noise_level(r)) for r in (residual, initial) if r is not None)
                       if f is not None), None)
        if factor is not None:  # bad input, not a model question: refused (exit 2), as jointid identify refuses it
            raise DataError(_unit_factor_message(head, *factor, misfit, "after the update"))
        return head + (
            f"after the update a typical value is still off by {100 * misfit:.3g} % (median |ln(H_model / H_measured)|), "
            f"{misfit / sigma:.3g} times the noise level of the data ({100 * sigma:.2g} %); no parameter is reported as "
            "determined: check the FRF file (free-free, not jointed), its units and the study"
            if sigma > 0 else
            f"after the update a typical value is still off by {100 * misfit:.3g} %; no parameter is reported as determined: "
            "check the FRF file (free-free, not jointed), its units and the study"
        )
    if model_hz is not None:
        scale, matched = frequency_scale(measured, np.asarray(model_hz, dtype=float), lo=0.9, hi=1.1)
        if matched and abs(scale - 1.0) > MAX_FREQUENCY_SHIFT:
            return head + (
                f"the measured resonances lie {100 * (scale - 1):+.2g} % from the updated model's ({matched} matched); "
                "no parameter is reported as determined: check the FRF file (free-free, not jointed) and the study"
            )
    return None


def _rejected(misfit: float, sigma: float) -> bool:
    return misfit > max(MISFIT_FLOOR, min(NOISE_FACTOR * sigma, MISFIT_CEILING))


def _unit_factor_message(head: str, label: str, why: str, misfit: float, when: str) -> str:
    return head + (f"every value is off by one factor, {label} ({why}; median |ln(H_model / H_measured)| {100 * misfit:.3g} % "
                   f"{when}): give the file's units (UFF dataset 164 / unit labels; a CSV file is read in SI units)")


def refuse_unit_factor(initial: np.ndarray, described: str) -> None:
    """Refuse FRFs that the initial model explains but for one unit factor on every value, before any update.

    The initial model's residual ``ln(H_model / H_measured)`` at ``-ln u`` on every value (:func:`unit_factor_of`)
    with the misfit of a rejected fit (module docstring): an update cannot remove the factor, or it takes it up as
    material values (``E`` and the density scaled together by one factor scale a free structure's FRFs and leave its
    resonances: within the parameters' bounds for the factor 2.2 of lbm), and it costs the whole fit first.

    Parameters
    ----------
    initial : ndarray, shape (F, r, c), complex
        ``ln(H_model / H_measured)`` of the initial model, phase wrapped to (-pi, pi].
    described : str
        What the FRFs should be a test of (as :func:`judge_update_fit`).

    Raises
    ------
    DataError
        ``"these FRFs do not look like a free-free test ...: every value is off by one factor, <label> (...)"``.
    """
    misfit, sigma = float(np.median(np.abs(initial))), noise_level(initial)
    if _rejected(misfit, sigma):
        factor = unit_factor_of(initial, sigma)
        if factor is not None:
            head = f"these FRFs do not look like a free-free test of the study's structure ({described}): "
            raise DataError(_unit_factor_message(head, *factor, misfit, "with the initial model"))


def unit_factor_of(residual: np.ndarray, sigma: float) -> tuple[str, str] | None:
    """``(label, why)`` of the unit factor of :data:`~jointid.methods.receptance.units_check.UNIT_FACTORS` that the FRFs
    are off by as a whole, or None.

    ``H_measured = u H_true`` leaves ``ln(H_model / H_measured) = -ln u`` on every value (and a phase near 0): the
    factor is taken when the median of the log-magnitude residual is within ``max(3 sigma, 0.05)`` of ``-ln u`` and
    its values scatter about it by less than :data:`MISFIT_FLOOR` (median absolute deviation, so a few lines the
    model misses do not decide); factors closer together than that are told apart by the nearest one.
    """
    from ..receptance.units_check import UNIT_FACTORS

    r = np.asarray(residual)
    mag = r.real.ravel()
    mag = mag[np.isfinite(mag)]
    if mag.size == 0:
        return None
    centre = float(np.median(mag))
    if float(np.median(np.abs(mag - centre))) >= MISFIT_FLOOR or float(np.median(np.abs(r.imag))) >= MISFIT_FLOOR:
        return None
    tol = max(3.0 * sigma, 0.05) if math.isfinite(sigma) else 0.05
    dist, label, why = min((abs(centre + math.log(u)), label, why) for u, label, why in UNIT_FACTORS)
    return (label, why) if dist <= tol else None
