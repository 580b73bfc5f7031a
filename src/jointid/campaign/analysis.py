"""Across tests: master curves (time-temperature superposition) and amplitude / preload dependence.

Per specimen, from its ``direct`` tests that were processed:

* **Master curve** (:func:`jointid.methods.direct.master_curve.build_master_curve`): one
  temperature curve per tested temperature, at the specimen's *reference condition*:
  the (amplitude, preload) pair tested at the most temperatures (ties: the smallest
  amplitude, the linear regime; then the smallest preload). Only the lines that reached
  the commanded amplitude (``amplitude_ok``) are used; repeated tests at one
  temperature are merged by the master-curve builder. The reference temperature is the
  one asked for, else the tested temperature nearest the median of those tested.
* **Amplitude dependence** (:func:`jointid.methods.direct.amplitude_dependence.fit_kraus`): at
  each temperature, preload and test frequency tested at >= 4 amplitudes, the storage
  stiffness against the *achieved* amplitude (commanded x ``amplitude_ratio``), and the
  loss stiffness K'' with the Kraus loss law sharing its ``Ac`` and ``m``
  (:func:`~jointid.methods.direct.amplitude_dependence.fit_kraus_loss`).
* **Preload dependence** (:func:`~jointid.methods.direct.amplitude_dependence.fit_preload`): at
  each temperature, amplitude and frequency tested at >= 3 preloads, a straight line
  ``K'(P)``.

A specimen or group whose data do not allow a fit is reported as a one-line finding,
never forced.
"""

from __future__ import annotations

import math
import statistics
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from ..errors import JointIdError

__all__ = ["SpecimenAnalysis", "analyze_specimens", "reference_condition", "KRAUS_MIN_AMPLITUDES", "PRELOAD_MIN_LEVELS"]

#: Amplitudes needed for a Kraus fit.
KRAUS_MIN_AMPLITUDES = 4
#: Preloads needed for a preload fit.
PRELOAD_MIN_LEVELS = 3


@dataclass(frozen=True, eq=False)
class SpecimenAnalysis:
    """What the campaign found for one specimen.

    Parameters
    ----------
    specimen : str
    reference_amplitude_m, reference_preload_n : float
        The reference condition of the master curve (NaN without one).
    master_curve : MasterCurve or None
        :class:`jointid.methods.direct.master_curve.MasterCurve`, None when not built.
    kraus : list of dict
        One per (temperature, preload, frequency): keys ``temperature_c``, ``preload_n``,
        ``frequency_hz``, ``amplitude_m`` (A,), ``storage_n_m`` (A,), ``loss_n_m`` (A,), ``fit`` (KrausFit),
        ``loss_fit`` (KrausLossFit or None).
    preload : list of dict
        One per (temperature, amplitude, frequency): ``temperature_c``, ``amplitude_m``,
        ``frequency_hz``, ``preload_n`` (P,), ``storage_n_m`` (P,), ``fit`` (PreloadFit).
    findings : list of str
        One line per thing that could not be done, and why.
    unit_slips : dict of int to str
        By manifest row, the tests whose stiffness is a unit factor off the others' and left out of the master curve:
        the factor, the probable cause and the fix (also in ``findings``; the tests table's ``warning``).
    """

    specimen: str
    reference_amplitude_m: float
    reference_preload_n: float
    master_curve: object | None
    kraus: list = field(default_factory=list)
    preload: list = field(default_factory=list)
    findings: list = field(default_factory=list)
    unit_slips: dict = field(default_factory=dict)


def _fkey(f: float) -> float:
    return float(f"{f:.9g}")


def reference_condition(tests) -> tuple[float, float]:
    """The (amplitude_m, preload_n) pair tested at the most temperatures (ties: smallest amplitude, then preload)."""
    temps = defaultdict(set)
    for t in tests:
        temps[(t.amplitude_m, t.preload_n)].add(t.temperature_c)
    return min(temps, key=lambda c: (-len(temps[c]), c[0], c[1]))


