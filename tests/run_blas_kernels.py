"""Run tests under other OpenBLAS kernels and BLAS thread counts (``make test-blas``, ``make test-kernel``).

A test's tolerance must follow from an error bound, not from the bits one CPU's
BLAS kernel produced. NumPy's and SciPy's OpenBLAS (``DYNAMIC_ARCH`` builds)
choose a kernel for the CPU at load time; ``OPENBLAS_CORETYPE`` forces another
one (on x86 only), ``OPENBLAS_NUM_THREADS`` the thread count (which changes how
products are blocked and summed). For each configuration this runs pytest in a
fresh process and prints one line: the kernel asked for, the kernel OpenBLAS
reports (``threadpoolctl``; a kernel this build lacks falls back to an older
one), the threads, the result and the wall time.

Usage: ``python tests/run_blas_kernels.py --kernels Prescott Nehalem --threads 1 2 [--tests numerics|all]``
(``default`` as a kernel name: the one OpenBLAS picks for this CPU). Exit status 1
if any configuration failed.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_PROBE = (
    "import numpy, scipy.linalg, threadpoolctl\n"
    "info = [i for i in threadpoolctl.threadpool_info() if i.get('internal_api') == 'openblas']\n"
    "print(','.join(sorted({str(i.get('architecture')) for i in info})) or 'none')\n"
)


def _env(kernel: str, threads: int) -> dict:
    env = dict(os.environ)
    env.pop("OPENBLAS_CORETYPE", None)
    if kernel != "default":
        env["OPENBLAS_CORETYPE"] = kernel
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = str(threads)
    return env


def _reported_kernel(env: dict) -> str:
    out = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, cwd=ROOT)
    return out.stdout.strip() or "unknown"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kernels", nargs="+", default=["Prescott", "Nehalem", "Sandybridge"])
    ap.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--tests", default="numerics", help="'numerics' (the marked tests) or 'all' (the whole suite)")
    ap.add_argument("pytest_args", nargs="*", help="more pytest arguments (after --)")
    args = ap.parse_args(argv)
    x86 = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686", "x86")
    default_kernel = _reported_kernel(_env("default", 1))
    if default_kernel == "none":
        print("test-blas: NumPy does not use OpenBLAS here (no OpenBLAS in threadpoolctl); "
              "only the thread counts are varied", flush=True)
    kernels = []
    for k in args.kernels:
        if k != "default" and (not x86 or default_kernel == "none"):
            why = f"this machine is {platform.machine()}" if not x86 else "NumPy does not use OpenBLAS"
            print(f"test-blas: skip kernel {k}: OPENBLAS_CORETYPE selects x86 kernels of OpenBLAS and {why}", flush=True)
            continue
        kernels.append(k)
    if not kernels:
        kernels = ["default"]
    selection = [] if args.tests == "all" else ["-m", args.tests]
    print(f"test-blas: tests {args.tests!r}; this CPU's OpenBLAS kernel: {default_kernel}", flush=True)
    failed = 0
    for k in kernels:
        for t in args.threads:
            env = _env(k, t)
            got = _reported_kernel(env)
            start = time.perf_counter()
            run = subprocess.run(
                [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *selection, *args.pytest_args],
                env=env, cwd=ROOT, capture_output=True, text=True,
            )
            dt = time.perf_counter() - start
            tail = [line for line in run.stdout.splitlines() if line.strip()]
            summary = re.sub(r"=+", "", tail[-1]).strip() if tail else "no output"
            ok = run.returncode == 0
            failed += not ok
            label = f"OPENBLAS_CORETYPE={k}" if k != "default" else "default kernel"
            print(f"{label:32s} (OpenBLAS {got}), {t} BLAS thread{'s' if t > 1 else ''}: "
                  f"{'PASS' if ok else 'FAIL'} {summary} [{dt:.0f} s]", flush=True)
            if not ok:
                for line in run.stdout.splitlines():
                    if line.startswith(("FAILED", "ERROR")):
                        print(f"    {line}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
