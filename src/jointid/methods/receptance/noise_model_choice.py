"""Without coherence: is the FRF noise relative (``var ~ |H|^2``), or has it a floor (a hammer test's response noise)?

A file without coherence leaves the variance model to jointid. The default is relative
noise, ``var H = s^2 |H|^2`` (a constant percentage on every value: what synthetic
studies add). A hammer test's noise is not: response noise is a floor, so near
anti-resonances, where ``|H|`` is small, the noise is many times ``s |H|``. Weighted as
relative, those values get weights far too large; the per-line residuals there are far
above the assumed noise, and the model check blames the free model (seen on the virtual
hammer test: "the free model does not explain these FRFs in 5-1000 Hz", K_theta_theta
80-90 % off with bands covering half the lines).

Two variance shapes, each with its scale profiled out, are compared by the likelihood of
the second differences over frequency of the residuals of the per-line fit weighted by each,
with their part along the excitation columns' directions left out (a scale error per column,
from wrong units, force calibration or force noise, follows ``|H|`` whatever the noise is)
(``r_f`` per value, ``h`` its leverage in the fit and the column directions; ``d_f = r_(f+1) - 2 r_f + r_(f-1)`` has variance
``w_f = s^2 ((1-h) V)_(f+1) + 4 ((1-h) V)_f + ((1-h) V)_(f-1)`` for white noise, while a
residual smooth over frequency, a free-model error, cancels and does not pass for noise;
complex Gaussian)::

    -2 log L(V) = 2 [N log(mean(|d|^2 / w)) + sum log w]
    relative:  V = |H_rj|^2
    floor:     V = max(|H_rj|^2, sqrt(max_r' |H_r'j|^2 max_j' |H_rj'|^2))   (per line)

Both have one parameter (the scale), so the lower ``-2 log L`` is chosen. The floor
shape is the noise of a response channel as a fraction of the largest response on the
line in its row and column (what ``floor_exact_zeros`` gives an FRF file whose coherence
is identically 1). When it wins, the identification goes on as for a file whose noise
level is unknown: the floor shape weights the column calibration, then the variance of
each value is measured from the residuals
(:func:`~jointid.methods.receptance.column_calibration.residual_variance`).

The lines compared are every line up to :data:`CHOICE_LINES`, else blocks of consecutive
lines spread over the band (second differences within each block). The identification asks
only where the layout leaves residuals outside the excitation columns' directions
(:func:`~jointid.methods.receptance.column_redundancy.column_redundancy`): a 6 x 6 layout of a
6-DOF mount leaves none, the comparison there is of round-off, and it chose "a floor" on
relative noise.

Caveats: a free-model error that shifts a lightly damped resonance or anti-resonance makes
residuals that change within a few lines there, which second differences keep; near
anti-resonances this favours the floor shape. Neighbouring lines of an impact test share
leakage (correlated noise), which second differences partly cancel: the comparison is of
shapes, and both models see it alike.
"""

from __future__ import annotations

import numpy as np

from ...parallel import single_threaded_blas
from .coupling_lines import symmetric_parametrization
from .force_noise import column_split

__all__ = ["NoiseModelChoice", "choose_noise_model", "floor_shape", "NOISE_FREE_LEVEL"]

#: Most lines the choice is made on, in :data:`CHOICE_BLOCKS` blocks of consecutive lines spread over the band (each
#: line's 21 or so values are evidence enough; every line of a 20 000-line file would cost 0.5 s).
CHOICE_LINES = 2000
CHOICE_BLOCKS = 20
#: Below this relative noise rms the data are noise-free (double round-off ~1e-16, 12-digit UFF ~1e-12; measured
#: FRFs 1e-3 and more): the weighting does not matter and no noise model is chosen.
NOISE_FREE_LEVEL = 1e-9


def floor_shape(H: np.ndarray) -> np.ndarray:
    """``max(|H_rj|^2, sqrt(max_r' |H_r'j|^2 max_j' |H_rj'|^2))`` per line, shape (F, m, e) (module docstring)."""
    a2 = H.real ** 2 + H.imag ** 2
    return np.maximum(a2, np.sqrt(a2.max(axis=2, keepdims=True) * a2.max(axis=1, keepdims=True)))