def _master_curve(specimen, tests, outcomes, reference_temperature_c, vertical_shift, findings, slips):
    from ..methods.direct.master_curve import TemperatureCurve, build_master_curve
    from ..methods.direct.phase_sign import reversed_phase

    amp, pre = reference_condition(tests)
    curves = []
    slips.update(_unit_slips(specimen, [t for t in tests if (t.amplitude_m, t.preload_n) == (amp, pre)], outcomes, findings))
    for t in tests:
        if (t.amplitude_m, t.preload_n) != (amp, pre) or t.row in slips:
            continue
        lines = outcomes[t.row].lines
        ok = np.asarray(lines["amplitude_ok"], dtype=bool)
        if ok.sum() < 3:
            findings.append(f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C) has {int(ok.sum())} lines at the "
                            "commanded amplitude; left out of the master curve (3 needed)")
            continue
        k = lines["stiffness_real"][ok] + 1j * lines["stiffness_imag"][ok]
        reversed_ = reversed_phase(k)
        if reversed_ is not None:  # no material superposes on a reversed phase (methods.direct.phase_sign)
            findings.append(f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C): {reversed_}; left out of the master curve")
            continue
        curves.append(TemperatureCurve(t.temperature_c, lines["frequency_hz"][ok], k))
    temps = sorted({c.temperature_c for c in curves})
    if len(temps) < 2:
        findings.append(f"specimen {specimen}: {len(temps)} temperature(s) at {amp:g} m, {pre:g} N; a master curve needs 2 or more")
        return amp, pre, None
    ref = reference_temperature_c
    if ref is None:
        med = statistics.median(temps)
        ref = min(temps, key=lambda x: (abs(x - med), x))
    try:
        return amp, pre, build_master_curve(curves, ref, vertical_shift=vertical_shift)
    except JointIdError as exc:
        findings.append(f"specimen {specimen}: no master curve: {' '.join(str(exc).split())}")
        return amp, pre, None


def _unit_slips(specimen, tests, outcomes, findings) -> dict:
    """The tests whose stiffness is a unit factor off the others' (:mod:`jointid.methods.direct.unit_slip`), by row:
    what is wrong (the factor, the probable cause and the fix), also one finding each; they are left out of the master
    curve."""
    from ..methods.direct.unit_slip import find_unit_slips

    levels = []
    for t in tests:
        lines = outcomes[t.row].lines
        ok = np.asarray(lines["amplitude_ok"], dtype=bool)
        k = np.hypot(lines["stiffness_real"], lines["stiffness_imag"])[ok if ok.sum() >= 3 else slice(None)]
        k = k[np.isfinite(k) & (k > 0)]
        levels.append(float(np.median(np.log(k))) if k.size else math.nan)
    rows = {}
    for slip in find_unit_slips([t.temperature_c for t in tests], levels):
        t = tests[slip.index]
        amp = float(np.median(outcomes[t.row].lines["amplitude_ratio"]))
        seen = (f"; its achieved amplitude is {amp:.4g} x the commanded, so it is the displacement"
                if abs(math.log(amp * slip.factor)) <= math.log(slip.tolerance) and abs(math.log(amp)) > math.log(slip.tolerance)
                else "")
        why = (f"its stiffness is {slip.ratio:.4g} x what the other tests give at {t.temperature_c:g} C, the unit factor "
               f"{slip.factor:.6g} (within their scatter, x/ {slip.tolerance:.3g}): probably {slip.cause}{seen}; left out of "
               "the master curve; name that file's columns with their units (force_kN, displacement_mm: converted "
               "exactly) or convert it (--column/--scale apply to every file of the campaign)")
        findings.append(f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C, {t.value('file')}): {why}")
        rows[t.row] = why
    return rows


def _storage_by_line(t, outcome, achieved: bool):
    """``{frequency: (amplitude, K', K'')}`` of a test (achieved or commanded amplitude)."""
    lines = outcome.lines
    amp = t.amplitude_m * (lines["amplitude_ratio"] if achieved else 1.0)
    amp = np.broadcast_to(amp, lines["frequency_hz"].shape)
    return {_fkey(f): (a, s, l) for f, a, s, l in zip(lines["frequency_hz"], amp, lines["stiffness_real"], lines["stiffness_imag"])}


