"""Accuracy of the campaign numerics (issue 27) on synthetic step-sine campaigns with a known truth.

For several noise seeds: the default campaign (:func:`jointid.measurement.campaign_synth.synthesize_campaign`,
fractional Zener, WLF c1 = 9, c2 = 110 K at 20 C, Kraus K'inf/K'0 = 0.6, Ac = 0.2 mm, m = 0.6;
6 temperatures x 10 lines 1-100 Hz x 5 amplitudes, 0.5 % noise on both channels) is written,
processed (step-sine), and the master curve (smallest amplitude) and the Kraus fits (20 C, every line)
are compared with the truth. Prints, per seed: worst |log10 aT error| (decades) and the worst
|error| / reported std, the WLF constants' errors in their reported sigmas, the worst relative
error of the fitted master curve over the shifted range, the worst storage-ratio error of the data
and of the Kraus fits; then CPU times (``time.process_time``) of writing, processing, the master
curve and one Kraus fit.

Usage::

    python benchmarks/master_curve_accuracy.py [--seeds 5] [--noise 0.005]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

import numpy as np

from jointid.measurement.campaign_synth import DEFAULT_AMPLITUDES_M, CampaignTruth, synthesize_campaign
from jointid.measurement.stepsine import process_stepsine, read_stepsine_csv
from jointid.methods.direct.amplitude_dependence import fit_kraus
from jointid.methods.direct.master_curve import TemperatureCurve, build_master_curve


def run(seed: int, noise: float, cpu: dict) -> dict:
    truth = CampaignTruth()
    amps = np.asarray(DEFAULT_AMPLITUDES_M)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.process_time()
        m = synthesize_campaign(tmp, truth, noise=noise, seed=seed)
        t1 = time.process_time()
        with open(m, newline="") as fh:
            rows = list(csv.DictReader(fh))
        res = {(float(r["temperature_c"]), float(r["amplitude_m"])):
               process_stepsine(read_stepsine_csv(Path(tmp) / r["file"]), parallel_joints=int(r["parallel_joints"]))
               for r in rows}
        t2 = time.process_time()
    temps = sorted({t for t, _ in res})
    curves = [TemperatureCurve(t, res[t, amps[0]].frequency_hz, res[t, amps[0]].stiffness) for t in temps]
    t3 = time.process_time()
    mc = build_master_curve(curves, truth.reference_temperature_c)
    t4 = time.process_time()
    err = [(abs(s - truth.log10_shift(t)), abs(s - truth.log10_shift(t)) / sd if sd > 0 else 0.0) for t, s, sd in mc.shift_factors]
    fr = np.logspace(*np.log10(mc.reduced_range_hz), 400)
    mod = np.max(np.abs(mc.stiffness(fr) / (truth.modulus(fr) * truth.kraus_factor(amps[0])) - 1))
    K = np.array([res[truth.reference_temperature_c, a].stiffness for a in amps])
    ratio_true = truth.kraus_factor(amps) / truth.kraus_factor(amps[0])
    data_ratio = np.max(np.abs(K.real / K.real[0] - ratio_true[:, None]))
    t5 = time.process_time()
    fits = [fit_kraus(amps, K[:, i].real) for i in range(K.shape[1])]
    t6 = time.process_time()
    fit_ratio = max(np.max(np.abs(f.storage(amps) / f.storage(amps[0]) - ratio_true)) for f in fits)
    for k, v in (("write", t1 - t0), ("process", t2 - t1), ("master", t4 - t3), ("kraus", (t6 - t5) / len(fits))):
        cpu.setdefault(k, []).append(v)
    return {"shift": max(e for e, _ in err), "shift_z": max(z for _, z in err),
            "c1_z": (mc.wlf.c1 - truth.wlf_c1) / mc.wlf.c1_std, "c2_z": (mc.wlf.c2 - truth.wlf_c2) / mc.wlf.c2_std,
            "modulus": mod, "data_ratio": data_ratio, "kraus_ratio": fit_ratio, "law": mc.preferred_shift_law,
            "not_overlapping": len(mc.not_overlapping)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--noise", type=float, default=0.005)
    a = ap.parse_args()
    cpu: dict = {}
    print(f"noise {a.noise:g}; must-show: shift < 0.1 decade, |c1|,|c2| error < 2 sigma, modulus < 3 %, storage ratio < 2 %")
    print("seed  max|dlog aT|  max z  c1 z   c2 z   modulus  data ratio  Kraus ratio  law  not-overlapping")
    for seed in range(a.seeds):
        r = run(seed, a.noise, cpu)
        print(f"{seed:4d}  {r['shift']:11.4f}  {r['shift_z']:5.2f}  {r['c1_z']:+5.2f}  {r['c2_z']:+5.2f}  {r['modulus']:7.4f}"
              f"  {r['data_ratio']:10.4f}  {r['kraus_ratio']:11.4f}  {r['law']:4s} {r['not_overlapping']}")
    print("CPU (process_time, s, median over seeds): " + ", ".join(f"{k} {np.median(v):.3g}" for k, v in cpu.items())
          + "  (write/process: 30 tests x 10 lines; kraus: per fit)")


if __name__ == "__main__":
    main()
