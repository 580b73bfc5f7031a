"""Craig-Bampton reduction: convergence to the full model's receptance, exact structure, identification through it."""

import numpy as np
import pytest

from jointid.errors import ModelError
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from jointid.physics import FrameSection, Material, build_frame
from jointid.physics.reduction import craig_bampton
from jointid.physics.sparse_model import SparseModel

STEEL = Material(210e9, 7850.0, loss_factor=0.002, poisson_ratio=0.3)


@pytest.fixture(scope="module")
def frame():
    """An L-shaped tube frame, 2 x 12 elements (~150 DOFs)."""
    sec = FrameSection.circle(0.04, 0.03)
    return build_frame({1: (0, 0, 0), 2: (1.0, 0, 0), 3: (1.0, 0.8, 0.3)}, [(1, 2, sec, STEEL, 12), (2, 3, sec, STEEL, 12)])


JOINT = [f"1{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
SENSORS = [f"{n}{c}" for n in (2, 3, 8, 20) for c in ("x", "y", "z")]


def _direct(fm):
    return SparseModel(fm.mass, fm.stiffness, fm.dofs, fm.loss_factor, method="direct")


def test_reduced_receptance_converges_to_the_full_model_below_the_cutoff(frame):
    f = Frequency(np.linspace(20.0, 400.0, 40))
    bnd = JOINT + SENSORS
    Y = _direct(frame).receptance(f, bnd, bnd)
    errs = []
    for n in (12, 30, 100):
        cb = craig_bampton(frame.mass, frame.stiffness, frame.dofs, bnd, n_modes=n, loss_factor=frame.loss_factor)
        assert cb.mass.shape == (len(bnd) + n,) * 2
        assert np.allclose(cb.stiffness[len(bnd):, len(bnd):], np.diag((2 * np.pi * cb.fixed_interface_hz) ** 2))
        assert [str(d) for d in cb.dofs.to_dofs()[len(bnd):len(bnd) + 2]] == ["1995001s", "1995002s"]
        Yr = cb.free_model().receptance(f, bnd, bnd)
        errs.append(np.max(np.abs(Yr - Y)) / np.max(np.abs(Y)))
    assert errs[0] > errs[1] > errs[2]  # measured 0.46, 0.025, 2.9e-4 (peaks of the free structure)
    assert errs[2] < 1e-3
    # static (constraint-mode) part is exact: at a frequency far below every mode the error is tiny
    low = Frequency(np.array([0.5]))
    cb0 = craig_bampton(frame.mass, frame.stiffness, frame.dofs, bnd, n_modes=0)
    Y0 = _direct(frame).receptance(low, bnd, bnd)
    assert np.max(np.abs(cb0.free_model().receptance(low, bnd, bnd) - Y0)) / np.max(np.abs(Y0)) < 1e-3


def test_cutoff_keeps_every_mode_below_it(frame):
    cb = craig_bampton(frame.mass, frame.stiffness, frame.dofs, JOINT + SENSORS, cutoff_hz=800.0)
    assert cb.fixed_interface_hz.size > 0 and cb.fixed_interface_hz.max() < 800.0
    more = craig_bampton(frame.mass, frame.stiffness, frame.dofs, JOINT + SENSORS, n_modes=cb.fixed_interface_hz.size + 1)
    assert more.fixed_interface_hz[-1] >= 800.0


def test_a_6dof_mount_is_identified_through_the_craig_bampton_model(frame):
    """Data from the full frame on a 6x6 mount; the free model is the reduced one (100 fixed-interface modes)."""
    f = Frequency(np.linspace(50.0, 300.0, 26))
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    K0 = np.diag([2e6, 3e6, 4e6, 2e4, 3e4, 1e4]) + 0.02 * np.sqrt(np.outer([2e6, 3e6, 4e6, 2e4, 3e4, 1e4], [2e6, 3e6, 4e6, 2e4, 3e4, 1e4])) * (A + A.T) / 2
    Du = np.broadcast_to(K0 * (1 + 0.1j), (f.hz.size, 6, 6))
    full = _direct(frame)
    m = e = SENSORS
    Y = full.receptance(f, m + JOINT, JOINT + e)
    Ymn, Yme, Ynn, Yne = Y[:, :12, :6], Y[:, :12, 6:], Y[:, 12:, :6], Y[:, 12:, 6:]
    H = Yme - Ymn @ np.linalg.solve(np.eye(6) + Du @ Ynn, Du @ Yne)
    measured = FRF(f, H, m, e, "receptance")
    cb = craig_bampton(frame.mass, frame.stiffness, frame.dofs, JOINT + SENSORS, n_modes=100, loss_factor=frame.loss_factor)
    r = identify_joint_coupling(cb.free_model(), measured, JOINT, CouplingOptions(smoothing="none", calibration="none"))
    d = np.abs(np.diagonal(Du, axis1=1, axis2=2))
    scale = np.sqrt(d[:, :, None] * d[:, None, :])  # |dK_ij| / sqrt(|K_ii K_jj|): units-free, every term
    exact = identify_joint_coupling(full, measured, JOINT, CouplingOptions(smoothing="none", calibration="none"))
    assert np.max(np.abs(exact.stiffness - Du) / scale) < 1e-8
    err = np.max(np.abs(r.stiffness - Du) / scale)
    assert 1e-8 < err < 1e-2  # the reduction's own error: measured 2.5e-3 with 100 fixed-interface modes


def test_bad_reductions_raise_one_line(frame):
    with pytest.raises(ModelError, match=r"^craig_bampton: give exactly one of n_modes \(a count\) or cutoff_hz \(keep modes below it\)$"):
        craig_bampton(frame.mass, frame.stiffness, frame.dofs, JOINT)
    with pytest.raises(ModelError, match=r"^craig_bampton: K_ii is singular; the boundary must restrain every rigid-body motion of the interior$"):
        craig_bampton(frame.mass, frame.stiffness, frame.dofs, ["1x", "1y"], n_modes=2)
    with pytest.raises(ModelError, match=r"collide with boundary nodes"):
        craig_bampton(frame.mass, frame.stiffness, frame.dofs, JOINT, n_modes=2, first_mode_id=1)
