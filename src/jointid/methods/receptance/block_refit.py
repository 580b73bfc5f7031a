"""Residuals of a weighted least-squares fit refitted with a block of rows left out or replaced, from the full fit.

Per line, a whitened design ``Q R = diag(sw) A`` (``Q`` with orthonormal columns, shape ``(N, p)``)
and data ``d`` give the fit's residual ``r = (I - Q Q^H) d``. A hypothesis about one record of the
measurement (a sensor left out, a channel rescaled, two records exchanged) changes only the rows
``B`` of that record: its data become ``d'_B`` and its design rows ``D_B A_B`` (``D`` the ratio of the
new weights to the old, ``sw'_B / sw_B``). Refitting needs no new factorization (that costs ``O(N p^2)``
per line, ``N`` rows; the refit ``O(|B|^2 p)`` for rows left out, ``O(|B| p^2 + p^3)`` for rows replaced): in
the coordinates ``y = R x``, with ``y0 = Q^H d`` the full fit,

* **left out** (the deleted-residual identity, Sherman-Morrison-Woodbury)::

      RSS_-B = ||r||^2 - r_B^H (I - Q_B Q_B^H)^-1 r_B

  (``|B| x |B|`` per line);
* **replaced**: with ``s_B = d'_B - D_B Q_B y0`` (``Q_B y0 = d_B - r_B``, the full fit's values at ``B``),
  ``M = I + Q_B^H diag(D_B^2 - 1) Q_B`` and ``g = Q_B^H (D_B s_B - r_B)``::

      RSS' = ||r||^2 - ||r_B||^2 + ||s_B||^2 - g^H M^-1 g

  (the normal equations of the correction ``y - y0``, in which the untouched rows have an identity Gram
  matrix because ``Q^H r = 0``; ``p x p`` per line).

Both are exact in exact arithmetic. Rounding: the left-out form's error is about
``eps ||d|| ||r_B|| / lambda_min``, ``lambda_min`` the smallest eigenvalue of ``I - Q_B Q_B^H`` (1 minus
the block's largest leverage). A line where ``lambda_min <= sqrt(eps)`` has no determined fit without
the block (the rows left out carry a direction of the parameters alone, or to half the working
digits): its RSS is ``inf`` there, so that such a hypothesis cannot look like a good explanation. The
replaced form's error grows with ``cond(M) <= max(1, max D^2) / min(1, min D^2)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["left_out_rss", "replaced_rss", "LEVERAGE_FLOOR"]

#: ``1 -`` the largest leverage of a block below which the fit without it is taken as undetermined (half the digits).
LEVERAGE_FLOOR = float(np.sqrt(np.finfo(float).eps))


def _ct(a: np.ndarray) -> np.ndarray:
    return np.conj(np.swapaxes(a, -1, -2))


def left_out_rss(r: np.ndarray, Q: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Residual sum of squares per line of the fit refitted without the rows ``rows`` (module docstring).

    Parameters
    ----------
    r : ndarray, shape (F, N), complex
        The full fit's whitened residual ``(I - Q Q^H) d`` per line.
    Q : ndarray, shape (F, N, p), complex
        Orthonormal basis of the whitened design's columns per line.
    rows : array of int
        The rows left out (the same on every line).

    Returns
    -------
    ndarray, shape (F,)
        ``RSS_-B`` (>= 0); ``inf`` on lines where the fit without the rows is undetermined
        (``1 -`` leverage ``<=`` :data:`LEVERAGE_FLOOR`).
    """
    rows = np.asarray(rows)
    QB, rB = Q[:, rows, :], r[:, rows]
    lam, U = np.linalg.eigh(np.eye(rows.size) - QB @ _ct(QB))  # ascending
    z = np.einsum("fba,fb->fa", np.conj(U), rB)
    ok = lam[:, 0] > LEVERAGE_FLOOR
    deleted = np.sum((z.real ** 2 + z.imag ** 2) / np.maximum(lam, LEVERAGE_FLOOR), axis=1)
    rss = np.maximum(np.sum(r.real ** 2 + r.imag ** 2, axis=1) - deleted, 0.0)
    return np.where(ok, rss, np.inf)


def replaced_rss(d: np.ndarray, r: np.ndarray, Q: np.ndarray, rows: np.ndarray, d_new: np.ndarray,
                 ratio: np.ndarray) -> np.ndarray:
    """Residual sum of squares per line of the fit refitted with rows ``rows`` replaced (module docstring).

    Parameters
    ----------
    d : ndarray, shape (F, N), complex
        The full fit's whitened data.
    r : ndarray, shape (F, N), complex
        Its residual ``(I - Q Q^H) d``.
    Q : ndarray, shape (F, N, p), complex
        Orthonormal basis of the whitened design's columns per line.
    rows : array of int, size b
        The rows replaced.
    d_new : ndarray, shape (F, b), complex
        Their new whitened data ``sw' (Y - H')``.
    ratio : ndarray, shape (F, b), > 0
        Their new weights over the old ones, ``sw' / sw`` (the design rows are scaled by it).

    Returns
    -------
    ndarray, shape (F,)
        ``RSS'`` (>= 0).
    """
    rows = np.asarray(rows)
    QB, rB = Q[:, rows, :], r[:, rows]
    s = d_new - ratio * (d[:, rows] - rB)
    g = np.einsum("fbp,fb->fp", np.conj(QB), ratio * s - rB)
    M = np.eye(Q.shape[2]) + _ct(QB) @ ((ratio ** 2 - 1.0)[:, :, None] * QB)
    x = np.linalg.solve(M, g[:, :, None])[:, :, 0]
    rss = (np.sum(r.real ** 2 + r.imag ** 2, axis=1) - np.sum(rB.real ** 2 + rB.imag ** 2, axis=1)
           + np.sum(s.real ** 2 + s.imag ** 2, axis=1) - np.einsum("fp,fp->f", np.conj(g), x).real)
    return np.maximum(rss, 0.0)
