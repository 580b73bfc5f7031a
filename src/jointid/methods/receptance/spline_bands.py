"""Bands of the joint spline fit: the bias of the chosen orders, measured against richer fits one term at a time.

:func:`~jointid.methods.receptance.spline_fit.fit_joint_spline` picks per-term orders (a score test from
the AIC's order up) or one uniform order: a term's class may be too small for the joint's shape, a bias that
its own linearized band does not contain. On a 6-DOF mount (power-law modulus over 2-150 Hz,
``benchmarks/mount_6dof.py``) the exact-data bias of a 3-coefficient rotational term reaches 1.8 of its noise
sigma; on a stiffening joint over 10-400 Hz (``benchmarks/spline_wide_band.py``) the 4-coefficient K_x_x is
1-3 sigma off, and the own bands of the diagonal terms cover 0.62-0.90 where 0.90 is nominal.

**The richer fits** (:func:`one_term_bias_variance`). For each term ``j`` in turn, the fit with that term alone
given its richer class (per-term orders: its missing coefficients up to the richest order; a uniform order
``nb``: :func:`~.spline_fit.richer_nested_order`, whose space holds ``nb``'s, via :func:`nested_extension`) is
nested around the chosen one, so ``d_tj = K_sel,t - K_j,t`` is a measured bias of term ``t`` with noise
``tau_tj^2 = sigma_j,t^2 - s_t^2`` independent of the chosen fit's error (nested least squares: the smaller fit's
error is uncorrelated with the difference of the two, as in Hausman's test). It is one Gauss-Newton step from
the chosen fit (partitioned normal equations), not another fit. Per line and part (real, imaginary)::

    sigma_t^2 = s_t^2 + sum_j max(0, q d_tj^2 - c tau_tj^2)      (q, c) from the table at rho = tau_tj^2 / s_t^2

Why one term at a time: the extra directions of every term together (the uniform richer order, the reference
until 2026-11-28) are so poorly determined that their ``d`` is noisier than the fit itself (``rho`` 3.6-9.8 on
the mount's rotations) and a band that holds for every bias then over-covers where there is none (0.96-0.98,
``benchmarks/README.md``); one term's extra direction is 2-100 times better determined. Why the sum over ``j``:
a term is also biased through the other terms' coefficients (the mount's K_x_x: own enrichment alone 0.82 on the
seeds with 4 coefficients everywhere), and where every term has the same shape error (the stiffening joint) the
sources add; the maximum over ``j`` left K_z_z, K_rx_rx at 0.84, 0.82 there. Measured (``benchmarks/README.md``):
the mount, 50 seeds, diagonal 0.87-0.93 (was 0.89-0.98), off-diagonal 0.88-0.93; the stiffening frame 0.88-0.97
at 1 % noise, 0.93-0.96 at 0.1 % (was 0.94-0.98, 0.96-0.99).

**The band per measured bias** (:func:`bias_band_variance`). ``K_sel - K_true = b + e_sel`` (``e_sel ~ N(0, s^2)``)
and ``d ~ N(b, tau^2)``. The band ``s^2 + max(0, q d^2 - c tau^2)`` with ``(q, c)`` from the table is the
narrowest of that form (smallest expected width at ``b = 0``) whose coverage ``P(|b + e_sel| <= 1.645 sigma)``
is >= 0.90 for every bias ``b``. ``benchmarks/spline_band_table.py`` searches ``(q, c)`` per node
``log10 rho = -3, -2.75, ..., 2`` (a quick quadrature as a guide), then lowers ``c`` until the table as used
here (interpolated linearly in ``log10 rho``, clamped outside) holds 0.90 at, between and beyond the nodes by
:func:`band_coverage` (exact over ``e_sel``, an accurate trapezoid rule over ``d``); ``tests/test_spline_fit.py``
checks >= 0.8999 for ``rho`` from 1e-4 to 1e4 and as ``rho -> inf``. Where ``d`` is precise (``rho -> 0``)
``q = 1.05``, ``c = 1``: ``s^2 + 1.05 d^2 - tau^2``, about the bias's unbiased square. A band of this form that
holds for every bias must over-cover where there is none once ``d`` is noisier than the fit (``rho >~ 1``):
a bias of the size of that noise cannot be told from none (``spline_band_table.py --tradeoff``).

For a uniform order the bias term is added to the Akaike average's variance (the average holds other orders
with their weights: its own difference from a richer fit is not the nested ``d``). Where the line count leaves
no room for the nested class, the next order is fitted uniformly and all of its variance is counted
(:func:`richer_fit_band` with ``nested=False``: ``max(var, var_rich / 2 + d^2)``).

Caveats: a bias that shows only when several terms are enriched at once is seen only in the sum of their
single contributions (opposite contributions are counted as if they added: conservative); ``tau^2`` is the
difference of two linearized variances, exact for nested linear least squares only (a negative one counts as
0); the chosen fit's own linearized band is too narrow on the weakly seen terms of a mount whose true couplings
are zero (the information on a rotation grows as soon as a coupling estimate leaves zero, so the Jacobian at the
estimate overstates it; on the mount's seeds with 4 coefficients everywhere the 4-coefficient fit's errors are
1.1-1.2 of its sigma with no bias on exact data); that part is not corrected separately.
"""

from __future__ import annotations

import numpy as np

