"""The one result of every inverse estimator, and the registry that chooses an estimator by name.

Every inverse estimator (Hong & Lee per line, :mod:`jointid.methods.hong_lee`; the
receptance-coupling estimator per line, smoothed or structured,
:mod:`jointid.methods.receptance`) takes the same inputs -- the free model (anything
with ``receptance(frequency, rows, cols)``), the measured :class:`~jointid.frf.FRF`
and the joint DOFs -- and returns a :class:`JointEstimate`. The CLI, the report and
test design read only what :class:`JointEstimate` defines; what an estimator adds
(condition numbers, the structured model's orders) is in :meth:`JointEstimate.diagnostics`.

The protocol a result satisfies (frozen dataclass; arrays frequency-first):

=====================  =======================================================================
``frequency``          :class:`~jointid.frequency.Frequency`, F lines
``joint_dofs``         tuple of :class:`~jointid.dofs.Dof`, n
``stiffness``          (F, n, n) complex: N/m, N/rad, N*m/m, N*m/rad (:mod:`jointid.terms`)
``std_real/std_imag``  (F, n, n): 1-sigma of each term's real and imaginary part; NaN where the
                       estimator gives no uncertainty (then ``has_uncertainty`` is False)
``reliable_terms``     (F, n, n) bool: the term is determined on that line
``findings()``         one line per thing the user must know (what could not be identified, why)
=====================  =======================================================================
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

from ..dofs import Dof
from ..errors import IdentificationError
from ..frequency import Frequency
from ..terms import Z90, joint_term, stiffness_columns, term_names, term_units

__all__ = ["JointEstimate", "ESTIMATORS", "estimator", "estimate_joint", "term_scale", "COUPLING_SCALE_FLOOR", "check_layout", "Z90"]


#: Off-diagonal terms are judged against at least this fraction of ``sqrt(|K_ii K_jj|)`` (see :func:`term_scale`).
COUPLING_SCALE_FLOOR = 0.05


def term_scale(K: np.ndarray) -> np.ndarray:
    """The scale a term's uncertainty is judged against, shape (F, n, n), same units as ``K``.

    ``|K_ij|``, but for an off-diagonal term at least ``COUPLING_SCALE_FLOOR sqrt(|K_ii K_jj|)``:
    a coupling that is truly (near) zero -- an absent cross term of a mount, a term between
    two joints -- is then judged by how well it is known on the scale of its two DOFs, not
    flagged "not identifiable" for being zero.
    """
    d = np.abs(np.diagonal(K, axis1=-2, axis2=-1))
    floor = COUPLING_SCALE_FLOOR * np.sqrt(d[..., :, None] * d[..., None, :])
    n = K.shape[-1]
    floor[..., np.arange(n), np.arange(n)] = 0.0
    return np.maximum(np.abs(K), floor)


def check_layout(n_joint: int, observed: Sequence, excited: Sequence) -> None:
    """Raise :class:`IdentificationError` unless ``|m| >= |n|`` and ``|e| >= |n|``."""
    if len(observed) < n_joint:
        raise IdentificationError(
            f"[measurement].observed: {len(observed)} observed coordinate(s) for {n_joint} joint DOFs: the estimation step needs "
            f"at least as many observed coordinates as joint DOFs (|m| >= |n|); observe more points"
        )
    if len(excited) < n_joint:
        raise IdentificationError(
            f"[measurement].excited: {len(excited)} excited coordinate(s) for {n_joint} joint DOFs: the identification step needs "
            f"at least as many excited coordinates as joint DOFs (|e| >= |n|); excite more points"
        )


@dataclass(frozen=True, eq=False)
class JointEstimate:
    """An identified joint stiffness: every inverse estimator's result (see the module docstring).

    Attributes
    ----------
    frequency : Frequency
    joint_dofs : tuple of Dof
    stiffness : ndarray, shape (F, n, n), complex
        N/m, N/rad, N*m/m, N*m/rad (:func:`jointid.terms.term_unit`).

    Subclasses provide ``std_real``, ``std_imag`` and ``reliable_terms`` (fields or
    properties), :meth:`subset`, and may extend :meth:`findings`, :meth:`diagnostics`,
    :meth:`options_summary` and :meth:`extra_columns`.
    """

    frequency: Frequency
    joint_dofs: tuple[Dof, ...]
    stiffness: np.ndarray

    #: The estimator's registry name.
    method: ClassVar[str] = ""

    # ----------------------------------------------------------------- terms
    def term_names(self) -> list[tuple[int, int, str]]:
        """``(i, j, "K_{i}_{j}")`` for every ordered pair of joint DOFs (:func:`jointid.terms.term_names`)."""
        return term_names(self.joint_dofs)

    def term(self, i: str, j: str) -> np.ndarray:
        """Stiffness term ``K_ij`` vs frequency, shape (F,); ``i``, ``j`` term labels (``"w"``, ``"x"``, ``"101x"``)."""
        return joint_term(self.stiffness, self.joint_dofs, i, j)

    def units(self) -> dict[str, str]:
        """Term name -> SI unit."""
        return term_units(self.joint_dofs)

    @property
    def has_uncertainty(self) -> bool:
        """True when the estimator gives a standard deviation per term (``std_real``/``std_imag`` finite somewhere)."""
        return bool(np.isfinite(self.std_real).any())

    @property
    def relative_std(self) -> np.ndarray:
        """Predicted relative standard deviation ``sqrt(var Re + var Im) / scale``, shape (F, n, n) (scale: :func:`term_scale`)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.hypot(self.std_real, self.std_imag) / term_scale(self.stiffness)

    def line_estimates(self) -> np.ndarray | None:
        """The per-line estimates behind :attr:`stiffness` (F, n, n), or None when the estimate is itself per line."""
        return None

    @property
    def reliable(self) -> np.ndarray:
        """Lines on which every term is reliable, shape (F,)."""
        return self.reliable_terms.all(axis=(1, 2))

    # ----------------------------------------------------------------- what to say
    def findings(self) -> list[str]:
        """One line per thing the user must know about this estimate (none by default)."""
        return []

    @property
    def estimator(self) -> str:
        """A short name of what made :attr:`stiffness` (default: the method's name)."""
        return self.method

    def describe_estimator(self) -> str:
        """One line: what made :attr:`stiffness`."""
        return self.method

    def diagnostics(self) -> dict:
        """JSON-ready, estimator-specific diagnostics (condition numbers, the structured model's orders, ...)."""
        return {}

    def options_summary(self) -> dict:
        """JSON-ready: the options the estimator ran with."""
        return {}

    def term_summary(self) -> dict:
        """Per term (JSON-ready): median ``|K|``, median loss factor where ``Re K > 0``, reliable fraction, predicted error."""
        rel = self.relative_std
        out = {}
        for a, b, name in self.term_names():
            k = self.stiffness[:, a, b]
            stiff = k.real > 0  # Im/Re is a loss factor only where the storage part is positive
            r = rel[:, a, b]
            out[name] = {
                "median_magnitude": float(np.median(np.abs(k))),
                "median_loss_factor": float(np.median(k.imag[stiff] / k.real[stiff])) if stiff.any() else None,
                "lines_with_positive_storage": int(stiff.sum()),
                "reliable_fraction": float(np.mean(self.reliable_terms[:, a, b])),
                "median_predicted_relative_std": float(np.nanmedian(r)) if np.isfinite(r).any() else None,
            }
        return out

    def to_json(self) -> dict:
        """JSON-ready summary: method, DOFs, band, per-term figures and units, estimator, options, diagnostics, findings."""
        f = self.frequency.hz
        return {
            "method": self.method,
            "joint_dofs": [str(d) for d in self.joint_dofs],
            "lines": int(f.size),
            "frequency_hz": [float(f[0]), float(f[-1])],
            "reliable_fraction": float(np.mean(self.reliable)),
            "has_uncertainty": self.has_uncertainty,
            "terms": self.term_summary(),
            "units": self.units(),
            "estimator": self.describe_estimator(),
            "options": self.options_summary(),
            "diagnostics": self.diagnostics(),
            "findings": self.findings(),
        }

    # ----------------------------------------------------------------- tables and figures
    def extra_columns(self) -> dict[str, np.ndarray]:
        """Estimator-specific per-line columns appended to :meth:`columns` (none by default)."""
        return {}

    def columns(self) -> dict[str, np.ndarray]:
        """Table columns: ``frequency_hz``, ``K_{i}_{j}_real/imag``, their ``_real_std/_imag_std`` (NaN: none),
        ``reliable_{i}_{j}`` (0/1) per term, ``reliable`` (all terms), then :meth:`extra_columns`."""
        cols = stiffness_columns(self.frequency, self.joint_dofs, self.stiffness)
        names = self.term_names()
        for a, b, name in names:
            cols[f"{name}_real_std"] = self.std_real[:, a, b]
            cols[f"{name}_imag_std"] = self.std_imag[:, a, b]
        for a, b, name in names:
            cols[f"reliable_{name[2:]}"] = self.reliable_terms[:, a, b]
        cols["reliable"] = self.reliable
        return cols | self.extra_columns()

    def to_csv(self, path) -> None:
        """Write :meth:`columns` to ``path`` as CSV (a path of the caller's; commands write through ``OutputSet``)."""
        from ..io.tables import write_csv

        write_csv(path, self.columns())

    def plot(self, truth: np.ndarray | None = None, axes=None):
        """Each term's ``|K|`` with its 90 % band and the loss factor (or phase) of diagonal terms; returns a Figure.

        ``axes``: an array of Axes (2, n_terms) to draw into (a joint of at most 3 DOFs).
        """
        from ..plots.joint_stiffness import plot_joint_stiffness

        return plot_joint_stiffness(self, truth=truth, axes=axes)

    def subset(self, indices) -> "JointEstimate":  # pragma: no cover - every estimator implements it
        """The estimate on a subset of the joint DOFs (one of several joints identified together)."""
        raise NotImplementedError


