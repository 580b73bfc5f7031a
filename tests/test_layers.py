"""Layering: no module under ``src/jointid`` imports a module of a higher layer.

Every ``import`` / ``from ... import`` statement of every module is read with :mod:`ast`
(module level, inside functions and methods, under ``if TYPE_CHECKING:`` alike: a lazy
import is still a dependency), resolved to an absolute ``jointid.*`` name and ranked.

Layers, bottom-up (a module may import its own layer and any lower one):

0. labels, axes and helpers: ``dofs``, ``frequency``, ``frf``, ``terms``, ``errors``, ``_lazy``,
   ``parallel``, and the file formats of those objects in ``io`` (UFF, CSV, matrices,
   atomic writes, output directories);
1. ``physics`` (elements, structures, the elastomer joint FE model, modes, synthesis);
2. ``measurement`` (impact and step-sine signal processing and their record files, virtual tests);
3. ``methods`` (inverse, direct material fit, updating, design);
4. the application: ``study``, ``benchmark``,
   ``pipeline``, ``models``, ``design``, ``hits``, ``reproduce``, ``report`` and ``plots``;
5. ``cli``; the package ``jointid/__init__.py`` re-exports every layer by name (lazily,
   no import statement), so it is the top.

The one exception: figures. A function or method whose name starts with ``plot`` may
import ``jointid.plots`` (e.g. ``FRF.plot()`` draws itself), so results of any layer can
be plotted without the lower layer depending on matplotlib or on ``plots`` at import time.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import jointid

SRC = Path(jointid.__file__).resolve().parent

#: Module or package prefix (relative to ``jointid``) -> layer rank; the longest prefix wins.
RANKS = {
    "dofs": 0,
    "frequency": 0,
    "frf": 0,
    "errors": 0,
    "_lazy": 0,
    "parallel": 0,
    "schema": 0,
    "terms": 0,
    "io": 0,
    "physics": 1,
    "measurement": 2,
    "methods": 3,
    "study": 4,
    "benchmark": 4,
    "pipeline": 4,
    "models": 4,
    "design": 4,
    "hits": 4,
    "reproduce": 4,
    "report": 4,
    "plots": 4,
    "campaign": 4,
    "cli": 5,
    "": 6,
}


def rank(module: str) -> int:
    """Layer rank of ``jointid.<...>`` (longest matching prefix of :data:`RANKS`).

    ``"jointid:__version__"`` (a name of the package itself, not a module) is metadata:
    the package ``__init__`` imports nothing eagerly, so its dunder names are layer 0.
    """
    module, _, name = module.partition(":")
    if name.startswith("__"):
        return 0
    parts = module.split(".")[1:]  # drop "jointid"
    for n in range(len(parts), -1, -1):
        key = ".".join(parts[:n])
        if key in RANKS:
            return RANKS[key]
    raise AssertionError(f"no layer for {module}")  # pragma: no cover


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), path))
    return out


MODULES = _modules()


def imports(module: str, path: Path) -> list[tuple[int, str, str | None]]:
    """``(line, imported jointid module, enclosing function name or None)`` for every import."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: list[tuple[int, str, str | None]] = []

    def visit(node: ast.AST, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            if not isinstance(child, (ast.stmt, ast.excepthandler, ast.match_case)):  # an expression holds no import
                continue
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(child, child.name)
                continue
            if isinstance(child, ast.Import):
                found.extend((child.lineno, a.name, function) for a in child.names if a.name.split(".")[0] == "jointid")
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")
                    base = base[: len(base) - (child.level - 1)]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module or ""
                if target.split(".")[0] != "jointid":
                    continue
                if child.module is None:  # from . import x, y: a submodule, or a name of the package
                    for a in child.names:
                        sub = SRC.parent.joinpath(*target.split("."), a.name)
                        is_module = sub.is_dir() or sub.with_suffix(".py").is_file()
                        found.append((child.lineno, f"{target}.{a.name}" if is_module else f"{target}:{a.name}", function))
                else:
                    found.append((child.lineno, target, function))
            visit(child, function)

    visit(tree, None)
    return found


def violations(module: str, path: Path) -> list[str]:
    """One line per import of a higher layer in ``module`` (outside the ``plot*`` exception)."""
    own = rank(module)
    out = []
    for line, target, function in imports(module, path):
        if rank(target) <= own:
            continue
        if target.startswith("jointid.plots") and function is not None and function.startswith("plot"):
            continue
        out.append(f"{path.relative_to(SRC.parent)}:{line}: {module} (layer {own}) imports {target} (layer {rank(target)})")
    return out


def test_every_module_has_a_layer():
    assert len(MODULES) > 50
    for module, _ in MODULES:
        rank(module)


@pytest.mark.parametrize("module,path", MODULES, ids=[m for m, _ in MODULES])
def test_no_lower_layer_imports_a_higher_one(module, path):
    assert violations(module, path) == []


def test_checker_sees_lazy_relative_and_plot_imports(tmp_path, monkeypatch):
    """The checker itself: a lazy relative import of a higher layer is caught; ``plot*`` may import plots."""
    monkeypatch.setitem(globals(), "SRC", tmp_path / "jointid")
    src = tmp_path / "jointid" / "physics"
    src.mkdir(parents=True)
    (tmp_path / "jointid" / "reproduce").mkdir()
    (src / "x.py").write_text(
        "from ..dofs import Dof\n"
        "def f():\n    from ..methods.hong_lee.inverse import identify_joint\n"
        "class A:\n    def plot(self):\n        from ..plots.frf import plot_frf\n"
        "    def table(self):\n        from .. import reproduce\n"
        "from .. import __version__\n"
    )
    assert imports("jointid.physics.x", src / "x.py") == [
        (1, "jointid.dofs", None),
        (3, "jointid.methods.hong_lee.inverse", "f"),
        (6, "jointid.plots.frf", "plot"),
        (8, "jointid.reproduce", "table"),
        (9, "jointid:__version__", None),
    ]
    assert violations("jointid.physics.x", src / "x.py") == [
        "jointid/physics/x.py:3: jointid.physics.x (layer 1) imports jointid.methods.hong_lee.inverse (layer 3)",
        "jointid/physics/x.py:8: jointid.physics.x (layer 1) imports jointid.reproduce (layer 4)",
    ]


def test_no_module_over_600_lines():
    long = {m: n for m, p in MODULES if (n := len(p.read_text(encoding="utf-8").splitlines())) > 600}
    assert long == {}
