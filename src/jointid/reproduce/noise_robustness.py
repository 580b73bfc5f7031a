"""Study 7 -- robustness of the inverse methods to FRF noise, with calibrated bands.

Exact accelerances of the constrained beam (the free beam meshed for
convergence, as :func:`jointid.pipeline.simulate` makes them, coupled to the
elastomer joint of Material A or B at mid-span or at the beam end; no
accelerometers; :func:`exact_frf`) get complex relative noise of rms
``level`` on every value, ``H (1 + level z)`` with ``z`` standard circular
Gaussian (:func:`~jointid.reproduce.common.add_noise`); the same ``z`` per case
and realization serves every level and every method (paired comparison). Three
methods identify the joint over 100-1000 Hz:

* ``hong-lee``: the paper's per-line method, ``[identification] method =
  "hong-lee"`` through :func:`jointid.pipeline.identify` (on the beam's grid
  nodes, as ``jointid identify`` runs it; its exact-data error is the grid
  model's discretization error);
* ``receptance``: the default (``method = "receptance"``, default options):
  weighted receptance coupling, the structured joint model over all lines (each term smoothed alone when it does not fit), with 1-sigma bands;
* ``receptance-raw``: the same formulation unweighted and unsmoothed
  (``CouplingOptions(weighting="none", smoothing="none")``).

Per case, level and method: the median and 90th percentile over lines and
realizations of the relative error ``|K - K_true| / |K_true|`` per term, and for
the receptance methods the band coverage: the fraction of lines whose true value
lies within ``+-1.645 sigma`` of the real part and of the imaginary part (90 %
if the bands are calibrated). The receptance methods share one free-model
receptance per case (:class:`CachedReceptance`), identical to what
:func:`jointid.pipeline.identify` computes each call.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterable, Mapping, Sequence

import numpy as np

from ..dofs import parse_dofs
from ..errors import StudyError
from ..frequency import Frequency
from ..frf import FRF
from ..methods.estimate import Z90
from ..methods.receptance.coupling import CouplingOptions, identify_joint_coupling
from ..physics.free_model import as_free_model
from ..pipeline import coupling_options, free_model, identify, inverse_options, true_joint
from ..report.html import Table
from ..study import FrequencySpec, IdentificationSpec, Study
from .common import Progress, StudyOutput, add_noise, band_errors, config_study

__all__ = [
    "run", "Case", "CaseResult", "CachedReceptance", "TERMS", "METHODS", "BAND_HZ",
    "cases", "case_study", "run_case", "exact_frf", "term_errors", "within_band", "method_options",
    "band_of", "position", "reference_level", "parts", "combine", "run_part", "Example",
]

#: Joint terms: label, row, column of the (F, 2, 2) stiffness.
TERMS = (("K_ww", 0, 0), ("K_wtheta", 0, 1), ("K_thetatheta", 1, 1))
#: Method key -> label in the report.
METHODS = {
    "hong-lee": "Hong-Lee",
    "receptance": "receptance (default)",
    "receptance-raw": "receptance, unweighted, unsmoothed",
}
#: Band of the study, Hz (clipped to the configuration's grid).
BAND_HZ = (100.0, 1000.0)


@dataclass(frozen=True)
class Case:
    """One configuration: layout key (``"model_3"``), joint node, material name."""

    layout: str
    node: int
    material: str

    def label(self, config) -> str:
        """E.g. ``"Model 3, beam end (node 1), Material A"``."""
        return f"{config.layouts[self.layout].name}, {position(config, self.node)}, Material {self.material}"


def position(config, node: int) -> str:
    """``"mid-span (node 10)"``, ``"beam end (node 1)"`` or ``"node k"``."""
    n = config.beam.nodes
    if node in (1, n):
        return f"beam end (node {node})"
    if 2 * node == n + 1:
        return f"mid-span (node {node})"
    return f"node {node}"


def cases(config) -> list[Case]:
    """The study's cases: ``[noise_robustness]`` layouts x joint nodes x the configuration's materials."""
    return [Case(lay, node, mat) for lay in config.robustness_layouts for node in config.robustness_joint_nodes for mat in config.materials]


def band_of(config) -> Frequency:
    """The study's grid: :data:`BAND_HZ` within the configuration's ``[frequency]`` grid (its step)."""
    lo, hi = max(config.start, BAND_HZ[0]), min(config.stop, BAND_HZ[1])
    if lo >= hi:
        raise StudyError(f"[frequency]: the noise-robustness study needs lines in {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz; the grid is {config.start:g}-{config.stop:g} Hz")
    return Frequency.from_range(lo, hi, config.step)


def case_study(config, case: Case, method: str = "receptance") -> Study:
    """The :class:`~jointid.study.Study` of ``case``: the study beam, no accelerometers, 100-1000 Hz."""
    lay = config.layouts[case.layout]
    f = band_of(config)
    return config_study(config, case.node, case.material, lay.observed, lay.excited,
                        FrequencySpec(float(f.hz[0]), float(f.hz[-1]), config.step), IdentificationSpec(method=method),
                        source=f"noise-robustness study, {case.label(config)}")


def method_options(study: Study) -> dict[str, CouplingOptions | None]:
    """Options per method key (None: Hong-Lee as the paper states it -- unweighted pseudo-inverses of its two steps --
    through the study's ``method = "hong-lee"``)."""
    return {
        "hong-lee": None,
        "receptance": coupling_options(study),  # the default [identification]
        "receptance-raw": CouplingOptions(weighting="none", smoothing="none"),
    }


class CachedReceptance:
    """A free model's receptance on a few DOFs and one grid, computed once (a :class:`~jointid.physics.free_model.FreeModel`).

    Every identification of a case asks for the same blocks of ``Y = Do^-1``
    on the same lines; this computes ``Y[d, d]`` for the DOFs ``d`` once and
    slices it. Other requests (other lines or DOFs) go to the model.

    Parameters
    ----------
    model : Structure or FreeModel
    frequency : Frequency
    dofs : iterable of Dof or labels
    """

    def __init__(self, model, frequency: Frequency, dofs: Iterable):
        self._model = as_free_model(model)
        self._frequency = frequency
        self._keys = tuple(parse_dofs(list(dofs)))
        self._index = {d: i for i, d in enumerate(self._keys)}
        self._Y = self._model.receptance(frequency, self._keys, self._keys)

    @property
    def dofs(self):
        """DOFs of the underlying model."""
        return self._model.dofs

    def receptance(self, frequency, rows, cols) -> np.ndarray:
        """``Y[rows, cols]``, shape (F, r, c), from the cache when it holds them."""
        rows, cols = parse_dofs(rows), parse_dofs(cols)
        hz = frequency.hz if isinstance(frequency, Frequency) else np.asarray(frequency, float)
        if np.array_equal(hz, self._frequency.hz) and all(d in self._index for d in (*rows, *cols)):
            r = [self._index[d] for d in rows]
            c = [self._index[d] for d in cols]
            return self._Y[:, r][:, :, c]
        return self._model.receptance(frequency, rows, cols)


def exact_frf(free: CachedReceptance, joint, frequency: Frequency, observed, excited) -> tuple[FRF, np.ndarray]:
    """Exact accelerances of ``free`` on ``joint`` to ground and the joint's stiffness, from the free receptance.

    ``H*[m, e] = Y[m, e] - Y[m, n] Du (I + Y[n, n] Du)^-1 Y[n, e]`` (Sherman-Morrison-Woodbury; the
    same FRFs as :func:`jointid.pipeline.simulate` to round-off, without a second modal solution).

    Parameters
    ----------
    free : CachedReceptance
        The free model (its cache holds observed, joint and excited DOFs).
    joint : ComplexStiffness
        The true joint (its ``dofs`` and ``__call__(hz) -> (F, n, n)``).
    observed, excited : sequence of Dof

    Returns
    -------
    frf : FRF
        Accelerance, (F, |m|, |e|).
    truth : ndarray, shape (F, n, n), complex
    """
    n = list(joint.dofs)
    Du = joint(frequency.hz)
    Ymn, Ynn = free.receptance(frequency, observed, n), free.receptance(frequency, n, n)
    Yne, Yme = free.receptance(frequency, n, excited), free.receptance(frequency, observed, excited)
    X = np.linalg.solve(np.eye(len(n)) + Ynn @ Du, Yne)
    H = Yme - Ymn @ (Du @ X)
    w2 = (2.0 * np.pi * frequency.hz) ** 2
    return FRF(frequency, -w2[:, None, None] * H, tuple(observed), tuple(excited), "accelerance"), Du


def term_errors(stiffness: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Relative error ``|K - K_true| / |K_true|`` of each term of :data:`TERMS`, shape (F, 3)."""
    return np.stack([np.abs(stiffness[:, i, j] - truth[:, i, j]) / np.abs(truth[:, i, j]) for _, i, j in TERMS], axis=-1)


def within_band(stiffness: np.ndarray, std_real: np.ndarray, std_imag: np.ndarray, truth: np.ndarray, z: float = Z90) -> np.ndarray:
    """Whether the truth lies within ``+-z sigma`` of the real and of the imaginary part, shape (2, F, 3).

    ``[0]``: real parts, ``[1]``: imaginary parts; last axis: the terms of :data:`TERMS`.
    The mean over lines is the band's coverage (0.9 for calibrated 90 % bands, ``z = 1.645``).
    """
    out = np.empty((2, stiffness.shape[0], len(TERMS)), bool)
    for t, (_, i, j) in enumerate(TERMS):
        out[0, :, t] = np.abs(stiffness[:, i, j].real - truth[:, i, j].real) <= z * std_real[:, i, j]
        out[1, :, t] = np.abs(stiffness[:, i, j].imag - truth[:, i, j].imag) <= z * std_imag[:, i, j]
    return out


@dataclass(frozen=True, eq=False)
class CaseResult:
    """Errors and band hits of one case.

    Attributes
    ----------
    case : Case
    frequency : Frequency
    truth : ndarray, shape (F, 2, 2), complex
    levels : tuple of float
    errors : mapping
        Method -> relative errors, shape (levels, seeds, F, 3).
    inside : mapping
        Receptance method -> band hits (:func:`within_band`), shape (levels, seeds, 2, F, 3).
    exact : mapping
        Method -> relative errors on exact FRFs, shape (F, 3).
    example : mapping
        Method -> the result of the first realization at ``example_level``.
    example_level : float
    """

    case: Case
    frequency: Frequency
    truth: np.ndarray
    levels: tuple
    errors: Mapping[str, np.ndarray]
    inside: Mapping[str, np.ndarray]
    exact: Mapping[str, np.ndarray]
    example: Mapping[str, object]
    example_level: float

    def median(self, method: str) -> np.ndarray:
        """Median relative error per level and term, shape (levels, 3)."""
        e = self.errors[method]
        return np.median(e.reshape(e.shape[0], -1, 3), axis=1)

    def p90(self, method: str) -> np.ndarray:
        """90th-percentile relative error per level and term, shape (levels, 3)."""
        e = self.errors[method]
        return np.percentile(e.reshape(e.shape[0], -1, 3), 90, axis=1)

    def coverage(self, method: str) -> np.ndarray:
        """Band coverage per level, part (real, imaginary) and term, shape (levels, 2, 3)."""
        return self.inside[method].mean(axis=(1, 3))


def reference_level(levels) -> float:
    """The level closest to 1 % (the figures' example)."""
    return min(levels, key=lambda x: abs(np.log(x / 0.01)))


@dataclass(frozen=True, eq=False)
class Example:
    """What the report keeps of one identification: its stiffness and 1-sigma bands (None for Hong-Lee)."""

    stiffness: np.ndarray
    std_real: np.ndarray | None = None
    std_imag: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class _Part:
    """Errors of one case for some of its realizations (a task of :func:`parts`)."""

    index: int
    seeds: tuple
    frequency: Frequency
    truth: np.ndarray
    errors: Mapping[str, np.ndarray]  # method -> (levels, len(seeds), F, 3)
    inside: Mapping[str, np.ndarray]  # receptance method -> (levels, len(seeds), 2, F, 3)
    exact: Mapping[str, np.ndarray] | None  # with the first realization only
    example: Mapping[str, Example] | None


def _setup(config, case: Case):
    study = case_study(config, case)
    f = study.grid
    m = study.measurement
    cached = CachedReceptance(free_model(study), f, [*m.observed_dofs, *study.joint.joint_dofs, *m.excited_dofs])
    exact_data, truth = exact_frf(cached, true_joint(study), f, m.observed_dofs, m.excited_dofs)
    return study, cached, exact_data, truth


def run_part(config, case: Case, index: int, seeds: Sequence[int], progress: Progress | None = None) -> _Part:
    """Identify ``case`` from its noisy realizations ``seeds`` at every level (and from exact FRFs with seed 0).

    The realization ``s`` of case ``index`` draws its noise from
    ``numpy.random.default_rng([config.seed, index, s])``, whichever task runs it.
    """
    progress = progress or Progress()
    levels = tuple(config.robustness_levels)
    seeds = tuple(int(s) for s in seeds)
    study, cached, exact_data, truth = _setup(config, case)
    hl_study = case_study(config, case, method="hong-lee")
    options = method_options(study)

    paper = replace(inverse_options(hl_study), weighting="none")  # the paper's unweighted two steps

    def solve(method, frf):
        if options[method] is None:
            return identify(hl_study, frf, paper)
        return identify_joint_coupling(cached, frf, study.joint.joint_dofs, options[method])

    exact = None
    if 0 in seeds:
        exact = {k: term_errors(solve(k, exact_data).stiffness, truth) for k in METHODS}
        progress.update()
    F = study.grid.hz.size
    errors = {k: np.empty((len(levels), len(seeds), F, 3)) for k in METHODS}
    inside = {k: np.empty((len(levels), len(seeds), 2, F, 3), bool) for k in METHODS if options[k] is not None}
    ref = reference_level(levels)
    example = {} if 0 in seeds else None
    for li, level in enumerate(levels):
        for si, s in enumerate(seeds):
            noisy = add_noise(exact_data, level, np.random.default_rng([config.seed, index, s]))
            for k in METHODS:
                r = solve(k, noisy)
                errors[k][li, si] = term_errors(r.stiffness, truth)
                if k in inside:
                    inside[k][li, si] = within_band(r.stiffness, r.std_real, r.std_imag, truth)
                if level == ref and s == 0:
                    example[k] = Example(r.stiffness, *((r.std_real, r.std_imag) if r.has_uncertainty else (None, None)))
            progress.update()
    return _Part(index, seeds, study.grid, truth, errors, inside, exact, example)


def _case_result(config, case: Case, parts: Sequence[_Part]) -> CaseResult:
    """One case's result from its parts (every realization once)."""
    parts = sorted(parts, key=lambda p: p.seeds[0])
    first = parts[0]
    return CaseResult(
        case, first.frequency, first.truth, tuple(config.robustness_levels),
        {k: np.concatenate([p.errors[k] for p in parts], axis=1) for k in first.errors},
        {k: np.concatenate([p.inside[k] for p in parts], axis=1) for k in first.inside},
        first.exact, first.example, reference_level(config.robustness_levels),
    )


def run_case(config, case: Case, index: int = 0, progress: Progress | None = None) -> CaseResult:
    """Identify ``case`` from exact FRFs and from ``config.robustness_seeds`` noisy realizations per level.

    The realization ``s`` of case ``index`` draws its noise from
    ``numpy.random.default_rng([config.seed, index, s])``.
    """
    return _case_result(config, case, [run_part(config, case, index, range(config.robustness_seeds), progress)])


def parts(config) -> list:
    """The study's tasks for :func:`jointid.reproduce.runner.study_tasks`: one per case and noise realization.

    Each is ``(run_part, (config, case, index, (s,)), cost)``; the first realization of a case
    also identifies the exact FRFs. :func:`combine` assembles their results in any order.
    """
    cost = 2.0 * len(config.robustness_levels)  # about the CPU seconds: three identifications per level
    return [(run_part, (config, c, i, (s,)), cost + (1.0 if s == 0 else 0.0))
            for i, c in enumerate(cases(config)) for s in range(config.robustness_seeds)]


def combine(config, results: Sequence[_Part]) -> StudyOutput:
    """The study's output from the results of :func:`parts` (any order)."""
    todo = cases(config)
    by_case: dict = {}
    for part in results:
        by_case.setdefault(part.index, []).append(part)
    return _output(config, [_case_result(config, c, by_case[i]) for i, c in enumerate(todo)])


def run(config, progress: Progress | None = None) -> StudyOutput:
    """Run the noise-robustness study on ``config`` (a :class:`~jointid.reproduce.config.ReproduceConfig`) in this process."""
    progress = progress or Progress()
    todo = cases(config)
    levels = tuple(config.robustness_levels)
    progress.total(len(todo) * (1 + len(levels) * config.robustness_seeds))
    return _output(config, [run_case(config, c, i, progress) for i, c in enumerate(todo)])


def _output(config, results) -> StudyOutput:
    """Tables, figures, data and findings of the case results."""
    from ..plots.noise_robustness import plot_band_examples, plot_error_vs_noise

    levels = tuple(config.robustness_levels)
    ref = reference_level(levels)
    figures = []
    for mat in config.materials:
        shown = _example_cases(config, results, mat)
        if shown:
            lay = config.layouts[shown[0].case.layout].name
            figures.append((
                f"noise_robustness_bands_material_{mat.lower()}",
                plot_band_examples(
                    [(position(config, r.case.node), r.frequency.hz, r.truth, r.example) for r in shown],
                    {k: METHODS[k] for k in ("receptance", "receptance-raw", "hong-lee")}, title=f"{lay}, Material {mat}: one realization of {100 * ref:g} % FRF noise",
                ),
                f"Material {mat}, {lay}, {100 * ref:g} % noise (one realization): |K| of each term from the default receptance "
                "estimator with its 90 % band (shaded), the unweighted unsmoothed receptance formulation and plain Hong-Lee, "
                "against the true joint (dashed)",
            ))
    figures.append((
        "noise_robustness_error_vs_noise",
        plot_error_vs_noise(levels, {k: np.stack([r.median(k) for r in results]) for k in METHODS},
                            {k: METHODS[k] for k in ("receptance", "receptance-raw", "hong-lee")}, [t for t, _, _ in TERMS]),
        f"Median relative error per term vs FRF noise level, per method: median over the {len(results)} cases (line) and their "
        f"range (shaded), log axes; {_realizations(config)} per level and case",
    ))
    return StudyOutput(
        name="noise-robustness",
        title="Robustness to FRF noise",
        paragraphs=_paragraphs(config, results),
        tables=_tables(config, results),
        data=_data(config, results),
        figures=tuple(figures),
        summary=_summary(config, results),
        findings=(_findings(config, results)[0],),
    )


def _realizations(config) -> str:
    """``"1 noise realization"`` / ``"3 noise realizations"``."""
    s = config.robustness_seeds
    return f"{s} noise realization{'s' if s != 1 else ''}"


def _example_cases(config, results, material):
    """The cases of ``material`` shown in the band figure: the last layout (Model 3 by default), every joint node."""
    lay = config.robustness_layouts[-1]
    return [r for r in results if r.case.material == material and r.case.layout == lay]


def _pct(x: float) -> str:
    return f"{100 * x:.3g}"


def _tables(config, results) -> tuple[Table, ...]:
    terms = [t for t, _, _ in TERMS]
    rows = []
    for r in results:
        for li, level in enumerate(r.levels):
            for k, label in METHODS.items():
                med, p90 = r.median(k)[li], r.p90(k)[li]
                row = [r.case.label(config), f"{100 * level:g} %", label] + [f"{_pct(a)} ({_pct(b)})" for a, b in zip(med, p90)]
                if k in r.inside:
                    cov = r.coverage(k)[li]
                    row += [f"{cov[0, t]:.2f} / {cov[1, t]:.2f}" for t in range(len(TERMS))]
                else:
                    row += ["-"] * len(TERMS)
                rows.append(row)
    main = Table(
        f"Median (90th percentile) relative error in % over {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz and {config.robustness_seeds} noise "
        f"realization{'s' if config.robustness_seeds != 1 else ''}, and band coverage (fraction of lines with the truth within +-1.645 sigma: real / imaginary part; 0.90 if calibrated)",
        ["case", "noise", "method"] + [f"{t} error %" for t in terms] + [f"{t} coverage" for t in terms],
        rows,
    )
    exact_rows = [[r.case.label(config)] + [", ".join(_pct(np.median(r.exact[k][:, t])) for t in range(len(TERMS))) for k in METHODS] for r in results]
    exact = Table(
        "Exact FRFs: median relative error in % (K_ww, K_wtheta, K_thetatheta): the floor under the noise",
        ["case"] + list(METHODS.values()),
        exact_rows,
    )
    return main, exact


def _data(config, results) -> dict:
    cols: dict[str, list] = {k: [] for k in ("case", "layout", "joint_node", "material", "noise", "method")}
    for t, _, _ in TERMS:
        cols[f"{t}_median"], cols[f"{t}_p90"], cols[f"{t}_coverage_real"], cols[f"{t}_coverage_imag"] = [], [], [], []
    for r in results:
        for li, level in enumerate(r.levels):
            for k in METHODS:
                cols["case"].append(r.case.label(config))
                cols["layout"].append(r.case.layout)
                cols["joint_node"].append(r.case.node)
                cols["material"].append(r.case.material)
                cols["noise"].append(level)
                cols["method"].append(k)
                cov = r.coverage(k)[li] if k in r.inside else np.full((2, 3), np.nan)
                for t, (name, _, _) in enumerate(TERMS):
                    cols[f"{name}_median"].append(r.median(k)[li, t])
                    cols[f"{name}_p90"].append(r.p90(k)[li, t])
                    cols[f"{name}_coverage_real"].append(cov[0, t])
                    cols[f"{name}_coverage_imag"].append(cov[1, t])
    return {"noise_robustness": {k: np.asarray(v) for k, v in cols.items()}}


def _summary(config, results) -> tuple:
    """Translational-stiffness errors of the example realization (default and Hong-Lee) for the summary table."""
    out = []
    for r in results:
        if r.case.layout != config.robustness_layouts[-1]:
            continue
        for k in ("receptance", "hong-lee"):
            K = r.example[k].stiffness[:, 0, 0]
            label = f"{r.case.label(config)}, {100 * r.example_level:g}% noise, {METHODS[k]}"
            out.append((label, *band_errors(K, r.truth[:, 0, 0], r.frequency, BAND_HZ)))
    return tuple(out)


def _findings(config, results) -> tuple[str, str]:
    """(finding on errors and coverage at the reference level, finding on the ranking at every level)."""
    levels = results[0].levels
    ref = reference_level(levels)
    li = levels.index(ref)
    med = {k: np.stack([r.median(k)[li] for r in results]) for k in METHODS}  # (cases, 3)
    rng = {k: ", ".join(f"{_pct(med[k][:, t].min())}-{_pct(med[k][:, t].max())} %" for t in range(len(TERMS))) for k in METHODS}
    cov = np.stack([r.coverage("receptance")[li] for r in results])  # (cases, 2, 3)
    first = (
        f"At {100 * ref:g} % FRF noise the default receptance estimator's median errors (K_ww, K_wtheta, K_thetatheta) over the "
        f"{len(results)} cases ({_realizations(config)} each) are {rng['receptance']}, against {rng['hong-lee']} for plain Hong-Lee and {rng['receptance-raw']} for "
        f"the unweighted, unsmoothed receptance formulation; its 90 % bands hold the truth on {cov.min():.2f}-{cov.max():.2f} of the "
        "lines (per case, term and part)."
    )
    wins = sum(int(np.all(r.median("receptance") <= r.median("hong-lee"))) for r in results)
    second = (
        f"The default's median error is at or below Hong-Lee's for every term and noise level in {wins} of the {len(results)} cases."
    )
    return first, second


def _paragraphs(config, results) -> tuple[str, ...]:
    f = results[0].frequency
    levels = ", ".join(f"{100 * x:g} %" for x in results[0].levels)
    layouts = ", ".join(f"{config.layouts[k].name} (observed {', '.join(map(str, config.layouts[k].observed))}; excited "
                        f"{', '.join(map(str, config.layouts[k].excited))})" for k in config.robustness_layouts)
    setup = (
        f"Exact accelerances of the beam on the elastomer joint (Materials {', '.join(config.materials)}; joint at "
        f"{' and '.join(position(config, n) for n in config.robustness_joint_nodes)}; layouts {layouts}; no accelerometers; "
        f"{f.hz[0]:g}-{f.hz[-1]:g} Hz, {f.hz.size} lines) get complex Gaussian noise of relative rms {levels} on every FRF value, "
        f"{config.robustness_seeds} realization{'s' if config.robustness_seeds != 1 else ''} per level (the same draws for every level and method; "
        "jointid reproduce --seeds N or [noise_robustness] seeds in the reproduce configuration set more, levels the levels). Three methods identify the joint: plain "
        "Hong-Lee (method = \"hong-lee\", on the beam's grid nodes as jointid identify runs it), the default (method = "
        "\"receptance\": weighted receptance coupling, the structured joint model fitted over all lines, with 1-sigma bands) and the receptance formulation "
        "unweighted and unsmoothed. Errors are |K - K_true| / |K_true| per line; the coverage is the fraction of lines whose true "
        "real (imaginary) part lies within +-1.645 sigma of the estimate, 0.90 for calibrated 90 % bands."
    )
    hl = np.stack([np.median(r.exact["hong-lee"], axis=0) for r in results])  # (cases, 3)
    rec = max(float(np.median(r.exact[k][:, t])) for r in results for k in ("receptance", "receptance-raw") for t in range(len(TERMS)))
    floor = (
        f"On exact FRFs both receptance variants recover every term to a median relative error of {rec:.1g} or less, while Hong-Lee on the grid "
        f"model is off by {_pct(hl[:, 0].min())}-{_pct(hl[:, 0].max())} % (K_ww), {_pct(hl[:, 1].min())}-{_pct(hl[:, 1].max())} % "
        f"(K_wtheta) and {_pct(hl[:, 2].min())}-{_pct(hl[:, 2].max())} % (K_thetatheta): the grid model's discretization error, "
        "a floor under its noisy results (second table)."
    )
    return (setup, *_findings(config, results), floor)
