"""A joint's dynamic stiffness as a few B-splines in log frequency, fitted to every line's FRFs at once.

With ``Y`` the free structure's receptance and ``H`` the measured receptance of the
jointed structure on observed m x excited e DOFs, a joint ``K`` on the joint DOFs n
predicts (receptance coupling, Sherman-Morrison-Woodbury)::

    H[m,e] = Y[m,e] - Y[m,n] X Y[n,e],     X = (Y[n,n] + K^-1)^-1 = (I + K Y[n,n])^-1 K

Here every term of ``K`` (each of the ``p = n(n+1)/2`` terms of a symmetric joint) is
a short complex B-spline series in ``u = log f``::

    K_ab(f) = sum_k c_abk B_k(log f),    k = 1..nb

(``nb = 1``: a constant; ``nb <= 4``: a polynomial of degree ``nb - 1`` in ``log f``
(Bernstein basis); more: cubic B-splines on uniform knots in ``log f``). The complex
coefficients ``c`` are fitted to all lines jointly by Levenberg-Marquardt on the
whitened residual ``w (Y[m,e] - H - Y[m,n] X(K) Y[n,e])``, ``w = 1 / sqrt(var H)``.
The model is holomorphic in ``c``, so the Gauss-Newton step is the complex one,
``(J^H J + mu D) dc = -J^H r``, with ``dr = -(Y[m,n] L) dK (R Y[n,e])``,
``L = (I + K Y[n,n])^-1``, ``R = (I + Y[n,n] K)^-1 = I - Y[n,n] X`` (``dX = L dK R``; the product's cancellation,
``eps |Y X| / |R|`` relative, reaches only the Jacobian, never the residual). The normal matrix is built from per-line
``p x p`` blocks (no Python loop over lines).

Why a joint fit: per line, a weakly seen term (a mount's rotation the measured translations hardly
feel) has an error of the order of the term itself, far from Gaussian, and smoothing those estimates
keeps their bias; here the whole band informs each coefficient and the bands come from the FRF noise.

Procedure (:func:`fit_joint_spline`):

1. a constant joint (``nb = 1``) from several starts - the componentwise median of a
   per-line estimate, and :data:`STARTS` log-normal perturbations of its diagonal with
   the couplings shrunk - keeping the lowest cost (the cost has local minima in the
   weakly seen terms);
2. ``nb = 2, 3, ...`` up to ``max_basis``, each from the previous fit projected (nested up to 4, and
   4 in 5); while the richest order tried is the AIC's best, one more, at most
   :data:`MAX_EXTENDED_BASIS` and ``F / 4`` (an order past the cap gets :data:`EXTENSION_ITERATIONS`
   first, and converges only if it already beats every order: a rejected one's AIC is an upper bound);
3. the order with the lowest AIC, ``2 N log(chi^2) + 4 P`` (N complex values, P complex
   coefficients; the noise scale is estimated, so only the weights' shape must be right);
4. covariance ``cov(c) = s^2 (J^H J)^-1`` with ``s^2 = chi^2 / (N - P)``, errors circular
   (half the variance in each part), propagated to ``std_real``/``std_imag`` per term and line;
   each part's variance is ``var + sum_j max(0, q d_j^2 - c tau_j^2)`` (the bias of the chosen class,
   :func:`~.spline_bands.one_term_bias_variance`), ``d_j`` the difference from the fit with term ``j`` alone in
   its richer class (one Gauss-Newton step), ``tau_j^2`` its noise: with per-term orders a term's missing
   coefficients up to the richest order; else the smallest richer order that holds the AIC's best
   (:func:`richer_nested_order`: the next one up to 4, ``2 nb - 3`` above), that bias term added to the Akaike
   average's ``var``. Where the line count leaves no room for ``2 nb - 3``, the next order fitted uniformly, its
   whole variance counted (``max(var, var_rich / 2 + d^2)``).

Units: ``frequency_hz`` in Hz; receptances in m/N, rad/N, m/(N*m), rad/(N*m); ``K`` in
N/m, N/rad, N*m/m, N*m/rad; ``variance`` in the squared units of ``H``.

Caveats: the bands hold when the joint is smooth in ``log f`` (a power-law or fractional modulus is;
an internal resonance of the joint inside the band is not) and the free model is right (its error is
not in them), and while the predicted relative errors are small (linearization). The multi-start finds
the global constant fit with high probability, not certainty; ``converged``: LM stopped on a small step.
"""

