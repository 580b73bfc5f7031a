"""Acquisition checks of ``jointid frf`` (measurement/impact_acquisition.py) on small synthetic hits (fixed seeds).

Two SDOF responses (20 Hz and 60 Hz, 2 % damping) to a 2 ms half-sine hammer pulse of 100 N, 4096 Hz, 5 hits;
each slip is the clean record with one change. The clean record processed with a force window gives no line.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.errors import DataError
from jointid.measurement.impact import ImpactOptions, ImpactRecord, estimate_frfs
from jointid.measurement.impact_files import write_impact_npz

FS = 4096.0
WINDOW = dict(force_window_s=0.010, force_pretrigger_s=0.005, force_taper_s=0.001)
BAND = (5.0, 500.0)
DC = ("excited node 3w: the force has a DC offset of 3 N (2.8 % of the peak; mean of the 402 pre-trigger samples, 1237 "
      "standard errors from 0): removed (each hit's pre-trigger mean subtracted); zero the force channel (AC coupling or "
      "auto-zero) before the test")
BADWIN = ("excited node 3w, hit 0: the force window (from --pretrigger-ms 5 before the pulse's start, --force-window-ms 3 "
          "long) ends 2.98 ms before the hit's peak: it would cut the hit out of the force; set --force-window-ms above "
          "--pretrigger-ms + the pulse's length (6.95 ms), e.g. --force-window-ms 14")


def _hits(seed=0, T=4.0, t0=0.1, dc=0.0, dead=False, n_hits=5) -> ImpactRecord:
    """5 hits at node 3 with responses at 1w and 5w: exact SDOF accelerations (periodic over 8 s, cut to T s)."""
    rng = np.random.default_rng(seed)
    n8 = int(8 * FS)
    t = np.arange(n8) / FS
    f_hz = np.fft.rfftfreq(n8, 1 / FS)
    s = 2j * np.pi * f_hz
    H = [s**2 / (1e3 * ((2 * np.pi * fn) ** 2 + 2 * 0.02 * 2 * np.pi * fn * s + s**2)) for fn in (20.0, 60.0)]
    n = int(T * FS)
    F, R = [], []
    for _ in range(n_hits):
        amp, w = 100.0 * (1 + 0.2 * rng.uniform(-1, 1)), 0.002
        on = (t >= t0) & (t <= t0 + w)
        f = np.where(on, amp * np.sin(np.pi * (t - t0) / w), 0.0)
        y = np.array([np.fft.irfft(h * np.fft.rfft(f), n=n8) for h in H])[:, :n]
        y = y + 1e-3 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)
        if dead:
            y[1] = 0.02 * rng.standard_normal(n)
        F.append(f[:n] + dc + 0.05 * rng.standard_normal(n))
        R.append(y)
    return ImpactRecord(np.array(F), np.array(R), FS, ("1w", "5w"), "3w")


def _notes(record, **kw) -> tuple[str, ...]:
    return estimate_frfs([record], ImpactOptions(band_hz=BAND, **kw)).notes


def test_clean_record_with_a_force_window_gives_no_line():
    assert _notes(_hits(), **WINDOW) == ()


def test_no_force_window_reports_the_force_noise_share():
    assert _notes(_hits()) == (
        "excited node 3w: force channel noise outside the pulse (0.0501 N rms) is 0.024 % of the hit's energy in 5-500 Hz, "
        "which scatters H1 by 0.7 % per line over 5 average(s): use --force-window-ms (e.g. --force-window-ms 11.9 "
        "--pretrigger-ms 4)",
    )


def test_dc_offset_on_the_force_is_removed_and_said():
    clean = estimate_frfs([_hits()], ImpactOptions(band_hz=BAND, **WINDOW))
    off = estimate_frfs([_hits(dc=3.0)], ImpactOptions(band_hz=BAND, **WINDOW))
    assert off.notes == (DC,)
    np.testing.assert_allclose(off.h1, clean.h1, rtol=2e-3)


def test_pulse_at_the_record_start_says_no_pretrigger():
    assert _notes(_hits(t0=0.0), **WINDOW) == (
        "excited node 3w: the force pulse starts at sample 1 (t = 0.244 ms) in 5 of 5 hit(s): the trigger has no "
        "pre-trigger, so the pulse's start is cut (and the force's offset cannot be measured); set a pre-trigger of a few "
        "ms (e.g. 5-10 % of the record) and repeat the hits",
    )


def test_response_ringing_at_the_record_end_is_leakage():
    assert _notes(_hits(T=0.25), **WINDOW) == (
        "excited node 3w: response(s) 1w, 5w still ring at the record's end (last 12.5 ms hold up to 13 % of the peak, at "
        "5w; above 0.01 %): leakage biases the FRFs near the lightly damped modes; use a longer record or an exponential "
        "window (--exp-tau-ms, e.g. 50 ms for this 0.25 s record)",
    )


def test_exponential_window_silences_the_leakage_line():
    notes = _notes(_hits(T=0.25), exp_tau_s=0.01, **WINDOW)
    assert not any("ring" in x for x in notes)
    assert estimate_frfs([_hits(T=0.25)], ImpactOptions(band_hz=BAND, exp_tau_s=0.01, **WINDOW)).leaking == ()


def test_leaking_records_are_marked_in_the_uff_file_and_read_back_as_a_note(tmp_path):
    """The records whose response rings at the end carry the mark into frf.uff (ID line 4); reading the file says so,
    naming them, and points at the processing before the free model. The other records stay unmarked."""
    from jointid.io.uff import LEAKAGE_MARK, read_uff_frf

    est = estimate_frfs([_hits(T=0.25)], ImpactOptions(band_hz=BAND, **WINDOW))
    assert [(str(r), str(c)) for r, c in est.leaking] == [("1w", "3w"), ("5w", "3w")]
    path = write_impact_npz(tmp_path / "hits_3.npz", _hits(T=0.25))
    assert main(["frf", str(path), "--out", str(tmp_path / "o"), "--band-hz", "5", "500", "--no-plots",
                 "--force-window-ms", "10", "--pretrigger-ms", "5", "--n-nodes", "5"]) == 0
    text = (tmp_path / "o" / "frf.uff").read_text()
    assert text.count(LEAKAGE_MARK) == 2
    frf = read_uff_frf(tmp_path / "o" / "frf.uff", n_nodes=5)
    assert frf.notes[-1] == (
        "2 record(s) marked by jointid frf as leaking (the response still rang at the record's end: 1w/3w, 5w/3w): their "
        "FRFs are biased near the lightly damped modes, so a free model that does not fit these FRFs there may be this, not "
        "the model; process the hits again with longer records or an exponential window (--exp-tau-ms) before updating the "
        "model")


def test_noise_only_channel_is_named():
    assert _notes(_hits(dead=True), **WINDOW) == (
        "response 5w: its coherence is that of noise uncorrelated with the force at excited node(s) 3w (above 0.68, "
        "noise's 99th percentile with 5 averages, on 1 % of the lines at most, noise: 1 %; the other responses: 100 %): "
        "a dead or disconnected sensor; check it and its cable, or leave it out",
    )


def test_force_window_ending_before_the_pulse_is_refused():
    with pytest.raises(DataError) as e:
        _notes(_hits(), force_window_s=0.003, force_pretrigger_s=0.005)
    assert str(e.value) == BADWIN


def test_cli_prints_the_line_and_refuses_a_bad_window(tmp_path, capsys):
    path = write_impact_npz(tmp_path / "hits_3.npz", _hits(dc=3.0))
    assert main(["frf", str(path), "--out", str(tmp_path / "o"), "--band-hz", "5", "500", "--no-plots",
                 "--force-window-ms", "10", "--pretrigger-ms", "5"]) == 0
    assert DC in capsys.readouterr().out.splitlines()
    assert main(["frf", str(path), "--out", str(tmp_path / "b"), "--band-hz", "5", "500", "--no-plots",
                 "--force-window-ms", "3", "--pretrigger-ms", "5"]) == 2
    assert capsys.readouterr().err.strip() == "jointid frf: error: " + BADWIN
