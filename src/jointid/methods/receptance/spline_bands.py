"""Bands of the joint spline fit: the bias of the chosen orders, measured against a richer fit.

:func:`~jointid.methods.receptance.spline_fit.fit_joint_spline` picks per-term orders (a score test from
the AIC's order up): a term left with fewer coefficients than the richest order fitted has a bias
that its own linearized band does not contain. On a 6-DOF mount (power-law modulus over 2-150 Hz,
``benchmarks/mount_6dof.py``) the exact-data bias of a 3-coefficient rotational term reaches
1.8 of its noise sigma, the 4-coefficient one 0.14; the 90 % bands of K_rx_rx, K_ry_ry covered
0.78, 0.74 (12 seeds) with per-term orders, 0.85, 0.75 with 4 everywhere.

The richest uniform fit (every term ``max_basis`` coefficients; the module's fits are nested, so
it holds every per-term model) is taken as unbiased in the class, and the difference of the two
estimates ``d = K_sel - K_rich`` as the measured bias of the chosen one. The band of each part
(real, imaginary) of each term at each line is::

    sigma^2 = max(sigma_sel^2,  sigma_rich^2 + d^2)

``K_sel - K_true = b + e_sel`` (``b`` the chosen class's bias, ``e_sel ~ N(0, sigma_sel^2)``) and
``d ~ N(b, sigma_rich^2 - sigma_sel^2)`` independent of ``e_sel`` (nested least squares: the smaller
fit's error is uncorrelated with the difference of the two fits, as in Hausman's test). The coverage
``P(|b + e_sel| <= z sqrt(sigma_rich^2 + d^2))`` is then, computed exactly over ``b`` at ``z = 1.645``,
never below 0.89995 for ``sigma_sel^2 / sigma_rich^2`` from 0.05 to 1 (the minimum, at equal
variances and ``|b| = 0.37 sigma``; 0.906-0.919 for ratios 0.05-0.95; 1 as ``|b| -> inf``;
``tests/test_spline_fit.py``): the band keeps the richer fit's coverage while the estimate keeps the
smaller error of the chosen orders.

The same band is used for a uniform order chosen by the AIC: the richer fit is then the order above
the best (the one that stopped the search past the cap ``max_basis``, or one fitted for the band
alone when the line count or :data:`~.spline_fit.MAX_EXTENDED_BASIS` stopped it). A joint whose
shape the cap cannot follow is biased by several of its own sigma although the AIC prefers 4 to 5:
one more coefficient on all 21 terms of a 6-DOF mount costs more than it gains on the one term that
needs it, and the richer class's extra directions are so poorly determined that no test on them
sees the bias (``benchmarks/spline_wide_band.py``: a stiffening ``1 + 0.3 (f / 100)^0.8`` over
10-400 Hz, K_x_x up to 6.7 sigma off with 4 coefficients; the diagonal terms' own bands cover
0.60-0.86 at 1 % noise, these 0.95-0.99). Cubic polynomials lie in the cubic B-splines with one
interior knot, so 4 is nested in 5 and the argument above holds; 5 and 6, 6 and 7 are not nested,
and there the band is the same formula without that proof (measured by the same script). An order
past the cap that the AIC rejects stops after a few iterations (the well-determined directions,
which set ``d`` where the band is narrow, converge in them; the others enter through their
variance). Where the chosen class is right, the noise in ``d`` makes these bands conservative
(``benchmarks/mount_6dof.py``: 0.93-0.99 where 0.9 is nominal).

Caveats: ``d`` is itself noisy (its variance ``~ sigma_rich^2 - sigma_sel^2`` adds to the band
where there is no bias: conservative by at most that); the richest fit's own linearized band is
too narrow by 5-20 % on the weakly seen terms of a mount whose true couplings are zero (the
information on a rotation grows as soon as a coupling estimate leaves zero, so the Jacobian at
the estimate overstates it); that part is not corrected separately: on the mount the noise in
``d`` widens the band by about as much (50 seeds, per-term orders only: 90 % bands cover 0.88-0.93 on
every diagonal term, 0.76-0.86 before; 0.89-0.93 on the off-diagonal ones; with the band at the cap
too, 0.93-0.99 and 0.94-0.99).
"""

from __future__ import annotations

import numpy as np

__all__ = ["richer_fit_band"]


def richer_fit_band(K: np.ndarray, var_real: np.ndarray, var_imag: np.ndarray, K_rich: np.ndarray,
                    var_rich: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """1-sigma bands of the chosen fit with the bias measured against a richer fit (module docstring).

    Parameters
    ----------
    K : ndarray, shape (F, n, n), complex
        Chosen estimate (per-term orders, or the Akaike average of uniform orders), N/m, N/rad, N*m/m, N*m/rad.
    var_real, var_imag : ndarray, shape (F, n, n)
        Its variance of the real and imaginary part (squared units of ``K``).
    K_rich : ndarray, shape (F, n, n), complex
        Estimate of the richer fit on the same data (the richest uniform order, or the order above the best).
    var_rich : ndarray, shape (F, n, n)
        ``E|dK|^2`` of the richer fit (circular: half in each part).

    Returns
    -------
    std_real, std_imag : ndarray, shape (F, n, n)
        ``sqrt(max(var_sel, var_rich / 2 + d^2))`` per part, ``d = K - K_rich``.
    """
    d = np.asarray(K) - np.asarray(K_rich)
    half = 0.5 * np.asarray(var_rich, float)
    std_re = np.sqrt(np.maximum(var_real, half + d.real ** 2))
    std_im = np.sqrt(np.maximum(var_imag, half + d.imag ** 2))
    return std_re, std_im
