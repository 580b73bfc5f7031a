"""A step-sine test whose force lags its displacement: a reversed phase sign, not a material.

A passive elastomer dissipates energy: over a cycle the force leads the displacement, so its
loss factor ``eta = Im K / Re K`` is positive (the transfer stiffness K21 of a joint with
inertia changes sign at and above its internal mode, where both parts turn, and ``eta``
stays positive on most lines). A test whose ``eta`` is negative on most lines has its phase
sign convention reversed (force and displacement
channels swapped in the phase, ``exp(+j w t)`` against ``exp(-j w t)``, a sign in the
controller's export). Fitted as it is, a material law takes the negative loss as a misfit
(a constant-modulus fit doubles its residual, a Zener fit moves its stiffness by 30-140 %);
:func:`reversed_phase` says so in one line, and the fits leave such a test out.
"""

from __future__ import annotations

import numpy as np

__all__ = ["reversed_phase", "REVERSED_FRACTION"]

#: A test is taken as reversed when its loss factor is negative on more than this fraction of its lines.
REVERSED_FRACTION = 0.5


def reversed_phase(stiffness: np.ndarray, quantity: str = "K21") -> str | None:
    """One line when the force lags the displacement on most lines (module docstring), else None.

    The loss factor per line is ``eta = Im K / Re K``; the test is reversed when
    ``eta < 0`` on more than :data:`REVERSED_FRACTION` of its lines.

    Parameters
    ----------
    stiffness : ndarray, shape (F,), complex
        K21 per line, N/m (or a complex modulus E*(f), Pa: any complex quantity whose phase is the loss angle).
    quantity : str
        Its name in the message (``"K21"``, ``"E*"``).
    """
    k = np.asarray(stiffness, complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = k.imag / k.real
    negative = eta < 0
    if k.size == 0 or not negative.mean() > REVERSED_FRACTION:
        return None
    median = float(np.median(eta))
    return (f"the force lags the displacement (loss factor Im {quantity} / Re {quantity} < 0, median {median:.2g}) on "
            f"{int(negative.sum())} of {k.size} lines, which a passive elastomer cannot do: a reversed phase sign convention (which channel "
            "leads, exp(+jwt) or exp(-jwt))? fix the export or the phase sign")
