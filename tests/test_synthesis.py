"""FRF synthesis: D H = I, reciprocity, kinds, modal vs direct, joints, 0 Hz."""

import numpy as np
import pytest

from jointid.dofs import Dof, parse_dofs
from jointid.errors import FrequencyError, ModelError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.physics.elements import Material, Section
from jointid.physics.structure import ComplexStiffness, build_beam
from jointid.parallel import single_threaded_blas
from jointid.physics.synthesis import choose_method, synthesize_frf

SEC = Section.rectangle(0.0127, 0.0127)
AL = Material(69e9, 2700.0, 0.006, 0.33)
BEAM = build_beam(0.9144, SEC, AL, 19)
FREQ = Frequency.from_range(5, 1000, 5)
ALL = BEAM.dofs


def _joint(node=10):
    def k(f):
        s = 1 + 0.3 * f / 1000
        m = np.array([[2e5, 1e3], [1e3, 60.0]])
        return (s[:, None, None] * m[None]) * (1 + 0.12j)
    return ComplexStiffness((Dof(node, "w"), Dof(node, "theta")), k)


def test_dynamic_stiffness_times_receptance_is_identity():
    s = BEAM.with_joint(_joint())
    H = synthesize_frf(s, FREQ, ALL, ALL).data
    D = s.dynamic_stiffness(FREQ)
    err = np.abs(D @ H - np.eye(len(ALL))).max()
    assert err < 1e-8


def test_reciprocity():
    s = BEAM.with_joint(_joint())
    H = synthesize_frf(s, FREQ, ALL, ALL).data
    assert np.abs(H - H.transpose(0, 2, 1)).max() <= 1e-9 * np.abs(H).max()


def test_modal_and_direct_agree():
    r = [Dof(n) for n in (1, 3, 6, 9, 12, 15, 19)] + [Dof(10, "theta")]
    c = [Dof(n) for n in (3, 9, 15)]
    a = synthesize_frf(BEAM, FREQ, r, c, method="direct").data
    b = synthesize_frf(BEAM, FREQ, r, c, method="modal").data
    assert np.abs(a - b).max() <= 1e-8 * np.abs(a).max()
    # line by line too (anti-resonances included)
    assert np.median(np.abs(a - b) / np.abs(a)) < 1e-8


def test_auto_method_choice():
    assert choose_method(BEAM) == "modal"
    assert choose_method(BEAM.with_joint(_joint())) == "coupled"  # joint-free part modal, joint by Woodbury
    assert choose_method(BEAM.with_spring("1w", None, 1e4 * (1 + 0.5j))) == "direct"  # non-proportional
    with pytest.raises(ModelError, match="proportional"):
        synthesize_frf(BEAM.with_joint(_joint()), FREQ, ["1w"], ["1w"], method="modal")


def test_coupled_synthesis_equals_the_direct_solve():
    s = BEAM.with_joint(_joint())
    d = synthesize_frf(s, FREQ, ["1w", "10theta"], ["3w", "10w"], method="direct").data
    c = synthesize_frf(s, FREQ, ["1w", "10theta"], ["3w", "10w"], method="coupled").data
    assert np.max(np.abs(c - d) / np.abs(d).max(axis=(1, 2), keepdims=True)) < 1e-10  # measured 4e-11


def test_kinds_are_exact_conversions():
    h = synthesize_frf(BEAM, FREQ, ["1w"], ["3w"])
    a = synthesize_frf(BEAM, FREQ, ["1w"], ["3w"], kind="accelerance")
    v = h.to("mobility")
    w = FREQ.omega[:, None, None]
    # element-wise products and quotients, no BLAS: each side carries a few roundings of eps/2 (w^2, the complex
    # product), so they agree to a small multiple of eps on every value
    tol = 16 * np.finfo(float).eps
    assert np.allclose(a.data, -(w**2) * h.data, rtol=tol, atol=0)
    assert np.allclose(v.data, 1j * w * h.data, rtol=tol, atol=0)
    assert np.allclose(a.to("receptance").data, h.data, rtol=2 * tol, atol=0)
    assert a.unit() == "(m/s^2)/N"


