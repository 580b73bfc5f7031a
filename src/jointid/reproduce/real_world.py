"""Study -- honest in the real world: flags and bands under model error, junk lines and a 6-DOF mount.

On the configuration's beam (joint at ``config.joint_node``, Material A, the Model 3 layout,
the benchmark's accelerometers) with 0.5 % complex relative noise on every FRF value
(:data:`NOISE`), the default estimator (``jointid.pipeline.identify``) is run on data it did
not make, as a user would:

* ``off``: the study's free model is off (:data:`NOMINAL_ERROR`: E +2 %, density -1 %, loss
  factor +2 %) against the true beam, whose mesh is also finer (``[truth]``,
  :data:`TRUE_MESH` elements per segment); identified with the nominal model;
* ``updated``: the same FRFs, identified after updating the model from a virtual free-free
  test of the true beam (``simulate_free`` with :data:`FREE_TEST_NOISE`, then ``update``);
* ``junk``: a study from 0 Hz whose first :data:`JUNK_LINES` lines (1-4 Hz on a 1 Hz grid) are
  junk: coherence :data:`JUNK_COHERENCE` and :data:`JUNK_NOISE` relative noise; every other
  line carries the coherence of its 0.5 % noise;
* ``mount``: a grounded 6-DOF mount on a Craig-Bampton model of a 3-D steel frame (the case
  of ``benchmarks/mount_6dof.py``: power-law modulus, loss factor per direction, 9 x 9
  translational FRFs at three grids, 1 % noise, 2-150 Hz every :data:`MOUNT_STEP_HZ` Hz),
  identified with ``smoothing = "spline"``; one realization.

Per case and term: the fraction of lines flagged reliable, the median relative error
``|K - K_true| / |K_true|`` on those lines, the coverage of their 90 % bands (real and
imaginary parts pooled) and the fraction of them off by more than 3 sigma; and the
estimate's findings (gist). The beam cases run ``config.robustness_seeds`` noise
realizations (``--seeds N``); the figures are medians over them. Every task seeds its noise
from ``config.seed``, the case and the realization: the numbers do not depend on the
number of processes.
"""

from __future__ import annotations

import re
import warnings
from collections import Counter
from dataclasses import fields, replace

import numpy as np

from ..frequency import Frequency
from ..frf import FRF
from ..report.html import Table
from ..terms import Z90
from .common import SUMMARY_BAND_HZ, Progress, StudyOutput, add_noise, band_errors, config_study

__all__ = [
    "run", "parts", "combine", "run_case", "CASES", "NOISE", "NOMINAL_ERROR", "FREE_TEST_NOISE", "TRUE_MESH",
    "JUNK_LINES", "JUNK_COHERENCE", "JUNK_NOISE", "beam_study", "off_study", "term_figures", "mount_case",
]

#: About the CPU seconds of one beam case (``jointid reproduce`` starts the longest tasks first).
COST = 3.5
#: Case key -> label in the report.
CASES = {
    "off": "free model off, not updated",
    "updated": "free model updated from a free-free test",
    "junk": "junk lines at 1-4 Hz",
    "mount": "6-DOF mount, Craig-Bampton frame",
}
#: Relative complex noise rms on every FRF value of the beam cases.
NOISE = 0.005
#: The study's free model against the true beam: parameter -> factor on the true value.
NOMINAL_ERROR = {"elastic_modulus": 1.02, "density": 0.99, "loss_factor": 1.02}
#: Elements per beam segment of the true beam: twice the model's (its mesh converged at 1000 Hz: 8), so the true
#: structure is the finer of the two.
TRUE_MESH = 16
#: Relative complex noise rms of the virtual free-free test.
FREE_TEST_NOISE = 0.01
#: Lowest line of the model cases, Hz (the benchmark's band starts there).
MODEL_START_HZ = 5.0
#: Junk lines: how many (the first lines of a grid from one step), their coherence and relative noise.
JUNK_LINES, JUNK_COHERENCE, JUNK_NOISE = 4, 0.2, 2.0
#: Line spacing of the mount case, Hz.
MOUNT_STEP_HZ = 2.0
#: Figure columns per term: reliable fraction, median error on reliable lines, band coverage, beyond 3 sigma.
FIGURES = ("reliable", "error", "coverage", "beyond_3_sigma")
_KEYS = tuple(CASES)
_TERM_FINDING = re.compile(r"^(K_\w+): (.*)$", re.S)
_PARENTHESES = re.compile(r" ?\([^()]*\)")
_WHERE = re.compile(r" (in|on) (\S+ )?(\d|every|scattered).*$")


