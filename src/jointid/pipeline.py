"""From a validated :class:`~jointid.study.parse.Study` to models, virtual tests and identifications.

These functions are the API behind ``jointid simulate`` and ``jointid identify``;
they only translate study settings into calls of :mod:`jointid.physics` and
:mod:`jointid.methods`. The models of a study (free model, true joints, test
article) come from :mod:`jointid.models`; ``free_model``, ``true_joint`` and
``constrained_model`` are re-exported here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .errors import DataError
from .frequency import Frequency
from .frf import FRF
from .methods.receptance.coupling import CouplingOptions, CouplingResult, identify_joint_coupling
from .methods.hong_lee.inverse import InverseOptions, InverseResult, check_layout, identify_joint
from .models import constrained_model, free_model, true_joint  # the study-to-model translation (re-exported)
from .physics.structure import Structure
from .physics.synthesis import synthesize_frf
from .study.parse import Study

__all__ = [
    "free_model", "true_joint", "constrained_model", "VirtualTest", "simulate", "read_measured", "identify",
    "inverse_options", "ExperimentResult", "experiment", "virtual_hits", "coupling_options",
    "true_beam_study", "simulate_free", "read_free_measured", "free_beam_parameters", "update", "study_frfs",
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
    """Synthesize the constrained beam's accelerances at the study's coordinates (a virtual test).

    Parameters
    ----------
    study : Study
        Needs ``[joint.model]``; ``[accelerometers]`` (if present) load the test article.
    frequency : Frequency, optional
        Default: the study's ``[frequency]`` grid.

    A ``[structure]`` study goes to :func:`jointid.pipeline_structure.simulate_structure`.
    """
    if study.is_structure:
        from .pipeline_structure import simulate_structure

        return simulate_structure(study, frequency)
    frequency = frequency or study.grid
    joint = true_joint(study)
    article = free_model(study, with_accelerometers=True).with_joint(joint)
    frf = synthesize_frf(
        article, frequency, study.measurement.observed_dofs, study.measurement.excited_dofs, kind="accelerance"
    )
    return VirtualTest(frf, joint(frequency.hz), joint.dofs)


def inverse_options(study: Study) -> InverseOptions:
    """The :class:`InverseOptions` of the study's ``[identification]`` section."""
    spec = study.identification
    return InverseOptions(
        symmetric=bool(spec.symmetric),
        regularization=spec.regularization,
        estimation=spec.estimation,
        cond_rtol=spec.cond_rtol,
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
    several = study.is_structure and len(study.joints) > 1
    if several and smoothing == "structured":
        from .errors import StudyError

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
    )


def read_measured(study: Study, path: str | os.PathLike) -> FRF:
    """Read a measured FRF file as the study describes it: only the FRFs the study uses, in SI.

    ``[measurement].points`` maps the file's point ids to beam nodes and
    ``[measurement].axis`` names the file's direction that is ``w`` (see
    :func:`jointid.io.frf_files.read_frf`). Only the observed x excited FRFs
    (and their coherence, when the file has it, in ``FRF.coherence``) are
    read; every other record is skipped. ``FRF.notes`` says in one line each
    what was converted to SI and what was skipped.

    Raises
    ------
    DataError
        A record the study needs cannot be read (naming the file and the record).

    A ``[structure]`` study reads 3-D directions
    (:func:`jointid.pipeline_structure.read_measured_structure`).
    """
    from .io.frf_files import read_frf

    if study.is_structure:
        from .pipeline_structure import read_measured_structure

        return read_measured_structure(study, path)
    m = study.measurement
    return read_frf(
        path,
        n_nodes=study.beam.nodes,
        points=m.point_map,
        axis=m.axis,
        responses=m.observed_dofs,
        references=m.excited_dofs,
        coherence=True,
    )


def study_frfs(study: Study, measured: FRF) -> FRF:
    """``measured`` on the study's observed x excited DOFs (in study order) and its ``start..stop`` band (above 0 Hz).

    Raises
    ------
    DataError
        The file lacks one of the study's DOFs (one line naming them and what the file has).
    """
    m = study.measurement
    for what, have, want in (("response", measured.responses, m.observed_dofs), ("reference", measured.references, m.excited_dofs)):
        missing = [str(d) for d in want if d not in have]
        if missing:
            raise DataError(
                f"the FRF file has no {what} at {', '.join(missing)} (it has {', '.join(map(str, have))}); "
                f"measure it or remove it from [measurement] in {study.source}"
            )
    # a 0 Hz line carries no information (and the free structure is singular there): skip it
    return measured.select(m.observed_dofs, m.excited_dofs).band(max(study.frequency.start, 1e-6), study.frequency.stop)


