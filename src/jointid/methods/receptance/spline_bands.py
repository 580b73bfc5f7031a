"""Bands of the joint spline fit: the bias of the chosen orders, measured against a richer fit.

:func:`~jointid.methods.receptance.spline_fit.fit_joint_spline` picks per-term orders (a score test from
the AIC's order up): a term left with fewer coefficients than the richest order fitted has a bias
that its own linearized band does not contain. On a 6-DOF mount (power-law modulus over 2-150 Hz,
``benchmarks/mount_6dof.py``) the exact-data bias of a 3-coefficient rotational term reaches
1.8 of its noise sigma, the 4-coefficient one 0.14; the 90 % bands of K_rx_rx, K_ry_ry covered
0.78, 0.74 (12 seeds) with per-term orders, 0.85, 0.75 with 4 everywhere.

The richest uniform fit (every term ``max_basis`` coefficients; the module's fits are nested, so
it holds every per-term model) is taken as unbiased in the class, and the difference of the two
estimates ``d = K_sel - K_rich`` as the measured bias of the chosen one. ``K_sel - K_true = b + e_sel``
(``b`` the chosen class's bias, ``e_sel ~ N(0, s^2)``) and ``d ~ N(b, tau^2)``, ``tau^2 = sigma_rich^2 -
s^2``, independent of ``e_sel`` (nested least squares: the smaller fit's error is uncorrelated with the
difference of the two fits, as in Hausman's test). The band of each part (real, imaginary) of each term
at each line is::

    sigma^2 = s^2 + max(0, q d^2 - c tau^2)          (q, c) from the table at rho = tau^2 / s^2

the narrowest band of that form (smallest expected width at ``b = 0``) whose coverage ``P(|b + e_sel|
<= 1.645 sigma)`` is >= 0.90 for every bias ``b``. ``benchmarks/spline_band_table.py`` searches ``(q, c)``
per node ``log10 rho = -3, -2.75, ..., 2`` (a quick quadrature as a guide), then lowers ``c`` until the
table as used here (interpolated linearly in ``log10 rho``, clamped outside) holds 0.90 at, between and
beyond the nodes by :func:`band_coverage` (exact over ``e_sel``, an accurate trapezoid rule over ``d``;
the guide's 80-point Gauss-Hermite rule said 0.900 where the coverage is 0.898, ``rho`` = 100, and the
clamp's limit needed ``c`` -0.981, not -0.959); ``tests/test_spline_fit.py`` checks >= 0.8999 for
``rho`` from 1e-4 to 1e4 and as ``rho -> inf``. Where ``d`` is precise (``rho -> 0``) ``q = 1.05``,
``c = 1``: ``s^2 + 1.05 d^2 - tau^2``, about the bias's unbiased square. The band it replaced,
``sigma_rich^2 + d^2`` (``q = 1``, ``c = -1``), held >= 0.90 too, with zero-bias coverage 0.927, 0.957,
0.990, 0.9997 at ``rho`` = 0.1, 0.3, 1, 3; this one 0.909, 0.923, 0.972, 0.998 with expected widths 6,
10, 8, 6 % smaller (``benchmarks/spline_band_table.py --check`` prints these). It cannot do much better:
a band that holds for every bias while ``d`` is noisier than the fit (``rho >~ 1``) must over-cover
where there is no bias (a bias of the size of that noise cannot be told from none). The estimate keeps
the smaller error of the chosen orders.

The same band is used for a uniform order chosen by the AIC: the richer fit is then the smallest
order whose class holds the best one (:func:`~.spline_fit.richer_nested_order`: the next order up to
4; above, the cubic splines on the best order's knots with every interval halved, ``2 nb - 3``,
fitted for the band alone from the best fit), ``d`` and ``tau^2`` are the best order's against it, and the bias term is added to the Akaike average's variance (the
average holds the richer order with its weight ``w``: its own difference from it, ``(1 - w) d``, is not
the nested one, and with ``w`` = 0.2-0.5 it covered 0.87-0.89). A joint whose
shape the cap cannot follow is biased by several of its own sigma although the AIC prefers 4 to 5:
one more coefficient on all 21 terms of a 6-DOF mount costs more than it gains on the one term that
needs it, and the richer class's extra directions are so poorly determined that no test on them
sees the bias (``benchmarks/spline_wide_band.py``: a stiffening ``1 + 0.3 (f / 100)^0.8`` over
10-400 Hz, K_x_x up to 6.7 sigma off with 4 coefficients; the diagonal terms' own bands cover
0.60-0.86 at 1 % noise, these 0.94-0.99). Cubic polynomials lie in the cubic B-splines with one
interior knot, so 4 is nested in 5 and the argument above holds; 5 and 6, 6 and 7 are not nested, but 5
is in 7 and 6 in 9. The next order, on other knots, was the reference once: ``tau^2`` is then not the variance
of ``d``, the band ``max(s^2, sigma_rich^2 + d^2)`` (still used where the line count leaves no room for
``2 nb - 3``), and where the joint's shape is hard to follow in ``log f`` the next order is biased
alike (a stiffness growing as ``f`` over 2-150 Hz on a 3-D frame, exact data: 6 coefficients
-2.1 sigma at 150 Hz, 7 -1.0, 9 -0.3), so ``d`` saw half the bias and K_x_x's real part covered 0.82
(21 seeds, 1 % noise); against ``2 nb - 3`` with the table, 0.92 (real parts of the diagonal terms
0.90-0.95, from 0.82-0.95; off-diagonal 0.90-0.92, from 0.88-0.93; ``benchmarks/README.md``). An order
past the cap that the AIC rejects stops after a few iterations (the well-determined directions,
which set ``d`` where the band is narrow, converge in them; the others enter through their
variance). Where the chosen class is right, the noise in ``d`` makes these bands conservative
(``benchmarks/mount_6dof.py``: 0.89-0.98 where 0.9 is nominal; 0.93-0.99 with the band it replaced).

Caveats: ``d`` is itself noisy, so where there is no bias the band over-covers as ``rho`` grows (above);
``tau^2`` is the difference of two linearized variances, exact for nested linear least squares only (a
negative one, e.g. an Akaike average's spread above the richer fit's variance, counts as 0); the
richest fit's own linearized band is too narrow by 5-20 % on the weakly seen terms of a mount whose true couplings are zero (the
information on a rotation grows as soon as a coupling estimate leaves zero, so the Jacobian at
the estimate overstates it); that part is not corrected separately: on the mount the noise in
``d`` widens the band by about as much (50 seeds, per-term orders only: 90 % bands cover 0.88-0.93 on
every diagonal term, 0.76-0.86 before; 0.89-0.93 on the off-diagonal ones; with the band at the cap
too, 0.93-0.99 and 0.94-0.99; with the table, 0.89-0.98 and 0.90-0.98).
"""