def _rng(config, case: str, realization: int) -> np.random.Generator:
    """The noise of ``case`` (``off`` and ``updated`` share their FRFs) and ``realization``, from the config's seed."""
    key = _KEYS.index("off" if case == "updated" else case)
    return np.random.default_rng([config.seed, 26, key, realization])


def beam_study(config, start: float, source: str = "real-world study"):
    """The configuration's beam study (Model 3 layout, Material A, the benchmark's accelerometers) from ``start`` Hz."""
    from ..study import AccelerometerSpec, FrequencySpec, IdentificationSpec

    lay = config.layouts["model_3"]
    acc = AccelerometerSpec(config.accelerometer_mass, config.accelerometer_rotary_inertia, tuple(lay.observed))
    return config_study(config, config.joint_node, "A", lay.observed, lay.excited, FrequencySpec(start, config.stop, config.step),
                        IdentificationSpec(model_accelerometers=True), accelerometers=acc, source=source)


def off_study(config):
    """:func:`beam_study` from :data:`MODEL_START_HZ` with the model off by :data:`NOMINAL_ERROR`; its ``[truth]``
    is the configuration's beam on :data:`TRUE_MESH` elements per segment (finer than the model's)."""
    from ..study import TruthSpec

    st = beam_study(config, max(config.start, MODEL_START_HZ))
    b = st.structure
    true = {k: float(getattr(b, k)) for k in NOMINAL_ERROR}
    model = replace(b, **{k: v * NOMINAL_ERROR[k] for k, v in true.items()})
    return replace(st, structure=model, truth=TruthSpec(**true, elements_per_segment=TRUE_MESH))


def _updated(study, values: dict, uncertainty: dict | None = None):
    """``study`` with the updated parameter ``values`` (``jointid update``'s names) in its beam and accelerometers, and
    the fit's standard errors and correlation (:meth:`UpdateResult.uncertainty`) as its ``[uncertainty]``."""
    from ..study import UncertaintySpec

    beam = {f.name for f in fields(study.structure)}
    st = replace(study, structure=replace(study.structure, **{k: v for k, v in values.items() if k in beam}))
    if uncertainty:
        std = {k: v for k, v in uncertainty.items() if k != "correlation"}
        corr = uncertainty.get("correlation")
        st = replace(st, uncertainty=UncertaintySpec(std, None if corr is None else tuple(tuple(r) for r in corr)))
    acc = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("accelerometers.")}
    if st.accelerometers is not None and acc:
        st = replace(st, accelerometers=replace(st.accelerometers, **acc))
    return st


def _noisy(frf: FRF, rng: np.random.Generator, coherence: bool = False) -> FRF:
    """``frf`` with :data:`NOISE` (:func:`~jointid.reproduce.common.add_noise`), with the coherence of that noise if asked."""
    out = add_noise(frf, NOISE, rng)
    return replace(out, coherence=np.full(frf.data.shape, 1.0 / (1.0 + NOISE ** 2))) if coherence else out


def term_figures(stiffness, std_real, std_imag, reliable, truth, terms) -> np.ndarray:
    """Per term of ``terms`` (``(i, j)`` pairs): the columns of :data:`FIGURES`, shape (T, 4).

    Error, coverage and the 3-sigma fraction are over the lines flagged reliable (NaN when none is).
    """
    i, j = np.asarray(terms).T
    k, t = stiffness[:, i, j], truth[:, i, j]
    ok = reliable[:, i, j]
    d = k - t
    err = np.abs(d) / np.abs(t)
    sr, si = std_real[:, i, j], std_imag[:, i, j]
    inside = 0.5 * ((np.abs(d.real) <= Z90 * sr).astype(float) + (np.abs(d.imag) <= Z90 * si))
    beyond = (np.abs(d.real) > 3.0 * sr) | (np.abs(d.imag) > 3.0 * si)
    n = ok.sum(axis=0)
    with np.errstate(invalid="ignore"):
        med = np.array([np.median(err[ok[:, c], c]) if n[c] else np.nan for c in range(len(n))])
        cov = np.where(n > 0, (inside * ok).sum(axis=0) / np.maximum(n, 1), np.nan)
        far = np.where(n > 0, (beyond & ok).sum(axis=0) / np.maximum(n, 1), np.nan)
    return np.stack([ok.mean(axis=0), med, cov, far], axis=-1)


