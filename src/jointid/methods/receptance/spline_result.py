"""The result of the joint spline fit (:func:`jointid.methods.receptance.spline_fit.fit_joint_spline`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["JointSplineFit"]


@dataclass(frozen=True, eq=False)
class JointSplineFit:
    """A joint fitted as B-splines in log frequency to all lines (:func:`~jointid.methods.receptance.spline_fit.fit_joint_spline`).

    Attributes
    ----------
    frequency_hz : ndarray, shape (F,)
    stiffness : ndarray, shape (F, n, n), complex
        N/m, N/rad, N*m/m, N*m/rad.
    std_real, std_imag : ndarray, shape (F, n, n)
        1-sigma standard deviation of the real and imaginary part of each term (linearized).
    n_basis : int
        B-spline functions per term of the chosen order.
    chi2_per_dof : float
        Whitened residual sum of squares per complex degree of freedom (``s^2``; ~1 when
        ``variance`` is on an absolute scale and the model fits).
    converged : bool
        LM stopped on a small step at the chosen order.
    coefficients : ndarray, shape (p, n_basis), complex
        ``c`` per term (upper triangle row by row if symmetric, else every entry).
    covariance : ndarray, shape (p * n_basis, p * n_basis), complex
        ``E[dc dc^H]`` (scaled by ``s^2``), coefficients ordered term-major.
    criterion : dict
        ``n_basis -> (AIC, chi2_per_dof)`` of every order fitted (an order past the cap that the AIC rejected:
        after :data:`~jointid.methods.receptance.spline_fit.EXTENSION_ITERATIONS` iterations, not converged),
        and ``"per-term"`` when per-term orders were chosen.
    starts : int
        Starts of the constant fit.
    symmetric : bool
    term_basis : ndarray of int, shape (p,)
        Coefficients per term (per-term orders: Legendre polynomials in ``log f``; else all ``n_basis``).
    bias_basis : int or None
        Coefficients per term of the richer class against which the bias in the bands is measured, one term at a time
        (:mod:`.spline_bands`); None: none.
    """

    frequency_hz: np.ndarray
    stiffness: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    n_basis: int
    chi2_per_dof: float
    converged: bool
    coefficients: np.ndarray
    covariance: np.ndarray
    criterion: dict = field(default_factory=dict)
    starts: int = 0
    symmetric: bool = True
    term_basis: np.ndarray | None = None
    bias_basis: int | None = None

    def describe(self) -> str:
        """One line: the orders chosen, by what, the fit's chi^2/dof and convergence."""
        orders = ", ".join(f"{k}: {v[1]:.3g}" for k, v in self.criterion.items())
        tb = self.term_basis
        if tb is not None and "per-term" in self.criterion:
            what = f"{tb.min()}-{tb.max()} coefficients per term (Legendre in log f, per-term orders by score test)"
        else:
            what = f"{self.n_basis} B-spline(s) in log f (order by AIC)"
        bias = "" if self.bias_basis is None else f"; bands hold the bias measured against {self.bias_basis} coefficients, one term at a time"
        return (f"every term {what}, fitted to all lines jointly; chi^2/dof per order {orders}{bias}"
                + ("" if self.converged else "; not converged"))
