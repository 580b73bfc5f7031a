"""Synthetic test campaign with a known truth: step-sine files over temperature, amplitude and specimen.

The truth (:class:`CampaignTruth`) is a joint stiffness (per joint, N/m) that
combines three laws:

* a fractional-derivative Zener stiffness at the reference temperature
  ``Tref``, ``K(f_r) = (K0 + Kinf (j 2 pi f_r tau)^alpha) / (1 + (j 2 pi f_r tau)^alpha)``
  (the same form as :func:`jointid.methods.direct.zener_fit.zener_modulus`, which
  this lower layer cannot import);
* time-temperature superposition with a WLF shift,
  ``log10 aT = -c1 (T - Tref) / (c2 + T - Tref)``: a test at temperature ``T``
  and frequency ``f`` sees the reduced frequency ``f_r = f aT``, optionally
  with the vertical (density-temperature) factor
  ``bT = (T + 273.15) / (Tref + 273.15)`` on the stiffness;
* a Kraus (Payne effect) amplitude factor on the whole complex stiffness,
  ``g(A) = r + (1 - r) / (1 + (A / Ac)^(2 m))`` with ``r = K'inf / K'0``, so
  the storage stiffness follows ``K'(A) = K'inf + (K'0 - K'inf) / (1 + (A/Ac)^(2m))``
  at every frequency and the loss factor does not depend on the amplitude.

and optionally a linear preload factor ``1 + preload_slope_per_n P``.
The stiffness of one test is ``K(f aT) bT g(A) (1 + s P)``.
:func:`synthesize_campaign` writes one step-sine CSV per test
(:func:`~jointid.measurement.stepsine_synth.synthesize_stepsine`, noise on both
channels, a third harmonic in the force) and a ``manifest.csv`` for
``jointid campaign``.
"""

from __future__ import annotations

import csv
import io
import os
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import DataError
from .stepsine import write_stepsine_csv
from .stepsine_synth import synthesize_stepsine

__all__ = ["CampaignTruth", "synthesize_campaign", "DEFAULT_TEMPERATURES_C", "DEFAULT_AMPLITUDES_M",
           "DEFAULT_FREQUENCIES_HZ", "MANIFEST_COLUMNS"]

#: Six test temperatures, deg C: neighbouring curves overlap by 0.9-1.5 decades with the default truth.
DEFAULT_TEMPERATURES_C = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0)
#: Five displacement amplitudes (peak), m, spanning the default Kraus critical amplitude.
DEFAULT_AMPLITUDES_M = (2.0e-5, 6.0e-5, 2.0e-4, 6.0e-4, 2.0e-3)
#: Ten test frequencies, log-spaced 1-100 Hz.
DEFAULT_FREQUENCIES_HZ = tuple(float(x) for x in np.round(np.logspace(0.0, 2.0, 10), 6))
#: Columns of the manifest written by :func:`synthesize_campaign`.
MANIFEST_COLUMNS = ("file", "specimen", "temperature_c", "amplitude_m", "preload_n", "parallel_joints")