from __future__ import annotations

import numpy as np

__all__ = ["richer_fit_band", "bias_band_variance", "bias_band_table", "band_coverage", "Z90", "BIAS_BAND_LOG10_RHO", "BIAS_BAND_Q",
           "BIAS_BAND_C"]

#: Nodes ``log10 rho`` of the bias band's table, ``rho = tau^2 / s^2`` (:func:`bias_band_variance`).
BIAS_BAND_LOG10_RHO = np.arange(-3.0, 2.0001, 0.25)
#: ``q`` per node: the weight of the measured bias ``d^2`` (``benchmarks/spline_band_table.py`` prints them).
BIAS_BAND_Q = (1.05, 1.05, 1.05, 1.05, 1.05, 1.05, 1.10, 1.15, 1.25, 1.40, 1.70,
               1.80, 1.45, 1.30, 1.20, 1.15, 1.10, 1.05, 1.00, 1.00, 0.95)
#: ``c`` per node: the part of the bias's noise ``tau^2`` taken off (rounded down: the band errs wide).
BIAS_BAND_C = (0.9999, 0.9999, 0.9999, 0.9999, 0.9999, 0.9339, 0.9999, 0.9999, 0.9999, 0.9733, 0.9574,
               0.3891, -0.2405, -0.4439, -0.6197, -0.7217, -0.8052, -0.8706, -0.9276, -0.9491, -0.9805)


#: z of the two-sided 90 % band.
Z90 = 1.6448536269514722


