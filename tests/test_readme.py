"""Every ```python block of README.md runs as pasted.

Each block runs in a fresh directory (its own namespace) after every ``jointid ...``
command of the ```bash blocks above it in the README, run there in the same order, as
a reader following the README from the repository root would; a file of the repository
a command names (``src/jointid/data/benchmark.toml``) is copied into the directory.
Commands other than ``jointid`` must be listed in ``NOT_RUN`` with the reason.

A failure names the block number, its README line and first line, and the README line
that raised (the code is compiled with README.md line numbers).
"""

from __future__ import annotations

import re
import shlex
import shutil
import traceback
from dataclasses import dataclass
from pathlib import Path

import pytest

from jointid.cli.main import main as jointid_main

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"

#: Shell commands of the README not run here, with the reason.
NOT_RUN = {
    "make run": "sets up .venv and runs `jointid reproduce` (tested in test_reproduce_runner.py)",
    "make test": "sets up .venv and runs this suite",
    "make test-blas": "runs the numerics tests under other OpenBLAS kernels (tests/run_blas_kernels.py, not from inside the suite)",
    "make test-kernel": "runs the numerics tests under one other OpenBLAS kernel (CI runs it after make test)",
}

_FENCE = re.compile(r"^```(\w*)\s*$")


@dataclass(frozen=True)
class Block:
    """A fenced code block of README.md: language, 1-based line of its first code line, code."""

    lang: str
    line: int
    code: str

    @property
    def first_line(self) -> str:
        return next((s.strip() for s in self.code.splitlines() if s.strip()), "")


def readme_blocks(text: str) -> list[Block]:
    """Fenced blocks of ``text`` in order (an unclosed fence is an error)."""
    blocks, lang, start, body = [], None, 0, []
    for n, line in enumerate(text.splitlines(), 1):
        m = _FENCE.match(line)
        if lang is None and m:
            lang, start, body = m.group(1), n + 1, []
        elif lang is not None and line.strip() == "```":
            blocks.append(Block(lang, start, "\n".join(body) + "\n"))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"README.md line {start - 1}: ``` fence never closed"
    return blocks


def shell_commands(block: Block) -> list[tuple[int, list[str]]]:
    """(README line, argv) of each command of a bash block; ``a && b`` gives two."""
    out = []
    for k, line in enumerate(block.code.splitlines()):
        words = shlex.split(line, comments=True)
        cmd: list[str] = []
        for w in words + ["&&"]:
            if w == "&&":
                if cmd:
                    out.append((block.line + k, cmd))
                cmd = []
            else:
                cmd.append(w)
    return out


BLOCKS = readme_blocks(README.read_text(encoding="utf-8"))
PYTHON = [(i, b) for i, b in enumerate((b for b in BLOCKS if b.lang == "python"), 1)]


def commands_before(block: Block) -> list[tuple[int, list[str]]]:
    """The ``jointid`` commands of the bash blocks above ``block``, in README order."""
    cmds = []
    for b in BLOCKS:
        if b.line >= block.line:
            break
        if b.lang in ("bash", "sh", "shell", "console"):
            for line, argv in shell_commands(b):
                text = " ".join(argv)
                if argv[0] == "jointid":
                    cmds.append((line, argv))
                else:
                    assert text in NOT_RUN, (
                        f"README.md line {line}: `{text}` is neither a jointid command nor listed in "
                        f"NOT_RUN of {Path(__file__).name}; run it in the test or list it with the reason"
                    )
    return cmds


def run_command(directory: Path, line: int, argv: list[str], capsys) -> None:
    """Run ``jointid argv[1:]`` in ``directory`` (repository files it names copied in first)."""
    for arg in argv[1:]:
        src = REPO / arg
        if not arg.startswith("-") and not (directory / arg).exists() and src.is_file():
            (directory / arg).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, directory / arg)
    try:
        code = jointid_main(argv[1:])
    except SystemExit as exc:  # argparse: bad usage
        code = exc.code
    captured = capsys.readouterr()
    assert code == 0, f"README.md line {line}: `{shlex.join(argv)}` exited {code}: {captured.err.strip()}"


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    """``prepared(cmds, capsys)`` -> a directory where ``cmds`` ran (cached per command list)."""
    cache: dict[tuple, Path] = {}

    def get(cmds, capsys, monkeypatch) -> Path:
        key = tuple((line, tuple(argv)) for line, argv in cmds)
        if key not in cache:
            d = tmp_path_factory.mktemp("readme_commands")
            monkeypatch.chdir(d)
            for line, argv in cmds:
                run_command(d, line, argv, capsys)
            cache[key] = d
        return cache[key]

    return get


def test_readme_has_python_blocks():
    assert len(PYTHON) >= 3, "README.md should show the Python API (inverse, direct)"


@pytest.mark.parametrize("number,block", PYTHON, ids=[f"block{i}-line{b.line}" for i, b in PYTHON])
def test_python_block_runs(number, block, prepared, tmp_path, monkeypatch, capsys):
    commands = commands_before(block)
    shutil.copytree(prepared(commands, capsys, monkeypatch), tmp_path, dirs_exist_ok=True)
    monkeypatch.chdir(tmp_path)
    # README line numbers in tracebacks: pad the code to its line in README.md
    code = compile("\n" * (block.line - 1) + block.code, str(README), "exec")
    message = None
    try:
        exec(code, {"__name__": f"readme_block_{number}"})
    except Exception as exc:
        where = [f for f in traceback.extract_tb(exc.__traceback__) if f.filename == str(README)]
        at = f" at README.md line {where[-1].lineno}: `{where[-1].line}`" if where else ""
        ran = "; ".join(shlex.join(argv) for _, argv in commands) or "no command"
        message = (
            f"README.md python block {number} (line {block.line}: `{block.first_line}`) failed{at}: "
            f"{type(exc).__name__}: {exc} [after: {ran}]"
        )
    if message:
        pytest.fail(message, pytrace=False)


def test_block_parser_reports_lines():
    text = "intro\n```bash\njointid simulate --out sim && jointid modes --out m  # two\nmake run\n```\n```python\nx = 1\n```\n"
    blocks = readme_blocks(text)
    assert [(b.lang, b.line) for b in blocks] == [("bash", 3), ("python", 7)]
    assert shell_commands(blocks[0]) == [
        (3, ["jointid", "simulate", "--out", "sim"]),
        (3, ["jointid", "modes", "--out", "m"]),
        (4, ["make", "run"]),
    ]
    assert blocks[1].first_line == "x = 1"