@dataclass(frozen=True)
class CampaignTruth:
    """The known truth of a synthetic campaign (stiffness per joint).

    Parameters
    ----------
    k0_n_m, kinf_n_m : float
        Relaxed and unrelaxed Zener stiffness at the reference temperature and
        vanishing amplitude, N/m (``kinf_n_m > k0_n_m``).
    tau_s : float
        Relaxation time at the reference temperature, s.
    alpha : float
        Fractional order, 0 < alpha < 1.
    reference_temperature_c : float
        Reference temperature of the WLF law and of the Zener parameters, deg C.
    wlf_c1 : float
        WLF constant c1 (decades), at the reference temperature.
    wlf_c2 : float
        WLF constant c2, K (deg C differences).
    kraus_kinf_ratio : float
        ``K'inf / K'0`` of the Kraus law (0 < r <= 1).
    kraus_critical_amplitude_m : float
        Kraus critical amplitude ``Ac`` (peak), m.
    kraus_exponent_m : float
        Kraus exponent ``m`` (> 0).
    vertical_shift : bool
        Apply the density-temperature factor ``bT = (T + 273.15) / (Tref + 273.15)``.
    preload_slope_per_n : float
        Relative stiffness change per newton of preload, 1/N (0: no preload dependence).

    Notes
    -----
    The WLF constants default to 9.0 and 110 K on purpose: not the "universal"
    17.44 / 51.6 K, so a method that assumes those constants fails the tests.
    """

    k0_n_m: float = 2.0e5
    kinf_n_m: float = 2.0e6
    tau_s: float = 1.0e-2
    alpha: float = 0.45
    reference_temperature_c: float = 20.0
    wlf_c1: float = 9.0
    wlf_c2: float = 110.0
    kraus_kinf_ratio: float = 0.6
    kraus_critical_amplitude_m: float = 2.0e-4
    kraus_exponent_m: float = 0.6
    vertical_shift: bool = False
    preload_slope_per_n: float = 0.0

    def __post_init__(self):
        ok = (self.k0_n_m > 0 and self.kinf_n_m > self.k0_n_m and self.tau_s > 0 and 0 < self.alpha < 1
              and self.wlf_c1 > 0 and self.wlf_c2 > 0 and 0 < self.kraus_kinf_ratio <= 1
              and self.kraus_critical_amplitude_m > 0 and self.kraus_exponent_m > 0)
        if not ok:
            raise DataError(f"CampaignTruth: inconsistent parameters {self!r}; need 0 < k0 < kinf, tau > 0, "
                            "0 < alpha < 1, c1, c2 > 0, 0 < kraus_kinf_ratio <= 1, Ac > 0, m > 0")

    def log10_shift(self, temperature_c):
        """WLF ``log10 aT = -c1 (T - Tref) / (c2 + T - Tref)`` (decades); float or ndarray like ``temperature_c``."""
        x = np.asarray(temperature_c, dtype=float) - self.reference_temperature_c
        out = -self.wlf_c1 * x / (self.wlf_c2 + x)
        return float(out) if out.ndim == 0 else out

    def modulus(self, reduced_frequency_hz) -> np.ndarray:
        """Zener stiffness at the reference temperature and vanishing amplitude, complex N/m, shape like the input."""
        s = (1j * 2.0 * np.pi * np.asarray(reduced_frequency_hz, dtype=float) * self.tau_s) ** self.alpha
        return (self.k0_n_m + self.kinf_n_m * s) / (1.0 + s)

    def kraus_factor(self, amplitude_m):
        """Kraus factor ``g(A) = r + (1 - r) / (1 + (A/Ac)^(2m))`` (1 at A -> 0); float or ndarray."""
        a = np.asarray(amplitude_m, dtype=float) / self.kraus_critical_amplitude_m
        r = self.kraus_kinf_ratio
        out = r + (1.0 - r) / (1.0 + a ** (2.0 * self.kraus_exponent_m))
        return float(out) if out.ndim == 0 else out

    def vertical_factor(self, temperature_c):
        """``bT = (T + 273.15) / (Tref + 273.15)`` if ``vertical_shift`` else 1."""
        t = np.asarray(temperature_c, dtype=float)
        out = (t + 273.15) / (self.reference_temperature_c + 273.15) if self.vertical_shift else np.ones_like(t)
        return float(out) if out.ndim == 0 else out

    def stiffness(self, frequency_hz, temperature_c: float, amplitude_m: float, preload_n: float = 0.0) -> np.ndarray:
        """True stiffness of one joint in a test, ``K(f aT) bT g(A) (1 + s P)``, complex N/m, shape (F,)."""
        f = np.asarray(frequency_hz, dtype=float)
        fr = f * 10.0 ** self.log10_shift(temperature_c)
        return (self.modulus(fr) * self.vertical_factor(temperature_c) * self.kraus_factor(amplitude_m)
                * (1.0 + self.preload_slope_per_n * float(preload_n)))


