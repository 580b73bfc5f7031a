"""Benchmark the identification: whole processes, command-line start-up, and the batched paths in process.

Sections (default: ``startup process``; ``all`` adds ``in-process``)::

    python benchmarks/identify.py [startup] [process] [in-process] [--lines N] [--repeats R] [--coherence]

* ``startup``: ``jointid --help`` and ``jointid identify --help`` against ``python -c "import numpy"``
  (median of R runs each, wall and CPU), and the ratio.
* ``process``: the whole ``jointid identify`` process (default estimator with its uncertainty,
  figures, CSV and report written) on a 7 x 3 accelerance UFF of the benchmark beam with N lines
  (default 19 901: 5-1000 Hz in 0.05 Hz steps, 1 % complex noise; written by ``jointid simulate``),
  against a plain per-line ``numpy.linalg.pinv`` loop in its own process reading the same UFF with
  pyuff (19-node model, both Hong & Lee steps, result written with ``numpy.savetxt``); R interleaved
  (loop, identify) pairs: best times, wall and CPU (user + sys of the child), and the median of the pairs' ratios. Then the identify process's CPU split by
  phase (imports, UFF read, column calibration, structured fit, ..., writing), from timers wrapped
  around each phase's function (the UFF is parsed by the figure worker while the identify process
  imports: the read phase is then its check only, and the wall time it waited for the worker is shown;
  this split's process imports every phase's module first, so there it waits for the whole read).
  ``--coherence``: the file also holds coherence records (weights from coherence, its column/response
  split, the residual variance).
* ``in-process``: the batched identification paths against the loop at 1000 and 20 000 lines
  (exact data, warm-up first).

Best-of-N (or median) times, because other processes on a shared machine only ever add time.
Run: python benchmarks/identify.py
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from jointid.benchmark import benchmark_beam
from jointid.frequency import Frequency
from jointid.benchmark import benchmark_study
from jointid.frf import FRF
from jointid.methods.receptance.coupling import identify_joint_coupling
from jointid.methods.hong_lee.inverse import InverseOptions, identify_joint
from jointid.physics.joints import parametric_joint
from jointid.physics.synthesis import synthesize_frf

OBSERVED = [1, 3, 6, 9, 12, 15, 19]
EXCITED = [3, 9, 15]


def pinv_loop(beam, frf, joint_dofs, diagnostics=False):
    """Straightforward reference: one pinv per line for both steps (no scaling).

    With ``diagnostics``, also the per-line outputs the batched path returns:
    cond of A, B and the measured H (``numpy.linalg.cond``) and |Du_ii| |Ho_ii|.
    """
    dofs = beam.dofs
    pos = {d: i for i, d in enumerate(dofs)}
    n = [pos[d] for d in joint_dofs]
    m = [pos[d] for d in frf.responses]
    e = [pos[d] for d in frf.references]
    N = len(dofs)
    nbar = [i for i in range(N) if i not in n]
    mbar = [i for i in range(N) if i not in m]
    H = frf.to("receptance").data
    I = np.eye(N)
    out = np.empty((frf.frequency.size, len(n), len(n)), complex)
    for k, f in enumerate(frf.frequency.hz):
        Do = beam.dynamic_stiffness(np.array([f]))[0]
        Hfull = np.zeros((N, len(e)), complex)
        Hfull[m] = H[k]
        rhs = I[np.ix_(nbar, e)] - Do[np.ix_(nbar, m)] @ H[k]
        Hfull[mbar] = np.linalg.pinv(Do[np.ix_(nbar, mbar)]) @ rhs
        C = I[np.ix_(n, e)] - Do[n, :] @ Hfull
        out[k] = C @ np.linalg.pinv(Hfull[n])
        if diagnostics:
            np.linalg.cond(Do[np.ix_(nbar, mbar)]), np.linalg.cond(Hfull[n]), np.linalg.cond(H[k])
            np.abs(np.diag(out[k])) * np.abs(np.diag(np.linalg.inv(Do)[np.ix_(n, n)]))
    return out


def _best(fn, repeats):
    """Smallest wall time of ``repeats`` calls (s) and the last result."""
    best, out = float("inf"), None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


_LOOP = {}


def t_loop_first(lines, beam, frf, jd):
    """The pinv loop's time at this size (measured once)."""
    if lines not in _LOOP:
        _LOOP[lines] = _best(lambda: pinv_loop(beam, frf, jd), 2)[0]
    return _LOOP[lines]