from __future__ import annotations

import numpy as np

from .smoothing import bspline_basis
from .spline_bands import nested_extension, normal_inverse, one_term_bias_variance, richer_fit_band
from .spline_result import JointSplineFit

__all__ = ["JointSplineFit", "fit_joint_spline", "log_frequency_basis", "legendre_log_basis", "richer_nested_order", "spline_covariance",
           "term_variance",
           "DEFAULT_MAX_BASIS", "MAX_EXTENDED_BASIS", "MAX_ITERATIONS", "EXTENSION_ITERATIONS", "STARTS"]

#: Most B-splines per term that :func:`fit_joint_spline` tries by default (orders 1..this, by AIC).
DEFAULT_MAX_BASIS = 4
#: Most B-splines per term when the AIC is best at the richest order tried (then added one at a time, <= F / 4).
MAX_EXTENDED_BASIS = 12
#: Levenberg-Marquardt iterations per order (at most).
MAX_ITERATIONS = 200
#: Iterations of an order past the cap before its AIC is compared (then to convergence only if the best: a rejected
#: one's AIC is an upper bound; its weakly seen directions crawl, 49 iterations on mount_6dof.py).
EXTENSION_ITERATIONS = 20
#: Perturbed starts of the constant fit, besides the per-line median itself.
STARTS = 8
#: Standard deviation of the log-normal factor on each diagonal term of a perturbed start.
START_SPREAD = 1.5
#: Iterations of each start before the best is refined (from where it stopped).
START_ITERATIONS = 15
#: A term gets another coefficient when its score statistic exceeds this times s^2 (the AIC's 2 per complex coefficient).
SCORE_THRESHOLD = 2.0
#: Orders whose Akaike weight is below this are left out of the average.
AVERAGE_MIN_WEIGHT = 1e-6
#: Finite-difference step (times the LM step) of the geodesic acceleration.
ACCELERATION_STEP = 0.1
#: The acceleration is used while ``2 |a| <= ACCELERATION_RATIO |v|`` (scaled norms).
ACCELERATION_RATIO = 0.75
#: LM stops when the scaled step is below this (relative to the scaled coefficients) or the cost stops falling by more.
STEP_TOLERANCE = 1e-10


def log_frequency_basis(frequency_hz: np.ndarray, n_basis: int) -> np.ndarray:
    """B-splines in ``log f`` over the band, shape (F, n_basis), dense.

    ``n_basis = 1``: ones; ``2..4``: Bernstein polynomials of degree ``n_basis - 1`` in
    ``log f`` (nested: each order holds the previous one); more: cubic B-splines on
    uniform knots in ``log f``. Frequencies must be > 0 Hz and increasing.
    """
    f = np.asarray(frequency_hz, float)
    if n_basis < 1:
        raise ValueError(f"n_basis must be >= 1, got {n_basis}")
    if n_basis == 1:
        return np.ones((f.size, 1))
    return bspline_basis(np.log(f), n_basis, degree=min(3, n_basis - 1)).toarray()


def legendre_log_basis(frequency_hz: np.ndarray, n_basis: int) -> np.ndarray:
    """Legendre polynomials ``P_0..P_{n_basis-1}`` of ``log f`` mapped to [-1, 1], shape (F, n_basis).

    The same space as :func:`log_frequency_basis` for ``n_basis <= 4``, but hierarchical: a term
    with ``k`` coefficients uses the first ``k`` columns (per-term orders).
    """
    u = np.log(np.asarray(frequency_hz, float))
    u = 2.0 * (u - u[0]) / (u[-1] - u[0]) - 1.0 if u.size > 1 else np.zeros_like(u)
    return np.polynomial.legendre.legvander(u, n_basis - 1)


