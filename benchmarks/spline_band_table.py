"""The table of the joint spline fit's bias band (``jointid.methods.receptance.spline_bands``): computed, then checked.

For the chosen fit's error ``b + e`` (``e ~ N(0, s^2)``) and the measured bias ``d ~ N(b, tau^2)``
independent of ``e`` (nested fits), the band of one part is ``z sqrt(s^2 + max(0, q d^2 - c tau^2))``
(``z = 1.645``). Per ratio ``rho = tau^2 / s^2`` (nodes ``log10 rho = -3, -2.75, ..., 2``) this script
finds the ``(q, c)`` with the smallest expected half-width at zero bias among those whose coverage is
>= 0.90 for every bias ``b`` (``q`` on a grid of step 0.05, the largest ``c`` by bisection; coverage by
80-point Gauss-Hermite over ``d`` and exact normal probabilities over ``e``, on a grid of ``b``), and
prints per node ``q``, ``c``, the coverage at zero bias and the expected half-width (in ``z s``)
against the band it replaced, ``z sqrt(s^2 + tau^2 + d^2)``.

The search's quadrature is a guide only (too coarse where ``rho`` is large); ``c`` is then lowered until the table
as the module uses it (``q``, ``c`` interpolated linearly in ``log10 rho``, clamped outside) holds 0.90 at and
between the nodes and beyond them, by the accurate
:func:`~jointid.methods.receptance.spline_bands.band_coverage`. ``--check``: the module's table by that function,
the smallest coverage over ``b`` on 161 ratios from ``1e-4`` to ``1e4`` and in the limit ``rho -> inf``.

``--tradeoff``: the price of a band that over-covers less at zero bias (the smallest coverage over the bias it must then
accept, per ``rho``).

Not a test (about 90 s; ``--check`` 10 s): ``python benchmarks/spline_band_table.py [--check | --tradeoff]``; the module's constants are its output
(``tests/test_spline_fit.py`` checks the guarantee on a finer grid).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import norm

from jointid.methods.receptance.spline_bands import BIAS_BAND_C, BIAS_BAND_LOG10_RHO, BIAS_BAND_Q, Z90, band_coverage, bias_band_table

NODES = np.arange(-3.0, 2.0001, 0.25)
X, W = np.polynomial.hermite_e.hermegauss(80)
W = W / W.sum()


def coverage_and_width(q: float, c: float, rho: float, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Coverage per bias ``b`` (in s) and the expected half-width at ``b = 0`` (in ``z s``) of one ``(q, c)``."""
    d = b[:, None] + np.sqrt(rho) * X[None, :]
    w = Z90 * np.sqrt(1.0 + np.maximum(0.0, q * d ** 2 - c * rho))
    cover = (norm.cdf(w - b[:, None]) - norm.cdf(-w - b[:, None])) @ W
    return cover, float(w[0] @ W / Z90) if b[0] == 0 else np.nan


def bias_grid(rho: float) -> np.ndarray:
    """Biases (in s) where the coverage is checked: fine near zero, out past where the band is |d| itself."""
    return np.r_[np.linspace(0.0, 4.0, 161), np.linspace(4.05, 10.0 + 8.0 * np.sqrt(rho), 400)]


def best(rho: float) -> tuple[float, float, float, float]:
    """``(q, c, coverage at b = 0, expected half-width)`` of the narrowest band that holds 0.90 for every bias."""
    b = bias_grid(rho)
    found = None
    for q in np.arange(0.9, 3.0001, 0.05):
        lo, hi = -3.0, 1.0
        if coverage_and_width(q, lo, rho, b)[0].min() < 0.9:
            continue
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if coverage_and_width(q, mid, rho, b)[0].min() >= 0.9 else (lo, mid)
        cover, width = coverage_and_width(q, lo, rho, b)
        if found is None or width < found[3]:
            found = (float(q), float(lo), float(cover[0]), width)
    return found


def interpolated_min_coverage(qs: np.ndarray, cs: np.ndarray, lr: float) -> float:
    """Smallest coverage over the bias of the table ``(qs, cs)`` at ``log10 rho = lr`` (interpolated, clamped; ``inf``:
    the limit), by :func:`~jointid.methods.receptance.spline_bands.band_coverage` (not the search's quadrature, too
    coarse where ``rho`` is large: 0.898 at ``rho = 100`` where it said 0.900)."""
    rho = 10.0 ** lr
    q, c = np.interp(lr, NODES, qs), np.interp(lr, NODES, cs)
    b = np.linspace(0.0, 10.0, 2001) if np.isinf(lr) else bias_grid(rho)
    return float(band_coverage(q, c, rho, b).min())


#: Where the table is checked beyond its last node (it is clamped there), ``log10 rho``; ``inf``: the limit.
BEYOND = (2.25, 2.5, 3.0, 4.0, np.inf)