def _beam_terms(result) -> tuple[list[str], list[tuple[int, int]]]:
    """Names and indices of the upper-triangle terms of a beam joint estimate."""
    names = [(a, b, name) for a, b, name in result.term_names() if a <= b]
    return [n for _, _, n in names], [(a, b) for a, b, _ in names]


def _result(case: str, realization: int, est, truth: np.ndarray, names=None, terms=None, extra=None) -> dict:
    """What a task hands to :func:`combine` (picklable): figures per term, findings, K_ww summary, per-line columns."""
    if names is None:
        names, terms = _beam_terms(est)
    fig = term_figures(est.stiffness, est.std_real, est.std_imag, est.reliable_terms, truth, terms)
    f = est.frequency
    cols = {"frequency_hz": f.hz}
    for name, (a, b) in zip(names, terms):
        cols[f"{name}_error"] = np.abs(est.stiffness[:, a, b] - truth[:, a, b]) / np.abs(truth[:, a, b])
        cols[f"{name}_reliable"] = est.reliable_terms[:, a, b].astype(float)
    band = f.mask(*SUMMARY_BAND_HZ)
    summary = band_errors(est.stiffness[:, 0, 0], truth[:, 0, 0], f) if case != "mount" and band.any() else None
    return {"case": case, "realization": realization, "terms": tuple(names), "figures": fig, "findings": tuple(est.findings()),
            "summary": summary, "columns": cols, **(extra or {})}


def _on_lines(truth: np.ndarray, data_hz: np.ndarray, est) -> np.ndarray:
    """``truth`` (on the data's lines) on the estimate's lines."""
    return truth[np.isin(data_hz, est.frequency.hz)]


def run_case(config, case: str, realization: int = 0) -> dict:
    """One task: case ``case`` of :data:`CASES` with noise realization ``realization``; a dict for :func:`combine`."""
    from ..pipeline import identify, simulate, simulate_free, update

    if case == "mount":
        return mount_case(config, realization)
    if case in ("off", "updated"):
        study = off_study(config)
        test = simulate(study.true_study())
        frf = _noisy(test.frf, _rng(config, case, realization))
        extra = {}
        if case == "updated":
            seed = int(np.random.default_rng([config.seed, 26, 99, realization]).integers(2 ** 31))
            up = update(study, simulate_free(study, noise=FREE_TEST_NOISE, seed=seed))
            true = {k: float(getattr(study.true_study().structure, k)) for k in NOMINAL_ERROR}
            extra = {"parameter_error": {k: up.values[k] / v - 1.0 for k, v in true.items()}, "update_finding": up.finding}
            study = _updated(study, up.values, up.uncertainty())
        est = identify(study, frf)
        return _result(case, realization, est, _on_lines(test.truth, test.frf.frequency.hz, est), extra=extra)
    # junk: a study from 0 Hz; data from one step (the 0 Hz line is not identified), the first lines junk
    study = beam_study(config, 0.0)
    test = simulate(study, Frequency.from_range(config.step, config.stop, config.step))
    rng = _rng(config, case, realization)
    frf = _noisy(test.frf, rng, coherence=True)
    data, coh = frf.data.copy(), frf.coherence.copy()
    bad = slice(0, JUNK_LINES)
    z = (rng.standard_normal(data[bad].shape) + 1j * rng.standard_normal(data[bad].shape)) / np.sqrt(2.0)
    data[bad], coh[bad] = test.frf.data[bad] * (1.0 + JUNK_NOISE * z), JUNK_COHERENCE
    est = identify(study, replace(frf, data=data, coherence=coh))
    return _result(case, realization, est, _on_lines(test.truth, test.frf.frequency.hz, est))


# --------------------------------------------------------------------------- the 6-DOF mount
_COMP = ("x", "y", "z", "rx", "ry", "rz")
_MOUNT_GRID, _MEASURED_GRIDS = 1, (3, 5, 10)
_K0_DIAGONAL = (3e6, 2e6, 4e6, 8e3, 6e3, 5e3)  # N/m, N*m/rad
_K0_COUPLINGS = (("x", "ry", 2e4), ("y", "rx", -1.5e4), ("x", "y", 4e5))
_ALPHA, _F_REF, _ETA_TRANSLATION, _ETA_ROTATION = 0.15, 50.0, 0.08, 0.2
#: Relative complex noise rms of the mount case.
MOUNT_NOISE = 0.01


