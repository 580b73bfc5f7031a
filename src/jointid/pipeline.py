"""From a validated :class:`~jointid.study.Study` to virtual tests, identifications and model updates: one pipeline.

These functions are the API behind ``jointid simulate``, ``identify``, ``experiment`` and
``update``. They take a study of any free structure (the ``[beam]`` factory, matrix files, ...)
and any number of joints; the models come from :mod:`jointid.models` (``free_model``,
``true_joint``, ``constrained_model`` are re-exported here), what differs between free
structures is asked of the study's structure spec (the free-structure protocol of
:mod:`jointid.study.structures`), and the estimator is chosen by name
(:mod:`jointid.methods.estimate`). All joints of a study are identified together (one ``Du``
on every joint DOF); :func:`split_joints` gives one result per joint.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .errors import DataError, FrequencyError, StudyError
from .frequency import Frequency
from .frf import FRF
from .methods.estimate import JointEstimate, estimate_joint
from .methods.estimate import check_layout
from .methods.hong_lee.inverse import InverseOptions
from .methods.receptance.coupling import CouplingOptions
from .models import constrained_model, free_model, true_joint, true_joint_matrix, uncertain_free_model  # the study-to-model translation (re-exported)
from .physics.synthesis import model_frf
from .study import Study

__all__ = [
    "free_model", "true_joint", "constrained_model", "VirtualTest", "simulate", "read_measured", "identify",
    "inverse_options", "ExperimentResult", "experiment", "virtual_hits", "coupling_options",
    "true_study", "simulate_free", "read_free_measured", "update", "study_frfs", "split_joints", "cross_joint_ratio",
]


@dataclass(frozen=True, eq=False)
class VirtualTest:
    """Exact FRFs of the constrained structure and the true joint stiffness.

    Attributes
    ----------
    frf : FRF
        Accelerance ``(m/s^2)/N``, observed x excited, shape (F, |m|, |e|).
    truth : ndarray, shape (F, |n|, |n|), complex
        True joint stiffness on ``joint_dofs``.
    joint_dofs : tuple of Dof
    """

    frf: FRF
    truth: np.ndarray
    joint_dofs: tuple

    @property
    def frequency(self) -> Frequency:
        """Frequency axis, Hz."""
        return self.frf.frequency


def simulate(study: Study, frequency: Frequency | None = None) -> VirtualTest:
    """Synthesize the test article's accelerances at the study's coordinates (a virtual test).

    The test article is the free structure with its ``[accelerometers]`` (if any) and every
    true joint (:func:`jointid.models.constrained_model`).

    Parameters
    ----------
    study : Study
        Every joint needs ``[joint.model]``.
    frequency : Frequency, optional
        Default: the study's ``[frequency]`` grid (a model coupled by Woodbury drops a 0 Hz line:
        :func:`jointid.physics.synthesis.model_frf`).

    Returns
    -------
    VirtualTest
        ``frf`` accelerance ``(m/s^2)/N`` (rotations rad/s^2, per N*m), ``truth`` (F, n, n) on every joint DOF.
    """
    frequency = frequency or study.grid
    article = constrained_model(study)
    m = study.measurement
    frf = model_frf(article, frequency, m.observed_dofs, m.excited_dofs, kind="accelerance")
    return VirtualTest(frf, true_joint_matrix(study, frf.frequency.hz), study.joint_dofs)


def inverse_options(study: Study) -> InverseOptions:
    """The :class:`InverseOptions` of the study's ``[identification]`` section (``weighting = "none"``: the paper's
    unweighted pseudo-inverses; any other: the estimation step weighted by the FRFs' relative noise)."""
    spec = study.identification
    return InverseOptions(
        symmetric=bool(spec.symmetric),
        regularization=spec.regularization,
        estimation=spec.estimation,
        cond_rtol=spec.cond_rtol,
        weighting="none" if spec.weighting == "none" else "relative",  # "none": the paper's unweighted two steps
    )