def bias_band_table(rho: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(q, c)`` of the table at ``rho = tau^2 / s^2`` (interpolated in ``log10 rho``, clamped; 0 and below: the
    first node, inf: the last)."""
    rho = np.asarray(rho, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = np.log10(rho)
    lr = np.where(np.isfinite(lr), lr, np.where(rho > 0, BIAS_BAND_LOG10_RHO[-1], BIAS_BAND_LOG10_RHO[0]))
    return np.interp(lr, BIAS_BAND_LOG10_RHO, BIAS_BAND_Q), np.interp(lr, BIAS_BAND_LOG10_RHO, BIAS_BAND_C)


def band_coverage(q: float, c: float, rho: float, bias: np.ndarray) -> np.ndarray:
    """Coverage of the band ``z sqrt(1 + max(0, q d^2 - c rho))`` per bias ``b`` (in units of ``s``, shape (B,)).

    ``P(|b + e| <= band)``, ``e ~ N(0, 1)``, ``d ~ N(b, rho)`` independent: exact normal probabilities over
    ``e``, the trapezoid rule over ``x = (d - b) / sqrt(rho)`` on [-9, 9] (tails < 3e-19) with a step of at
    most 0.02 and ten points across the integrand's step (width ``~1 / (z sqrt(q rho))`` in ``x``, where
    ``|d|`` passes ``|b| / (z sqrt q)``). The integrand is smooth but for the kink of ``max`` (``c > 0``), so the
    rule's error is ``O(step^2)`` times that kink's slope jump: within 1.3e-6 of a rule of step 5e-4 on [-12, 12]
    (``rho`` = 1e-3, 0.1, 0.7, 5, 100, 1e4). ``rho = inf``: the limit ``e / tau -> 0``, in closed form (``b`` then in units of ``tau``).
    """
    b = np.atleast_1d(np.asarray(bias, float))
    from scipy.special import ndtr

    if np.isinf(rho):  # covered iff (b + x)^2 >= (b^2 / z^2 + c) / q
        r = np.sqrt(np.maximum((b ** 2 / Z90 ** 2 + c) / q, 0.0))
        return 1.0 - (ndtr(r - b) - ndtr(-r - b))
    step = min(0.02, 0.1 / (Z90 * np.sqrt(max(q, 1e-12) * max(rho, 1e-12))))
    n = int(np.ceil(18.0 / step)) + 1
    x = np.linspace(-9.0, 9.0, n)
    wx = np.exp(-0.5 * x ** 2) / np.sqrt(2.0 * np.pi) * (x[1] - x[0])
    wx[[0, -1]] *= 0.5
    out = np.empty(b.size)
    chunk = max(1, 4_000_000 // n)
    for i in range(0, b.size, chunk):
        bb = b[i:i + chunk, None]
        w = Z90 * np.sqrt(1.0 + np.maximum(0.0, q * (bb + np.sqrt(rho) * x) ** 2 - c * rho))
        out[i:i + chunk] = (ndtr(w - bb) - ndtr(-w - bb)) @ wx
    return out


def bias_band_variance(var: np.ndarray, tau2: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Band variance of one part of a fit whose bias is measured as ``d`` with noise ``tau2`` (module docstring).

    ``var + max(0, q d^2 - c tau^2)``, ``(q, c)`` interpolated in ``log10(tau2 / var)`` on the table
    (clamped outside it): the narrowest band of that form whose coverage is >= 0.90 for every bias.

    Parameters
    ----------
    var : ndarray
        Variance of the part (real or imaginary) of the chosen fit, > 0 (squared units of ``K``).
    tau2 : ndarray, same shape
        Variance of the part of ``d`` (the richer fit's minus the chosen one's; < 0 taken as 0).
    d : ndarray, same shape, real
        The part of ``K_sel - K_rich``.
    """
    var = np.asarray(var, float)
    tau2 = np.maximum(np.asarray(tau2, float), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        q, c = bias_band_table(np.where(tau2 > 0, tau2 / var, 0.0))
    return var + np.maximum(0.0, q * np.asarray(d, float) ** 2 - c * tau2)


def richer_fit_band(K: np.ndarray, var_real: np.ndarray, var_imag: np.ndarray, K_rich: np.ndarray,
                    var_rich: np.ndarray, nested: bool = True) -> tuple[np.ndarray, np.ndarray]:
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
    nested : bool
        The chosen fit's class lies in the richer one's (then ``d``'s variance is ``var_rich / 2 - var``).

    Returns
    -------
    std_real, std_imag : ndarray, shape (F, n, n)
        Per part, ``d = K - K_rich``: nested, ``sqrt(bias_band_variance(var, var_rich / 2 - var, d))``; else
        ``sqrt(max(var, var_rich / 2 + d^2))`` (the noise of ``d`` unknown: all of the richer fit's counted).
    """
    d = np.asarray(K) - np.asarray(K_rich)
    half = 0.5 * np.asarray(var_rich, float)
    if not nested:
        return np.sqrt(np.maximum(var_real, half + d.real ** 2)), np.sqrt(np.maximum(var_imag, half + d.imag ** 2))
    std_re = np.sqrt(bias_band_variance(var_real, half - var_real, d.real))
    std_im = np.sqrt(bias_band_variance(var_imag, half - var_imag, d.imag))
    return std_re, std_im