def test_free_free_receptance_at_zero_hz_is_an_error():
    with pytest.raises(FrequencyError, match="rigid-body modes"):
        synthesize_frf(BEAM, Frequency([0.0, 10.0]), ["1w"], ["1w"])
    # a clamped beam is fine at 0 Hz and gives the static flexibility
    c = BEAM.clamped(1)
    E, I, A, G, L = AL.elastic_modulus, SEC.second_moment, SEC.area, AL.G, 0.9144
    static = L**3 / (3 * E * I) + L / (5 / 6 * G * A)
    for method, tol in (("direct", 1e-10), ("modal", 1e-8)):
        h0 = synthesize_frf(c, Frequency([0.0, 1.0]), ["19w"], ["19w"], method=method).data[0, 0, 0]
        assert h0 == pytest.approx(static / (1 + 0.006j), rel=tol)


def test_accelerance_to_receptance_at_zero_hz_is_an_error():
    frf = FRF(Frequency([0.0, 1.0]), np.ones((2, 1, 1)), ["1w"], ["1w"], "accelerance")
    with pytest.raises(FrequencyError, match="0 Hz"):
        frf.to("receptance")


def test_selection_by_label():
    frf = synthesize_frf(BEAM, FREQ, ["1w", "3w", "10theta"], ["3w", "9w"])
    sub = frf.select(["10theta", "1w"], ["9w"])
    assert sub.responses == (Dof(10, "theta"), Dof(1, "w"))
    assert np.array_equal(sub.data[:, 0, 0], frf("10theta", "9w"))
    assert frf.select(["10theta"], ["3w"]).unit() == "rad/N"
    with pytest.raises(KeyError, match="DOF 5w is not in the FRF responses"):
        frf.select(["5w"])


def test_large_model_paths_agree():
    big = build_beam(0.9144, SEC, AL, 1000)  # 2000 DOFs: sparse direct and truncated modal
    f = Frequency.from_range(10, 1000, 10)
    r, c = ["1w", "300w", "1000w"], ["300w"]
    a = synthesize_frf(big, f, r, c, method="direct").data
    b = synthesize_frf(big, f, r, c, method="modal").data
    rel = np.abs(a - b) / np.abs(a)
    # truncated modes + residual flexibility: ~1e-5 typical, worst near anti-resonances
    assert np.median(rel) < 1e-4
    assert np.abs(a - b).max() <= 2e-3 * np.abs(a).max()


def test_sparse_direct_path_with_a_joint_equals_the_dense_one(monkeypatch):
    import jointid.physics.synthesis as synthesis

    s = build_beam(0.9144, SEC, AL, 400).with_joint(_joint(200))  # 800 DOFs: the sparse path
    f = Frequency.from_range(10, 1000, 30)
    r, c = ["1w", "200w", "200theta", "400w"], ["100w", "300w"]
    sparse = synthesize_frf(s, f, r, c).data
    monkeypatch.setattr(synthesis, "DENSE_DIRECT_LIMIT", 1000)
    dense = synthesize_frf(s, f, r, c).data
    assert np.abs(sparse - dense).max() <= 1e-7 * np.abs(dense).max()  # measured 7e-9 (fine-mesh round-off)