def coupling_options(study: Study) -> CouplingOptions:
    """The :class:`CouplingOptions` of the study's ``[identification]`` section.

    A study of several joints identifies them together; the structured joint model
    (one material, one modulus, shared internal modes) does not hold for them, so
    ``smoothing = "auto"`` is then ``"gcv"`` and ``"structured"`` is refused.

    Raises
    ------
    StudyError
        ``smoothing = "structured"`` with several ``[[joint]]``s.
    """
    spec = study.identification
    smoothing = spec.smoothing
    several = len(study.joints) > 1
    if several and smoothing == "structured":
        raise StudyError(
            f"{study.source}: [identification].smoothing = \"structured\" fits the model of one joint of one material, and this "
            f"study identifies {len(study.joints)} joints together: use \"auto\" or \"gcv\"")
    return CouplingOptions(
        symmetric=True if spec.symmetric is None else spec.symmetric,
        smoothing="gcv" if several and smoothing == "auto" else smoothing,
        weighting=spec.weighting,
        averages=spec.averages,
        max_relative_std=spec.max_relative_std,
        calibration=spec.calibration,
        units_check=spec.units_check,
        model_check=spec.model_check,
        targets=spec.targets,
    )


def read_measured(study: Study, path: str | os.PathLike, preread: FRF | None = None) -> FRF:
    """Read a measured FRF file as the study describes it: only the FRFs the study uses, in SI.

    ``[measurement].points`` maps the file's point ids to model nodes; how the file's
    directions map to the model's DOFs is the free structure's (a beam: ``[measurement].axis``
    is the file's direction that is ``w``; matrix files: UFF direction codes 1-6 are x..rz,
    negative ones flipped; see :func:`jointid.io.frf_files.read_frf`). Only the observed x
    excited FRFs (and their coherence, when the file has it) are read; ``FRF.notes`` says in one
    line each what was converted to SI and what was skipped.

    ``preread``: the file as :func:`jointid.study.measured.read_study_frf` read it elsewhere (``jointid
    identify`` reads it in its figure worker while this process imports the estimators); None: read here.
    Either way the study's DOFs are checked here.

    Raises
    ------
    DataError
        A record the study needs cannot be read (naming the file and the record).
    """
    from .study.measured import read_study_frf

    measured = preread if preread is not None else read_study_frf(study, path)
    _require_study_dofs(study, measured, f"the FRF file {path}")
    return measured


def _require_study_dofs(study: Study, measured: FRF, what_file: str) -> None:
    """Raise DataError (one line naming ``what_file`` and the DOFs) when ``measured`` lacks a DOF of [measurement]."""
    m = study.measurement
    for what, have, want in (("response", measured.responses, m.observed_dofs), ("reference", measured.references, m.excited_dofs)):
        missing = [str(d) for d in want if d not in have]
        if missing:
            raise DataError(
                f"{what_file} has no {what} at {', '.join(missing)} (it has {', '.join(map(str, have)) or 'none'}); "
                f"measure it or remove it from [measurement] in {study.source}"
            )


def study_frfs(study: Study, measured: FRF) -> FRF:
    """``measured`` on the study's observed x excited DOFs (in study order) and its ``start..stop`` band (above 0 Hz).

    Raises
    ------
    DataError
        The file lacks one of the study's DOFs (one line naming them and what the file has).
    """
    m = study.measurement
    _require_study_dofs(study, measured, "the FRF file")
    # a 0 Hz line carries no information (and the free structure is singular there): skip it
    try:
        return measured.select(m.observed_dofs, m.excited_dofs).band(max(study.frequency.start, 1e-6), study.frequency.stop)
    except FrequencyError as exc:
        raise DataError(f"the FRF file does not reach the study's band: {exc}; check the file's frequency unit (Hz; a "
                        f"kHz or rad/s axis is not converted without its label) or [frequency] start/stop in "
                        f"{study.source}") from None


