"""A short Monte Carlo of the default estimator on a layout's synthetic noisy FRFs (the design's last check).

The analytic prediction (:mod:`jointid.methods.design.estimator`) is linear in
the FRF errors and takes the expected GCV lambda. The rotational term's per-line
errors are 100 % and more on most lines, so the estimator is not linear there
(its first smoothing pass starts from heavy-tailed per-line estimates), and how
far it departs depends on the layout: layouts with nearly equal predicted
errors can differ severalfold in their actual median K_theta_theta error
(``benchmarks/design.py`` prints predicted and actual errors per layout and
seed). A Monte Carlo of the estimator itself resolves that, at a cost of one
identification per layout and seed (``benchmarks/design.py`` prints its time).

Each realization: the exact receptance ``H`` of the test article (from the
:class:`~jointid.methods.design.layout.LayoutPredictor`, sensors and joint included) with
complex circular Gaussian noise of the predictor's noise model,
``H + sqrt(var H) z``, ``E|z|^2 = 1`` (for the additive model with the coherence
``1 / (1 + var H / |H_noisy|^2)`` that a test would measure, so the estimator weights
by coherence as it does a hammer test's FRFs), identified by
:func:`~jointid.methods.receptance.coupling.identify_joint_coupling` with the identification's
free model restricted to the layout's DOFs. The coherence is the noisy FRF's: a measured
coherence comes from the same records as ``H1``, so ``|H1|^2 (1 - g^2) / g^2`` is the noise power
over the force power whatever the noise did to ``H1``; one from the exact ``H`` makes that estimate
``var |H_noisy|^2 / |H|^2``, a random factor near anti-resonances (a value whose noise nearly
cancels ``H`` got a weight 1e3-1e4 times too large: a mount's rotations 20-300 % off on one seed in
four, the model check blaming the exact free model). The same seeds serve every layout of
the same size (paired noise). The statistic per term is the median over lines of
``|K_hat - K| / ref`` (``ref`` as the design's), then the median over seeds.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from ...dofs import Dof
from ...errors import IdentificationError
from ...frequency import Frequency
from ...frf import FRF
from ..receptance.coupling import CouplingOptions, identify_joint_coupling

__all__ = ["BlockModel", "monte_carlo_errors"]


class BlockModel:
    """A free model given by its receptance on fixed lines and DOFs (what the identification needs of a layout).

    Parameters
    ----------
    dofs : sequence of Dof
    hz : ndarray, shape (F,)
    receptance : ndarray, shape (F, D, D), complex
    """

    def __init__(self, dofs: Sequence[Dof], hz: np.ndarray, receptance: np.ndarray):
        self._dofs = tuple(dofs)
        self._pos = {d: i for i, d in enumerate(self._dofs)}
        self._hz = np.asarray(hz, float)
        self._Y = receptance

    @property
    def dofs(self) -> tuple[Dof, ...]:
        return self._dofs

    def receptance(self, frequency, rows, cols) -> np.ndarray:
        hz = frequency.hz if isinstance(frequency, Frequency) else np.asarray(frequency, float)
        if hz.shape != self._hz.shape or not np.allclose(hz, self._hz, rtol=0, atol=1e-9):
            raise IdentificationError("BlockModel: asked for lines other than the ones it holds")
        r = [self._pos[d] for d in rows]
        c = [self._pos[d] for d in cols]
        return self._Y[:, np.asarray(r)[:, None], np.asarray(c)[None, :]]


def monte_carlo_errors(predictor, observed: Sequence, excited: Sequence, seeds: int,
                       options: CouplingOptions | None = None) -> np.ndarray:
    """Actual relative error of the default estimator per seed and term, shape (seeds, T).

    Parameters
    ----------
    predictor : LayoutPredictor
        On the lines to identify (the full band), with the noise model and level to simulate.
    observed, excited : sequence of int or DOFs
        As the predictor's candidates (beam nodes, or DOFs such as ``"12x"``).
    seeds : int
        Realizations (seeds 0..seeds-1).
    options : CouplingOptions, optional
        The study's identification options (default: the defaults). Where they ask for the
        structured estimate (a joint of 1-3 DOFs), ``smoothing = "gcv"``: the estimator
        :mod:`jointid.methods.design.estimator` predicts (the structured estimate pools every
        term and line and was more accurate on every layout tested, so the ranking is that of
        the per-term smoother). A mount of 4-6 DOFs runs its own default, the joint spline fit.
    """
    options = options or CouplingOptions()
    if options.over_frequency(len(predictor.joint_dofs)) == "structured":  # the estimator the predictor models
        options = dataclasses.replace(options, smoothing="gcv")
    model, m_dofs, e_dofs = predictor.identification_model(observed, excited)
    H = predictor.exact_receptance(observed, excited)
    var = predictor.frf_variance(H)
    sd = np.sqrt(var)
    ref = predictor.reference
    out = np.zeros((seeds, len(predictor.terms)))
    for k in range(seeds):
        rng = np.random.default_rng(k)
        z = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2.0)
        noisy = H + sd * z
        # additive noise: the coherence a test would measure with this FRF (module docstring), so the estimator weights
        # as in a hammer test
        coherence = 1.0 / (1.0 + var / np.abs(noisy) ** 2) if predictor.noise_model == "additive" else None
        frf = FRF(predictor.frequency, noisy, tuple(m_dofs), tuple(e_dofs), "receptance", coherence=coherence)
        r = identify_joint_coupling(model, frf, predictor.joint_dofs, options)
        keep = np.isin(predictor.frequency.hz, r.frequency.hz)  # lines it left out (junk) are not scored
        K, Du, rf = r.stiffness, predictor.Du[keep], ref[keep]
        out[k] = [np.median(np.abs(K[:, i, j] - Du[:, i, j]) / rf[:, i, j]) for i, j, _ in predictor.terms]
    return out
