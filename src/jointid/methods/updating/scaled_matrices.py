"""Model updating of a free structure given by matrices: stiffness scale, mass scale, loss factor.

A ``[structure]`` study's free model is

    D(w) = alpha K (1 + j eta) - w^2 beta M

with the matrices ``K``, ``M`` of its files and three parameters:
``stiffness_scale`` (alpha), ``mass_scale`` (beta) and ``loss_factor`` (eta).
:func:`jointid.methods.updating.fit.update_free_model` fits them to free-free FRFs
through :class:`ScaledMatrixFamily`, which never rebuilds the modes: the exact
scaling law

    Y(w; alpha, beta, eta) = (alpha K c - w^2 beta M)^-1 = Y(w sqrt(beta / alpha); 1, 1, eta) / alpha,
    c = 1 + j eta,

evaluates every parameter set on the one :class:`~jointid.physics.sparse_model.SparseModel`
of the reference matrices at the scaled lines ``f sqrt(beta / alpha)``. Its modes
and residual moments do not depend on ``eta`` (the modal sum and the residual
series carry ``c`` explicitly), so the model is only told the loss factor. The
law is exact for the receptance itself; with a truncated modal basis it evaluates
the reference model's approximation (modal sum plus residual series, whose terms
``z^k / c^(k+1)``, ``z = w^2 + s c``, are the same series at the scaled line) at
the scaled frequency, where the basis is extended automatically should the fit
move above the frequency it covers. A model of at most
:data:`~jointid.physics.sparse_model.DENSE_EIGEN_LIMIT` DOFs has all its modes
(one dense eigensolution, no truncation): the sum is exact and every evaluation
costs one ``(F, r, k) x (k, c)`` product.

Stage 1 (frequency alignment) moves alpha by ``s^2`` (or beta by ``s^-2``):
every natural frequency scales as ``sqrt(alpha / beta)``. alpha and beta separate
through the FRF level as E and density do for a beam: below and between
resonances a free-free FRF follows its rigid-body mass line (``1 / beta``).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ...frequency import Frequency
from ...physics.sparse_model import DENSE_EIGEN_LIMIT, SparseModel
from .fit import ModelFamily

__all__ = ["ScaledMatrixFamily"]


class ScaledMatrixFamily(ModelFamily):
    """``alpha K (1 + j eta) - w^2 beta M`` as a :class:`~jointid.methods.updating.fit.ModelFamily` (see the module docstring).

    Parameters
    ----------
    model : SparseModel
        The reference model: the matrices at ``initial``'s ``stiffness_scale`` and
        ``mass_scale`` (its own loss factor is ignored). It is owned by the family
        (its ``loss_factor`` is set per evaluation; its modes are cached).
    initial : mapping of str to float
        ``stiffness_scale``, ``mass_scale`` and ``loss_factor`` the reference model stands for.
    method : {"auto", "modal", "direct"}
        The receptance method; "auto" takes "modal" for a model whose modes are all
        computed (at most ``DENSE_EIGEN_LIMIT`` DOFs: exact and cheapest), else the
        model's own choice per number of lines.
    """

    frequency_parameters = (("stiffness_scale", 2), ("mass_scale", -2))
    described = "this structure"
    dof_hint = "measure at DOFs of the [structure] DOF list"

    def __init__(self, model: SparseModel, initial: Mapping[str, float], method: str = "auto") -> None:
        self.model = model
        self.alpha0 = float(initial["stiffness_scale"])
        self.beta0 = float(initial["mass_scale"])
        self.eta0 = float(initial["loss_factor"])
        if method == "auto" and model.size <= DENSE_EIGEN_LIMIT:
            method = "modal"
        self.method = method

    def _ratios(self, values: Mapping[str, float]) -> tuple[float, float, float]:
        """``(alpha / alpha0, beta / beta0, eta)``."""
        a = float(values.get("stiffness_scale", self.alpha0)) / self.alpha0
        b = float(values.get("mass_scale", self.beta0)) / self.beta0
        return a, b, float(values.get("loss_factor", self.eta0))

    def dofs(self, values):
        return self.model.dofs

    def receptance(self, values, frequency, rows, cols) -> np.ndarray:
        """``Y(f sqrt(b / a); eta) / a`` with ``a``, ``b`` the scales relative to the reference model; shape (F, r, c)."""
        a, b, eta = self._ratios(values)
        f = frequency.hz if isinstance(frequency, Frequency) else np.atleast_1d(np.asarray(frequency, dtype=float))
        self.model.loss_factor = eta
        return self.model.receptance(f * math.sqrt(b / a), rows, cols, method=self.method) / a

    def natural_frequencies_hz(self, values, top_hz: float) -> np.ndarray:
        """The reference model's natural frequencies times ``sqrt(a / b)``."""
        a, b, _ = self._ratios(values)
        return self.model.ensure_modes(top_hz * math.sqrt(b / a)).frequencies_hz * math.sqrt(a / b)