#: Estimator name -> (module under :mod:`jointid.methods`, function, options class). Every function is
#: ``f(free, measured, joint_dofs, options) -> JointEstimate``.
ESTIMATORS: dict[str, tuple[str, str, str]] = {
    "receptance": (".receptance.coupling", "identify_joint_coupling", "CouplingOptions"),
    "hong-lee": (".hong_lee.inverse", "identify_joint", "InverseOptions"),
}


def estimator(name: str):
    """``(function, options class)`` of the estimator registered as ``name``.

    Raises
    ------
    IdentificationError
        An unknown name (one line listing the known ones).
    """
    if name not in ESTIMATORS:
        raise IdentificationError(f"unknown estimator {name!r}; known: {', '.join(ESTIMATORS)}")
    module, function, options = ESTIMATORS[name]
    mod = importlib.import_module(module, __package__)
    return getattr(mod, function), getattr(mod, options)


def estimate_joint(free, measured, joint_dofs: Sequence[Dof], method: str = "receptance", options=None) -> JointEstimate:
    """Identify the joint on ``joint_dofs`` with the estimator registered as ``method``.

    Parameters
    ----------
    free : free model
        Anything with ``receptance(frequency, rows, cols)`` (the Hong & Lee method needs a dense
        model with ``dynamic_stiffness``).
    measured : FRF
        The constrained structure's FRFs, observed x excited.
    joint_dofs : sequence of Dof
    method : str
        A key of :data:`ESTIMATORS`.
    options : optional
        That estimator's options (default: its defaults).
    """
    function, options_class = estimator(method)
    return function(free, measured, joint_dofs, options if options is not None else options_class())

