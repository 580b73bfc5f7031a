"""Master curve of a joint's stiffness by time-temperature superposition (TTS).

Physics
-------
For a thermorheologically simple elastomer, a test at temperature ``T`` and
frequency ``f`` gives the stiffness the material has at the reference
temperature ``Tref`` and the *reduced frequency* ``f_r = f aT``:
``K(f, T) = bT K_ref(f aT)``, with the horizontal shift factor ``aT`` (> 1
below ``Tref``) and the optional vertical (density-temperature) factor
``bT = (T + 273.15) rho(T) / ((Tref + 273.15) rho(Tref))``, taken here with
``rho(T) = rho(Tref)``. Curves measured over 1-100 Hz at several temperatures
then form one curve over many decades of reduced frequency: low-frequency
tests predict the high-frequency stiffness that an elastomer test machine
cannot reach.

Method (:func:`build_master_curve`)
-----------------------------------
1. Curves at the same temperature are merged (equal frequencies averaged in
   ``ln K``); with ``vertical_shift`` each stiffness is divided by ``bT``.
2. The shift between neighbouring temperatures is estimated from the data,
   from the overlap of ``ln|K|`` and the loss angle on the ``log10 f`` axis
   (:mod:`.shift_estimation`), with its standard error; a pair whose best
   overlap still misfits is refused. When a temperature does not overlap its
   neighbour, the next temperature is tried.
3. The accepted pairwise shifts ``d_ij = s_j - s_i`` are combined by weighted
   least squares on the graph of temperatures, anchored at ``s = 0`` at the
   reference temperature (or, when it was not measured, at the nearest
   measured one; the shift laws then fit the constant). Temperatures not
   connected to the anchor are reported in ``not_overlapping`` and left out
   of everything that follows (not forced).
4. WLF and Arrhenius are fitted to the shift factors with their covariance
   (:mod:`.shift_laws`); the one with the lower AIC is preferred.
5. A fractional Zener stiffness (:func:`.zener_fit.fit_zener`; the fit is on
   the stiffness itself, proportional to the modulus) is fitted to all
   shifted data: ``K(f_r) = (K0 + Kinf (j w_r tau)^alpha) / (1 + (j w_r tau)^alpha)``.

Caveats: the pairwise shifts share data between neighbouring pairs, so the
chained standard errors treat them as independent (a slight underestimate);
the standard errors include the local polynomial's model error; a
thermorheologically complex material (loss factor curves that do not overlap
at any shift) is refused pairwise, not averaged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import DataError
from .master_zener import fit_zener_fast, zener_covariance, zener_jacobian
from .shift_estimation import PairShift, curve_noise, estimate_pair_shift
from .shift_laws import (KELVIN, ArrheniusFit, WLFFit, fit_arrhenius, fit_wlf, moved_shift_covariance, preferred_law,
                         wlf_undetermined)
from .zener_fit import ZenerFit, zener_modulus

__all__ = ["TemperatureCurve", "MasterCurve", "build_master_curve"]


def _f(x) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


@dataclass(frozen=True, eq=False)
class TemperatureCurve:
    """Stiffness of one test (or specimen) at one temperature.

    Parameters
    ----------
    temperature_c : float
        Test temperature, deg C.
    frequency_hz : ndarray, shape (F,)
        Test frequencies, Hz (> 0, F >= 3).
    stiffness : ndarray, shape (F,), complex
        Complex stiffness, N/m.
    stiffness_std : ndarray, shape (F,), optional
        1-sigma of ``|K|``, N/m; weights the fits (``|K| / std``). None: equal relative weights.
    """

    temperature_c: float
    frequency_hz: np.ndarray
    stiffness: np.ndarray
    stiffness_std: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class MasterCurve:
    """Master curve at the reference temperature: shift factors, shift laws, Zener fit, coverage, findings.

    Parameters
    ----------
    reference_temperature_c : float
        Tref, deg C.
    vertical_shift : bool
        The stiffness was divided by ``bT = (T + 273.15) / (Tref + 273.15)``.
    shift_factors : tuple of (float, float, float)
        ``(temperature_c, log10 aT, std)`` from the data, for the temperatures in the master curve.
    wlf, arrhenius : WLFFit or ArrheniusFit or None
        Fitted shift laws (None when too few temperatures).
    preferred_shift_law : str or None
        ``"wlf"`` or ``"arrhenius"`` (lower AIC).
    zener : ZenerFit or None
        Fractional Zener fit of the shifted stiffness (parameters in N/m although labelled Pa).
    reduced_range_hz : (float, float)
        Reduced-frequency range of the shifted data, Hz.
    coverage : tuple of (float, float, float)
        ``(temperature_c, reduced f min, reduced f max)`` per temperature in the master curve.
    not_overlapping : tuple of (float, str)
        ``(temperature_c, reason)`` of temperatures left out.
    findings : tuple of str
        One line each.
    pairs : tuple of (float, float, PairShift)
        ``(T_i, T_j, shift of j onto i)`` of every pair tried.
    curves : tuple of TemperatureCurve
        The merged curves (one per temperature), as measured.
    modulus_covariance : ndarray, shape (4, 4), optional
        Covariance of (K0, Kinf, tau, alpha): the Zener fit's plus the shift
        factors' error propagated through the fit (N/m, N/m, s, -).
    """

    reference_temperature_c: float
    vertical_shift: bool
    shift_factors: tuple
    wlf: WLFFit | None
    arrhenius: ArrheniusFit | None
    preferred_shift_law: str | None
    zener: ZenerFit | None
    reduced_range_hz: tuple
    coverage: tuple
    not_overlapping: tuple
    findings: tuple
    pairs: tuple[tuple[float, float, PairShift], ...] = ()
    curves: tuple = ()
    modulus_covariance: np.ndarray | None = None

    @property
    def measured_shift(self) -> dict:
        """``{temperature_c: log10 aT}`` from the data (temperatures in the master curve)."""
        return {t: s for t, s, _ in self.shift_factors}

    def _law(self):
        return {"wlf": self.wlf, "arrhenius": self.arrhenius}.get(self.preferred_shift_law or "")

    def log10_shift(self, temperature_c):
        """``log10 aT`` from the preferred shift law (decades); the measured shift if no law was fitted.

        Raises
        ------
        DataError
            No law fitted and the temperature was not in the master curve.
        """
        law = self._law()
        if law is not None:
            return law.log10_shift(temperature_c)
        t = np.asarray(temperature_c, dtype=float)
        table = self.measured_shift
        out = []
        for v in t.reshape(-1):
            hit = [s for tt, s in table.items() if abs(tt - v) <= 1e-9]
            if not hit:
                raise DataError(f"no shift law fitted; {v:g} deg C is not a temperature of the master curve")
            out.append(hit[0])
        out = np.array(out).reshape(t.shape)
        return float(out) if out.ndim == 0 else out

    def vertical_factor(self, temperature_c):
        """``bT = (T + 273.15) / (Tref + 273.15)`` with ``vertical_shift``, else 1."""
        t = np.asarray(temperature_c, dtype=float)
        out = (t + KELVIN) / (self.reference_temperature_c + KELVIN) if self.vertical_shift else np.ones_like(t)
        return float(out) if out.ndim == 0 else out

    def reduced_frequency(self, frequency_hz, temperature_c):
        """``f_r = f aT`` (Hz) with ``aT`` from :meth:`log10_shift`."""
        return np.asarray(frequency_hz, dtype=float) * 10.0 ** self.log10_shift(temperature_c)

    def stiffness(self, frequency_hz, temperature_c=None) -> np.ndarray:
        """The fitted master curve, complex N/m: ``bT K_zener(f aT)``; ``temperature_c=None``: ``f`` is the reduced frequency.

        Raises
        ------
        DataError
            The Zener fit failed (no modulus).
        """
        if self.zener is None:
            raise DataError("the master curve has no fitted Zener stiffness (see its findings)")
        z = self.zener
        if temperature_c is None:
            return zener_modulus(frequency_hz, z.E0, z.Einf, z.tau_s, z.alpha)
        fr = self.reduced_frequency(frequency_hz, temperature_c)
        return zener_modulus(fr, z.E0, z.Einf, z.tau_s, z.alpha) * self.vertical_factor(temperature_c)

    def stiffness_std(self, frequency_hz, temperature_c=None) -> tuple[np.ndarray, np.ndarray]:
        """1-sigma of the fitted master curve's ``|K|`` (N/m) and loss factor, from :attr:`modulus_covariance`.

        Delta method: with ``s = (j w tau)^alpha``, ``dK/dK0 = 1/(1+s)``,
        ``dK/dKinf = s/(1+s)``, ``dK/ds = (Kinf - K0)/(1+s)^2``, ``ds/dtau = alpha s / tau``,
        ``ds/dalpha = s ln(j w tau)``; ``d|K| = Re(conj(K) dK) / |K|``,
        ``d eta = (Im dK Re K - Re dK Im K) / (Re K)^2``. The covariance includes
        the shift factors' error carried through the fit; at a test temperature
        the error of that temperature's shift law is not added. NaN where a
        parameter is not determined.

        Parameters
        ----------
        frequency_hz : array_like, shape (F,)
            Frequency, Hz (reduced frequency when ``temperature_c`` is None).
        temperature_c : float, optional
            Test temperature, deg C.

        Returns
        -------
        magnitude_std : ndarray, shape (F,)
            N/m (scaled by ``bT`` at a temperature).
        loss_factor_std : ndarray, shape (F,)
        """
        if self.zener is None:
            raise DataError("the master curve has no fitted Zener stiffness (see its findings)")
        z = self.zener
        f = np.asarray(frequency_hz, dtype=float).reshape(-1)
        b = 1.0
        if temperature_c is not None:
            f = self.reduced_frequency(f, temperature_c)
            b = self.vertical_factor(temperature_c)
        cov = self.modulus_covariance if self.modulus_covariance is not None else np.full((4, 4), np.nan)
        K, J, _ = zener_jacobian(f, z)
        dmag = (np.conj(K)[:, None] * J).real / np.abs(K)[:, None]
        deta = (J.imag * K.real[:, None] - J.real * K.imag[:, None]) / (K.real**2)[:, None]
        with np.errstate(invalid="ignore"):
            vm = np.einsum("fi,ij,fj->f", dmag, cov, dmag)
            ve = np.einsum("fi,ij,fj->f", deta, cov, deta)
        return b * np.sqrt(np.maximum(vm, 0.0)), np.sqrt(np.maximum(ve, 0.0))

    def stiffness_band(self, frequency_hz, temperature_c=None, sigmas: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
        """Band of the fitted master curve: ``K' -+ sigmas sd(K')`` and ``K'' -+ sigmas sd(K'')`` as complex arrays.

        Same covariance and delta method as :meth:`stiffness_std` (storage and
        loss parts separately).

        Parameters
        ----------
        frequency_hz : array_like, shape (F,)
            Frequency, Hz (reduced frequency when ``temperature_c`` is None).
        temperature_c : float, optional
            Test temperature, deg C.
        sigmas : float
            Half-width in standard deviations (2: about 95 %).

        Returns
        -------
        lower, upper : ndarray, shape (F,), complex
            ``(K' - w') + j (K'' - w'')`` and ``(K' + w') + j (K'' + w'')``, N/m.
        """
        if self.zener is None:
            raise DataError("the master curve has no fitted Zener stiffness (see its findings)")
        f = np.asarray(frequency_hz, dtype=float).reshape(-1)
        b = 1.0
        if temperature_c is not None:
            f = self.reduced_frequency(f, temperature_c)
            b = self.vertical_factor(temperature_c)
        cov = self.modulus_covariance if self.modulus_covariance is not None else np.full((4, 4), np.nan)
        K, J, _ = zener_jacobian(f, self.zener)
        with np.errstate(invalid="ignore"):
            sr = np.sqrt(np.maximum(np.einsum("fi,ij,fj->f", J.real, cov, J.real), 0.0))
            si = np.sqrt(np.maximum(np.einsum("fi,ij,fj->f", J.imag, cov, J.imag), 0.0))
        w = sigmas * (sr + 1j * si)
        return b * (K - w), b * (K + w)

    def shifted(self) -> list:
        """``[(temperature_c, reduced frequency (F,) Hz, stiffness at Tref (F,) complex N/m)]`` from the measured shifts."""
        table = self.measured_shift
        out = []
        for c in self.curves:
            if c.temperature_c in table:
                out.append((c.temperature_c, c.frequency_hz * 10.0 ** table[c.temperature_c],
                            c.stiffness / self.vertical_factor(c.temperature_c)))
        return out

    def _modulus_dict(self) -> dict | None:
        if self.zener is None:
            return None
        names = {"E0_pa": "K0_n_m", "Einf_pa": "Kinf_n_m", "tau_s": "tau_s", "alpha": "alpha"}
        d = {"model": "fractional_zener"}
        cov = self.modulus_covariance
        for k, p in enumerate(self.zener.parameters):
            sd = math.sqrt(cov[k, k]) if cov is not None and cov[k, k] >= 0 else p.std_error
            d[names[p.name]] = {"value": _f(p.value), "std": _f(sd), "status": p.status}
        d["identified"] = bool(self.zener.identified)
        d["residual_rms"] = _f(self.zener.residual_rms)
        d["reduced_frequency_min_hz"] = _f(self.reduced_range_hz[0])
        d["reduced_frequency_max_hz"] = _f(self.reduced_range_hz[1])
        return d

    def to_dict(self) -> dict:
        """Strict-JSON form (None for anything not finite); see the README's ``master_curve.json``."""
        return {
            "reference_temperature_c": float(self.reference_temperature_c),
            "vertical_shift": bool(self.vertical_shift),
            "shift_factors": [{"temperature_c": float(t), "log10_shift": _f(s), "std": _f(sd)}
                              for t, s, sd in self.shift_factors],
            "wlf": self.wlf.to_dict() if self.wlf is not None else None,
            "arrhenius": self.arrhenius.to_dict() if self.arrhenius is not None else None,
            "preferred_shift_law": self.preferred_shift_law,
            "modulus": self._modulus_dict(),
            "coverage": [{"temperature_c": float(t), "reduced_frequency_min_hz": _f(lo), "reduced_frequency_max_hz": _f(hi)}
                         for t, lo, hi in self.coverage],
            "not_overlapping": [{"temperature_c": float(t), "reason": r} for t, r in self.not_overlapping],
            "pairs": [{"temperature_c": float(ti), "other_temperature_c": float(tj), "relative_log10_shift": _f(p.shift),
                       "std": _f(p.std), "rms_misfit": _f(p.rms_residual), "noise": _f(p.noise),
                       "accepted": bool(p.accepted)} for ti, tj, p in self.pairs],
            "findings": list(self.findings),
        }


