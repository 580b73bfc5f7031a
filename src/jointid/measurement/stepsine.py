"""Step-sine processing of a direct (elastomer test system) test: time histories to K21(f).

The test system imposes a sinusoidal displacement ``x(t)`` on one side of the
joint(s), one test frequency at a time, and the load cell on the blocked side
measures the transmitted force ``F(t)``. One *block* of time data is recorded
per test frequency.

CSV long format
---------------
One file, one row per sample, a header row with (by default) the columns

=================  ====  ==============================================
``frequency_hz``   Hz    test frequency of the block the sample belongs to
``time_s``         s     sample time (strictly increasing within a block)
``displacement_m`` m     imposed displacement x(t)
``force_n``        N     transmitted force F(t) (all joints in parallel)
=================  ====  ==============================================

Other columns are ignored. Rows with the same ``frequency_hz`` form one block
(blocks are returned in ascending frequency; the rows of a block keep their
file order and must have increasing time). Other column names and units are
mapped with the ``columns`` and ``scale`` options of :func:`read_stepsine_csv`,
keyed by the logical names ``frequency``, ``time``, ``displacement``,
``force``: e.g. ``columns={"displacement": "disp_mm", "force": "load_kN"}``,
``scale={"displacement": 1e-3, "force": 1e3}`` reads millimetres and
kilonewtons (SI value = file value x scale). An empty cell reads as NaN (and
is then rejected, naming the block).

Processing (:func:`process_stepsine`), per block
------------------------------------------------
1. **Checks** (:class:`StepSineBlock`): finite values, strictly increasing
   time, at least 2 whole cycles recorded, at least 4 samples per cycle, a
   displacement that is not identically constant. Violations raise
   :class:`~jointid.errors.DataError` naming the block's frequency.
2. **Settling transient**: each whole cycle (counted from the first sample) is
   fitted with DC + the fundamental, giving per-cycle displacement and force
   amplitudes and the per-cycle complex ratio F/X. The steady reference is
   the median over the last half of the cycles (which must not drift itself:
   its two halves may differ by at most ``max(settle_tolerance, 4 sigma_mean)``,
   else the block did not settle and is rejected); a cycle in the first half
   is unsettled when any of the three deviates from the reference by more
   than ``max(settle_tolerance, 4 sigma)`` (relative; sigma: the standard
   error of a one-cycle estimate from the cycles' own fit residuals, so
   noise does not make every cycle unsettled).
   Everything up to and including the last unsettled cycle is dropped; at
   least ``min_cycles`` whole cycles must remain. Records under 4 whole
   cycles are fitted as they are.
3. **Fit** over the remaining whole cycles (:mod:`.stepsine_fit`): least squares of
   DC + harmonics ``1..harmonics`` (cos, sin) at the test frequency + linear
   trends of the DC and of the fundamental's phasor, both channels (harmonics
   at or above the Nyquist frequency are left out). Fitting the harmonics
   keeps a distorted force (3rd harmonic) from biasing the fundamental; the
   trends keep a slow drift (a specimen heating, ``F(t) = F_0 (1 + r t)``)
   from biasing it: the phasors are those at the block's first sample.
4. **Results**: ``K21 = F1 / X1`` (fundamental phasors at the block's first sample, ``Re{P e^{j w t}}``),
   divided by ``parallel_joints`` (2 in double shear); the displacement
   amplitude |X1| over the commanded amplitude (``commanded_amplitude_m``;
   default: the median achieved amplitude), lines off by more than
   ``tolerance`` flagged ``amplitude_ok = False``; the force's total harmonic
   distortion ``sqrt(sum_{h>=2} |F_h|^2) / |F_1|``; the rms residual of each
   channel's fit relative to the rms of its fundamental.
5. **Clipping, distortion and drift** (:mod:`.stepsine_checks`): a block with a clipped
   (flat tops; or flat peaks under noise added after the clip: the samples near the
   extremes no longer follow the fundamental) or heavily distorted channel, or whose
   ``|F1/X1|`` drifts by more than 1 % over its settled cycles, is flagged
   ``distorted`` and is not usable (``amplitude_ok`` False: never fitted); too few
   usable lines: refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import DataError
from ..frequency import Frequency
from .stepsine_checks import distortion_problems, drift_problem, peak_slope
from .stepsine_fit import fit_harmonics_with_trend
# the block and the CSV long format (re-exported: ``from jointid.measurement.stepsine import ...`` as before)
from .stepsine_files import DEFAULT_COLUMNS, StepSineBlock, hz_text, read_stepsine_csv, write_stepsine_csv

__all__ = [
    "StepSineBlock",
    "StepSineResult",
    "process_block",
    "process_stepsine",
    "pooled_drift",
    "DRIFT_CHI2",
    "read_stepsine_csv",
    "write_stepsine_csv",
    "DEFAULT_COLUMNS",
]

#: ``chi2`` (two degrees of freedom) of a test's mean drift rate above which its lines are taken at each block's first
#: sample with a linear trend fitted (:func:`pooled_drift`; :mod:`.stepsine_fit`): ``P(chi2_2 > 25) = e^-12.5``.
DRIFT_CHI2 = 25.0


@dataclass(frozen=True, eq=False)
class StepSineResult:
    """Complex stiffness per test frequency from a step-sine test (per joint).

    Parameters
    ----------
    frequency_hz : ndarray, shape (F,)
        Test frequencies, Hz (ascending).
    stiffness : ndarray, shape (F,), complex
        K21 = F1 / X1 divided by ``parallel_joints``, N/m (phasors at each block's first sample: a linear drift
        along the block is fitted, :mod:`.stepsine_fit`).
    displacement_amplitude_m : ndarray, shape (F,)
        Achieved fundamental displacement amplitude |X1| (peak), m.
    force_amplitude_n : ndarray, shape (F,)
        Fundamental force amplitude |F1| (peak, all joints), N.
    commanded_amplitude_m : ndarray, shape (F,)
        Commanded displacement amplitude (peak), m.
    amplitude_ratio : ndarray, shape (F,)
        Achieved / commanded displacement amplitude.
    amplitude_ok : ndarray of bool, shape (F,)
        The line is usable: ``|amplitude_ratio - 1| <= tolerance`` and not ``distorted``.
    force_thd : ndarray, shape (F,)
        Total harmonic distortion of the force (harmonics 2..H over the fundamental).
    force_residual, displacement_residual : ndarray, shape (F,)
        rms fit residual over the rms of the fitted fundamental.
    settled_time_s : ndarray, shape (F,)
        Time from the block's first sample to the start of the analysed cycles, s.
    cycles_used : ndarray of int, shape (F,)
        Whole cycles in the fit.
    parallel_joints : int
        Number of joints loaded in parallel (the force was divided by it).
    tolerance : float
        Amplitude tolerance used for ``amplitude_ok``.
    distorted : ndarray of bool, shape (F,), optional
        Force or displacement clipped (flat tops) or harmonically distorted (:mod:`.stepsine_checks`).
    distortion : tuple of str
        One line per distorted block: its frequency and what is wrong.
    drift_rate_per_s : ndarray, shape (F,), optional
        Relative drift of ``|K21|`` along each block, ``Re d ln(F1/X1) / dt``, 1/s (from the trend fit).
    notes : tuple of str
        Test-level notes on usable lines (a drift, :func:`pooled_drift`); never a reason to drop a line.
    """

    frequency_hz: np.ndarray
    stiffness: np.ndarray
    displacement_amplitude_m: np.ndarray
    force_amplitude_n: np.ndarray
    commanded_amplitude_m: np.ndarray
    amplitude_ratio: np.ndarray
    amplitude_ok: np.ndarray
    force_thd: np.ndarray
    force_residual: np.ndarray
    displacement_residual: np.ndarray
    settled_time_s: np.ndarray
    cycles_used: np.ndarray
    parallel_joints: int = 2
    tolerance: float = 0.05
    distorted: np.ndarray | None = None
    distortion: tuple[str, ...] = ()
    drift_rate_per_s: np.ndarray | None = None
    notes: tuple[str, ...] = ()

    @property
    def frequency(self) -> Frequency:
        """The test frequencies as a :class:`~jointid.frequency.Frequency`."""
        return Frequency(self.frequency_hz)

    @property
    def magnitude(self) -> np.ndarray:
        """|K21| per joint, N/m, shape (F,)."""
        return np.abs(self.stiffness)

    @property
    def loss_factor(self) -> np.ndarray:
        """Loss factor eta = Im K / Re K, shape (F,)."""
        return self.stiffness.imag / self.stiffness.real

    def columns(self) -> dict:
        """Columns of ``direct_stiffness.csv`` (per joint): name -> array (F,)."""
        return {
            "frequency_hz": self.frequency_hz,
            "stiffness_real": self.stiffness.real,
            "stiffness_imag": self.stiffness.imag,
            "magnitude": self.magnitude,
            "loss_factor": self.loss_factor,
            "amplitude_ratio": self.amplitude_ratio,
            "amplitude_ok": self.amplitude_ok,
        }


# ---------------------------------------------------------------- processing
def _cycle_phasors(t: np.ndarray, y: np.ndarray, f: float, ncyc: int) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental phasor of each whole cycle (DC + cos + sin fit per cycle) and its relative standard error.

    Returns
    -------
    P : ndarray, shape (channels, ncyc), complex
    rel_se : ndarray, shape (channels, ncyc)
        Standard error of |P| over |P|, from the cycle's own fit residual
        (independent of any drift between cycles).
    """
    k = np.floor(t * f + 1e-9).astype(int)
    keep = k < ncyc
    k, tt, yy = k[keep], t[keep], y[:, keep]
    starts = np.searchsorted(k, np.arange(ncyc))
    counts = np.diff(np.append(starts, k.size)).astype(float)
    ph = 2.0 * np.pi * f * tt
    c, s = np.cos(ph), np.sin(ph)
    basis = [np.ones_like(c), c, s]
    G = np.empty((ncyc, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            G[:, a, b] = G[:, b, a] = np.add.reduceat(basis[a] * basis[b], starts)
    rhs = np.stack([np.add.reduceat(yy * bs[None, :], starts, axis=1) for bs in basis], axis=-1)  # (channels, ncyc, 3)
    coef = np.linalg.solve(G[None], rhs[..., None])[..., 0]
    rss = np.add.reduceat(yy**2, starts, axis=1) - np.sum(coef * rhs, axis=-1)
    P = coef[..., 1] - 1j * coef[..., 2]
    se = np.sqrt(np.maximum(rss, 0.0) / np.maximum(counts - 3.0, 1.0)) * np.sqrt(2.0 / counts)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(np.abs(P) > 0, se / np.abs(P), np.inf)
    return P, rel


def _settled_start(P: np.ndarray, rel_se: np.ndarray, settle_tolerance: float, frequency_hz: float) -> int:
    """Index of the first settled cycle from per-cycle phasors P (2, ncyc) of (x, F) and their relative errors.

    Raises DataError if the last half of the record itself still drifts (the
    transient lasts longer than half the record).
    """
    ncyc = P.shape[1]
    if ncyc < 4:
        return 0
    tail = slice(ncyc // 2, None)
    ntail = ncyc - ncyc // 2
    h = ntail // 2
    se_x, se_f = (float(np.median(r[tail])) for r in rel_se)
    checks = (
        ("displacement amplitude", np.abs(P[0]), se_x),
        ("force amplitude", np.abs(P[1]), se_f),
        ("force/displacement ratio", P[1] / P[0], math.hypot(se_x, se_f)),
    )
    start = 0
    for label, q, sigma in checks:
        qt = q[tail]
        ref = complex(np.median(qt.real), np.median(qt.imag)) if np.iscomplexobj(q) else float(np.median(qt))
        if ref == 0:
            continue
        # the reference window must not drift: compare its two halves
        drift = abs(np.mean(qt[:h]) - np.mean(qt[h:])) / abs(ref)
        if drift > max(settle_tolerance, 4.0 * sigma * math.sqrt(1.0 / h + 1.0 / (ntail - h))):
            raise DataError(
                f"block at {hz_text(frequency_hz)}: not settled: the {label} still changes by {drift:.1%} over the last "
                f"{ntail} of {ncyc} cycles; record more cycles after the transient"
            )
        dev = np.abs(q[: ncyc // 2] / ref - 1.0)
        bad = np.nonzero(dev > max(settle_tolerance, 4.0 * sigma))[0]
        if bad.size:
            start = max(start, int(bad[-1]) + 1)
    return start


def process_block(block: StepSineBlock, harmonics: int = 5, settle_tolerance: float = 0.02, min_cycles: int = 2) -> dict:
    """Fundamental phasors and quality measures of one block (see the module docstring).

    Parameters
    ----------
    block : StepSineBlock
        Time histories at one test frequency.
    harmonics : int
        Highest harmonic fitted (>= 1); those at or above Nyquist are dropped.
    settle_tolerance : float
        Relative deviation from the steady state below which a cycle is settled.
    min_cycles : int
        Whole settled cycles required.

    Returns
    -------
    dict
        ``X`` (complex, m), ``F`` (complex, N) (the average over the analysed cycles), ``X0``, ``F0`` (at the
        block's first sample, a linear trend fitted: :mod:`.stepsine_fit`), ``drift_rate`` (``d ln(F1/X1) / dt``,
        complex, 1/s: its real part is the relative drift of ``|K21|``) and ``drift_rate_std`` (the standard error
        of its real and of its imaginary part, 1/s), ``thd``, ``force_residual``,
        ``displacement_residual``, ``settled_time_s``, ``cycles_used``, ``displacement_thd`` and
        ``distortion`` (``""``, or ``"block at 10 Hz: force clipped (flat tops on 33 % of the samples)"``).
    """
    f = block.frequency_hz
    t = block.time_s - block.time_s[0]
    y = np.stack([block.displacement_m, block.force_n])
    dt = block.sample_interval_s
    ncyc = int(math.floor((t[-1] + dt) * f + 1e-6))
    P, rel_se = _cycle_phasors(t, y, f, ncyc)
    k0 = _settled_start(P, rel_se, settle_tolerance, f)
    if ncyc - k0 < min_cycles:
        raise DataError(
            f"block at {hz_text(f)}: only {ncyc - k0} whole cycle(s) left after dropping {k0} settling cycle(s); "
            f"record at least {min_cycles} settled cycles"
        )
    t0, t1 = k0 / f, ncyc / f
    m = (t >= t0 - 1e-9 / f) & (t < t1 - 1e-9 / f)
    tt, yy = t[m], y[:, m]
    spc = 1.0 / (f * dt)
    H = max(1, min(int(harmonics), int(math.ceil(spc / 2.0)) - 1))
    fit = fit_harmonics_with_trend(tt, yy, f, H)
    ph_all, resid = fit.plain_phasors, fit.plain_residual  # (H, 2), (n, 2): the average over the analysed cycles
    X, F = ph_all[0, 0], ph_all[0, 1]
    X0, F0 = fit.phasors[0]  # at the block's first sample (t = 0), a linear trend fitted
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = complex((fit.fundamental_slope[1] / F0 - fit.fundamental_slope[0] / X0) * f)  # d ln K / dt, 1/s
        # (floored at 1e-9 per cycle, a round-off's: noise-free records do not "drift" by 1e-17)
        rate_std = float(max(math.hypot(fit.slope_std[1] / abs(F0), fit.slope_std[0] / abs(X0)), 1e-9) * f)
    if abs(X) <= 1e-12 * max(np.max(np.abs(block.displacement_m)), 1e-300):
        raise DataError(f"block at {hz_text(f)}: no displacement at the test frequency; check the displacement channel")
    rms1 = np.abs(ph_all[0]) / math.sqrt(2.0)
    rres = np.sqrt(np.mean(resid**2, axis=0)) / np.where(rms1 > 0, rms1, np.inf)
    thd = float(np.sqrt(np.sum(np.abs(ph_all[1:, 1]) ** 2)) / abs(F)) if F != 0 else float("nan")
    thd_x = float(np.sqrt(np.sum(np.abs(ph_all[1:, 0]) ** 2)) / abs(X))
    envelope = np.abs(fit.phasors[0][None, :] + (f * tt)[:, None] * fit.fundamental_slope[None, :])
    detrended = yy.T - fit.offset
    peaks = [peak_slope(detrended[:, i], fit.fundamental[:, i], envelope[:, i]) for i in (0, 1)]
    problems = distortion_problems(yy[1], thd, yy[0], thd_x, force_peak=peaks[1], displacement_peak=peaks[0])
    drift = drift_problem(P[1, k0:ncyc] / P[0, k0:ncyc], f)
    if drift:
        problems.append(drift)
    return {
        "distortion": f"block at {hz_text(f)}: " + ", ".join(problems) if problems else "",
        "displacement_thd": thd_x,
        "X": complex(X),
        "F": complex(F),
        "X0": complex(X0),
        "F0": complex(F0),
        "drift_rate": rate,
        "drift_rate_std": rate_std,
        "thd": thd,
        "displacement_residual": float(rres[0]),
        "force_residual": float(rres[1]),
        "settled_time_s": float(t0),
        "cycles_used": int(ncyc - k0),
    }


def process_stepsine(
    blocks: Sequence[StepSineBlock],
    parallel_joints: int = 2,
    commanded_amplitude_m: float | Sequence[float] | None = None,
    tolerance: float = 0.05,
    harmonics: int = 5,
    settle_tolerance: float = 0.02,
    min_cycles: int = 2,
) -> StepSineResult:
    """Complex stiffness per joint from step-sine blocks (see the module docstring).

    Parameters
    ----------
    blocks : sequence of StepSineBlock
        One block per test frequency (any order; distinct frequencies).
    parallel_joints : int
        Joints loaded in parallel (2 in double shear); the stiffness is divided by it.
    commanded_amplitude_m : float or sequence of float, optional
        Commanded displacement amplitude (peak), m, one value or one per block
        (in the order given); default: the median achieved amplitude.
    tolerance : float
        Relative amplitude deviation above which a line is flagged.
    harmonics, settle_tolerance, min_cycles
        See :func:`process_block`.

    Returns
    -------
    StepSineResult
        Lines in ascending frequency.
    """
    if not blocks:
        raise DataError("no step-sine blocks to process; the file holds no data rows")
    if not (isinstance(parallel_joints, (int, np.integer)) and parallel_joints >= 1):
        raise DataError(f"parallel_joints must be an integer >= 1, got {parallel_joints!r}")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise DataError(f"amplitude tolerance must be a positive number, got {tolerance!r}")
    freq = np.array([b.frequency_hz for b in blocks])
    uniq, counts = np.unique(freq, return_counts=True)
    if np.any(counts > 1):
        raise DataError(f"block at {hz_text(uniq[np.argmax(counts > 1)])}: given {counts.max()} times; merge or drop the duplicates")
    rows = [process_block(b, harmonics, settle_tolerance, min_cycles) for b in blocks]
    X = np.array([r["X"] for r in rows])
    F = np.array([r["F"] for r in rows])
    amp = np.abs(X)
    if commanded_amplitude_m is None:
        cmd = np.full(freq.shape, float(np.median(amp)))
    else:
        cmd = np.broadcast_to(np.asarray(commanded_amplitude_m, dtype=float), freq.shape).copy()
        if not np.all(np.isfinite(cmd) & (cmd > 0)):
            raise DataError(f"commanded amplitude must be positive (m, peak), got {commanded_amplitude_m!r}")
    drift_note = pooled_drift(np.array([r["drift_rate"] for r in rows]), np.array([r["drift_rate_std"] for r in rows]))
    if drift_note:  # the test drifts: every line at its block's first sample, the trend fitted (exact for a linear drift)
        X = np.array([r["X0"] for r in rows])
        F = np.array([r["F0"] for r in rows])
    order = np.argsort(freq)
    ratio = amp / cmd
    distorted = np.array([bool(r["distortion"]) for r in rows])
    usable = (np.abs(ratio - 1.0) <= tolerance) & ~distorted
    notes = tuple(rows[i]["distortion"] for i in order if rows[i]["distortion"])
    if distorted.any() and usable.sum() < 2:
        raise DataError(
            f"{int(distorted.sum())} of {distorted.size} blocks are clipped or distorted ({notes[0]}); jointid does not "
            "identify a stiffness from them: lower the excitation or raise the load cell's (amplifier's, actuator's) "
            "range and measure again"
        )

    def col(key, dtype=float):
        return np.array([r[key] for r in rows], dtype=dtype)[order]

    return StepSineResult(
        frequency_hz=freq[order],
        stiffness=(F / X / parallel_joints)[order],
        displacement_amplitude_m=amp[order],
        force_amplitude_n=np.abs(F)[order],
        commanded_amplitude_m=cmd[order],
        amplitude_ratio=ratio[order],
        amplitude_ok=usable[order],
        force_thd=col("thd"),
        force_residual=col("force_residual"),
        displacement_residual=col("displacement_residual"),
        settled_time_s=col("settled_time_s"),
        cycles_used=col("cycles_used", int),
        parallel_joints=int(parallel_joints),
        tolerance=float(tolerance),
        distorted=distorted[order],
        distortion=notes,
        drift_rate_per_s=np.array([r["drift_rate"].real for r in rows])[order],
        notes=(drift_note,) if drift_note else (),
    )


def pooled_drift(rate: np.ndarray, rate_std: np.ndarray) -> str:
    """One line when a test's blocks drift, else ``""``: the weighted mean of the blocks' drift rates against its error.

    Each block's trend fit gives ``rho_b = d ln(F1/X1) / dt`` (complex, 1/s) with standard error ``s_b`` of its real
    and of its imaginary part. Their weighted mean ``rho = sum(rho_b / s_b^2) / sum(1 / s_b^2)`` has standard error
    ``s = sum(1 / s_b^2)^(-1/2)``; the test drifts when ``chi2 = |rho|^2 / s^2 >`` :data:`DRIFT_CHI2` (two degrees of
    freedom: a false alarm once in 270 000 clean tests). Pooling matters: one block alone cannot see a drift that biases
    its average by one standard error (the slope's lever arm, ``sqrt(12)``, is against it), a test's low-frequency
    blocks together can.

    Parameters
    ----------
    rate : ndarray, shape (B,), complex
        ``rho_b``, 1/s.
    rate_std : ndarray, shape (B,)
        ``s_b``, 1/s (blocks with a non-finite or zero one are left out).

    Returns
    -------
    str
        e.g. ``"the stiffness drifts along the blocks (|K21| +0.2 %/s, 14 standard errors): the specimen heating or the
        machine drifting; K21 is taken at each block's first sample (a linear trend fitted per block)"``.
    """
    rate, rate_std = np.asarray(rate, complex), np.asarray(rate_std, float)
    ok = np.isfinite(rate) & np.isfinite(rate_std) & (rate_std > 0)
    if not ok.any():
        return ""
    w = 1.0 / rate_std[ok] ** 2
    mean = complex(np.sum(w * rate[ok]) / np.sum(w))
    chi2 = abs(mean) ** 2 * float(np.sum(w))
    if chi2 <= DRIFT_CHI2:
        return ""
    return (f"the stiffness drifts along the blocks (|K21| {100 * mean.real:+.2g} %/s, {math.sqrt(chi2):.0f} standard "
            "errors): the specimen heating or the machine drifting; K21 is taken at each block's first sample (a "
            "linear trend fitted per block)")
