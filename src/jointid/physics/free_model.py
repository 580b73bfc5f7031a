"""The free structure's receptance on any DOFs: the seam between models and identification methods.

The receptance-coupling identification (:mod:`jointid.methods.receptance.coupling`) needs
the free (unconstrained) structure's receptance ``Y = Do^-1`` only on the
observed, joint and excited DOFs, never ``Do`` itself. Anything that can give
``receptance(frequency, rows, cols)`` can feed it: an FE structure (here), a
modal model, a large sparse model (modal superposition with residual
compensation), a measured free-free FRF set.

:class:`StructureModel` is built once (its modes computed once) and then applied
to any DOF subsets and frequency lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Protocol, runtime_checkable

import numpy as np

from ..dofs import Dof, parse_dofs
from ..errors import ModelError
from ..frequency import Frequency
from ..parallel import single_threaded_blas
from .modes import DENSE_EIGEN_LIMIT, Modes, natural_modes
from .structure import Structure
from .synthesis import check_zero_frequency, receptance_direct, receptance_modal_refined

__all__ = ["FreeModel", "StructureModel", "UncertainFreeModel", "as_free_model"]


@runtime_checkable
class FreeModel(Protocol):
    """What an identification method needs of a free structure."""

    @property
    def dofs(self) -> tuple[Dof, ...]:
        """Every DOF the model can give a receptance at."""

    def receptance(self, frequency, rows: Iterable, cols: Iterable) -> np.ndarray:
        """Receptance ``Y[rows, cols]`` at each line, shape (F, r, c), m/N, rad/N, m/(N*m), rad/(N*m)."""


@dataclass(frozen=True, eq=False)
class StructureModel:
    """A :class:`~jointid.physics.structure.Structure` as a :class:`FreeModel`.

    Proportionally damped models up to
    :data:`~jointid.physics.modes.DENSE_EIGEN_LIMIT` DOFs use modal superposition
    over every mode with one step of iterative refinement
    (:func:`~jointid.physics.synthesis.receptance_modal_refined`): the plain modal
    sum loses accuracy to the eigensolver's round-off (up to about
    ``eps lam_max / (eta lam_r)`` relative at a resonance, so most on fine meshes,
    and an inverse method amplifies it most in the rotational term); the refined
    sum agrees with an extended-precision direct solve to round-off
    (``tests/test_synthesis.py``), at the cost of a modal sum on the requested
    rows and columns only, no N x N work per line. The modes are computed once, here.
    Others use a batched direct solve.

    Parameters
    ----------
    structure : Structure
        The free structure (no frequency-dependent joints).
    """

    structure: Structure
    modes: Modes | None = None

    def __post_init__(self) -> None:
        if self.structure.joints:
            raise ModelError("a free model must not contain frequency-dependent joints: Do is the free structure alone")
        if self.modes is None and len(self.structure.dofs) <= DENSE_EIGEN_LIMIT:
            try:
                with single_threaded_blas():  # a small dense eigh: BLAS threads only contend (several times slower on a loaded machine)
                    modes = natural_modes(self.structure)
            except np.linalg.LinAlgError:  # e.g. massless DOFs: M not positive definite
                return
            if modes.loss_factor is not None:  # proportional damping: the modal path is exact
                object.__setattr__(self, "modes", modes)

    @property
    def dofs(self) -> tuple[Dof, ...]:
        """Active DOFs of the structure."""
        return self.structure.dofs

    def receptance(self, frequency, rows: Iterable, cols: Iterable) -> np.ndarray:
        """Receptance ``Y[rows, cols]``, shape (F, r, c) (see :class:`FreeModel`)."""
        frequency = frequency if isinstance(frequency, Frequency) else Frequency(frequency)
        rows, cols = parse_dofs(rows), parse_dofs(cols)
        check_zero_frequency(self.structure, frequency)
        if self.modes is not None:
            return receptance_modal_refined(self.structure, frequency, rows, cols, self.modes)
        return receptance_direct(self.structure, frequency, rows, cols)


@dataclass(frozen=True, eq=False)
class UncertainFreeModel:
    """A free model with a stated parameter uncertainty: its receptance and the receptance's deviation per direction.

    The parameters' covariance ``C = sum_i v_i v_i^T`` (``v_i``: eigenvectors scaled by the square root of
    their eigenvalue) is carried as one pair of models per direction, built at ``p - v_i`` and ``p + v_i``;
    :meth:`receptance_deviations` gives the central differences ``dY_i = (Y(p + v_i) - Y(p - v_i)) / 2``, so a
    quantity ``q(Y)`` has the linearized variance ``sum_i (dq/dY dY_i)^2``. Caveat: linear in the parameters over
    one standard deviation (the central difference is exact to second order).

    Parameters
    ----------
    model : FreeModel
        The nominal free model (its receptance is :meth:`receptance`).
    directions : tuple of (FreeModel, FreeModel)
        The models at ``p - v_i`` and ``p + v_i``, one pair per direction.
    described : str
        What the uncertainty is, for findings (e.g. ``"[uncertainty]: elastic_modulus, density"``).
    references : tuple of FreeModel
        Finer discretizations of the same structure: each adds the deviation ``Y_ref - Y`` (the nominal
        model's discretization error, one-sided).
    """

    model: FreeModel
    directions: tuple[tuple[FreeModel, FreeModel], ...]
    described: str = "the free model's parameter uncertainty"
    references: tuple[FreeModel, ...] = ()

    @property
    def dofs(self) -> tuple[Dof, ...]:
        """The nominal model's DOFs."""
        return self.model.dofs

    def receptance(self, frequency, rows: Iterable, cols: Iterable) -> np.ndarray:
        """The nominal model's receptance ``Y[rows, cols]``, shape (F, r, c)."""
        return self.model.receptance(frequency, rows, cols)

    def receptance_deviations(self, frequency, rows: Iterable, cols: Iterable) -> np.ndarray:
        """``dY_i[rows, cols]`` per direction, then ``Y_ref - Y`` per reference, shape (D, F, r, c), receptance units."""
        out = [(plus.receptance(frequency, rows, cols) - minus.receptance(frequency, rows, cols)) / 2.0
               for minus, plus in self.directions]
        if self.references:
            Y = self.model.receptance(frequency, rows, cols)
            out += [ref.receptance(frequency, rows, cols) - Y for ref in self.references]
        return np.stack(out)


def as_free_model(model) -> FreeModel:
    """``model`` as a :class:`FreeModel` (a Structure is wrapped in :class:`StructureModel`)."""
    if isinstance(model, Structure):
        return StructureModel(model)
    if isinstance(model, FreeModel):
        return model
    raise ModelError(f"expected a Structure or an object with dofs and receptance(frequency, rows, cols), got {type(model).__name__}")