def _name(specimen: str, t: float, a: float, p: float) -> str:
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in specimen)
    return f"{safe}_T{t:g}C_A{a * 1e6:g}um_P{p:g}N.csv"


def synthesize_campaign(
    directory: str | os.PathLike,
    truth: CampaignTruth = CampaignTruth(),
    *,
    temperatures_c: Sequence[float] = DEFAULT_TEMPERATURES_C,
    amplitudes_m: Sequence[float] = DEFAULT_AMPLITUDES_M,
    frequencies_hz: Sequence[float] = DEFAULT_FREQUENCIES_HZ,
    preloads_n: Sequence[float] = (0.0,),
    noise: float = 0.005,
    seed: int = 0,
    specimens: Sequence[str] = ("S1",),
    parallel_joints: int = 2,
    samples_per_cycle: float = 32.0,
    cycles: float = 8.37,
    settling_cycles: float = 2.0,
) -> Path:
    """Write a synthetic step-sine campaign (one CSV per test) and its ``manifest.csv``.

    Every combination specimen x temperature x amplitude x preload is one
    test: a step-sine file (one block per frequency) of two joints in
    parallel, with Gaussian noise of rms ``noise`` x the channel amplitude on
    displacement and force and a 3 % third harmonic in the force.

    Parameters
    ----------
    directory : path-like
        Output folder (created); files ``<specimen>_T<T>C_A<A um>um_P<P>N.csv``.
    truth : CampaignTruth
        The known laws (stiffness per joint).
    temperatures_c : sequence of float
        Test temperatures, deg C.
    amplitudes_m : sequence of float
        Displacement amplitudes (peak), m.
    frequencies_hz : sequence of float
        Test frequencies of every test, Hz.
    preloads_n : sequence of float
        Static preloads, N (they scale the stiffness by ``1 + truth.preload_slope_per_n P``).
    noise : float
        Relative noise rms on both channels.
    seed : int
        Base random seed; each test's stream is seeded by it and the file
        name, so a file does not depend on which other tests are generated.
    specimens : sequence of str
        Specimen names (same truth; independent noise).
    parallel_joints : int
        Joints in parallel in every test (the force is that many times one joint's).
    samples_per_cycle, cycles, settling_cycles : float
        Sampling and record length of each block (see ``synthesize_stepsine``).

    Returns
    -------
    Path
        The manifest, ``directory/manifest.csv``, with columns :data:`MANIFEST_COLUMNS`
        (``file`` relative to the manifest).
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    if not (len(temperatures_c) and len(amplitudes_m) and len(frequencies_hz) and len(specimens) and len(preloads_n)):
        raise DataError("synthesize_campaign: temperatures, amplitudes, frequencies, preloads and specimens must not be empty")
    f = np.asarray(frequencies_hz, dtype=float)
    rows = []
    for spec in specimens:
        for t in temperatures_c:
            for a in amplitudes_m:
                for p in preloads_n:
                    k = truth.stiffness(f, float(t), float(a), float(p))
                    name = _name(str(spec), float(t), float(a), float(p))
                    if any(r[0] == name for r in rows):
                        raise DataError(f"synthesize_campaign: two tests map to the file {name}; use distinct specimens and values")
                    test_seed = int(np.random.SeedSequence([int(seed), zlib.crc32(name.encode())]).generate_state(1)[0])
                    blocks = synthesize_stepsine(f, k, float(a), parallel_joints=parallel_joints, cycles=cycles,
                                                 settling_cycles=settling_cycles, samples_per_cycle=samples_per_cycle,
                                                 displacement_noise=noise, force_noise=noise, seed=test_seed)
                    write_stepsine_csv(out / name, blocks)
                    rows.append((name, str(spec), repr(float(t)), repr(float(a)), repr(float(p)), str(int(parallel_joints))))
    from ..io.atomic import atomic_write_text

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(MANIFEST_COLUMNS)
    w.writerows(rows)
    return atomic_write_text(out / "manifest.csv", buf.getvalue())