def _kraus(specimen, tests, outcomes, findings):
    from ..methods.direct.amplitude_dependence import fit_kraus, fit_kraus_loss

    groups = defaultdict(list)
    for t in tests:
        groups[(t.temperature_c, t.preload_n)].append(t)
    out = []
    for (temp, pre), group in sorted(groups.items()):
        if len({t.amplitude_m for t in group}) < KRAUS_MIN_AMPLITUDES:
            continue
        per_line = defaultdict(list)
        for t in group:
            for f, point in _storage_by_line(t, outcomes[t.row], achieved=True).items():
                per_line[f].append(point)
        for f, pts in sorted(per_line.items()):
            if len({p[0] for p in pts}) < KRAUS_MIN_AMPLITUDES:
                continue
            pts.sort()
            a, s, loss = (np.array([p[i] for p in pts]) for i in range(3))
            where = f"specimen {specimen}: {temp:g} C, {pre:g} N, {f:g} Hz"
            try:
                fit = fit_kraus(a, s)
            except JointIdError as exc:
                findings.append(f"{where}: no Kraus fit: {' '.join(str(exc).split())}")
                continue
            try:
                loss_fit = fit_kraus_loss(a, loss, fit)
            except JointIdError as exc:
                loss_fit = None
                findings.append(f"{where}: no Kraus loss fit: {' '.join(str(exc).split())}")
            out.append({"temperature_c": temp, "preload_n": pre, "frequency_hz": f, "amplitude_m": a, "storage_n_m": s,
                        "loss_n_m": loss, "fit": fit, "loss_fit": loss_fit})
    return out


def _preload(specimen, tests, outcomes, findings):
    from ..methods.direct.amplitude_dependence import fit_preload

    groups = defaultdict(list)
    for t in tests:
        groups[(t.temperature_c, t.amplitude_m)].append(t)
    out = []
    for (temp, amp), group in sorted(groups.items()):
        if len({t.preload_n for t in group}) < PRELOAD_MIN_LEVELS:
            continue
        per_line = defaultdict(list)
        for t in group:
            for f, (_, s, _) in _storage_by_line(t, outcomes[t.row], achieved=False).items():
                per_line[f].append((t.preload_n, s))
        for f, pts in sorted(per_line.items()):
            if len({p for p, _ in pts}) < PRELOAD_MIN_LEVELS:
                continue
            pts.sort()
            p = np.array([x[0] for x in pts])
            s = np.array([x[1] for x in pts])
            try:
                fit = fit_preload(p, s)
            except JointIdError as exc:
                findings.append(f"specimen {specimen}: {temp:g} C, {amp:g} m, {f:g} Hz: no preload fit: {' '.join(str(exc).split())}")
                continue
            out.append({"temperature_c": temp, "amplitude_m": amp, "frequency_hz": f, "preload_n": p, "storage_n_m": s, "fit": fit})
    return out


def analyze_specimens(tests, outcomes, *, reference_temperature_c: float | None = None,
                      vertical_shift: bool = False) -> dict[str, SpecimenAnalysis]:
    """Master curve, amplitude and preload dependence of every specimen with direct tests.

    Parameters
    ----------
    tests : sequence of CampaignTest
        The manifest's tests.
    outcomes : mapping of int to TestOutcome
        Outcome per manifest row; failed tests are left out.
    reference_temperature_c : float, optional
        Reference temperature of every master curve, degrees C (default: per specimen, see the module docstring).
    vertical_shift : bool
        Also shift vertically by the density-temperature factor (see ``build_master_curve``).

    Returns
    -------
    dict of str to SpecimenAnalysis
        By specimen, in manifest order.
    """
    by_specimen = defaultdict(list)
    for t in tests:
        if t.kind == "direct" and outcomes[t.row].ok:
            by_specimen[t.specimen].append(t)
    result = {}
    for specimen, group in by_specimen.items():
        findings: list[str] = [f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C): columns converted to SI: "
                               f"{outcomes[t.row].parameters['columns_converted']}"
                               for t in group if outcomes[t.row].parameters.get("columns_converted")]
        findings += [f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C): lines not used: "
                     f"{outcomes[t.row].parameters['lines_not_used']}"
                     for t in group if outcomes[t.row].parameters.get("lines_not_used")]
        findings += [f"specimen {specimen}: row {t.row} ({t.temperature_c:g} C): {outcomes[t.row].parameters['notes']}"
                     for t in group if outcomes[t.row].parameters.get("notes")]
        slips: dict = {}
        amp, pre, mc = _master_curve(specimen, group, outcomes, reference_temperature_c, vertical_shift, findings, slips)
        if mc is not None:  # what the master curve found (temperatures left out, laws not determined, ...) is the campaign's
            findings.extend(f"specimen {specimen}: master curve: {f}" for f in mc.findings)
        kraus = _kraus(specimen, group, outcomes, findings)
        preload = _preload(specimen, group, outcomes, findings)
        result[specimen] = SpecimenAnalysis(specimen, amp, pre, mc, kraus, preload, findings, slips)
    return result