class NoiseModelChoice:
    """The variance shape chosen for FRFs without coherence, and ``-2 log L`` of both.

    Attributes
    ----------
    floor : bool
        The floor shape fits the residuals better than the relative one.
    variance : ndarray, shape (F, m, e)
        The chosen shape.
    relative, floored : float
        ``-2 log L`` of each (module docstring).
    """

    def __init__(self, floor: bool, variance: np.ndarray, relative: float, floored: float):
        self.floor = floor
        self.variance = variance
        self.relative = relative
        self.floored = floored

    @property
    def finding(self) -> str:
        """One line when the floor shape is used, else ""."""
        if not self.floor:
            return ""
        return ("the FRF file has no coherence and its noise is not relative to |H|: it has a floor, as a hammer test's "
                f"response noise (-2 log L {self.relative - self.floored:.3g} lower; or the free model is off where |H| is "
                "small: see the model check), so the variance of each value was measured from the residuals; give the "
                "coherence to weight by it")


def _minus_two_log_likelihood(Ymn, Yne, change, H, V, symmetric, inner) -> tuple[float, float]:
    """``-2 log L`` of the shape ``V`` (module docstring) and the scale ``s^2`` it gives; ``inner`` (F - 2,): the
    second differences that lie within one block of consecutive lines."""
    F, m, _ = Ymn.shape
    e = Yne.shape[2]
    with single_threaded_blas():
        sw, Q, rw, Uz, _ = column_split(Ymn, Yne, change, H, V, symmetric, keep=False)  # a subset of the lines: not kept
    # the residual along the excitation columns' directions (a scale error per column: units, force calibration,
    # force noise) is left out: it follows |H| whatever the noise is
    rw = rw - np.einsum("fkc,fc->fk", Uz, np.einsum("fkc,fk->fc", np.conj(Uz), rw))
    ru = rw / sw  # residual, m/N
    free = np.clip(1.0 - np.sum(np.abs(Q) ** 2, axis=2) - np.sum(np.abs(Uz) ** 2, axis=2), 0.0, None)
    v = V.reshape(F, m * e)
    # second differences over frequency: white noise stays (variance sum of the three), a residual smooth over
    # frequency (a free-model error) cancels, so it does not pass for noise
    d2 = ru[2:] - 2.0 * ru[1:-1] + ru[:-2]
    var = free[2:] * v[2:] + 4.0 * free[1:-1] * v[1:-1] + free[:-2] * v[:-2]
    use = (var > 1e-3 * 6.0 * v[1:-1]) & inner[:, None]  # values the fit leaves (almost) no residual to: no evidence
    z = np.abs(d2[use]) ** 2 / var[use]
    s2 = float(np.mean(z)) if z.size else 0.0
    if not s2 > 0:
        return np.inf, 0.0
    return float(2.0 * (z.size * np.log(s2) + np.sum(np.log(var[use])))), s2


def choose_noise_model(Ymn: np.ndarray, Yne: np.ndarray, change: np.ndarray, H: np.ndarray,
                       symmetric: bool = True) -> NoiseModelChoice | None:
    """Relative or floor variance shape for FRFs without coherence (module docstring).

    Parameters
    ----------
    Ymn, Yne : ndarray, shapes (F, m, n), (F, n, e), complex
        Free receptance blocks, m/N.
    change : ndarray, shape (F, m, e), complex
        ``Y[m,e] - H[m,e]``, m/N.
    H : ndarray, shape (F, m, e), complex
        Measured receptance, m/N.
    symmetric : bool

    Returns
    -------
    NoiseModelChoice, or None when a line has fewer than 3 residual degrees of freedom beyond the joint's terms and the
    columns, a value is 0, or the data
    are noise-free (relative noise below :data:`NOISE_FREE_LEVEL`).
    """
    F, m, n = Ymn.shape
    e = Yne.shape[2]
    if m * e - symmetric_parametrization(n, symmetric).shape[1] - e < 3:
        return None
    relative = np.abs(H) ** 2
    if not np.all(np.isfinite(relative) & (relative > 0)):
        return None
    # the evidence: CHOICE_BLOCKS blocks of consecutive lines spread over the band (every line up to CHOICE_LINES)
    if F > CHOICE_LINES:
        length = CHOICE_LINES // CHOICE_BLOCKS
        starts = np.unique(np.linspace(0, F - length, CHOICE_BLOCKS).round().astype(int))
        idx = (starts[:, None] + np.arange(length)[None, :]).ravel()
        idx = np.unique(idx)
    else:
        idx = np.arange(F)
    inner = (idx[1:-1] - idx[:-2] == 1) & (idx[2:] - idx[1:-1] == 1)
    sub = (Ymn[idx], Yne[idx], change[idx], H[idx])
    a, s2 = _minus_two_log_likelihood(*sub, relative[idx], symmetric, inner)
    if not s2 > NOISE_FREE_LEVEL ** 2:  # noise-free data (round-off, 12-digit files): no noise to model
        return None
    floor = floor_shape(H)
    b, _ = _minus_two_log_likelihood(*sub, floor[idx], symmetric, inner)
    return NoiseModelChoice(b < a, floor if b < a else relative, a, b)