def _pairs(n: int, symmetric: bool) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of each parametrized term: the upper triangle row by row, or every entry."""
    if symmetric:
        return np.triu_indices(n)
    a, b = np.indices((n, n))
    return a.ravel(), b.ravel()


def _stiffness(coef: np.ndarray, basis: np.ndarray, pairs, n: int, symmetric: bool = True) -> np.ndarray:
    """``K(f)`` (F, n, n) from coefficients (p, nb) on ``basis`` (F, nb); symmetric: the upper triangle mirrored."""
    ia, ib = pairs
    terms = basis @ coef.T  # (F, p)
    K = np.zeros((basis.shape[0], n, n), complex)
    if symmetric:
        K[:, ib, ia] = terms
    K[:, ia, ib] = terms
    return K


class _Problem:
    """The whitened data of one fit and its residual and per-line Jacobian at a joint ``K``."""

    def __init__(self, Ymn, Ynn, Yne, change, weight, symmetric: bool):
        self.Ymn, self.Ynn, self.Yne = Ymn, Ynn, Yne
        self.change, self.weight = change, weight  # change = Y[m,e] - H; weight = 1/sqrt(var), 0 for unused values
        self.n = Ynn.shape[1]
        self.pairs = _pairs(self.n, symmetric)
        self.symmetric = symmetric
        self.count = int(np.count_nonzero(weight))

    def residual(self, K: np.ndarray, factors: bool = True) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Whitened residual (F, m, e) and ``A = Y[m,n] L``, ``B = R Y[n,e]`` at ``K`` (None, None if not ``factors``:
        the cost and the acceleration's residual need ``r`` only)."""
        eye = np.eye(self.n)
        L = np.linalg.inv(eye + K @ self.Ynn)
        X = L @ K
        r = (self.change - self.Ymn @ X @ self.Yne) * self.weight
        if not factors:
            return r, None, None
        R = eye - self.Ynn @ X  # = (I + Y[n,n] K)^-1 (module docstring): a product instead of a second inverse
        return r, self.Ymn @ L, R @ self.Yne

    def cost(self, K: np.ndarray) -> float:
        """Whitened residual sum of squares at ``K`` (inf where ``I + K Y[n,n]`` is singular)."""
        with np.errstate(all="ignore"):
            try:
                r = self.residual(K, factors=False)[0]
            except np.linalg.LinAlgError:
                return np.inf
        c = float(np.sum(r.real ** 2 + r.imag ** 2))
        return c if np.isfinite(c) else np.inf

    def line_jacobian(self, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Whitened ``d r / d K_t`` per line, shape (F, m*e, p): ``-w (A E_t B)`` (``E_t`` the term's unit pattern)."""
        ia, ib = self.pairs
        Bt = B.transpose(0, 2, 1)  # (F, e, n)
        G = A[:, :, None, ia] * Bt[:, None, :, ib]  # (F, m, e, p): A[i, a] B[b, j]
        if self.symmetric:
            off = ia != ib
            G[..., off] += A[:, :, None, ib[off]] * Bt[:, None, :, ia[off]]
        G *= -self.weight[..., None]
        F, m, e, p = G.shape
        return G.reshape(F, m * e, p)

    def normal(self, K: np.ndarray, basis: np.ndarray):
        """Whitened residual, ``J^H J`` (P, P) and ``J^H r`` (P,) for coefficients on ``basis`` (term-major)."""
        r, A, B = self.residual(K)
        G = self.line_jacobian(A, B)
        GH = np.conj(np.swapaxes(G, 1, 2))
        M = GH @ G  # per-line p x p
        g = (GH @ r.reshape(r.shape[0], -1, 1))[:, :, 0]
        F, p, nb = G.shape[0], G.shape[2], basis.shape[1]
        BB = (basis[:, :, None] * basis[:, None, :]).reshape(F, nb * nb)  # sum over lines as one product (10x einsum's)
        N = (M.reshape(F, p * p).T @ BB).reshape(p, p, nb, nb).transpose(0, 2, 1, 3).reshape(p * nb, p * nb)
        grad = (g.T @ basis).reshape(p * nb)
        return r, N, grad, G


def _terms(step: np.ndarray, basis: np.ndarray, p: int) -> np.ndarray:
    """Term values (F, p) of a coefficient vector (p * nb,) on ``basis``."""
    return basis @ step.reshape(p, -1).T


def _levenberg_marquardt(problem: _Problem, coef: np.ndarray, basis: np.ndarray, iterations: int, active=None):
    """Minimize the whitened cost over the coefficients (p, nb) from ``coef``; returns (coef, cost, converged).

    ``active`` (bool, p * nb), optional: only those coefficients move (the others keep their values).

    Levenberg-Marquardt with Marquardt's diagonal scaling and geodesic acceleration
    (Transtrum & Sethna 2012): the second directional derivative of the residual along
    the step, by one extra residual, bends the step along the cost's curved valleys,
    where the weakly seen terms make plain LM crawl.
    """
    n, sym = problem.n, problem.symmetric
    p, nb = coef.shape
    x = coef.reshape(-1).astype(complex)
    K = _stiffness(coef, basis, problem.pairs, n, sym)
    cost = problem.cost(K)
    if not np.isfinite(cost):
        return coef, cost, False
    mu, converged = 1e-3, False
    eye = np.eye(x.size)
    for _ in range(iterations):
        r, N, grad, G = problem.normal(K, basis)
        if active is not None:
            N, grad = _restrict(N, grad, active)
        d = np.sqrt(np.maximum(np.real(np.diagonal(N)), 1e-300))
        Ns = N / d[:, None] / d[None, :]
        gs = grad / d
        rflat = r.reshape(r.shape[0], -1)
        accepted = False
        for _ in range(40):
            try:
                lhs = Ns + mu * eye
                z = np.linalg.solve(lhs, -gs)
            except np.linalg.LinAlgError:
                mu *= 10.0
                continue
            v = z / d
            # geodesic acceleration: r'' along v by a finite difference of the residual
            h = ACCELERATION_STEP
            try:
                rh = problem.residual(_stiffness((x + h * v).reshape(p, nb), basis, problem.pairs, n, sym), factors=False)[0]
            except np.linalg.LinAlgError:
                rh = None
            step = v
            if rh is not None:
                Jv = np.einsum("fkt,ft->fk", G, _terms(v, basis, p))
                rpp = (2.0 / h) * ((rh.reshape(rflat.shape) - rflat) / h - Jv)
                ga = np.einsum("ft,fk->tk", np.einsum("fkt,fk->ft", G.conj(), rpp), basis).reshape(-1)
                if active is not None:
                    ga = np.where(active, ga, 0.0)
                za = np.linalg.solve(lhs, -ga / d)
                if np.all(np.isfinite(za)) and 2.0 * np.linalg.norm(za) <= ACCELERATION_RATIO * np.linalg.norm(z):
                    step = v + 0.5 * za / d
            x_new = x + step
            K_new = _stiffness(x_new.reshape(p, nb), basis, problem.pairs, n, sym)
            cost_new = problem.cost(K_new)
            if cost_new <= cost:
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            converged = True  # no step lowers the cost: a minimum to round-off
            break
        small = np.linalg.norm(step * d) <= STEP_TOLERANCE * (1.0 + np.linalg.norm(x * d))
        flat = cost - cost_new <= STEP_TOLERANCE * cost
        x, K, cost = x_new, K_new, cost_new
        mu = max(mu / 5.0, 1e-12)
        if small or (flat and mu < 1e-4) or cost == 0.0:
            converged = True
            break
    return x.reshape(p, nb), cost, converged


def _per_term_orders(problem: _Problem, coef: np.ndarray, basis_from: np.ndarray, f: np.ndarray, max_basis: int):
    """From a uniform fit, add one coefficient at a time to the terms whose score test says it lowers the AIC.

    On the Legendre basis (hierarchical), the score statistic of the next coefficient ``j`` of a
    term at the current fit is the predicted fall of the cost, ``|g_j - N_ja N_aa^-1 g_a|^2 /
    (N_jj - N_ja N_aa^-1 N_aj)``; every term whose statistic exceeds :data:`SCORE_THRESHOLD`
    times ``s^2`` gets it, then all are refitted, until none does. Returns
    (coef (p, max_basis), cost, converged, basis, active (p * max_basis,), orders (p,)).
    """
    p = coef.shape[0]
    basis = legendre_log_basis(f, max_basis)
    orders = np.full(p, basis_from.shape[1])
    coef = _project(coef, basis_from, basis)
    col = np.tile(np.arange(max_basis), p)
    term = np.repeat(np.arange(p), max_basis)
    active = col < orders[term]
    coef = np.where(active.reshape(p, max_basis), coef, 0.0)
    coef, cost, converged = _levenberg_marquardt(problem, coef, basis, MAX_ITERATIONS, active)
    for _ in range(p * max_basis):
        K = _stiffness(coef, basis, problem.pairs, problem.n, problem.symmetric)
        _, N, grad, _ = problem.normal(K, basis)
        s2 = cost / max(problem.count - int(active.sum()), 1)
        a = np.flatnonzero(active)
        cand = np.flatnonzero(~active & (col == orders[term]))
        if cand.size == 0:
            break
        inv = normal_inverse(N[np.ix_(a, a)])
        Nja = N[np.ix_(cand, a)]
        g = grad[cand] - Nja @ (inv @ grad[a])
        schur = np.real(N[cand, cand] - np.einsum("ja,ab,jb->j", Nja, inv, Nja.conj()))
        score = np.abs(g) ** 2 / np.maximum(schur, 1e-300)
        add = cand[score > SCORE_THRESHOLD * s2]
        if add.size == 0:
            break
        active[add] = True
        orders[term[add]] += 1
        coef, cost, converged = _levenberg_marquardt(problem, coef, basis, MAX_ITERATIONS, active)
    return coef, cost, converged, basis, active, orders


def _restrict(N: np.ndarray, grad: np.ndarray, active: np.ndarray):
    """Normal matrix and gradient with the inactive coefficients held fixed (identity rows, zero gradient)."""
    N = np.where(active[:, None] & active[None, :], N, 0.0)
    N[~active, ~active] = 1.0
    return N, np.where(active, grad, 0.0)


def _constant_starts(initial: np.ndarray, pairs, rng: np.random.Generator, starts: int) -> list[np.ndarray]:
    """Starting coefficients (p, 1) of the constant fit: the per-line median and perturbations of it."""
    ia, ib = pairs
    vals = initial[:, ia, ib]
    med = np.nanmedian(vals.real, axis=0) + 1j * np.nanmedian(vals.imag, axis=0)
    med = np.where(np.isfinite(med), med, 0.0)
    diag = ia == ib
    # a diagonal term whose median is not a positive stiffness: start from the magnitude of it
    scale = np.nanmedian(np.abs(vals), axis=0)
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    bad = diag & ~(med.real > 0)
    med[bad] = scale[bad] * (1 + 0.1j)
    out = [med[:, None].copy()]
    for _ in range(starts):
        c = med.copy()
        c[diag] = c[diag] * np.exp(START_SPREAD * rng.standard_normal(int(diag.sum())))
        c[~diag] = c[~diag] * rng.uniform(0.0, 1.0, int((~diag).sum()))
        out.append(c[:, None])
    return out


def richer_nested_order(n_basis: int) -> int:
    """The smallest richer order of :func:`log_frequency_basis` whose space holds order ``n_basis``'s.

    Up to 4 (polynomials of ``log f``) the next order; above, the cubic splines on the same uniform knots with every
    interval halved: ``k`` interior knots at ``i / (k + 1)`` lie among the ``2 k + 1`` at ``i / (2 k + 2)``, so order
    ``nb`` (``k = nb - 4``) is held by ``2 nb - 3`` (5 in 7, 6 in 9, 7 in 11), not by ``nb + 1``.
    """
    return n_basis + 1 if n_basis <= 4 else 2 * n_basis - 3


def _project(coef: np.ndarray, basis_from: np.ndarray, basis_to: np.ndarray) -> np.ndarray:
    """Coefficients on ``basis_to`` of the series ``basis_from @ coef.T`` (least squares over the lines)."""
    values = basis_from @ coef.T  # (F, p)
    sol = np.linalg.lstsq(basis_to, values, rcond=None)[0]
    return sol.T.copy()


def spline_covariance(problem_or_data, K: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``(J^H J)^-1`` (P, P) of the coefficients on ``basis`` at the joint ``K`` (unit noise scale).

    ``problem_or_data``: a tuple ``(Ymn, Ynn, Yne, variance, symmetric)``. With the true
    variance and the true joint, the per-term variance this gives (:func:`term_variance`)
    is the Cramer-Rao bound of the spline class of that order.
    """
    Ymn, Ynn, Yne, variance, symmetric = problem_or_data
    weight = _weights(variance)
    problem = _Problem(Ymn, Ynn, Yne, np.zeros_like(variance, complex), weight, symmetric)
    _, N, _, _ = problem.normal(K, basis)
    return normal_inverse(N)


def term_variance(covariance: np.ndarray, basis: np.ndarray, n: int, symmetric: bool = True) -> np.ndarray:
    """``E|dK_ab(f)|^2`` (F, n, n) from the coefficients' covariance on ``basis``."""
    nb = basis.shape[1]
    ia, ib = _pairs(n, symmetric)
    p = ia.size
    blocks = covariance.reshape(p, nb, p, nb)[np.arange(p), :, np.arange(p), :]  # (p, nb, nb)
    v = np.einsum("fk,tkl,fl->ft", basis, blocks, basis).real
    out = np.zeros((basis.shape[0], n, n))
    if symmetric:
        out[:, ib, ia] = v
    out[:, ia, ib] = v
    return np.maximum(out, 0.0)


def _weights(variance: np.ndarray) -> np.ndarray:
    """``1 / sqrt(variance)``; zero for non-finite or non-positive variances (those values are not used)."""
    v = np.asarray(variance, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isfinite(v) & (v > 0), 1.0 / np.sqrt(np.abs(v)), 0.0)


def _aic_and_scale(cost: float, count: int, P: int) -> tuple[float, float]:
    """``(AIC, s^2)`` of a fit: ``2 N log(cost) + 4 P`` (N complex values, P complex coefficients) and ``cost / (N - P)``."""
    return float(2.0 * count * np.log(max(cost, 1e-300)) + 4.0 * P), float(cost / max(count - P, 1))


def _best_order(criterion: dict):
    """The key of the lowest AIC."""
    return min(criterion, key=lambda k: criterion[k][0])


def _estimate_and_variance(problem: _Problem, fit: tuple, count: int, n: int) -> tuple:
    """One order's fit ``(coef, cost, converged, basis)``: ``K`` (F, n, n), ``E|dK|^2`` (F, n, n), the coefficients'
    covariance and ``s^2 = cost / (N - P)`` (its scale)."""
    coef, cost, _, basis = fit
    s2 = _aic_and_scale(cost, count, coef.size)[1]
    K = _stiffness(coef, basis, problem.pairs, n, problem.symmetric)
    cov = s2 * normal_inverse(problem.normal(K, basis)[1])
    return K, term_variance(cov, basis, n, problem.symmetric), cov, s2


def _averaged(problem: _Problem, fits: dict, criterion: dict, best: int, average: bool, count: int, n: int):
    """Estimate, std (real, imag), covariance of the chosen order and s^2: with ``average``, the orders averaged by
    Akaike weight and the spread between them (a lower order's bias) added to the bands."""
    aic = np.array([criterion[k][0] for k in fits])
    weights = np.exp(-(aic - aic.min()) / 2.0) if average else (np.array(list(fits)) == best).astype(float)
    weights /= weights.sum()
    parts = {}
    for (nb, fit), w in zip(fits.items(), weights):
        if w < AVERAGE_MIN_WEIGHT and nb != best:
            continue
        parts[nb] = (w, *_estimate_and_variance(problem, fit, count, n))
    total = sum(v[0] for v in parts.values())
    K = sum(v[0] * v[1] for v in parts.values()) / total
    var_re = sum(v[0] * (v[2] / 2.0 + (v[1] - K).real ** 2) for v in parts.values()) / total
    var_im = sum(v[0] * (v[2] / 2.0 + (v[1] - K).imag ** 2) for v in parts.values()) / total
    return K, np.sqrt(var_re), np.sqrt(var_im), parts[best][3], parts[best][4]


def fit_joint_spline(
    frequency_hz,
    Ymn: np.ndarray,
    Ynn: np.ndarray,
    Yne: np.ndarray,
    Yme: np.ndarray,
    H: np.ndarray,
    variance: np.ndarray,
    symmetric: bool = True,
    max_basis: int = DEFAULT_MAX_BASIS,
    initial: np.ndarray | None = None,
    starts: int = STARTS,
    seed: int = 0,
    n_basis: int | None = None,
) -> JointSplineFit:
    """Fit ``K(f) = sum_k c_k B_k(log f)`` per term to every line's FRFs jointly (module docstring).

    Minimizes ``sum |w (Y[m,e] - H[m,e] - Y[m,n] X(K) Y[n,e])|^2`` over the complex
    coefficients, ``X = (Y[n,n] + K^-1)^-1``, ``w = 1 / sqrt(variance)``.

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Lines, Hz, > 0 and increasing.
    Ymn, Ynn, Yne, Yme : ndarray, shapes (F, m, n), (F, n, n), (F, n, e), (F, m, e), complex
        Free structure's receptance blocks (m observed, n joint, e excited DOFs).
    H : ndarray, shape (F, m, e), complex
        Measured receptance of the jointed structure.
    variance : ndarray, shape (F, m, e)
        Variance of each value of ``H`` (shape is enough: the scale is estimated from the
        residuals, e.g. ``|H|^2`` for relative noise). Non-finite or zero: value not used.
    symmetric : bool
        ``K = K^T`` (p = n(n+1)/2 terms), else every entry.
    max_basis : int
        Orders ``1..max_basis`` are fitted in turn, chosen by AIC, and more while the richest one tried is the
        best (not a hard maximum: ``n_basis`` fixes the order, e.g. ``n_basis=1`` for a constant joint).
    initial : ndarray, shape (F, n, n), complex, optional
        A per-line estimate (its componentwise median starts the constant fit); default: the
        weighted per-line least squares (:func:`~jointid.methods.receptance.coupling_lines.coupling_per_line`).
    starts : int
        Perturbed starts of the constant fit.
    seed : int
        Seed of the perturbations (the fit is deterministic for a given seed).
    n_basis : int, optional
        Use this order (orders ``1..n_basis`` are still fitted in turn, as starts) instead of the AIC's choice.

    Returns
    -------
    JointSplineFit
    """
    f = np.asarray(frequency_hz, float)
    Ymn, Ynn, Yne, Yme, H = (np.asarray(a, complex) for a in (Ymn, Ynn, Yne, Yme, H))
    F, n = f.size, Ynn.shape[1]
    if np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise ValueError("fit_joint_spline: frequencies must be > 0 Hz and increasing")
    if max_basis < 1:
        raise ValueError(f"fit_joint_spline: max_basis must be >= 1, got {max_basis}")
    change = Yme - H
    weight = _weights(variance)
    weight = np.where(np.isfinite(change), weight, 0.0)
    change = np.where(weight > 0, change, 0.0)
    problem = _Problem(Ymn, Ynn, Yne, change, weight, symmetric)
    if initial is None:
        from .coupling_lines import coupling_per_line

        initial = coupling_per_line(Ymn, Yne, Ynn, change, np.where(weight > 0, variance, np.inf), symmetric).stiffness
    rng = np.random.default_rng(seed)
    basis1 = log_frequency_basis(f, 1)
    candidates = _constant_starts(np.asarray(initial, complex), problem.pairs, rng, starts)
    scored = []
    for c0 in candidates:
        coef, cost, _ = _levenberg_marquardt(problem, c0, basis1, START_ITERATIONS)
        if np.isfinite(cost):
            scored.append((cost, coef))
    if not scored:
        raise ValueError("fit_joint_spline: no start gives a finite residual (I + K Y[n,n] singular)")
    coef = min(scored, key=lambda t: t[0])[1]
    fits, criterion = {}, {}
    count = problem.count

    def order(nb: int, iterations: int) -> tuple:
        """Fit of ``nb`` coefficients per term from the previous order projected; a short one (``iterations <
        MAX_ITERATIONS``) goes on to convergence only if its AIC already beats every order's."""
        previous = fits[nb - 1] if nb > 1 else (coef, None, None, basis1)
        basis = log_frequency_basis(f, nb)
        c = _project(previous[0], previous[3], basis) if nb > 1 else previous[0]
        c, cost, converged = _levenberg_marquardt(problem, c, basis, iterations)
        if not converged and iterations < MAX_ITERATIONS and _aic_and_scale(cost, count, c.size)[0] < min(v[0] for v in criterion.values()):
            c, cost, converged = _levenberg_marquardt(problem, c, basis, MAX_ITERATIONS)
        return c, cost, converged, basis

    for nb in range(1, (max_basis if n_basis is None else n_basis) + 1):
        fits[nb] = order(nb, MAX_ITERATIONS)
        criterion[nb] = _aic_and_scale(fits[nb][1], count, fits[nb][0].size)
    limit = min(MAX_EXTENDED_BASIS, F // 4)
    while n_basis is None and _best_order(criterion) == max(fits) < limit:  # past the cap while the richest is the best
        nb = max(fits) + 1
        fits[nb] = order(nb, EXTENSION_ITERATIONS)
        criterion[nb] = _aic_and_scale(fits[nb][1], count, fits[nb][0].size)
    best = n_basis if n_basis is not None else _best_order(criterion)
    if n_basis is None and best < max_basis <= 4:
        # per-term orders: the terms that need more coefficients get them, one at a time
        coef, cost, converged, basis, active, orders = _per_term_orders(problem, fits[best][0], fits[best][3], f, max_basis)
        criterion["per-term"] = _aic_and_scale(cost, count, int(active.sum()))
        s2 = criterion["per-term"][1]
        K = _stiffness(coef, basis, problem.pairs, n, problem.symmetric)
        _, N, grad, _ = problem.normal(K, basis)
        a = np.flatnonzero(active)
        cov = np.zeros(N.shape, complex)
        cov[np.ix_(a, a)] = s2 * normal_inverse(N[np.ix_(a, a)])
        var_sel = term_variance(cov, basis, n, symmetric) / 2.0  # circular errors: half in each part
        # the bias of the terms left with fewer coefficients: each one in turn given its missing ones (:mod:`.spline_bands`)
        b_re, b_im = one_term_bias_variance(N, grad, basis, active, s2, problem.pairs)
        std, std_im = np.sqrt(var_sel + b_re), np.sqrt(var_sel + b_im)
        bias_basis = max_basis
        best = int(orders.max())
        term_orders = orders
    else:
        term_orders = np.full(len(problem.pairs[0]), best)
        coef, cost, converged, _ = fits[best]
        K, std, std_im, cov, s2 = _averaged(problem, fits, criterion, best, n_basis is None, count, n)
        bias_basis = None
        rich = richer_nested_order(best)
        P = len(problem.pairs[0])
        if n_basis is None and not (rich * P < count and rich <= F // 4):
            rich = best + 1  # no room for the nested refinement: the next order, its whole variance counted
        if n_basis is None and rich * P < count and rich == richer_nested_order(best):
            # the bias measured against the fits with one term at a time in the richer class (:mod:`.spline_bands`)
            Bb = fits[best][3]
            Bx = np.hstack([Bb, nested_extension(Bb, log_frequency_basis(f, rich))])
            cx = np.zeros((P, rich), complex)
            cx[:, :best] = fits[best][0]
            _, Nx, gx, _ = problem.normal(_stiffness(cx, Bx, problem.pairs, n, symmetric), Bx)
            active = np.tile(np.arange(rich) < best, P)
            b_re, b_im = one_term_bias_variance(Nx, gx, Bx, active, _aic_and_scale(fits[best][1], count, fits[best][0].size)[1], problem.pairs)
            std, std_im = np.sqrt(std ** 2 + b_re), np.sqrt(std_im ** 2 + b_im)
            bias_basis = rich
        elif n_basis is None and rich * P < count:  # no room for the nested class: the next order, its whole variance counted
            above = fits[rich] if rich in fits else order(rich, EXTENSION_ITERATIONS)
            K_b, V_b = _estimate_and_variance(problem, fits[best], count, n)[:2]
            b_re, b_im = richer_fit_band(K_b, V_b / 2.0, V_b / 2.0, *_estimate_and_variance(problem, above, count, n)[:2], nested=False)
            std = np.sqrt(std ** 2 + np.maximum(b_re ** 2 - V_b / 2.0, 0.0))
            std_im = np.sqrt(std_im ** 2 + np.maximum(b_im ** 2 - V_b / 2.0, 0.0))
            bias_basis = rich
    return JointSplineFit(f, K, std, std_im, best, float(s2), bool(converged), coef, cov, criterion, len(candidates), symmetric, term_orders,
                          bias_basis)
