"""A Ctrl-C before the run's signal handling (imports, the parser) is the interrupt's one line and exit 130, no traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest

import jointid.cli.main as cli_main

#: The console script (``[project.scripts] jointid = "jointid.cli.main:entry_point"``), with the import of
#: ``{module}`` by ``jointid.cli.main`` raising KeyboardInterrupt: what a Ctrl-C during that import does.
_SCRIPT = """
import builtins, sys
real_import = builtins.__import__

def interrupting_import(name, globals=None, locals=None, fromlist=(), level=0):
    if name == {module!r} and (globals or {{}}).get("__name__") == "jointid.cli.main":
        raise KeyboardInterrupt
    return real_import(name, globals, locals, fromlist, level)

builtins.__import__ = interrupting_import
sys.argv = ["jointid"] + {argv!r}
from jointid.cli.main import entry_point
sys.exit(entry_point())
"""


@pytest.mark.parametrize("module, argv, line", [
    ("argparse", ["design", "--out", "d"], "jointid design: interrupted; no partial output was written\n"),
    ("errors", ["--debug", "identify", "s.toml"], "jointid identify: interrupted; no partial output was written\n"),
    ("pathlib", ["--help"], "jointid: interrupted; no partial output was written\n"),
])
def test_interrupt_while_the_entry_module_imports_is_one_line_exit_130(tmp_path, module, argv, line):
    r = subprocess.run([sys.executable, "-c", _SCRIPT.format(module=module, argv=argv)], capture_output=True, text=True,
                       timeout=60, cwd=tmp_path)
    assert (r.returncode, r.stdout, r.stderr) == (130, "", line)
    assert list(tmp_path.iterdir()) == []


def test_the_import_hook_is_gone_once_imported_and_leaves_other_interrupts_alone(tmp_path):
    script = ("import sys\nhook = sys.excepthook\nimport jointid.cli.main\nassert sys.excepthook is hook\n"
              "raise KeyboardInterrupt\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert r.returncode != 130 and r.stderr.startswith("Traceback") and r.stderr.endswith("KeyboardInterrupt\n")


@pytest.mark.parametrize("argv, line", [
    (["design", "--out", "d"], "jointid design: interrupted; no partial output was written\n"),
    (["--version"], "jointid: interrupted; no partial output was written\n"),
])
def test_interrupt_while_the_parser_is_built_is_one_line_exit_130(monkeypatch, capsys, argv, line):
    def interrupted():  # a Ctrl-C while build_parser imports the subcommand modules
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_main, "build_parser", interrupted)
    assert cli_main.main(argv) == 130
    cap = capsys.readouterr()
    assert (cap.out, cap.err) == ("", line)


#: The console script with ``main`` replaced by a probe of what it runs under.
_PROBE = """
import os, sys
import jointid.cli.main as m

def probe(argv=None):
    print(os.environ.get("OPENBLAS_THREAD_TIMEOUT"), "numpy" in sys.modules, flush=True)
    return 0

m.main = probe
sys.argv = ["jointid", "--version"]
m.entry_point()
"""


@pytest.mark.parametrize("preset, seen", [(None, "20"), ("7", "7")])
def test_the_command_has_openblas_threads_sleep_after_2_to_the_20_cycles_unless_the_environment_says(preset, seen):
    """Set before numpy loads (OpenBLAS reads it once, then); a value of the user's is kept."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    if preset is not None:
        env["OPENBLAS_THREAD_TIMEOUT"] = preset
    r = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, timeout=60)
    assert (r.returncode, r.stdout, r.stderr) == (0, f"{seen} False\n", "")
    assert cli_main.BLAS_THREAD_TIMEOUT == "20"
