"""Bands of the per-term smoothing fallback when the lines err more than their stated variance.

Each term smoothed on its own (:mod:`.smoothing`) takes the per-line variance (from the coherence) as absolute.
When the FRFs err more than their coherence says (hammer records without a force window: the structured joint model
rejected at chi^2/dof 7 with the model right), two parts of that error must reach the bands:

* the part that varies faster than the smoother's resolution shows in its residuals: the posterior variance is scaled
  by the residuals' chi^2 per degree of freedom where it is significant (:func:`.smoothing.residual_scale`);
* the part smooth over frequency is followed by the smoother and shows in no residual about it. Where the structured
  model was fitted and rejected for its misfit (``chi^2/dof`` above its limit), its estimate is a second, independent
  smooth of the same lines; their difference, averaged over the smoother's resolution
  (:func:`.smoothing.running_mean` of its square, per part), is added to the variance of each term whose residuals
  showed errors above their variance. (Measured on the benchmark beam's hammer records without a force window: the
  smoothed K_theta_theta 20-42 % off at 5-50 Hz, its difference from the structured estimate the same size.)

A term whose residuals agree with its variance keeps its bands: the structured model's misfit then comes from the
model (not one viscoelastic material), and the smoothed term is the better estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .smoothing import running_mean

__all__ = ["FallbackWidening", "widen_fallback_bands"]


@dataclass(frozen=True, eq=False)
class FallbackWidening:
    """The fallback's variances after widening and what was widened.

    Attributes
    ----------
    var_real, var_imag : ndarray, shape (F, n, n)
        Variance of the real and imaginary part of each term (unit of the term squared).
    terms : tuple of str
        Terms whose residuals showed errors above their variance.
    max_scale : float
        Largest residual scale of those terms (dimensionless; 1 when none).
    structured_added : bool
        The structured estimate's difference was added to their variance.
    """

    var_real: np.ndarray
    var_imag: np.ndarray
    terms: tuple
    max_scale: float
    structured_added: bool

    def finding(self) -> str:
        """One line for the findings when something was widened, else ""."""
        if not self.terms:
            return ""
        also = ("; and, the structured joint model rejected, by the difference of its estimate from the smoothed terms "
                "(an error smooth over frequency shows in no residual)" if self.structured_added else "")
        return (f"{', '.join(self.terms)}: the per-line estimates scatter about the smoothed term more than their "
                f"coherence-based variance allows (up to {self.max_scale:.3g}x the variance): the FRFs err more than their "
                "coherence says (e.g. hammer records without a force window) or the free model is off there; the bands are "
                "widened by that scatter"
                f"{also}")


def widen_fallback_bands(K: np.ndarray, var_real: np.ndarray, var_imag: np.ndarray, scales: dict, half: dict,
                         structured_stiffness: np.ndarray | None, symmetric: bool = True) -> FallbackWidening:
    """Add the rejected structured estimate's smoothed difference to the variance of the terms that err (module docstring).

    Parameters
    ----------
    K : ndarray, shape (F, n, n), complex
        Each term smoothed on its own (N/m, N/rad, N*m/m, N*m/rad).
    var_real, var_imag : ndarray, shape (F, n, n)
        Their variance, already scaled by the residuals (unit of K squared).
    scales : dict
        Term name -> ``(a, b, largest residual scale)`` (dimensionless) of each smoothed term.
    half : dict
        Term name -> half-width (lines) of the smoother's resolution (:func:`.smoothing.resolution_lines`).
    structured_stiffness : ndarray, shape (F, n, n), complex, or None
        The structured estimate rejected for its misfit (None: not fitted, or rejected for another reason).
    symmetric : bool
        Mirror each term onto its transpose.

    Returns
    -------
    FallbackWidening
    """
    var_real, var_imag = var_real.copy(), var_imag.copy()
    erring = {name: v for name, v in scales.items() if v[2] > 1.0}
    Ks = structured_stiffness
    added = Ks is not None and bool(np.all(np.isfinite(Ks))) and bool(erring)
    for name, (a, b, _) in (erring.items() if added else ()):
        d = Ks[:, a, b] - K[:, a, b]
        add_re, add_im = running_mean(d.real ** 2, half[name]), running_mean(d.imag ** 2, half[name])
        for i, j in {(a, b), (b, a)} if symmetric else {(a, b)}:
            var_real[:, i, j] = var_real[:, i, j] + add_re
            var_imag[:, i, j] = var_imag[:, i, j] + add_im
    top = max((v[2] for v in erring.values()), default=1.0)
    return FallbackWidening(var_real, var_imag, tuple(erring), float(top), added)
