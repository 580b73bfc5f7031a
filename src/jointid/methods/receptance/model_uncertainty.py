"""The free model's parameter uncertainty carried into the joint estimate's bands.

The FRFs of the jointed structure cannot tell a free-model error from a joint term: the
coupling equations ``Y[m,e] - H[m,e] = Y[m,n] X Y[n,e]`` absorb a small error ``dY`` of the
free receptance into ``X`` (and the residual shows nothing, :mod:`.model_check`). So where the
free model's parameters are uncertain by a stated covariance (``[uncertainty]``, which
``jointid update`` writes from its fit), that uncertainty is propagated: for each direction
``v_i`` of the covariance (:class:`~jointid.physics.free_model.UncertainFreeModel`,
``dY_i = (Y(p + v_i) - Y(p - v_i)) / 2``) the FRFs the estimate ``K`` predicts,
``H_c = Y[m,e] - Y[m,n] X Y[n,e]`` with ``X = K (I + Y[n,n] K)^-1``, are identified per line
with ``Y + dY_i`` and ``Y - dY_i``; half their difference is the estimate's deviation ``dK_i``,
and its linearized covariance is ``sum_i dK_i dK_i^H``, added to each term's real and imaginary
variance (a systematic error: smoothing over lines does not reduce it). A free model meshed
coarser than its convergence criterion adds the converged model as one more deviation,
``dY = Y_ref - Y`` (its discretization error, one-sided).

The rotational term of a beam is the most sensitive: a free-model loss factor off by 2 % moves
K_theta_theta by ~10 % while the residual stays at the noise (``benchmarks/real_world_checks.py``
prints the coverage after ``jointid update`` with and without the propagated uncertainty).
Caveats: linear over one standard deviation; noise-free (the deviation of the predicted FRFs,
not of each noisy line); a model *form* error other than the mesh (a boundary condition, a
missing component) is in no direction and not in the bands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coupling_lines import coupling_per_line

__all__ = ["ModelUncertainty", "model_uncertainty", "DOMINANT_SHARE"]

#: A term's band is "set by the free model" on a line when the propagated variance is more than this share of it.
DOMINANT_SHARE = 0.5


@dataclass(frozen=True, eq=False)
class ModelUncertainty:
    """The joint estimate's deviation per direction of the free model's parameter covariance.

    Attributes
    ----------
    deviations : ndarray, shape (D, F, n, n), complex
        ``dK_i`` per direction (the estimate's units).
    described : str
        What the uncertainty is (for the finding).
    """

    deviations: np.ndarray
    described: str

    @property
    def variance_real(self) -> np.ndarray:
        """``sum_i (Re dK_i)^2``, shape (F, n, n)."""
        return np.sum(self.deviations.real ** 2, axis=0)

    @property
    def variance_imag(self) -> np.ndarray:
        """``sum_i (Im dK_i)^2``, shape (F, n, n)."""
        return np.sum(self.deviations.imag ** 2, axis=0)

    def finding(self, hz: np.ndarray, names, var_re: np.ndarray, var_im: np.ndarray) -> str | None:
        """One line naming the terms whose band the free model's uncertainty sets on some lines (None: on none).

        ``var_re``, ``var_im`` (F, n, n): the bands' total variances (the propagated part included)."""
        share = (self.variance_real + self.variance_imag) / np.maximum(var_re + var_im, np.finfo(float).tiny)
        parts = []
        for a, b, name in names:
            if b < a:
                continue
            s = share[:, a, b] > DOMINANT_SHARE
            if s.any():
                parts.append(f"{name} on {100 * s.mean():.0f} % of lines")
        if not parts:
            return None
        return (f"{self.described} is in the bands: it sets the band of " + ", ".join(parts)
                + " (a better free-free test or a finer model narrows them)")


def model_uncertainty(Ymn: np.ndarray, Yne: np.ndarray, Ynn: np.ndarray, Yme: np.ndarray, deviations, K: np.ndarray,
                      variance: np.ndarray, symmetric: bool = True, described: str = "the free model's parameter uncertainty"
                      ) -> ModelUncertainty:
    """The estimate's deviation ``dK_i`` for each receptance deviation ``dY_i`` (module docstring).

    Parameters
    ----------
    Ymn, Yne, Ynn, Yme : ndarray, shapes (F, m, n), (F, n, e), (F, n, n), (F, m, e), complex
        The nominal free receptance blocks (m/N, rad/N, ...).
    deviations : sequence of 4-tuples of ndarray
        ``(dYmn, dYne, dYnn, dYme)`` per direction (parameter covariance or mesh reference), the same shapes.
    K : ndarray, shape (F, n, n), complex
        The joint estimate (N/m, N*m/rad, ...).
    variance : ndarray, shape (F, m, e)
        The FRF variance shape the per-line fit weights by.
    symmetric : bool
        Fit a symmetric joint.

    Returns
    -------
    ModelUncertainty
    """
    n = K.shape[1]
    X = K @ np.linalg.inv(np.eye(n) + Ynn @ K)  # (Y[n,n] + K^-1)^-1 without inverting a singular K
    Hc = Yme - Ymn @ X @ Yne
    out = []
    for dmn, dne, dnn, dme in deviations:
        fits = [coupling_per_line(Ymn + s * dmn, Yne + s * dne, Ynn + s * dnn, Yme + s * dme - Hc, variance, symmetric).stiffness
                for s in (1.0, -1.0)]
        out.append((fits[0] - fits[1]) / 2.0)
    return ModelUncertainty(np.array(out).reshape(len(out), *K.shape), described)