def identify(study: Study, measured: FRF, options: InverseOptions | CouplingOptions | None = None) -> JointEstimate:
    """Identify every joint of the study from measured FRFs, over the study's ``start..stop`` band.

    The estimator is ``[identification].method`` unless ``options`` says otherwise
    (:class:`~jointid.methods.receptance.coupling.CouplingOptions`: "receptance",
    :class:`~jointid.methods.hong_lee.inverse.InverseOptions`: "hong-lee"); it is run by
    :func:`jointid.methods.estimate.estimate_joint` on the free model (the receptance method:
    meshed for convergence; Hong & Lee: the structure's dense model, ``dense_model``, since its
    estimation step solves for every unobserved DOF).

    The lines of ``measured`` inside ``[frequency] start..stop`` (above 0 Hz) are used on the
    data's own grid (``step`` is ignored). Responses/references are reordered to the study's
    observed/excited coordinates; extra ones in the file are ignored.

    Raises
    ------
    DataError
        If the file lacks one of the study's coordinates or has no line in the band.
    IdentificationError
        If the layout has too few coordinates.
    StudyError
        Hong & Lee on a model too large to be dense.
    """
    m = study.measurement
    check_layout(len(study.joint_dofs), m.observed_dofs, m.excited_dofs)
    data = study_frfs(study, measured)
    if options is None:
        method = study.identification.method
        options = coupling_options(study) if method == "receptance" else inverse_options(study)
    method = "receptance" if isinstance(options, CouplingOptions) else "hong-lee"
    if method == "receptance":
        free = uncertain_free_model(study, free_model(study))
    else:
        try:
            free = study.structure.dense_model(study.frequency.stop)
        except StudyError as exc:
            raise StudyError(f"{study.source}: {exc}") from None
        acc = study.accelerometers
        if study.identification.model_accelerometers and acc is not None:
            free = free.with_masses(acc.nodes, acc.mass, acc.rotary_inertia)
    return estimate_joint(free, data, study.joint_dofs, method, options)


def split_joints(study: Study, result: JointEstimate) -> dict:
    """One result per joint (name -> its block of ``result``), in study order."""
    out, i = {}, 0
    for joint in study.joints:
        k = len(joint.joint_dofs)
        out[joint.name] = result.subset(range(i, i + k)) if len(study.joints) > 1 else result
        i += k
    return out


def cross_joint_ratio(study: Study, stiffness: np.ndarray) -> float:
    """Largest ``|K_ij|`` between DOFs of different joints over the largest within-joint ``|K_ij|`` (all lines).

    0 for a single joint. The true ``Du`` is block diagonal, so on exact data this is
    round-off; a large value points to model error or a joint missing from the study.
    """
    owner = np.concatenate([np.full(len(j.joint_dofs), a) for a, j in enumerate(study.joints)])
    cross = owner[:, None] != owner[None, :]
    if not cross.any():
        return 0.0
    mag = np.abs(stiffness)
    return float(mag[:, cross].max() / mag[:, ~cross].max())


@dataclass(frozen=True, eq=False)
class ExperimentResult:
    """A virtual roving-hammer test: estimated FRFs, coherence, the true joint.

    Attributes
    ----------
    impact : ImpactFRF
        H1/H2/coherence over the study's band, with rejected hits and window notes.
    frf : FRF
        H1 accelerance, (m/s^2)/N, observed x excited.
    truth : ndarray, shape (F, |n|, |n|), complex
        True joint stiffness on the FRF's lines.
    """

    impact: object
    frf: FRF
    truth: np.ndarray

    @property
    def coherence(self) -> np.ndarray:
        """Coherence, shape (F, |m|, |e|)."""
        return self.impact.coherence


