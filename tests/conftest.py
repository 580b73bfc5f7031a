"""Test configuration: a headless matplotlib backend, and the ``numerics`` marker.

``numerics`` marks the modules whose assertions compare floating-point results of
BLAS/LAPACK with tolerances from an error bound (``n eps cond``, a convergence
rate): ``make test-blas`` and ``make test-kernel`` (CI) run them under other
OpenBLAS kernels and thread counts (``OPENBLAS_CORETYPE``, ``OPENBLAS_NUM_THREADS``),
where the bits differ but the bounds must hold.
"""

import matplotlib
import pytest

matplotlib.use("Agg")

#: Test modules whose results come from BLAS/LAPACK with tolerances near round-off.
NUMERICS_MODULES = frozenset({
    "test_condition", "test_coupling", "test_coupling_kronecker", "test_column_calibration", "test_elements",
    "test_frame", "test_frame_mounts", "test_frf_variance", "test_inverse", "test_joint_model", "test_jointed_model",
    "test_reduction", "test_smoothing", "test_sparse_model", "test_structure_elastomer", "test_structured",
    "test_synthesis",
})


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.module is not None and item.module.__name__.rpartition(".")[2] in NUMERICS_MODULES:
            item.add_marker(pytest.mark.numerics)