def _merge(curves: Sequence[TemperatureCurve], vertical: bool, tref: float):
    """One (x = log10 f, y = ln K, w) per distinct temperature, ascending; validated."""
    by_t: dict = {}
    for k, c in enumerate(curves):
        f = np.asarray(c.frequency_hz, dtype=float).reshape(-1)
        K = np.asarray(c.stiffness, dtype=complex).reshape(-1)
        if f.shape != K.shape:
            raise DataError(f"curve {k} ({c.temperature_c:g} deg C): {f.size} frequencies but {K.size} stiffness values")
        if not math.isfinite(float(c.temperature_c)):
            raise DataError(f"curve {k}: temperature is not finite")
        if not (np.all(np.isfinite(f)) and np.all(f > 0) and np.all(np.isfinite(K)) and np.all(K != 0)):
            raise DataError(f"curve {k} ({c.temperature_c:g} deg C): frequencies must be > 0 and the stiffness finite "
                            "and non-zero; drop the failed lines")
        if c.stiffness_std is None:
            w = np.ones(f.size)
        else:
            sd = np.asarray(c.stiffness_std, dtype=float).reshape(-1)
            if sd.shape != f.shape or not np.all(np.isfinite(sd) & (sd > 0)):
                raise DataError(f"curve {k} ({c.temperature_c:g} deg C): stiffness_std must be positive and finite, one per line")
            w = np.abs(K) / sd
        by_t.setdefault(float(c.temperature_c), []).append((f, K, w))
    out = []
    for t in sorted(by_t):
        f = np.concatenate([a[0] for a in by_t[t]])
        K = np.concatenate([a[1] for a in by_t[t]])
        w = np.concatenate([a[2] for a in by_t[t]])
        uf, inv = np.unique(f, return_inverse=True)
        cnt = np.bincount(inv)
        y = np.log(K)
        if vertical:
            y = y - math.log((t + KELVIN) / (tref + KELVIN))
        ym = (np.bincount(inv, y.real) + 1j * np.bincount(inv, y.imag)) / cnt
        wm = np.sqrt(np.bincount(inv, w**2))
        if uf.size < 3:
            raise DataError(f"{t:g} deg C: {uf.size} distinct frequencies; a temperature curve needs at least 3")
        out.append((t, uf, ym, wm))
    if len(out) < 2:
        raise DataError(f"a master curve needs at least 2 temperatures, got {len(out)}")
    return out


