"""Pieces shared by the studies: outputs, progress, error metrics, the true joints."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

from ..frequency import Frequency
from ..frf import FRF
from ..physics.structure import ComplexStiffness
from ..report.html import Table

__all__ = [
    "StudyOutput",
    "Progress",
    "band_errors",
    "relative_error",
    "elastomer_joint",
    "material_joint",
    "study_beam",
    "add_noise",
    "fmt",
    "pct",
    "terms_of",
    "percentiles",
    "layout_table",
    "SUMMARY_BAND_HZ",
    "png",
    "config_study",
]

#: Band of the summary error figures, Hz.
SUMMARY_BAND_HZ = (100.0, 1000.0)


class Progress:
    """Progress of one study run in this process: ``total(n)`` once, then ``update(k)`` (no-op unless given callbacks;
    ``jointid reproduce`` reports per study, :mod:`jointid.reproduce.runner`)."""

    def __init__(self, on_total: Callable[[int], None] | None = None, on_update: Callable[[int], None] | None = None):
        self._on_total = on_total or (lambda n: None)
        self._on_update = on_update or (lambda k: None)

    def total(self, n: int) -> None:
        """Announce ``n`` steps."""
        self._on_total(n)

    def update(self, k: int = 1) -> None:
        """``k`` more steps done."""
        self._on_update(k)


@dataclass(frozen=True)
class StudyOutput:
    """What a study hands to the report.

    Attributes
    ----------
    name, title : str
        Machine name (``"conditioning"``) and section title.
    paragraphs : tuple of str
        Text of the section, computed from the data.
    tables : tuple of Table
    data : mapping
        CSV base name -> columns (name -> 1-D array), written to ``data/<name>.csv``.
    figures : tuple of (name, Figure or PNG bytes, caption)
        Written to ``figures/<name>.png`` and embedded in the report.
    summary : tuple of (label, magnitude error, loss-factor error)
        Median relative error of the identified translational stiffness magnitude and
        median absolute error of its loss factor over :data:`SUMMARY_BAND_HZ`.
    findings : tuple of str
        Sentences for the report's summary paragraph, computed from the data.
    """

    name: str
    title: str
    paragraphs: tuple[str, ...] = ()
    tables: tuple[Table, ...] = ()
    data: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)
    figures: tuple = ()
    summary: tuple[tuple[str, float, float], ...] = ()
    findings: tuple[str, ...] = ()


def png(fig, dpi: int = 110) -> bytes:
    """``fig`` as PNG bytes (:func:`jointid.io.png.figure_png`): a figure of the report, as it crosses a process boundary."""
    from ..io.png import figure_png

    return figure_png(fig, dpi=dpi)


def band_errors(identified: np.ndarray, truth: np.ndarray, frequency: Frequency, band=SUMMARY_BAND_HZ) -> tuple[float, float]:
    """Median relative magnitude error and median absolute loss-factor error over ``band`` (Hz)."""
    m = frequency.mask(*band)
    k, t = identified[m], truth[m]
    mag = np.abs(np.abs(k) / np.abs(t) - 1.0)
    eta = np.abs(k.imag / k.real - t.imag / t.real)
    return float(np.median(mag)), float(np.median(eta))


def relative_error(identified: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``|k - t| / |t|`` per line."""
    return np.abs(identified - truth) / np.abs(truth)


def elastomer_joint(config, material: str):
    """The :class:`~jointid.physics.elastomer_joint.ElastomerJoint` of ``config.materials[material]`` without end caps
    (:func:`jointid.models.config_elastomer_joint`; the beam-side cap belongs to the beam, see :func:`study_beam`)."""
    from ..models import config_elastomer_joint

    return config_elastomer_joint(config, material)


def material_joint(config, material: str) -> ComplexStiffness:
    """The FE elastomer-cylinder joint of ``config.materials[material]`` at the joint node (w, theta), caps excluded."""
    return elastomer_joint(config, material).complex_stiffness(config.joint_node, ("w", "theta"))


def config_study(config, node: int, material: str, observed, excited, frequency, identification, *, accelerometers=None,
                 experiment=None, source: str = "<config>"):
    """A :class:`~jointid.study.Study` of the configuration's beam with the elastomer joint of ``material`` at ``node``.

    Built from the configuration's already validated values (no study text is written or parsed): the beam,
    the joint ``(node w, node theta)`` with ``[joint.model] type = "elastomer"`` of the material's modulus, loss
    factor and density, the layout (beam nodes), the frequency and identification sections given.
    """
    from ..dofs import Dof
    from ..study import ExperimentSpec, JointModelSpec, JointSpec, MeasurementSpec, Study

    m = config.materials[material]
    model = JointModelSpec("elastomer", {"elastic_modulus": m.elastic_modulus, "loss_factor": m.loss_factor, "density": m.density})
    joint = JointSpec("joint", (Dof(node, "w"), Dof(node, "theta")), (), model)
    return Study(config.beam, (joint,), MeasurementSpec(tuple(observed), tuple(excited)), frequency, accelerometers,
                 identification, experiment or ExperimentSpec(), source)


def study_beam(config, scale: Mapping[str, float] | None = None):
    """The free beam of the studies with the joint's beam-side steel cap at the joint node
    (:func:`jointid.models.config_beam`; ``scale``: beam parameter -> factor for model-error variants)."""
    from ..models import config_beam

    return config_beam(config, scale)


def add_noise(frf: FRF, level: float, rng: np.random.Generator) -> FRF:
    """``frf`` with complex Gaussian noise of relative rms ``level`` on every value (multiplicative)."""
    shape = frf.data.shape
    noise = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)
    return FRF(frf.frequency, frf.data * (1.0 + level * noise), frf.responses, frf.references, frf.kind)


def fmt(x: float, digits: int = 3) -> str:
    """Format a number for a table."""
    if not np.isfinite(x):
        return "inf"
    return f"{x:.{digits}g}"


def pct(x: float) -> str:
    """Format a fraction as a percentage."""
    return f"{100 * x:.2f} %"


def terms_of(stiffness: np.ndarray) -> dict[str, np.ndarray]:
    """Translational, coupling and rotational terms of (F, 2, 2) stiffness."""
    return {"translational": stiffness[:, 0, 0], "coupling": stiffness[:, 0, 1], "rotational": stiffness[:, 1, 1]}


def percentiles(err: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """Median and 90th percentile of ``err[mask]``."""
    e = err[mask]
    return float(np.median(e)), float(np.percentile(e, 90))


def layout_table(layouts: Sequence) -> Table:
    """The coordinate layouts as a table."""
    return Table(
        "Coordinate layouts (beam nodes; transverse w measured, transverse force applied)",
        ["layout", "observed nodes m", "excited nodes e", "|m|", "|e|"],
        [[l.name, ", ".join(map(str, l.observed)), ", ".join(map(str, l.excited)), str(len(l.observed)), str(len(l.excited))] for l in layouts],
    )