def _mount_stiffness(f_hz) -> np.ndarray:
    """The mount's true K(f), shape (F, 6, 6): power-law modulus, loss factor per direction."""
    K0 = np.diag(np.asarray(_K0_DIAGONAL, float))
    for a, b, v in _K0_COUPLINGS:
        K0[_COMP.index(a), _COMP.index(b)] = K0[_COMP.index(b), _COMP.index(a)] = v
    eta = np.where(np.arange(6) < 3, _ETA_TRANSLATION, _ETA_ROTATION)
    f = np.atleast_1d(np.asarray(f_hz, float))
    return (f / _F_REF)[:, None, None] ** _ALPHA * (K0 * (1.0 + 0.5j * (eta[:, None] + eta[None, :])))


def _mount_model():
    """(free Craig-Bampton model, joint DOFs, measured DOFs) of the steel frame with the mount at grid 1."""
    from ..physics import FrameSection, Material, build_frame

    steel = Material(210e9, 7850.0, loss_factor=0.002, poisson_ratio=0.3)
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.8, 0.0, 0.0), 3: (0.8, 0.5, 0.0), 4: (0.0, 0.5, 0.0), 5: (0.8, 0.0, 0.3)}
    tube, box = FrameSection.circle(0.04, 0.032), FrameSection.rectangle(0.03, 0.05)
    members = [(1, 2, tube, steel, 4), (2, 3, box, steel, 4), (3, 4, tube, steel, 4), (4, 1, box, steel, 4), (2, 5, tube, steel, 2)]
    fm = build_frame(nodes, members)
    joint = tuple(f"{_MOUNT_GRID}{c}" for c in _COMP)
    measured = tuple(f"{g}{c}" for g in _MEASURED_GRIDS for c in ("x", "y", "z"))
    return _craig_bampton_dense(fm, joint + measured, 2000.0, 0.002).free_model(), joint, measured


def _craig_bampton_dense(fm, boundary, cutoff_hz: float, loss_factor: float):
    """:func:`jointid.physics.reduction.craig_bampton` of a small model with dense LAPACK eigenvectors.

    The same reduction (constraint modes, then the fixed-interface modes below ``cutoff_hz``); dense
    ``eigh`` with each mode's sign fixed makes the model the same bits in every process (ARPACK's
    random start depends on the calls before it in the process).
    """
    from scipy.linalg import eigh, solve

    from ..dofs import COMPONENT_CODES, DofArray
    from ..physics.reduction import CraigBamptonModel

    dofs = fm.dofs if isinstance(fm.dofs, DofArray) else DofArray.from_dofs(fm.dofs)
    M, K = np.asarray(fm.mass.toarray(), float), np.asarray(fm.stiffness.toarray(), float)
    b = dofs.indices(boundary, "model")
    i = np.setdiff1d(np.arange(len(dofs)), b)
    Psi = -solve(K[np.ix_(i, i)], K[np.ix_(i, b)], assume_a="sym")
    lam, Phi = eigh(K[np.ix_(i, i)], M[np.ix_(i, i)])  # mass-normalized
    keep = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi) < cutoff_hz
    lam, Phi = lam[keep], Phi[:, keep]
    Phi = Phi * np.sign(Phi[np.abs(Phi).argmax(axis=0), np.arange(lam.size)])
    T = np.block([[np.eye(b.size), np.zeros((b.size, lam.size))], [Psi, Phi]])
    order = np.concatenate([b, i])
    Kr, Mr = T.T @ K[np.ix_(order, order)] @ T, T.T @ M[np.ix_(order, order)] @ T
    Kr, Mr = 0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T)
    Kr[b.size:, b.size:], Mr[b.size:, b.size:] = np.diag(lam), np.eye(lam.size)
    Kr[:b.size, b.size:] = Kr[b.size:, :b.size] = 0.0
    ids = 1995001 + np.arange(lam.size)
    out = DofArray(np.concatenate([dofs.node[b], ids]), np.concatenate([dofs.code[b], np.full(lam.size, COMPONENT_CODES["s"])]))
    return CraigBamptonModel(Mr, Kr, out, np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi), float(loss_factor))