def _extended_precision_solve(structure, f_hz, ri, ci, iterations=4):
    """D(w)^-1 E by a scaled LU refined with long-double residuals: exact to ~1e-15 for these models."""
    import scipy.linalg as sla

    K, M = structure.K, structure.M
    E = np.zeros((K.shape[0], len(ci)), complex)
    E[ci, np.arange(len(ci))] = 1.0
    sc = 1.0 / np.sqrt(np.abs(np.diag(K)))
    i, j = np.nonzero((K != 0) | (M != 0))  # banded: the residual over the nonzeros only
    Kl, Ml = K[i, j].astype(np.clongdouble), M[i, j].astype(np.longdouble)
    out = []
    for f in f_hz:
        w2 = (2.0 * np.pi * f) ** 2
        lu = sla.lu_factor((K - w2 * M) * np.outer(sc, sc))
        X = sc[:, None] * sla.lu_solve(lu, sc[:, None] * E)
        d = (Kl - np.longdouble(w2) * Ml)[:, None]
        for _ in range(iterations):
            R = E.astype(np.clongdouble)
            np.subtract.at(R, i, d * X[j].astype(np.clongdouble))
            X = X + sc[:, None] * sla.lu_solve(lu, sc[:, None] * R.astype(complex))
        out.append(X[ri])
    return np.array(out)


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="needs an extended-precision long double")
def test_refined_modal_receptance_equals_an_extended_precision_direct_solve(monkeypatch):
    """The 290-DOF refined benchmark beam at 5 Hz, at and beside every resonance below 1 kHz."""
    import jointid.physics.synthesis as synthesis
    from jointid.benchmark import benchmark_study
    from jointid.physics.modes import natural_modes

    s = benchmark_study().beam.structure(1000.0)
    with single_threaded_blas():
        modes = natural_modes(s)
    fr = modes.frequencies_hz[(modes.frequencies_hz > 5) & (modes.frequencies_hz < 1000)]
    f = Frequency(np.sort(np.r_[5.0, 7.0, 50.0, fr, 1.003 * fr, 1000.0]))
    r = parse_dofs(["1w", "3w", "6w", "9w", "12w", "15w", "19w", "10w", "10theta"])
    c = parse_dofs(["10w", "10theta", "3w", "9w", "15w"])
    ri, ci = s.index(r), s.index(c)
    with single_threaded_blas():  # 290 x 290 LU per line: BLAS threads only contend
        ref = _extended_precision_solve(s, f.hz, ri, ci)

    def err(Y):  # worst line, relative to the line's largest entry
        return np.max(np.abs(Y - ref) / np.abs(ref).max(axis=(1, 2), keepdims=True))

    plain = np.einsum("rk,fk,ck->frc", modes.shapes[ri], 1 / (modes.eigenvalues * (1 + 1j * modes.loss_factor) - f.omega[:, None] ** 2), modes.shapes[ci])
    fast = synthesis.receptance_modal_refined(s, f, r, c, modes)
    monkeypatch.setattr(synthesis, "REFINE_FACTOR", 1e6)  # every mode in the refinement, no series
    every_mode = synthesis.receptance_modal_refined(s, f, r, c, modes)
    monkeypatch.setattr(synthesis, "_EXTENDED", False)  # the residual on every DOF (platforms without long double)
    residual = synthesis.receptance_modal_refined(s, f, r, c, modes)
    # measured: plain modal sum 1e-8 - 1.2e-7 (at resonances; it depends on the eigensolver's
    # round-off), residual refinement 1.2e-9, fast path 1.6e-11
    assert err(plain) > 1e-9
    assert err(residual) < 5e-9
    assert err(fast) < 1e-10
    # fast and every-mode refinement differ by the omitted modes' share (< 1e-12, see REFINE_FACTOR) and by the
    # round-off of the refinement: dA, dB are N-term dot products (N eps relative to lam_r) that g = 1 / (lam* - w^2)
    # amplifies by up to 1 / eta at a resonance (measured 3e-13 - 1.9e-12 over OpenBLAS kernels, bound 1.2e-11)
    eta = modes.loss_factor if modes.loss_factor is not None else s.proportional_loss_factor
    bound = 1e-12 + len(s.dofs) * np.finfo(float).eps / np.min(eta)
    assert np.max(np.abs(fast - every_mode) / np.abs(every_mode).max(axis=(1, 2), keepdims=True)) < bound