def in_process() -> None:
    """The batched paths against the per-line loop, in this process (1000 and 20 000 lines)."""
    beam = benchmark_beam()
    joint = parametric_joint(10, 2e5, 60.0, 1.5e3, 0.12, growth=0.5, reference_frequency=100, exponent=0.5)
    jd = joint.dofs
    warm = Frequency(np.linspace(5, 1000, 1000))  # first-call costs (imports, thread pool) out of the timings
    identify_joint(beam, synthesize_frf(beam.with_joint(joint), warm, [f"{n}w" for n in OBSERVED], [f"{n}w" for n in EXCITED]), jd)
    for lines in (1000, 20000):
        freq = Frequency(np.linspace(5, 1000, lines))
        frf = synthesize_frf(beam.with_joint(joint), freq, [f"{n}w" for n in OBSERVED], [f"{n}w" for n in EXCITED], kind="accelerance")
        K = joint(freq.hz)
        t_qr, r = _best(lambda: identify_joint(beam, frf, jd), 3)
        t_svd, r_svd = _best(lambda: identify_joint(beam, frf, jd, InverseOptions(estimation="svd")), 2)
        t_loop, ref = _best(lambda: pinv_loop(beam, frf, jd), 1)
        _LOOP[lines] = min(_LOOP.get(lines, np.inf), t_loop)
        t_diag, _ = _best(lambda: pinv_loop(beam, frf, jd, diagnostics=True), 1)
        e_qr = (np.abs(r.stiffness - K) / np.abs(K)).max()
        e_svd = (np.abs(r_svd.stiffness - K) / np.abs(K)).max()
        e_loop = (np.abs(ref - K) / np.abs(K)).max()
        refined = benchmark_study().beam.structure(1000.0)  # the default method's converged free model (8x mesh)
        rng = np.random.default_rng(0)
        noisy = FRF(freq, frf.data * (1 + 0.01 * (rng.standard_normal(frf.shape) + 1j * rng.standard_normal(frf.shape)) / np.sqrt(2)),
                    frf.responses, frf.references, frf.kind)
        t_rc, r_rc = _best(lambda: identify_joint_coupling(refined, noisy, jd), 5)
        print(f"{lines:6d} lines (best of 5/3/2/1/1 runs):")
        print(f"    receptance method (jointid default: weighted, smoothed, with uncertainty, 290-DOF free model) "
              f"{t_rc:6.3f} s   {t_loop_first(lines, beam, frf, jd) / t_rc:5.1f}x vs pinv loop (19-node model)")
        print(f"    batched, QR estimation (default), with diagnostics {t_qr:6.3f} s   "
              f"{t_loop / t_qr:5.1f}x vs pinv loop   max rel. error {e_qr:.1e}")
        print(f"        cond_A from {int(np.sum(r.cond_A_bound == 0))} SVD lines, certified within "
              f"{r.cond_A_bound.max():.1e} (relative) on the others")
        print(f"    batched, SVD estimation, with diagnostics          {t_svd:6.3f} s   "
              f"{t_loop / t_svd:5.1f}x vs pinv loop   max rel. error {e_svd:.1e}")
        print(f"    pinv loop                                          {t_loop:6.3f} s                       max rel. error {e_loop:.1e}")
        print(f"    pinv loop with the same diagnostics                {t_diag:6.3f} s   (QR path {t_diag / t_qr:4.1f}x faster)")


#: Environment of the timed processes. Bytecode is cached (in a directory of this run, not in the source tree):
#: an installed package has its modules compiled, and a shell that sets PYTHONDONTWRITEBYTECODE would otherwise
#: charge every run the compilation of each jointid module it imports (~0.15 s for identify, less for the loop).
_ENV: dict | None = None