def mount_case(config, realization: int = 0) -> dict:
    """The 6-DOF mount case: one noisy 9 x 9 receptance, ``smoothing = "spline"``; figures per diagonal term."""
    from ..methods.receptance.coupling import CouplingOptions, identify_joint_coupling
    from ..physics.jointed_model import JointedModel
    from ..physics.structure import ComplexStiffness

    free, joint, measured = _mount_model()
    freq = Frequency.from_range(2.0, 150.0, MOUNT_STEP_HZ)
    mount = ComplexStiffness(joint, _mount_stiffness, "mount")
    exact = FRF(freq, JointedModel(free, [mount]).receptance(freq, measured, measured), measured, measured, "receptance")
    frf = add_noise(exact, MOUNT_NOISE, _rng(config, "mount", realization))
    est = identify_joint_coupling(free, frf, joint, CouplingOptions(smoothing="spline"))
    truth = _mount_stiffness(est.frequency.hz)
    return _result("mount", realization, est, truth, [f"K_{c}_{c}" for c in _COMP], [(d, d) for d in range(6)])


# --------------------------------------------------------------------------- tasks and output
def _tasks(config) -> list[tuple[str, int]]:
    return [(c, s) for c in ("off", "updated", "junk") for s in range(config.robustness_seeds)] + [("mount", 0)]


def parts(config) -> list:
    """The study's tasks for :func:`jointid.reproduce.runner.study_tasks`: one per beam case and realization, one mount."""
    return [(run_case, (config, c, s), COST + (1.0 if c == "off" else 0.0)) for c, s in _tasks(config)]


def run(config, progress: Progress | None = None) -> StudyOutput:
    """Run the real-world study on ``config`` in this process."""
    progress = progress or Progress()
    todo = _tasks(config)
    progress.total(len(todo))
    results = []
    for c, s in todo:
        results.append(run_case(config, c, s))
        progress.update()
    return combine(config, results)


def _first_words(text: str) -> str:
    """A finding's gist: without its parentheses, up to its first semicolon, at most 140 characters."""
    while True:
        short = _PARENTHESES.sub("", text)
        if short == text:
            break
        text = short
    short = text.split("; ")[0].strip()
    return short if len(short) <= 140 else short[:137].rstrip() + "..."


def _finding_counts(results) -> list[tuple[str, int]]:
    """The findings of ``results`` (gist) with the number of realizations that said each, most said first.

    A finding about one term (``"K_x_y: not identifiable ... in 2-20 Hz (..."``) is counted with the others of
    the same words, its term names listed: ``"K_x_y, K_x_z: not identifiable from these FRFs"``.
    """
    said, terms = Counter(), {}
    for r in results:
        seen = {}  # ordered: the report does not depend on string hashing
        for f in r["findings"]:
            m = _TERM_FINDING.match(f)
            key = _first_words(f) if m is None else _WHERE.sub("", _first_words(m.group(2)))
            if m is not None:
                terms.setdefault(key, []).append(m.group(1))
            seen[key] = None
        said.update(list(seen))
    out = []
    for key, n in said.most_common():
        names = list(dict.fromkeys(terms.get(key, ())))
        out.append((f"{', '.join(names)}: {key}" if names else key, n))
    return out


def _pct(x: float) -> str:
    """A fraction as a percentage for the table ("-" when NaN)."""
    return "-" if not np.isfinite(x) else f"{100 * x:.3g} %"


