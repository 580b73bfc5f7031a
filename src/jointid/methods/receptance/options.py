"""Options of the receptance estimator (:func:`jointid.methods.receptance.coupling.identify_joint_coupling`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import IdentificationError
from .column_calibration import CALIBRATION_BASES
from .frf_variance import WEIGHTINGS

__all__ = ["CouplingOptions", "SMOOTHINGS", "CALIBRATIONS", "AUTO_STRUCTURED_MAX_DOFS", "AUTO_SPLINE_MAX_DOFS", "MAX_CONDITION"]

#: Values of ``CouplingOptions.smoothing``.
SMOOTHINGS = ("auto", "structured", "gcv", "spline", "none")
#: Values of ``CouplingOptions.calibration``.
CALIBRATIONS = ("auto", "columns", "none")
#: ``smoothing = "auto"`` uses the structured estimate for joints of at most this many DOFs.
AUTO_STRUCTURED_MAX_DOFS = 3
#: ``smoothing = "auto"`` fits a symmetric joint of more DOFs than the structured model's, up to this many, by the joint
#: spline fit (every term over all lines at once: the per-term P-spline's bands cover 0.3-0.7 on a 6-DOF mount,
#: the spline fit's 0.89-0.98; ``benchmarks/mount_6dof.py``).
AUTO_SPLINE_MAX_DOFS = 6
#: Weighted per-line designs above this condition number make a line unreliable (the FRFs do not separate the terms).
MAX_CONDITION = 1e8


@dataclass(frozen=True)
class CouplingOptions:
    """Options of :func:`identify_joint_coupling`.

    Parameters
    ----------
    symmetric : bool
        Enforce ``Du = Du^T`` (reciprocity of a passive joint).
    smoothing : {"auto", "structured", "gcv", "spline", "none"}
        Over frequency: the structured joint model (one viscoelastic material, all terms and
        lines at once; falls back to "gcv" when it does not fit), each term smoothed alone
        (P-spline, lambda by GCV), every term a few B-splines in log f fitted to all lines
        at once ("spline": :mod:`.spline_fit`; any joint size, symmetric; slower), or the
        per-line estimates; "auto" = "structured" for a symmetric joint of at most 3 DOFs,
        "spline" for one of 4-6 DOFs, else "gcv" (:meth:`over_frequency`).
    weighting : {"auto", "coherence", "relative", "none"}
        FRF variance model (:func:`~jointid.methods.receptance.frf_variance.frf_variance`).
    averages : int, optional
        Averages behind the coherence (only scales; the scale comes from the residuals).
    max_relative_std : float
        Largest predicted relative standard deviation of a reliable term (default 0.1).
    n_basis : int, optional
        B-spline basis functions of the smoother (default ``min(F // 2, 200)``).
    calibration : {"auto", "columns", "none"}
        Force-calibration error per excitation column: corrected when the F test finds it
        ("auto"), always estimated and corrected ("columns"), or ignored ("none").
    calibration_basis : int or tuple of int
        B-spline functions per column for that error over the band; a tuple: the candidates, the one of
        lowest AIC is used (default :data:`~jointid.methods.receptance.column_calibration.CALIBRATION_BASES`).
    units_check : bool
        FRFs off by one gross factor in every excitation column (e.g. 1/9.81: g/N read as SI) are
        refused (:class:`~jointid.errors.DataError`); False: used as they are, with a finding and
        every term flagged unreliable (:mod:`jointid.methods.receptance.units_check`).
    model_check : bool
        Test per octave band whether the free model explains the FRFs; where not, every term is
        flagged unreliable with a finding (:mod:`jointid.methods.receptance.model_check`).
    targets : tuple of (str, float)
        ``(term, relative error)``, e.g. ``(("K_z_z", 0.002),)``: the term is flagged reliable only
        where its predicted relative std is within the target (and ``max_relative_std``).
    """

    symmetric: bool = True
    smoothing: str = "auto"
    weighting: str = "auto"
    averages: int | None = None
    max_relative_std: float = 0.1
    n_basis: int | None = None
    calibration: str = "auto"
    calibration_basis: int | tuple = CALIBRATION_BASES
    units_check: bool = True
    model_check: bool = True
    targets: tuple = ()

    def threshold(self, term_names) -> np.ndarray:
        """Largest predicted relative std of a reliable term, shape (n, n), from ``term_names``' ``(i, j, name)``.

        Raises
        ------
        IdentificationError
            A target names no term of the joint.
        """
        n = 1 + max((max(i, j) for i, j, _ in term_names), default=-1)
        out = np.full((n, n), float(self.max_relative_std))
        where = {name: (i, j) for i, j, name in term_names}
        for name, value in self.targets:
            if name not in where:
                raise IdentificationError(f"targets: {name!r} is not a term of the joint; expected one of: "
                                          f"{', '.join(t for i, j, t in term_names if i <= j)}")
            i, j = where[name]
            out[i, j] = out[j, i] = min(out[i, j], float(value))
        return out

    def over_frequency(self, n_dofs: int) -> str:
        """What ``smoothing`` asks for on a joint of ``n_dofs`` DOFs: "structured", "spline", "gcv" or "none".

        "structured" may still fall back to "gcv" on the data (a rejected fit, too few lines);
        "spline" to "gcv" when the fit does not converge.
        """
        if self.smoothing != "auto":
            return self.smoothing
        if self.symmetric and n_dofs <= AUTO_STRUCTURED_MAX_DOFS:
            return "structured"
        if self.symmetric and n_dofs <= AUTO_SPLINE_MAX_DOFS:
            return "spline"
        return "gcv"

    def __post_init__(self) -> None:
        if self.smoothing not in SMOOTHINGS:
            raise IdentificationError(f"smoothing must be one of {SMOOTHINGS}, got {self.smoothing!r}")
        if self.weighting not in WEIGHTINGS:
            raise IdentificationError(f"weighting must be one of {WEIGHTINGS}, got {self.weighting!r}")
        if not (isinstance(self.max_relative_std, (int, float)) and self.max_relative_std > 0):
            raise IdentificationError(f"max_relative_std must be a positive number, got {self.max_relative_std!r}")
        if self.calibration not in CALIBRATIONS:
            raise IdentificationError(f"calibration must be one of {CALIBRATIONS}, got {self.calibration!r}")
        bases = self.calibration_basis if isinstance(self.calibration_basis, tuple) else (self.calibration_basis,)
        if not (bases and all(isinstance(b, int) and not isinstance(b, bool) and b >= 4 for b in bases)):
            raise IdentificationError(f"calibration_basis must be an integer >= 4 or a tuple of them, got {self.calibration_basis!r}")
