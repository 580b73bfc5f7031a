"""The command line starts fast: building the parser and ``--help`` import no heavy module.

A timing would be noisy on a shared machine; what makes ``jointid --help`` slow is
*which* modules it imports (scipy.stats, matplotlib and the methods took ~2 s), so the
test checks ``sys.modules`` in a fresh interpreter. Each subcommand imports its heavy
dependencies inside ``run()``; ``benchmarks/identify.py`` prints the time ratio.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from jointid.cli.main import COMMANDS

#: Top-level packages and jointid modules the parser must not import (they load with a command's ``run``).
HEAVY = ("scipy", "matplotlib", "pyuff", "pyyeti", "pyarrow", "dask", "jointid.methods", "jointid.physics",
         "jointid.measurement", "jointid.pipeline", "jointid.plots", "jointid.report", "jointid.reproduce.runner")
#: Pure-Python modules under a heavy package that the parser may import (names for ``--help``).
ALLOWED = ("jointid.methods", "jointid.methods.updating", "jointid.methods.updating.parameters")

_PROBE = """
import json, sys
from jointid.cli.main import main
try:
    main({argv!r})
except SystemExit as exc:
    code = exc.code
else:
    code = None
print(json.dumps({{"code": code, "modules": sorted(sys.modules)}}))
"""


def _heavy_modules_after(argv: list[str]) -> tuple[int | None, list[str], str]:
    """Run ``jointid ARGV`` in a fresh interpreter; its exit code, the heavy modules it imported, its stdout."""
    r = subprocess.run([sys.executable, "-c", _PROBE.format(argv=argv)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    *text, last = r.stdout.strip().splitlines()
    report = json.loads(last)
    heavy = [m for m in report["modules"] if m not in ALLOWED and any(m == h or m.startswith(h + ".") for h in HEAVY)]
    return report["code"], heavy, "\n".join(text)


def test_help_imports_no_heavy_module():
    code, heavy, text = _heavy_modules_after(["--help"])
    assert code == 0
    assert "identify" in text and "reproduce" in text  # the help lists the subcommands
    assert heavy == []


@pytest.mark.parametrize("command", COMMANDS)
def test_subcommand_help_imports_no_heavy_module(command):
    code, heavy, text = _heavy_modules_after([command, "--help"])
    assert code == 0
    assert f"jointid {command}" in text
    assert heavy == []


def test_the_probe_sees_a_command_s_imports(tmp_path):
    """The check can fail: running a command loads its heavy modules, and the probe lists them."""
    code, heavy, text = _heavy_modules_after(["modes", "--out", str(tmp_path), "--no-plots"])
    assert code is None  # main returned (0) rather than exiting
    assert "jointid.physics.modes" in heavy and "scipy" in heavy
    assert (tmp_path / "modes.csv").is_file()