def experiment(study: Study, seed: int | None = None, *, periodic: bool = False) -> ExperimentResult:
    """Run the study's virtual roving-hammer test and estimate its FRFs (H1).

    The test article (the free structure, its ``[accelerometers]``, every true joint) is hit at
    each excited DOF ``[experiment].averages`` times with a half-sine pulse; the exact sampled
    responses (see :mod:`jointid.measurement.virtual_hammer`) get noise, and
    :func:`jointid.measurement.impact.estimate_frfs` turns them into H1 with a force
    window (and, for a transient test, the exponential window of
    ``[experiment].exponential_window``, corrected) on the study's ``start..stop`` band.

    The force window keeps ``g = 16`` samples either side of the pulse flat (plus a ``g``
    half-cosine taper): the sampled force is band-limited at ``fs / 2`` and rings there, and a
    window that cuts that ringing biases H1 (``benchmarks/impact.py`` measures both).

    Parameters
    ----------
    study : Study
        Every joint needs ``[joint.model]``.
    seed : int, optional
        Overrides ``[experiment].seed``.
    periodic : bool
        False: a transient test (each record the first ``duration`` s after a hit). Noise-free,
        its H1 differs from the model's FRF by the physics of the record: leakage if the
        response has not decayed within ``duration`` and, for the hysteretic (non-causal)
        damping of the models, the response before the record start, which no record length
        captures. True: a periodic test (each record one period of the steady response to hits
        repeated every ``duration`` s; no leakage, no exponential window, which is then not
        applied): noise-free, H1 equals the model's FRF up to the force window's ringing.
    """
    from .measurement.impact import estimate_frfs

    records, options = virtual_hits(study, seed, periodic=periodic)
    impact = estimate_frfs(records, options)
    frf = impact.to_frf("h1")
    return ExperimentResult(impact, frf, true_joint_matrix(study, frf.frequency.hz))


def virtual_hits(study: Study, seed: int | None = None, *, periodic: bool = False):
    """The hits of the study's virtual roving-hammer test and the processing options :func:`experiment` uses.

    Returns
    -------
    records : list of ImpactRecord
        One per excited node (``[experiment].averages`` hits each), with noise.
    options : ImpactOptions
        Force window, exponential window (transient test only) and band.
    """
    from .measurement.impact import ImpactOptions, ImpactRecord
    from .measurement.virtual_hammer import HammerSettings, simulate_hits

    x = study.experiment
    shared = ("sample_rate", "duration", "averages", "force_noise", "response_noise", "pulse_duration", "pulse_amplitude")
    guard = 16.0 / x.sample_rate  # s: flat margin and taper of the force window either side of the pulse
    settings = HammerSettings(
        **{k: getattr(x, k) for k in shared}, pretrigger=max(0.005, 2.5 * guard), pad=1 if periodic else 8
    )
    if study.frequency.stop >= x.sample_rate / 2:
        raise DataError(
            f"[experiment].sample_rate = {x.sample_rate:g} Hz cannot resolve [frequency].stop = {study.frequency.stop:g} Hz; "
            "use a sample rate above twice the highest frequency"
        )
    if x.pulse_duration * x.sample_rate < 4:
        raise DataError(
            f"[experiment]: the {1e3 * x.pulse_duration:g} ms hammer pulse spans {x.pulse_duration * x.sample_rate:.1f} samples at "
            f"{x.sample_rate:g} Hz; a force window needs at least 4: raise sample_rate or pulse_duration"
        )
    rng = np.random.default_rng(x.seed if seed is None else seed)
    article = constrained_model(study)
    hits = simulate_hits(article, study.measurement.observed_dofs, study.measurement.excited_dofs, settings, rng)
    records = [ImpactRecord(h.force, h.responses, h.sample_rate, h.response_dofs, h.reference) for h in hits]
    options = ImpactOptions(
        force_window_s=x.pulse_duration + 2.0 * guard,
        force_pretrigger_s=guard,
        force_taper_s=guard,
        exp_tau_s=None if periodic else (x.exponential_window or None),
        band_hz=(max(study.frequency.start, 1.0 / x.duration), study.frequency.stop),
    )
    return records, options


# --------------------------------------------------------------------------- free-free test and model updating
def true_study(study: Study, truth: Study | None = None) -> Study:
    """``study`` with its free structure replaced by the true one: ``[truth]`` applied, or ``truth``'s structure.

    Parameters
    ----------
    truth : Study, optional
        Another study whose free structure (with its own ``[truth]`` applied) is the true one;
        it must be of the same kind with the same nodes/DOFs. Default: the study's structure
        with its ``[truth]`` overrides.

    Raises
    ------
    StudyError
        ``truth``'s structure cannot stand for this study's (one line saying why).
    """
    from dataclasses import replace

    if truth is None:
        return study.true_study()
    structure = truth.true_study().structure
    why = study.structure.compatible(structure, study.source)
    if why is not None:
        raise StudyError(f"{truth.source}: {why}")
    return replace(study, structure=structure, truth=None)