__all__ = ["richer_fit_band", "one_term_bias_variance", "nested_extension", "normal_inverse", "bias_band_variance", "bias_band_table", "band_coverage", "Z90", "BIAS_BAND_LOG10_RHO", "BIAS_BAND_Q",
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


def normal_inverse(N: np.ndarray) -> np.ndarray:
    """Inverse of a Hermitian positive (semi)definite normal matrix, diagonally equilibrated (pseudo-inverse if singular)."""
    d = np.sqrt(np.maximum(np.real(np.diagonal(N)), 1e-300))
    Ns = N / d[:, None] / d[None, :]
    Ns = 0.5 * (Ns + Ns.conj().T)
    try:
        inv = np.linalg.inv(Ns)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(Ns, hermitian=True)
    return inv / d[:, None] / d[None, :]


def nested_extension(basis: np.ndarray, rich: np.ndarray) -> np.ndarray:
    """The functions of ``rich``'s space outside ``basis``'s, shape (F, k), ``k = rich.shape[1] - basis.shape[1]``.

    ``basis`` (F, nb) must lie in the span of ``rich`` (F, nb + k) (nested orders, e.g. 4 in 5 or 6 in 9):
    the orthonormal complement of ``span(basis)`` there, times ``sqrt(F)`` (unit mean square per line).
    """
    q, _ = np.linalg.qr(basis)
    u, _, _ = np.linalg.svd(rich - q @ (q.T @ rich), full_matrices=False)
    return u[:, : rich.shape[1] - basis.shape[1]] * np.sqrt(basis.shape[0])


def one_term_bias_variance(N: np.ndarray, grad: np.ndarray, basis: np.ndarray, active: np.ndarray, s2: float,
                           pairs: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The bias part of each term's band, measured against the fits with one term at a time given its richer class.

    The chosen fit has the coefficients ``active`` of a term-major layout over ``basis`` (``p`` terms, ``nb`` functions
    each); the fit with term ``j``'s inactive coefficients ``E_j`` freed too is nested around it, one Gauss-Newton step
    away (partitioned normal equations, ``C = N_AA^-1``, ``S_j = N_EE - N_EA C N_AE``)::

        gamma_j = -S_j^-1 (g_E - N_EA C g_A),    delta_A = -C (g_A + N_AE gamma_j)

    so ``d_tj = K_sel,t - K_j,t`` (``-B (delta, gamma)`` on term ``t``'s rows) and its noise
    ``tau^2_tj = s^2 u S_j^-1 u^H``, ``u = B_E [t = j] - B_A C N_AE`` (the richer fit's variance less the chosen
    one's). Per term ``t``, line and part (real, imaginary: half of each) the bias part is
    ``sum_j (bias_band_variance(var, tau^2 / 2, d) - var)`` (:func:`bias_band_variance`; ``var`` the chosen fit's):
    why one term at a time and why the sum, in the module docstring. Caveat: the step is exact for a linear model;
    here the residual is nonlinear in ``K``, so ``d`` is the linearized richer fit's (``rho = tau^2 / s^2`` of the
    term's own enrichment 0.02-1.7 on the mount's diagonal terms, ``benchmarks/mount_6dof.py``).

    Parameters
    ----------
    N, grad : ndarray, shapes (P, P), (P,), complex
        ``J^H J`` and ``J^H r`` of the coefficients at the chosen fit's ``K`` (``P = p nb``, term-major), unit noise scale.
    basis : ndarray, shape (F, nb)
        The functions of every term (the chosen ones and the richer class's extra ones).
    active : ndarray of bool, shape (P,)
        The chosen fit's coefficients; a term without inactive ones gets no richer fit.
    s2 : float
        The noise scale (``chi^2 / (N - P_active)``).
    pairs : (ndarray, ndarray)
        Row and column of each term in ``K`` (a symmetric joint's upper triangle is mirrored).

    Returns
    -------
    bias_real, bias_imag : ndarray, shape (F, n, n)
        Variance to add to each part's ``var`` (>= 0, squared units of ``K``).
    """
    F, nb = basis.shape
    P = active.size
    p = P // nb
    term, func = np.arange(P) // nb, np.arange(P) % nb
    A = np.flatnonzero(active)
    C = normal_inverse(N[np.ix_(A, A)])
    gA = grad[A]

    def on_terms(v):  # coefficients on A, shape (|A|, ...) -> term values (F, p, ...)
        full = np.zeros((P,) + v.shape[1:], complex)
        full[A] = v
        return np.einsum("fb,tb...->ft...", basis, full.reshape((p, nb) + v.shape[1:]))

    C_all = np.zeros((P, P), complex)  # C on every coefficient (0 for the inactive ones)
    C_all[np.ix_(A, A)] = C
    blocks = C_all.reshape(p, nb, p, nb)[np.arange(p), :, np.arange(p), :]  # (p, nb, nb): each term's own block
    var = 0.5 * s2 * np.einsum("fk,tkl,fl->ft", basis, blocks, basis).real  # b_A,t C b_A,t^H / 2, O(F p) memory
    extra = [np.zeros((F, p)), np.zeros((F, p))]
    for j in range(p):
        E = np.flatnonzero(~active & (term == j))
        if E.size == 0:
            continue
        NAE = N[np.ix_(A, E)]
        M = C @ NAE  # (|A|, k)
        Si = normal_inverse(N[np.ix_(E, E)] - NAE.conj().T @ M)
        gamma = -Si @ (grad[E] - M.conj().T @ gA)
        dK = on_terms(-C @ gA - M @ gamma)
        BE = basis[:, func[E]]
        dK[:, j] += BE @ gamma
        U = -on_terms(M)
        U[:, j] += BE
        tau2 = 0.5 * s2 * np.einsum("ftk,kl,ftl->ft", U, Si, U.conj()).real
        for out, d in zip(extra, (-dK.real, -dK.imag)):
            out += bias_band_variance(var, tau2, d) - var
    ia, ib = pairs
    n = int(max(ia.max(), ib.max())) + 1
    square = np.zeros((2, F, n, n))
    square[:, :, ib, ia] = square[:, :, ia, ib] = np.stack(extra)
    return square[0], square[1]