def _graph_shifts(temps, edges, anchor):
    """Weighted least squares of node shifts from edges (i, j, d, std); returns (nodes, s, cov) of the anchor's component."""
    adj = {i: set() for i in range(len(temps))}
    for i, j, _, _ in edges:
        adj[i].add(j)
        adj[j].add(i)
    comp, stack = {anchor}, [anchor]
    while stack:
        for nb in adj[stack.pop()]:
            if nb not in comp:
                comp.add(nb)
                stack.append(nb)
    nodes = sorted(comp)
    free = [n for n in nodes if n != anchor]
    col = {n: k for k, n in enumerate(free)}
    rows = [(i, j, d, sd) for i, j, d, sd in edges if i in comp and j in comp]
    s = np.zeros(len(nodes))
    cov = np.zeros((len(nodes), len(nodes)))
    if free:
        A = np.zeros((len(rows), len(free)))
        b = np.zeros(len(rows))
        for r, (i, j, d, sd) in enumerate(rows):
            if j in col:
                A[r, col[j]] += 1.0 / sd
            if i in col:
                A[r, col[i]] -= 1.0 / sd
            b[r] = d / sd
        N = A.T @ A
        Cf = np.linalg.inv(N)
        sf = Cf @ (A.T @ b)
        idx = [nodes.index(n) for n in free]
        s[idx] = sf
        cov[np.ix_(idx, idx)] = Cf
    return nodes, s, cov


