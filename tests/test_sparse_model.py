"""Sparse free models: modal superposition with residual compensation vs a direct solve, the beam, identification."""

import numpy as np
import pytest
import scipy.sparse as sp

from jointid.benchmark import benchmark_beam
from jointid.errors import DofError, ModelError
from jointid.frequency import Frequency
from jointid.methods.receptance.coupling import identify_joint_coupling
from jointid.physics.free_model import FreeModel, StructureModel
from jointid.physics.joints import parametric_joint
from jointid.physics.sparse_model import SparseModel
from jointid.physics.synthesis import synthesize_frf

BEAM = benchmark_beam()


def _chain(n=2000, seed=1):
    """A free chain of n masses (0.04-0.06 kg) and springs (3.2-4.8e8 N/m) along x: modes 0, 22 Hz, ..."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(0.8, 1.2, n - 1) * 4e8
    m = rng.uniform(0.8, 1.2, n) * 0.05
    K = sp.diags([np.r_[k, 0] + np.r_[0, k], -k, -k], [0, 1, -1], format="csc")
    return sp.diags(m, format="csc"), K, [f"{i + 1}x" for i in range(n)]


CHAIN = _chain()
FREQ = np.linspace(2.0, 400.0, 200)  # ~18 modes in the band, modes kept up to 1000 Hz
ROWS, COLS = ["1x", "500x", "1000x", "2000x"], ["1x", "777x", "2000x"]


@pytest.fixture(scope="module")
def chain_direct():
    return SparseModel(*CHAIN, loss_factor=0.002).receptance(FREQ, ROWS, COLS, method="direct")


@pytest.mark.parametrize("terms, bound, floor", [(0, None, 0.5), (1, 0.2, 0.01), (2, 1e-2, 1e-4), (6, 3e-7, 0.0)])
def test_modal_with_residual_converges_to_the_direct_solve_on_a_2000_dof_chain(chain_direct, terms, bound, floor):
    """Relative error per entry, worst over the band (measured: none 3.0, 1 term 7.7e-2, 2 terms 3.7e-3, 6 terms 5.6e-8)."""
    model = SparseModel(*CHAIN, loss_factor=0.002, method="modal", residual_terms=terms)
    Y = model.receptance(FREQ, ROWS, COLS)
    err = np.max(np.abs(Y - chain_direct) / np.abs(chain_direct))
    assert err >= floor
    if bound is not None:
        assert err < bound
    modes = model.modes
    assert not modes.complete and modes.frequencies_hz[-1] >= 2.5 * FREQ[-1]
    assert modes.frequencies_hz[0] < 1e-3 and abs(modes.frequencies_hz[1] - 22.2855) < 1e-3  # rigid body, first elastic


def test_auto_method_and_per_call_override():
    model = SparseModel(*CHAIN, loss_factor=0.002)
    assert model.choose_method(8) == "direct" and model.choose_method(500) == "direct" and model.choose_method(501) == "modal"
    Yd = model.receptance(FREQ[:5], ["3x"], ["3x", "9x"])
    assert model.modes is None  # 5 lines: solved directly, no modes
    Ym = model.receptance(FREQ[:5], ["3x"], ["3x", "9x"], method="modal")
    assert np.max(np.abs(Ym - Yd) / np.abs(Yd)) < 1e-7
    assert Yd.shape == (5, 1, 2) and np.allclose(Yd[:, 0, 1], model.receptance(FREQ[:5], ["9x"], ["3x"])[:, 0, 0], rtol=1e-12)


def test_the_beams_own_matrices_give_the_beams_receptance():
    freq = Frequency.from_range(5, 1000, 5)
    dofs = ["1w", "10w", "10theta", "19w"]
    ref = StructureModel(BEAM).receptance(freq, dofs, dofs)
    sparse = SparseModel.from_dense(BEAM)
    assert isinstance(sparse, FreeModel) and sparse.dofs == BEAM.dofs
    d = np.sqrt(np.abs(np.diagonal(ref, axis1=1, axis2=2)))
    scale = d[:, :, None] * d[:, None, :]  # sqrt(|Y_ii Y_jj|): Y[10w, 10theta] is ~0 by symmetry
    Y = sparse.receptance(freq, dofs, dofs, method="direct")
    assert np.max(np.abs(Y - ref) / scale) < 1e-9  # measured 1.1e-10: both agree with a dense inverse to ~1e-10 (conditioning)
    # every mode (38 DOFs: dense eigensolution, no truncation): the plain modal sum's round-off, measured 6e-9
    Y = sparse.receptance(freq, dofs, dofs, method="modal")
    assert sparse.modes.complete and np.max(np.abs(Y - ref) / scale) < 2e-8


def test_identification_through_a_sparse_model_recovers_the_joint():
    freq = Frequency.from_range(5, 1000, 5)
    joint = parametric_joint(10, 2e5, 60.0, 1.5e3, 0.12, growth=0.5, reference_frequency=100, exponent=0.5)
    frf = synthesize_frf(BEAM.with_joint(joint), freq, ["1w", "3w", "6w", "9w", "12w", "15w", "19w"], ["3w", "9w", "15w"], kind="accelerance")
    r = identify_joint_coupling(SparseModel.from_dense(BEAM), frf, ["10w", "10theta"])  # 199 lines x 38 DOFs: direct
    K = joint(freq.hz)
    assert np.max(np.abs(r.stiffness - K) / np.abs(K)) < 3e-8  # measured 1.3e-8 (worst at 5 Hz; the dense path: < 1e-8)


def test_bad_inputs_raise_one_line():
    M, K, dofs = _chain(600)
    model = SparseModel(M, K, dofs)
    with pytest.raises(DofError, match=r"^DOF 601x is not in the sparse model \(it has 600 DOFs, nodes 1..600\)$"):
        model.receptance([10.0], ["601x"], ["1x"])
    with pytest.raises(ModelError, match=r"^the free structure is singular at 0 Hz \(rigid-body modes\); drop the 0 Hz line$"):
        model.receptance(np.linspace(0, 100, 600), ["1x"], ["1x"], method="modal")
    with pytest.raises(ModelError, match=r"^the dynamic stiffness is singular at 0 Hz \(rigid-body modes\); drop the 0 Hz line$"):
        model.receptance([0.0], ["1x"], ["1x"], method="direct")
    with pytest.raises(ModelError, match=r"^the stiffness matrix is 600 x 600 but the model has 599 DOFs$"):
        SparseModel(M[:-1, :-1], K, dofs[:-1])
    with pytest.raises(ModelError, match=r"^method must be one of \('auto', 'modal', 'direct'\), got 'dense'$"):
        SparseModel(M, K, dofs, method="dense")
    with pytest.raises(ModelError, match=r"^the stiffness matrix must be real \(damping comes from loss_factor\)$"):
        SparseModel(M, K * (1 + 0.01j), dofs)