def simulate_free(
    study: Study, frequency: Frequency | None = None, noise: float = 0.0, seed: int = 0, truth: Study | None = None
) -> FRF:
    """A virtual free-free test: accelerances of the true free structure with its accelerometers (no joint).

    The structure is the study's with the ``[truth]`` overrides (or ``truth``'s, see
    :func:`true_study`), carrying the ``[accelerometers]`` as the test article does; FRFs at
    the study's observed x excited coordinates.

    Parameters
    ----------
    frequency : Frequency, optional
        Default: the study's grid (a 0 Hz line is dropped: a free structure has no receptance there).
    noise : float
        Relative rms of complex Gaussian noise on every value, ``H (1 + noise n)``
        with ``n`` circular, ``E|n|^2 = 1`` (0: exact).
    seed : int
        Seed of the noise.

    Returns
    -------
    FRF
        Accelerance, (m/s^2)/N (rotations rad/s^2, per N*m), shape (F, |m|, |e|).
    """
    if not (np.isfinite(noise) and noise >= 0):
        raise DataError(f"noise must be a relative rms >= 0, got {noise!r}")
    frequency = frequency or study.grid
    if frequency.hz[0] <= 0:
        frequency = frequency[frequency.hz > 0]
    from .physics.banded_receptance import receptance_banded
    from .physics.structure import Structure

    article = free_model(true_study(study, truth), with_accelerometers=True)
    m = study.measurement
    # a banded beam: the banded solver (exact within its conditioning, fast on fine meshes)
    Y = receptance_banded(article, frequency, m.observed_dofs, m.excited_dofs) if isinstance(article, Structure) else None
    if Y is None:
        frf = model_frf(article, frequency, m.observed_dofs, m.excited_dofs, kind="accelerance")
    else:
        frf = FRF(frequency, Y, m.observed_dofs, m.excited_dofs, "receptance").to("accelerance")
    if noise > 0:
        rng = np.random.default_rng(seed)
        shape = frf.data.shape
        n = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)
        frf = FRF(frf.frequency, frf.data * (1.0 + noise * n), frf.responses, frf.references, frf.kind)
    return frf


def read_free_measured(study: Study, path: str | os.PathLike) -> FRF:
    """Read a free-free FRF file in SI, with coherence: every FRF between the structure's nodes (any subset) in the
    file's directions as the structure maps them (:func:`read_measured`; no selection of rows and columns).

    Raises
    ------
    DataError
        A record at a node outside the structure, or one that cannot be read (naming the file and record).
    """
    from .io.frf_files import read_frf

    m = study.measurement
    return read_frf(path, points=m.point_map, coherence=True, **study.structure.frf_reading(m))


def update(study: Study, measured: FRF, options=None):
    """Update the study's free structure (and sensors) from free-free FRFs over the study's band.

    See :func:`jointid.methods.updating.fit.update_free_model`; the free structure gives the
    parameterized model (``update_model``: a beam's E, density, loss factor, shear coefficient
    and sensor masses; matrix files' stiffness and mass scales and loss factor). The lines of
    ``measured`` in ``[frequency] start..stop`` (above 0 Hz) are used on the data's own grid.

    Returns
    -------
    UpdateResult

    Raises
    ------
    ModelError
        A parameter the free structure does not have (one line naming the allowed ones).
    """
    from .methods.updating.fit import UpdateOptions, check_parameter_names, update_free_model

    known, default = study.structure.update_parameter_names()
    options = options or UpdateOptions(parameters=default)
    kind = "" if study.beam is not None else f"a [{study.structure.study_table}] study: "  # the beam's names are the default ones
    check_parameter_names(options.parameters, known=known, prefix=f"{study.source}: {kind}")
    try:
        model, initial, _, _ = study.structure.update_model(study.accelerometers, study.frequency.stop)
    except StudyError as exc:
        raise StudyError(f"{study.source}: {exc}") from None
    data = measured.band(max(study.frequency.start, 1e-6), study.frequency.stop)
    return update_free_model(model, initial, data, options)