def build_master_curve(curves: Sequence[TemperatureCurve], reference_temperature_c: float, *,
                       vertical_shift: bool = False, overlap_ratio: float = 3.0, overlap_floor: float = 2e-3) -> MasterCurve:
    """Shift temperature curves onto the reference temperature, fit WLF / Arrhenius and a fractional Zener stiffness.

    Parameters
    ----------
    curves : sequence of TemperatureCurve
        One or more curves per temperature (same specimen and amplitude), at
        least 2 distinct temperatures, at least 3 distinct frequencies each.
    reference_temperature_c : float
        Tref, deg C (need not be a measured temperature).
    vertical_shift : bool
        Divide the stiffness by ``bT = (T + 273.15) / (Tref + 273.15)`` first.
    overlap_ratio, overlap_floor : float
        Overlap check of :func:`.shift_estimation.estimate_pair_shift`.

    Returns
    -------
    MasterCurve
        See the module docstring; ``to_dict()`` is the ``master_curve.json`` form.

    Raises
    ------
    DataError
        Fewer than 2 temperatures, a curve with fewer than 3 lines, non-finite
        or zero stiffness, mismatched shapes, a non-finite reference temperature.
    """
    tref = float(reference_temperature_c)
    if not math.isfinite(tref) or tref <= -KELVIN:
        raise DataError(f"reference temperature must be a finite temperature above -273.15 deg C, got {reference_temperature_c!r}")
    data = _merge(curves, vertical_shift, tref)
    temps = [d[0] for d in data]
    findings = []
    # pairwise shifts between neighbours (the next temperature tried when a neighbour does not overlap)
    pairs, edges = [], []
    n = len(data)
    for i in range(n - 1):
        for j in range(i + 1, min(i + 3, n)):
            _, xi_f, yi, wi = data[i]
            _, xj_f, yj, wj = data[j]
            p = estimate_pair_shift(np.log10(xi_f), yi, wi, np.log10(xj_f), yj, wj, ratio=overlap_ratio, floor=overlap_floor)
            pairs.append((temps[i], temps[j], p))
            if p.accepted:
                edges.append((i, j, p.shift, p.std))
                if p.shift > 0:
                    findings.append(f"{temps[j]:g} deg C lies {p.shift:.2f} decades ABOVE {temps[i]:g} deg C on the reduced "
                                    "frequency axis: a warmer curve should shift to lower frequencies; check the temperatures")
                break
    ref_idx = [k for k, t in enumerate(temps) if abs(t - tref) <= 1e-9]
    measured_ref = bool(ref_idx)
    anchor = ref_idx[0] if measured_ref else int(np.argmin(np.abs(np.array(temps) - tref)))
    if not measured_ref:
        findings.append(f"the reference temperature {tref:g} deg C was not measured: shifts anchored at {temps[anchor]:g} deg C "
                        "and moved to the reference by the preferred shift law")
    nodes, s, cov = _graph_shifts(temps, edges, anchor)
    not_overlapping = []
    for k, t in enumerate(temps):
        if k in nodes:
            continue
        tried = [p for ti, tj, p in pairs if t in (ti, tj)]
        reason = "; ".join(p.reason for p in tried if p.reason) or "no overlapping neighbour"
        not_overlapping.append((t, f"does not overlap the curves connected to {temps[anchor]:g} deg C ({reason})"))
        findings.append(f"{t:g} deg C: its curve does not overlap the others; left out of the master curve and the shift laws "
                        "(curves that differ by a constant factor need the vertical shift; a thermorheologically complex "
                        "material does not superpose)")
    T = np.array([temps[k] for k in nodes])
    # shift laws
    wlf = arr = None
    free_offset = not measured_ref
    # a warmer curve shifted to higher frequencies (found above) is a temperature typed wrong, or a material that
    # does not superpose: no law through such shift factors is the material's, nor are shifts moved by one
    backwards = any(e[2] > 0 for e in edges)
    if backwards:
        findings.append("shift laws not fitted: the shift factors do not fall as the temperature rises (above)")
    for name, fn in (() if backwards else (("WLF", fit_wlf), ("Arrhenius", fit_arrhenius))):
        try:
            law = fn(T, s, tref, cov, free_offset=free_offset)
        except DataError as exc:
            findings.append(f"{name} not fitted: {exc}")
            continue
        if name == "WLF":
            wlf = law
        else:
            arr = law
    # a WLF law whose pole lies in the measured range or whose constants the temperatures do not determine is shown
    # (findings below) but never preferred: its shifts between and beyond the temperatures are not the data's
    # (c1, c2) determined: the curvature of log aT seen (profile likelihood; the linearized std of c1, c2 is not to be
    # trusted near a straight line) and, with no degree of freedom, a span of at least a quarter of c2 (shift_laws)
    wlf_pole = wlf is not None and not (wlf.c2 > 0 and np.all(wlf.c2 + (T - tref) > 0))
    wlf_why = "" if wlf is None or wlf_pole else wlf_undetermined(wlf, T, s, tref, cov, free_offset=free_offset)
    if wlf is not None and not wlf_pole and not wlf_why and not (wlf.c1_std <= 0.5 * abs(wlf.c1) and wlf.c2_std <= 0.5 * abs(wlf.c2)):
        wlf_why = "relative std > 50 %"
    wlf_usable = wlf is not None and not wlf_pole and not wlf_why
    pref = preferred_law(wlf if wlf_usable else None, arr)
    offset = offset_var = 0.0
    if pref is not None:
        chosen = wlf if pref == "wlf" else arr
        offset, offset_var = chosen.offset, chosen.offset_std**2
        other = arr if pref == "wlf" else wlf
        findings.append(f"shift law: {pref.upper() if pref == 'wlf' else 'Arrhenius'} preferred (AIC {chosen.aic:.3g}"
                        + (f" vs {other.aic:.3g}" if other is not None else "") + ")")
        if chosen.n_points <= 1:  # one shift factor (the anchor fixes the offset): the law passes through it exactly
            findings.append(f"shift law: {'WLF' if pref == 'wlf' else 'Arrhenius'} has as many constants as shift factors "
                            f"({chosen.n_points}) and passes through them exactly: the data do not test it; its shifts "
                            "between and beyond the temperatures are the law's, not the data's")
    if wlf is not None:
        x = T - tref
        if np.any(wlf.c2 + x <= 0) or wlf.c2 <= 0:
            findings.append(f"WLF c2 = {wlf.c2:.3g} K puts the law's pole inside or below the measured temperatures: not physical, not used")
        if wlf_why:
            findings.append(f"WLF c1 = {wlf.c1:.3g} +- {wlf.c1_std:.2g}, c2 = {wlf.c2:.3g} +- {wlf.c2_std:.2g} K: not determined "
                            f"by these temperatures ({wlf_why}): not used; use the shift factors or the Arrhenius law")
    if pref is None and not measured_ref:
        findings.append(f"no shift law fitted: the shift factors and the fitted modulus stay relative to {temps[anchor]:g} deg C, "
                        f"not {tref:g} deg C" + ("" if vertical_shift else f" (reference_temperature_c {temps[anchor]:g})"))
    sf = s - offset
    if offset_var > 0:  # moved to an unmeasured reference: the law's offset is common to every shift (and tau)
        fit_law = fit_wlf if pref == "wlf" else fit_arrhenius
        cov = moved_shift_covariance(fit_law, T, s, tref, cov, offset_var)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    shift_factors = tuple((float(t), float(v), float(e)) for t, v, e in zip(T, sf, sd))
    # shifted data and the Zener fit
    fr_all, K_all, node_all, coverage = [], [], [], []
    for pos, (k, v) in enumerate(zip(nodes, sf)):
        t, f, y, _ = data[k]
        fr = f * 10.0**v
        fr_all.append(fr)
        K_all.append(np.exp(y))
        node_all.append(np.full(f.size, pos))
        coverage.append((t, float(fr.min()), float(fr.max())))
    fr_all = np.concatenate(fr_all)
    K_all = np.concatenate(K_all)
    node_all = np.concatenate(node_all)
    order = np.argsort(fr_all)
    zener = zcov = None
    try:
        weighted = any(c.stiffness_std is not None for c in curves)
        noise = math.nan if weighted else max(curve_noise(np.log10(data[k][1]), data[k][2], data[k][3]) for k in nodes)
        lnK = np.log(K_all)
        if max(np.ptp(lnK.real), np.ptp(lnK.imag)) <= max(6.0 * noise, 1e-3):  # NaN noise (weighted): always fit
            findings.append("the stiffness does not change over the reduced band (no relaxation seen): "
                            "fractional Zener not fitted")
        else:
            zener = fit_zener_fast(fr_all[order], K_all[order], noise)
            findings.extend(w.replace("Pa", "N/m") for w in zener.warnings)
            zcov = zener_covariance(zener, fr_all, K_all, node_all, cov)
    except DataError as exc:
        findings.append(f"fractional Zener fit failed: {exc}")
    curves_out = tuple(TemperatureCurve(t, f, np.exp(y) * ((t + KELVIN) / (tref + KELVIN) if vertical_shift else 1.0))
                       for t, f, y, _ in data)
    # without a law the shifts (and the Zener fit on them) stay at the anchor: labelled so (the vertical factor was
    # taken at tref, so there the label stays tref and the finding says what holds)
    label = temps[anchor] if pref is None and not measured_ref and not vertical_shift else tref
    return MasterCurve(label, bool(vertical_shift), shift_factors, wlf, arr, pref, zener,
                       (float(fr_all.min()), float(fr_all.max())), tuple(coverage), tuple(not_overlapping),
                       tuple(findings), tuple(pairs), curves_out, zcov)
