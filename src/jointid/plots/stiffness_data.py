"""The data of the joint stiffness figure, without matplotlib (it crosses to the figure worker's process)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frequency import Frequency

__all__ = ["JointStiffnessData"]


@dataclass(frozen=True, eq=False)
class JointStiffnessData:
    """What :func:`plot_joint_stiffness` reads of an estimate, as plain data (it pickles without the estimator's modules).

    A figure drawn from it is the figure of the estimate itself (:meth:`of`): the same arrays, the
    same texts. :class:`~jointid.plots.figure_worker.FigureWorker` sends it to the process that draws.

    Attributes
    ----------
    frequency : Frequency
    joint_dofs : tuple of Dof
    stiffness, std_real, std_imag : ndarray, shape (F, n, n)
        Complex estimate (N/m, N/rad, N*m/rad) and the 1-sigma of its real and imaginary parts.
    reliable_terms : ndarray of bool, shape (F, n, n)
    relative_std : ndarray, shape (F, n, n)
        Predicted relative error (1 sigma).
    per_line : ndarray, shape (F, n, n), complex, or None
        The per-line estimates behind a smoothed estimate (``line_estimates()``).
    options : dict
        ``options_summary()``.
    method, estimator : str
    """

    frequency: Frequency
    joint_dofs: tuple
    stiffness: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    reliable_terms: np.ndarray
    relative_std: np.ndarray
    per_line: np.ndarray | None
    options: dict
    method: str
    estimator: str

    @classmethod
    def of(cls, result) -> "JointStiffnessData":
        """The figure's data of a :class:`~jointid.methods.estimate.JointEstimate`."""
        return cls(result.frequency, tuple(result.joint_dofs), result.stiffness, result.std_real, result.std_imag,
                   result.reliable_terms, result.relative_std, result.line_estimates(), dict(result.options_summary()),
                   str(result.method), str(result.estimator))

    def line_estimates(self) -> np.ndarray | None:
        """The per-line estimates, shape (F, n, n), or None."""
        return self.per_line

    def options_summary(self) -> dict:
        """The estimator's options (JSON-ready)."""
        return self.options
