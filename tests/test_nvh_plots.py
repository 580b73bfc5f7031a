"""NVH figure conventions: |K| bands, loss factor or phase, log frequency, robust limits, a legend entry per artist."""

from types import SimpleNamespace

import numpy as np
import pytest

from jointid.dofs import parse_dofs
from jointid.frequency import Frequency
from jointid.plots.nvh_axes import loss_or_phase, loss_or_phase_std, magnitude_band, robust_log_limits, use_log_frequency

Z90 = 1.6448536269514722


def test_magnitude_band_is_first_order_propagation():
    # |K| of a real K moves with Re only, of an imaginary K with Im only: the band is |K| -+ z sigma of that part
    lo, hi = magnitude_band(np.array([3.0 + 0j, 4j]), np.array([0.1, 0.7]), np.array([0.5, 0.2]), Z90)
    assert np.allclose(hi - lo, 2 * Z90 * np.array([0.1, 0.2]), rtol=0, atol=1e-15)
    # a general K: sigma_|K| = sqrt((Re s_re)^2 + (Im s_im)^2) / |K| against a finite-difference Jacobian
    k, sr, si = 3.0 + 4.0j, 0.3, 0.2
    h = 1e-7
    d_re = (abs(k + h) - abs(k - h)) / (2 * h)
    d_im = (abs(k + 1j * h) - abs(k - 1j * h)) / (2 * h)
    lo, hi = magnitude_band(np.array([k]), np.array([sr]), np.array([si]), 1.0)
    assert (hi[0] - lo[0]) / 2 == pytest.approx(np.hypot(d_re * sr, d_im * si), rel=1e-8)


def test_loss_factor_until_re_k_crosses_zero_then_phase():
    f = np.linspace(10.0, 1000.0, 200)
    eta = 0.15
    stiff = 1e5 * (1 + 1j * eta) * np.ones_like(f)
    v, kind = loss_or_phase(f, stiff)
    assert kind == "loss factor" and np.allclose(v, eta, rtol=1e-14)
    mass_line = 1e5 * (1 + 1j * eta) - 0.5 * (2 * np.pi * f) ** 2  # Re K crosses zero at ~71 Hz
    v, kind = loss_or_phase(f, mass_line)
    assert kind == "phase"
    assert v[0] == pytest.approx(np.degrees(np.arctan2(mass_line[0].imag, mass_line[0].real)), abs=1e-12)
    assert np.all(np.diff(v) > 0) and v[-1] == pytest.approx(180 - np.degrees(np.arctan(1.5e4 / 0.5 / (2 * np.pi * 1000) ** 2)), abs=1e-3)
    # the band of the loss factor: first order in Re and Im
    s = loss_or_phase_std(np.array([2.0 + 0.3j]), np.array([0.01]), np.array([0.02]), "loss factor")
    assert s[0] == pytest.approx(np.hypot(0.02, 0.15 * 0.01) / 2.0, rel=1e-14)


def test_log_frequency_only_over_a_decade_and_limits_ignore_a_collapsed_band():
    assert use_log_frequency(np.array([5.0, 1000.0])) and not use_log_frequency(np.array([100.0, 400.0]))
    assert not use_log_frequency(np.array([0.0, 1000.0]))
    lo, hi = robust_log_limits(np.array([10.0, 20.0]), band=(np.array([1e-9, 15.0]), np.array([30.0, 1e9])))
    assert lo == pytest.approx(1.0 / 1.25) and hi == pytest.approx(200.0 * 1.25)  # a band reaching ~0 or ~inf: a decade at most
    lo, hi = robust_log_limits(np.array([1e5, 1e6]), np.array([10.0, 0.0]))  # terms of different units on one axis: all shown
    assert lo == pytest.approx(10.0 / 1.25) and hi == pytest.approx(1e6 * 1.25)


def _result(f, K, rel=0.01, outlier=1e3):
    """A stand-in JointEstimate: K with 1 % bands, per-line estimates with one wild outlier per term."""
    per_line = K * (1 + 0.01 * np.cos(np.arange(f.size)))[:, None, None]
    per_line[f.size // 2] *= outlier
    std = rel * np.abs(K) / np.sqrt(2)
    reliable = np.ones(K.shape, bool)
    reliable[-5:, 1, 1] = False
    return SimpleNamespace(
        frequency=Frequency(f), joint_dofs=parse_dofs(["10w", "10theta"]), stiffness=K, std_real=std, std_imag=std,
        line_estimates=lambda: per_line, reliable_terms=reliable, relative_std=np.full(K.shape, rel), has_uncertainty=True,
        options_summary=lambda: {"max_relative_std": 0.1, "weighting": "coherence"}, method="receptance", estimator="structured",
    )


def test_joint_stiffness_figure_reads_as_nvh_expects():
    from jointid.plots.joint_stiffness import plot_joint_stiffness

    f = np.linspace(5.0, 1000.0, 400)
    w2 = (2 * np.pi * f) ** 2
    K = np.empty((f.size, 2, 2), complex)
    K[:, 0, 0] = 6e4 * (1 + 0.1j) - 0.02 * w2          # Re K crosses zero at ~276 Hz: phase
    K[:, 0, 1] = K[:, 1, 0] = -800 * (1 + 0.1j)        # coupling: no loss factor
    K[:, 1, 1] = 20 * (1 + 0.1j) * np.ones_like(f)     # ~20 N m/rad: a loss factor, not a flat line on a +-2000 axis
    fig = plot_joint_stiffness(_result(f, K))
    top = fig.axes[:3]
    bottom = fig.axes[3:]
    for ax, k in zip(top, (K[:, 0, 0], K[:, 0, 1], K[:, 1, 1])):
        assert ax.get_yscale() == "log" and ax.get_xscale() == "log"
        lo, hi = ax.get_ylim()
        assert lo <= np.abs(k).min() and hi >= np.abs(k).max()
        assert hi < 10 * np.abs(k).max()  # the 1000x outlier of the per-line estimates does not set the axis
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert sorted(legend) == sorted(a.get_label() for a in ax.lines + ax.collections)
        assert len(legend) == len(ax.lines) + len(ax.collections)  # every artist has an entry (dots included)
        assert "per-line estimate (not smoothed)" in legend and "90 % band" in legend
    assert bottom[0].get_ylabel() == "phase [deg]" and bottom[2].get_ylabel() == "loss factor [-]"
    assert bottom[1].get_ylabel().startswith("predicted relative error")  # the coupling column: no loss factor
    eta_lo, eta_hi = bottom[2].get_ylim()
    assert eta_lo <= 0.0 and 0.1 < eta_hi < 0.2  # scaled to the loss factor and its band