def combine(config, results) -> StudyOutput:
    """The study's output from the results of :func:`parts` (any order)."""
    from ..plots.real_world import plot_case_terms
    from ..plots.style import new_figure

    by_case: dict = {}
    for r in sorted(results, key=lambda r: (_KEYS.index(r["case"]), r["realization"])):
        by_case.setdefault(r["case"], []).append(r)
    rows, found_rows, groups, data, summary, stats = [], [], [], {}, [], {}
    for case, rs in by_case.items():
        figs = np.stack([r["figures"] for r in rs])  # (realizations, terms, 4)
        with warnings.catch_warnings():  # a term no realization flagged reliable: NaN, no warning
            warnings.simplefilter("ignore", RuntimeWarning)
            med = np.nanmedian(figs, axis=0)
        stats[case] = dict(zip(rs[0]["terms"], med))
        for name, (rel, err, cov, far) in zip(rs[0]["terms"], med):
            rows.append([CASES[case], name, _pct(rel), _pct(err), _pct(cov), _pct(far)])
        groups.append((CASES[case], rs[0]["terms"], med))
        text = "; ".join(f"{t} [{n}/{len(rs)}]" for t, n in _finding_counts(rs)) or "none"
        found_rows.append([CASES[case], str(len(rs)), text])
        data[f"real_world_{case}"] = rs[0]["columns"]
        if rs[0]["summary"] is not None:
            summary.append((CASES[case], *np.median([r["summary"] for r in rs], axis=0)))
    fig, axes = new_figure(1, 3, figsize=(15.0, 5.0), sharex=False)
    plot_case_terms(groups, 0, ylabel="lines flagged reliable [%]", scale=100.0, ax=axes[0])
    plot_case_terms(groups, 1, ylabel="median error on reliable lines [%]", scale=100.0, log=True, legend=False, ax=axes[1])
    plot_case_terms(groups, 2, ylabel="90 % band coverage on reliable lines [%]", scale=100.0, reference=90.0, legend=False, ax=axes[2])
    findings, paragraphs = _findings(config, by_case, stats)
    seeds = config.robustness_seeds
    table = Table(
        f"Per case and term: lines flagged reliable, the median relative error |K - K_true| / |K_true| on them, their 90 % "
        f"band coverage (real and imaginary parts) and the fraction of them beyond 3 sigma; medians over {seeds} noise "
        f"realization{'s' if seeds != 1 else ''} (the mount: one)",
        ["case", "term", "reliable", "median error (reliable)", "90 % coverage (reliable)", "beyond 3 sigma"], rows)
    found = Table("The estimate's findings per case (gist) [realizations that said it / realizations]",
                  ["case", "realizations", "findings"], found_rows)
    return StudyOutput(
        name="real-world",
        title="Honest in the real world: model error, junk lines, a 6-DOF mount",
        paragraphs=paragraphs,
        tables=(table, found),
        data=data,
        figures=(("real_world", fig, "Per case and term: lines flagged reliable (left), the median error on them (middle) and "
                  "the coverage of their 90 % bands (right, 90 % dashed); no bar in the middle and right panels: no line flagged reliable"),),
        summary=tuple(summary),
        findings=findings,
    )


def _findings(config, by_case: dict, stats: dict) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Summary sentences and paragraphs, computed from the results."""
    def terms_text(case: str) -> str:
        return ", ".join(f"{t} {100 * v[0]:.0f} % reliable" + (f" ({100 * v[1]:.2g} % error, coverage {100 * v[2]:.0f} %)"
                                                               if np.isfinite(v[1]) else "") for t, v in stats[case].items())

    def said(case: str, words: str) -> str:
        hits = [f for r in by_case.get(case, []) for f in r["findings"] if words in f]
        if not hits:
            return ""
        gist = _first_words(hits[0])  # the model check's fix can follow its first clause: kept
        return gist + (": update it from a free-free test" if "update it from a free-free test" in hits[0] and "update it" not in gist else "")

    off = "E +2 %, density -1 %, loss factor +2 %"
    out = []
    if "off" in by_case:
        check = said("off", "free model does not explain")
        out.append(f"With the free model off ({off}) and a finer true mesh: {terms_text('off')}; "
                   + (f"the model check says \"{check}\"." if check else "the model check says nothing."))
    if "updated" in by_case:
        pe = by_case["updated"][0].get("parameter_error", {})
        errs = ", ".join(f"{k.replace('_', ' ')} {100 * v:+.2g} %" for k, v in pe.items())
        check = said("updated", "does not explain")
        carried = said("updated", "is in the bands")
        out.append(f"Updated from a virtual free-free test ({100 * FREE_TEST_NOISE:g} % noise; left {errs}), its standard errors "
                   f"and correlation as [uncertainty]: {terms_text('updated')}"
                   + (f"; the model check still says \"{check}\"" if check else "; the model check is silent")
                   + (f"; \"{carried}\"." if carried else "."))
    if "junk" in by_case:
        junk = said("junk", "junk")
        out.append(f"Junk lines ({JUNK_LINES} lines at coherence {JUNK_COHERENCE:g} at the bottom of a band from 0 Hz): "
                   f"{terms_text('junk')}; " + (f"\"{junk}\"." if junk else "no finding names them."))
    if "mount" in by_case:
        out.append(f"6-DOF mount ({100 * MOUNT_NOISE:g} % noise, smoothing = \"spline\", one realization): {terms_text('mount')}.")
    intro = (f"The default estimator on data it did not make: the beam with {100 * NOISE:g} % complex FRF noise (Model 3, "
             f"Material A, joint at node {config.joint_node}), identified with a free model that is off, after updating it, "
             "and with junk lines; and a grounded 6-DOF mount on a Craig-Bampton frame. A term is honest when its reliable "
             "lines have the truth inside their 90 % bands on about 90 % of them, or it is not flagged reliable and a finding "
             "says why.")
    return tuple(out), (intro, *out)