def identify(
    study: Study, measured: FRF, options: InverseOptions | CouplingOptions | None = None
) -> InverseResult | CouplingResult:
    """Identify the study's joint from measured FRFs, over the study's ``start..stop`` band.

    The method is ``[identification].method`` unless ``options`` says otherwise:
    "receptance" (default; :func:`~jointid.methods.receptance.coupling.identify_joint_coupling`
    with the free beam meshed for convergence) or "hong-lee"
    (:func:`~jointid.methods.hong_lee.inverse.identify_joint` on the beam's grid nodes: its
    estimation step solves for every unobserved DOF, so a refined mesh would
    multiply its cost; ``[beam].elements_per_segment`` refines it explicitly).

    The lines of ``measured`` inside ``[frequency] start..stop`` are used on the
    data's own grid (``step`` is ignored). Responses/references are reordered to
    the study's observed/excited coordinates; extra ones in the file are ignored.

    Raises
    ------
    DataError
        If the file lacks one of the study's coordinates or has no line in the band.
    IdentificationError
        If the layout has too few coordinates.

    A ``[structure]`` study identifies all its joints at once
    (:func:`jointid.pipeline_structure.identify_structure`; Hong & Lee on models of
    at most 500 DOFs).
    """
    if study.is_structure:
        from .pipeline_structure import identify_structure

        return identify_structure(study, measured, options)
    m = study.measurement
    check_layout(len(study.joint.dofs), m.observed, m.excited)
    data = study_frfs(study, measured)
    if isinstance(options, CouplingOptions) or (options is None and study.identification.method == "receptance"):
        return identify_joint_coupling(free_model(study), data, study.joint.joint_dofs, options or coupling_options(study))
    refined = study.beam.elements_per_segment is not None
    return identify_joint(free_model(study, refined=refined), data, study.joint.joint_dofs, options or inverse_options(study))


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

    The test article (beam, ``[accelerometers]``, true joint) is hit at each excited
    node ``[experiment].averages`` times with a half-sine pulse; the exact sampled
    responses (see :mod:`jointid.measurement.virtual_hammer`) get noise, and
    :func:`jointid.measurement.impact.estimate_frfs` turns them into H1 with a force
    window (and, for a transient test, the exponential window of
    ``[experiment].exponential_window``, corrected) on the study's ``start..stop`` band.

    The force window keeps ``g = 16`` samples either side of the pulse flat (plus a
    ``g`` half-cosine taper): the sampled force is band-limited at ``fs / 2`` and
    rings there; a window of ``0.5`` pulse lengths cut that ringing and biased H1
    by 3e-4 (median, benchmark), 16 samples leave 3e-7.

    Parameters
    ----------
    study : Study
        Needs ``[joint.model]``.
    seed : int, optional
        Overrides ``[experiment].seed``.
    periodic : bool
        False: a transient test (each record the first ``duration`` s after a
        hit). Noise-free, its H1 differs from the model's FRF by the physics of
        the record: leakage if the response has not decayed within
        ``duration``, and, for the hysteretic (non-causal) damping of the
        models, the response before the record start, which no record length
        captures (benchmark, 100-1000 Hz, median relative: 4.4e-4 with its
        2 s records and 0.5 s exponential window, 3.4e-4 with 4 s records and
        no window, 2.6e-4 of it the precursor). True: a periodic test (each record one period of the
        steady response to hits repeated every ``duration`` s; no leakage, no
        exponential window, which is then not applied): noise-free, H1 equals
        the model's FRF to ~3e-7 median, 3e-6 max (benchmark).
    """
    from .measurement.impact import estimate_frfs

    records, options = virtual_hits(study, seed, periodic=periodic)
    impact = estimate_frfs(records, options)
    frf = impact.to_frf("h1")
    if study.is_structure:
        from .models import true_joint_matrix

        return ExperimentResult(impact, frf, true_joint_matrix(study, frf.frequency.hz))
    return ExperimentResult(impact, frf, true_joint(study)(frf.frequency.hz))


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
def true_beam_study(study: Study, truth: Study | None = None) -> Study:
    """``study`` with its beam replaced by the true one: ``[truth]`` applied, or ``truth``'s beam.

    Parameters
    ----------
    truth : Study, optional
        Another study whose ``[beam]`` (with its own ``[truth]`` applied) is the
        true beam; it must have the same number of grid nodes. Default: the
        study's ``[beam]`` with its ``[truth]`` overrides.

    Raises
    ------
    StudyError
        ``truth`` is a ``[structure]`` study, or has a different number of beam nodes.
    """
    from dataclasses import replace

    from .errors import StudyError

    if truth is None:
        return study.true_study()
    if truth.is_structure:
        raise StudyError(
            f"{truth.source}: --truth needs a [beam] study (the true beam of {study.source}); "
            "this one is a [structure] study"
        )
    beam = truth.true_study().beam
    if beam.nodes != study.beam.nodes:
        raise StudyError(
            f"{truth.source}: [beam].nodes = {beam.nodes} differs from the {study.beam.nodes} of {study.source}; "
            "the true beam needs the same grid of nodes"
        )
    return replace(study, beam=beam, truth=None)


def simulate_free(
    study: Study, frequency: Frequency | None = None, noise: float = 0.0, seed: int = 0, truth: Study | None = None
) -> FRF:
    """A virtual free-free test: accelerances of the free true beam with its accelerometers (no joint).

    The structure is the study's beam with the ``[truth]`` overrides (or
    ``truth``'s beam, see :func:`true_beam_study`), meshed by the true study's
    ``elements_per_segment`` (or automatically), carrying the ``[accelerometers]``
    as the test article does; FRFs at the study's observed x excited coordinates.

    Parameters
    ----------
    frequency : Frequency, optional
        Default: the study's grid (a 0 Hz line is dropped: a free beam has no receptance there).
    noise : float
        Relative rms of complex Gaussian noise on every value, ``H (1 + noise n)``
        with ``n`` circular, ``E|n|^2 = 1`` (0: exact).
    seed : int
        Seed of the noise.

    Returns
    -------
    FRF
        Accelerance, (m/s^2)/N, shape (F, |m|, |e|).
    """
    if not (np.isfinite(noise) and noise >= 0):
        raise DataError(f"noise must be a relative rms >= 0, got {noise!r}")
    frequency = frequency or study.grid
    if frequency.hz[0] <= 0:
        frequency = frequency[frequency.hz > 0]
    from .physics.banded_receptance import receptance_banded

    true = true_beam_study(study, truth)
    article = free_model(true, with_accelerometers=True)
    m = study.measurement
    Y = receptance_banded(article, frequency, m.observed_dofs, m.excited_dofs)  # exact to ~1e-8, fast on fine meshes
    if Y is None:
        frf = synthesize_frf(article, frequency, m.observed_dofs, m.excited_dofs, kind="accelerance")
    else:
        frf = FRF(frequency, Y, m.observed_dofs, m.excited_dofs, "receptance").to("accelerance")
    if noise > 0:
        rng = np.random.default_rng(seed)
        shape = frf.data.shape
        n = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)
        frf = FRF(frf.frequency, frf.data * (1.0 + noise * n), frf.responses, frf.references, frf.kind)
    return frf


def read_free_measured(study: Study, path: str | os.PathLike) -> FRF:
    """Read a free-free FRF file: every FRF between the beam's grid nodes (any subset), in SI, with coherence.

    ``[measurement].points`` and ``.axis`` apply as in :func:`read_measured`;
    a record at a node outside the beam is an error naming the file and record.
    A ``[structure]`` study reads its observed x excited DOFs
    (:func:`jointid.pipeline_structure.read_free_measured_structure`).
    """
    from .io.frf_files import read_frf

    if study.is_structure:
        from .pipeline_structure import read_free_measured_structure

        return read_free_measured_structure(study, path)

    m = study.measurement
    return read_frf(path, n_nodes=study.beam.nodes, points=m.point_map, axis=m.axis, coherence=True)


def free_beam_parameters(study: Study):
    """The study's free beam with its accelerometers as a parameterized model for updating.

    Returns
    -------
    build : callable
        ``build(values) -> Structure``: the beam meshed with the study's
        refinement at ``[frequency].stop`` (fixed, so the model is smooth in the
        parameters), ``values`` replacing ``[beam]`` keys (``elastic_modulus``,
        ``density``, ``loss_factor``, ``shear_coefficient``) and
        ``accelerometers.mass`` / ``accelerometers.rotary_inertia``.
    initial : dict
        The study's value of each of those keys (the accelerometer ones only
        with an ``[accelerometers]`` section).
    """
    from dataclasses import replace

    beam = study.beam
    r = beam.mesh_refinement(study.frequency.stop)
    beam_keys = ("elastic_modulus", "density", "loss_factor", "shear_coefficient")
    initial = {k: float(getattr(beam, k)) for k in beam_keys}
    acc = study.accelerometers
    if acc is not None:
        initial["accelerometers.mass"] = acc.mass
        initial["accelerometers.rotary_inertia"] = acc.rotary_inertia

    def build(values) -> Structure:
        spec = replace(beam, elements_per_segment=r, **{k: values[k] for k in beam_keys if k in values})
        s = spec.structure()
        if acc is not None:
            s = s.with_masses(
                acc.nodes, values.get("accelerometers.mass", acc.mass),
                values.get("accelerometers.rotary_inertia", acc.rotary_inertia),
            )
        return s

    return build, initial


def update(study: Study, measured: FRF, options=None):
    """Update the study's free beam (and sensors) from free-free FRFs over the study's band.

    See :func:`jointid.methods.updating.fit.update_free_model`; the lines of
    ``measured`` in ``[frequency] start..stop`` (above 0 Hz) are used on the
    data's own grid. Returns its :class:`~jointid.methods.updating.fit.UpdateResult`.
    A ``[structure]`` study fits its stiffness and mass scales and loss factor
    (:func:`jointid.pipeline_structure.update_structure`).
    """
    from .methods.updating.fit import update_free_model

    if study.is_structure:
        from .pipeline_structure import update_structure

        return update_structure(study, measured, options)

    data = measured.band(max(study.frequency.start, 1e-6), study.frequency.stop)
    build, initial = free_beam_parameters(study)
    return update_free_model(build, initial, data, options)
