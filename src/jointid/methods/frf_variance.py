"""The variance of each measured FRF value: the weights of the statistical estimators.

An FRF estimated by H1 from ``n`` averages with ordinary coherence ``g^2`` has a
complex random error of variance (Bendat & Piersol, *Random Data*, 9.2; both the
magnitude and the phase have normalized random error
``eps = sqrt(1 - g^2) / (|g| sqrt(2 n))``)::

    E|dH|^2 / |H|^2 = 2 eps^2 = (1 - g^2) / (n g^2)

Antiresonances and lines near the noise floor have low coherence and get
little weight. Without coherence the error is taken as relative
(``E|dH|^2 ~ |H|^2``: a constant signal-to-noise ratio per FRF value). Only the
*shape* of the variance matters to the estimators here: its scale is
re-estimated from the least-squares residuals, so a wrong ``n`` or an unknown
noise level does not bias the uncertainty. A floor of relative standard
deviation :data:`RELATIVE_FLOOR` keeps lines with coherence 1 (noise-free
simulations) finitely weighted.
"""

from __future__ import annotations

import numpy as np

from ..errors import IdentificationError

__all__ = ["frf_variance", "WEIGHTINGS", "RELATIVE_FLOOR"]

WEIGHTINGS = ("auto", "coherence", "relative", "none")
#: Smallest relative standard deviation assigned to an FRF value (calibration, round-off).
RELATIVE_FLOOR = 1e-6


def frf_variance(
    data: np.ndarray,
    coherence: np.ndarray | None = None,
    weighting: str = "auto",
    averages: int | None = None,
) -> tuple[np.ndarray, str]:
    """Variance shape of each FRF value, ``E|dH|^2`` up to a common scale, shape (F, m, e).

    Parameters
    ----------
    data : ndarray, shape (F, m, e), complex
        FRF values (any kind: the variance is in the square of its unit).
    coherence : ndarray, shape (F, m, e), optional
        Ordinary coherence of each value (0..1).
    weighting : {"auto", "coherence", "relative", "none"}
        "auto": coherence if given, else relative.
    averages : int, optional
        Number of averages behind the coherence (default 1; it only scales).

    Returns
    -------
    variance : ndarray, shape (F, m, e)
    source : str
        The weighting used.
    """
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    mag2 = np.abs(data) ** 2
    if weighting == "auto":
        weighting = "coherence" if coherence is not None else "relative"
    if weighting == "none":
        return np.full(data.shape, float(np.median(mag2)) or 1.0), "none"
    rel = np.full(data.shape, RELATIVE_FLOOR**2)
    if weighting == "coherence":
        if coherence is None:
            raise IdentificationError("weighting = 'coherence' needs coherence records in the FRF file; use 'relative'")
        g2 = np.clip(np.asarray(coherence, dtype=float), 1e-6, 1.0)
        if g2.shape != data.shape:
            raise IdentificationError(f"coherence has shape {g2.shape}, the FRFs {data.shape}")
        rel = rel + (1.0 - g2) / (g2 * (averages or 1))
    else:
        rel = rel + 1.0
    return rel * np.maximum(mag2, np.finfo(float).tiny), weighting