def _child_env(pycache: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(pycache)
    return env


def _run(argv: list[str], env: dict | None = None) -> tuple[float, float, str]:
    """Wall and CPU (user + sys) seconds of one child process (and of the processes it waited for), and its stdout; fails loudly."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run(argv, capture_output=True, text=True, env=env if env is not None else _ENV)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({r.returncode}): {r.stderr.strip()}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), r.stdout


def _jointid() -> str:
    return str(Path(sys.executable).with_name("jointid"))


def startup(repeats: int) -> None:
    """``jointid --help`` and ``jointid identify --help`` against ``python -c "import numpy"``."""
    cases = {
        'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
        "jointid --help": [_jointid(), "--help"],
        "jointid identify --help": [_jointid(), "identify", "--help"],
    }
    times = {name: [_run(argv) for _ in range(repeats)] for name, argv in cases.items()}
    base_wall = statistics.median(t[0] for t in times['python -c "import numpy"'])
    base_cpu = statistics.median(t[1] for t in times['python -c "import numpy"'])
    print(f"start-up (median of {repeats} runs; wall / CPU):")
    for name, runs in times.items():
        wall, cpu = statistics.median(t[0] for t in runs), statistics.median(t[1] for t in runs)
        print(f"    {name:28s} {wall:6.3f} s / {cpu:6.3f} s   {wall / base_wall:4.1f}x / {cpu / base_cpu:4.1f}x import numpy")


def study_text(lines: int) -> str:
    """The benchmark study with ``lines`` lines over 5-1000 Hz."""
    from jointid.benchmark import benchmark_study_path

    text = Path(benchmark_study_path()).read_text()
    step = (1000.0 - 5.0) / (lines - 1)
    out = [f"step = {step!r}" if line.startswith("step =") else line for line in text.splitlines()]
    assert any(line.startswith("step =") for line in text.splitlines())
    return "\n".join(out) + "\n"


LOOP_SCRIPT = """
import numpy as np
import pyuff
from jointid.study import load_study
from jointid.frequency import Frequency
from jointid.frf import FRF
from jointid.dofs import Dof

study = load_study({study!r})
sets = [s for s in pyuff.UFF({uff!r}).read_sets() if s["type"] == 58 and s["func_type"] == 4]
rsp = sorted({{s["rsp_node"] for s in sets}})
ref = sorted({{s["ref_node"] for s in sets}})
f = sets[0]["x"]
H = np.empty((f.size, len(rsp), len(ref)), complex)
for s in sets:
    H[:, rsp.index(s["rsp_node"]), ref.index(s["ref_node"])] = s["data"]
frf = FRF(Frequency(f), H, [Dof(n, "w") for n in rsp], [Dof(n, "w") for n in ref], "accelerance")
{pinv_loop}
K = pinv_loop(study.beam.structure(), frf, study.joint.joint_dofs)
np.savetxt({out!r}, np.column_stack([f, K.reshape(f.size, -1).real, K.reshape(f.size, -1).imag]), delimiter=",")
"""


def _with_coherence(uff: Path, out: Path) -> Path:
    """``uff`` with coherence records: the H1 coherence of 1e-4..2e-4 force noise per column and a response noise
    floor per channel (the split's model, :mod:`jointid.methods.receptance.frf_variance`), scattered as from 10 averages."""
    from jointid.io.uff import read_uff_frf, write_uff_frf

    frf = read_uff_frf(uff)
    H = frf.data
    rng = np.random.default_rng(0)
    a = 1e-4 * (1 + rng.random(H.shape[2]))
    s = 1e-3 * (1 + rng.random(H.shape[1])) * np.median(np.abs(H)) ** 2
    q = (a[None, None, :] + s[None, :, None] / np.abs(H) ** 2) * rng.chisquare(10, size=H.shape) / 10
    write_uff_frf(out, frf, kind="accelerance", coherence=1.0 / (1.0 + q))
    return out


def process(lines: int, repeats: int, coherence: bool = False) -> None:
    """The whole ``jointid identify`` process against a whole per-line pinv-loop process on the same UFF."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        study = tmp / "study.toml"
        study.write_text(study_text(lines))
        _run([_jointid(), "simulate", str(study), "--noise", "0.01", "--out", str(tmp / "sim")])
        uff = tmp / "sim" / "frf.uff"
        if coherence:
            uff = _with_coherence(uff, tmp / "frf_coherence.uff")
        import inspect

        script = LOOP_SCRIPT.format(pinv_loop=inspect.getsource(pinv_loop), study=str(study), uff=str(uff), out=str(tmp / "loop.csv"))
        loop = [sys.executable, "-c", script]  # imports numpy, pyuff and jointid's study and beam model only
        ident = [_jointid(), "identify", str(study), "--frf", str(uff), "--out", str(tmp / "id")]
        global _ENV
        _ENV = _child_env(tmp / "pycache")
        _run(loop), _run(ident)  # warm-up: bytecode cached, files in the page cache (not timed)
        # interleaved (loop, identify) pairs: a shared machine's speed drifts by 20-30 % over minutes, and the ratio of
        # two runs next to each other drifts far less than the ratio of two blocks of runs
        pairs = [(_run(loop), _run(ident)) for _ in range(repeats)]
        t_loop, t_id = [p[0] for p in pairs], [p[1] for p in pairs]
        wall_l, cpu_l = min(t[0] for t in t_loop), min(t[1] for t in t_loop)
        wall_i, cpu_i = min(t[0] for t in t_id), min(t[1] for t in t_id)
        wall_r = statistics.median(i[0] / lp[0] for lp, i in pairs)
        cpu_r = statistics.median(i[1] / lp[1] for lp, i in pairs)
        n = t_id[0][2].split(" lines (")[0].rsplit(" ", 1)[-1]
        what = " and coherences" if coherence else ""
        print(f"whole process, {n} lines, 7 x 3 accelerances{what}, {uff.stat().st_size / 1e6:.1f} MB ASCII UFF "
              f"(best of {repeats}, run in interleaved pairs; wall / CPU):")
        print(f"    per-line pinv loop (pyuff read, 19-node model, savetxt)   {wall_l:6.2f} s / {cpu_l:6.2f} s")
        print(f"    jointid identify (default estimator, uncertainty, outputs) {wall_i:6.2f} s / {cpu_i:6.2f} s")
        print(f"    ratio identify / loop, median of the {repeats} pairs: {wall_r:.2f} wall / {cpu_r:.2f} CPU "
              f"(best / best: {wall_i / wall_l:.2f} / {cpu_i / cpu_l:.2f})")
        _split(ident[1:], tmp)


#: Phases of the identify process: (label, module, function or Class.method); indented labels run inside the one above.
PHASES = (
    ("read the UFF (read_measured; read by the worker)", "jointid.pipeline", "read_measured"),
    ("identification (pipeline.identify)", "jointid.pipeline", "identify"),
    ("  column calibration", "jointid.methods.receptance.column_calibration", "estimate_column_calibration"),
    ("  FRF variance", "jointid.methods.receptance.frf_variance", "frf_variance"),
    ("  coherence split", "jointid.methods.receptance.frf_variance", "column_noise_fraction"),
    ("  residual variance", "jointid.methods.receptance.column_calibration", "residual_variance"),
    ("  per-line fit", "jointid.methods.receptance.coupling_lines", "coupling_per_line"),
    ("  structured fit", "jointid.methods.receptance.structured_select", "structured_estimate"),
    ("  smoothing", "jointid.methods.receptance.smoothing", "smooth_series"),
    ("  junk lines (residual test)", "jointid.methods.receptance.junk_lines", "junk_lines"),
    ("  residual statistics (junk test; model check reuses)", "jointid.methods.receptance.model_check", "residual_statistics"),
    ("figure data (JointStiffnessData.of)", "jointid.plots.stiffness_data", "JointStiffnessData.of"),
    ("CSV (OutputSet.write_csv)", "jointid.io.output_dir", "OutputSet.write_csv"),
    ("report.html", "jointid.report.identification", "identification_report"),
    ("commit (OutputSet.commit)", "jointid.io.output_dir", "OutputSet.commit"),
)

SPLIT_SCRIPT = """
import importlib, json, sys, time
t0 = time.process_time()
from jointid.cli.main import main
PHASES = {phases!r}
for _, module, _ in PHASES:
    importlib.import_module(module)
preimport = time.process_time() - t0
spent = {{}}

def timed(f, label):
    def wrapper(*args, **kwargs):
        t = time.process_time()
        try:
            return f(*args, **kwargs)
        finally:
            spent[label] = spent.get(label, 0.0) + time.process_time() - t
    return wrapper

for label, module, name in PHASES:
    mod = sys.modules[module]
    if "." in name:
        cls, meth = name.split(".")
        setattr(getattr(mod, cls), meth, timed(getattr(getattr(mod, cls), meth), label))
        continue
    f = getattr(mod, name)
    w = timed(f, label)
    for m in list(sys.modules.values()):  # every module that imported the function by name
        if getattr(m, "__name__", "").startswith("jointid"):
            for k, v in list(vars(m).items()):
                if v is f:
                    setattr(m, k, w)
import resource
from jointid.plots.figure_worker import FigureWorker, PendingFigure
waited = [0.0]
waited_frf = [0.0]
_result = PendingFigure.result
_first = FigureWorker.first

def first(self):  # wall-clock time this process waits for the worker's read of the UFF (after its imports)
    t = time.perf_counter()
    try:
        return _first(self)
    finally:
        waited_frf[0] += time.perf_counter() - t

FigureWorker.first = first

def result(self):  # wall-clock time this process waits for the worker's PNG (no CPU: not in the phases)
    t = time.perf_counter()
    try:
        return _result(self)
    finally:
        waited[0] += time.perf_counter() - t

PendingFigure.result = result
t1 = time.process_time()
rc = main({argv!r})
total = time.process_time() - t1
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({{"rc": rc, "preimport": preimport, "run": total, "spent": spent, "modules": sorted(sys.modules),
                  "worker": kids.ru_utime + kids.ru_stime, "waited": waited[0], "waited_frf": waited_frf[0]}}))
"""


def _split(argv: list[str], tmp: Path) -> None:
    """CPU seconds by phase of one ``jointid identify`` process (timers wrapped around the phases' functions)."""
    import json

    _, _, out = _run([sys.executable, "-c", SPLIT_SCRIPT.format(phases=PHASES, argv=argv)])
    report = json.loads(out.strip().splitlines()[-1])
    mods = [m for m in report["modules"] if not m.startswith("__") and m != "jointid.cli.main"]
    _, bare, _ = _run([sys.executable, "-c", "pass"])
    _, imports, _ = _run([sys.executable, "-c", "import importlib\nfor m in %r:\n    try: importlib.import_module(m)\n    except Exception: pass" % mods])
    print("    identify process CPU by phase (one run; timers around each phase's function):")
    print(f"        {'python start-up':36s} {bare:6.2f} s")
    print(f"        {'imports (every module the run loads)':36s} {imports - bare:6.2f} s")
    print(f"        {'run (after the imports of jointid.cli, pipeline, methods)':36s} {report['run']:6.2f} s, of which:")
    for label, _, _ in PHASES:
        print(f"          {label:34s} {report['spent'].get(label, 0.0):6.2f} s")
    print(f"        {'figure worker (second process: UFF read, matplotlib import, figure, PNG)':36s} {report['worker']:6.2f} s")
    print(f"        {'wall time this process waited for the UFF the worker reads':36s} {report['waited_frf']:6.2f} s")
    print(f"        {'wall time this process waited for the PNG (after its CSV)':36s} {report['waited']:6.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", default=["startup", "process"], choices=["startup", "process", "in-process", "all"])
    parser.add_argument("--lines", type=int, default=19901)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--coherence", action="store_true", help="the UFF also holds coherence records (the coherence weighting path)")
    args = parser.parse_args()
    sections = {"startup", "process", "in-process"} if "all" in args.sections else set(args.sections)
    if "startup" in sections:
        startup(max(args.repeats, 5))
    if "process" in sections:
        process(args.lines, args.repeats, args.coherence)
    if "in-process" in sections:
        in_process()


if __name__ == "__main__":
    main()