def repair(qs: np.ndarray, cs: np.ndarray) -> np.ndarray:
    """``cs`` lowered (the band widened: coverage grows as ``c`` falls) until the interpolated table holds 0.90
    at the nodes, between them (8 points per interval) and beyond the last, interval by interval from the left."""
    cs = cs.copy()
    for i in range(NODES.size - 1):
        for lr in np.linspace(NODES[i], NODES[i + 1], 9):
            while interpolated_min_coverage(qs, cs, lr) < 0.9:
                cs[i:i + 2] -= 0.002
    for lr in BEYOND:
        while interpolated_min_coverage(qs, cs, lr) < 0.9:
            cs[-1] -= 0.002
    return cs


def tradeoff() -> None:
    """How far below 0.90 a band of this form must go for some bias if it may over-cover at most to a cap at zero bias.

    Per ``rho`` and cap (0.93, 0.95): over a ``(q, c)`` grid (q 0.5-4 step 0.1, c -2 to 1.5 step 0.05), the largest
    smallest-coverage-over-every-bias among the bands whose zero-bias coverage is at most the cap (the guide's
    quadrature; the chosen band's figures again by ``band_coverage``).
    """
    print("cap at b = 0   rho    smallest coverage over every bias (best band)   q     c")
    for cap in (0.93, 0.95):
        for rho in (0.3, 1.0, 3.0, 10.0, 100.0):
            b = bias_grid(rho)
            best = None
            for q in np.arange(0.5, 4.0001, 0.1):
                for c in np.arange(-2.0, 1.5001, 0.05):
                    cover = coverage_and_width(q, c, rho, b)[0]
                    if cover[0] <= cap and (best is None or cover.min() > best[0]):
                        best = (cover.min(), q, c)
            accurate = band_coverage(best[1], best[2], rho, b)
            print(f"{cap:12.2f} {rho:6g} {accurate.min():30.3f} (zero bias {accurate[0]:.3f}) {best[1]:8.2f} {best[2]:6.2f}", flush=True)


def main(argv=None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only check the module's table (seconds)")
    ap.add_argument("--tradeoff", action="store_true",
                    help="only the trade-off: the smallest coverage a band may have if it over-covers at most 0.93 / 0.95 at zero bias")
    args = ap.parse_args(argv)
    if args.tradeoff:
        tradeoff()
        return
    if not args.check:
        compute()
    check()


def compute() -> None:
    """Search and print the table (about a minute)."""
    print("node  log10 rho      q        c    coverage b=0   E half-width (z s)   replaced band: coverage b=0, E half-width")
    qs, cs = [], []
    for k, lr in enumerate(NODES):
        rho = 10.0 ** lr
        q, c, cov0, width = best(rho)
        old_cover, old_width = coverage_and_width(1.0, -1.0, rho, bias_grid(rho))
        qs.append(q)
        cs.append(c)
        print(f"{k:4d} {lr:10.2f} {q:6.2f} {c:8.4f} {cov0:13.4f} {width:20.3f} {old_cover[0]:22.4f} {old_width:12.3f}", flush=True)
    cs = repair(np.array(qs), np.array(cs))
    print("\nBIAS_BAND_Q = (" + ", ".join(f"{v:.2f}" for v in qs) + ")")
    print("BIAS_BAND_C = (" + ", ".join(f"{np.floor(v * 1e4) / 1e4:.4f}" for v in cs) + ")")


def check() -> None:
    """The module's table (its constants, not the ones just printed): guarantee and figures."""
    assert np.array_equal(BIAS_BAND_LOG10_RHO, NODES), "the module's nodes differ from this script's"
    qs, cs = np.asarray(BIAS_BAND_Q), np.asarray(BIAS_BAND_C)
    worst = min(interpolated_min_coverage(qs, cs, lr) for lr in (*np.linspace(-4.0, 4.0, 161), np.inf))
    print(f"\nthe module's table (q {qs.min():.2f}-{qs.max():.2f}, c {cs.min():.3f}-{cs.max():.3f}): smallest coverage over "
          f"every bias, rho 1e-4 to 1e4 and its limit: {worst:.5f}")
    print("rho    coverage at b = 0 (replaced -> module)   E half-width at b = 0, z s (replaced -> module)")
    for rho in (0.1, 0.3, 1.0, 3.0, 10.0):
        q, c = bias_band_table(rho)
        _, width = coverage_and_width(float(q), float(c), rho, np.zeros(1))
        cover = band_coverage(float(q), float(c), rho, np.zeros(1))[0]
        _, old_width = coverage_and_width(1.0, -1.0, rho, np.zeros(1))
        old_cover = band_coverage(1.0, -1.0, rho, np.zeros(1))[0]
        print(f"{rho:<6g} {old_cover:.4f} -> {cover:.4f}   {old_width:.3f} -> {width:.3f} ({100 * (1 - width / old_width):.0f} % narrower)")


if __name__ == "__main__":
    main()
