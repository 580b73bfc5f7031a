"""Lazy re-exports for package ``__init__`` files (PEP 562 module ``__getattr__``).

A package's public face lists its main classes and functions in ``__all__`` while
importing nothing until a name is first used, so ``import jointid`` stays fast
(numpy, scipy and matplotlib load only with the module that needs them) and a
package ``__init__`` never creates an import cycle between layers.

Usage in ``pkg/__init__.py``::

    __getattr__, __dir__, __all__ = attach(__name__, {".modes": ("natural_modes", "Modes")})
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, Sequence

__all__ = ["attach"]


def attach(
    package: str,
    exports: Mapping[str, Sequence[str]],
    submodules: Sequence[str] = (),
) -> tuple[Callable[[str], object], Callable[[], list[str]], list[str]]:
    """``__getattr__``, ``__dir__`` and ``__all__`` of a package with lazy re-exports.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to sequence of str
        Module (relative to ``package``, e.g. ``".modes"``) -> names re-exported from it.
        A name is imported from its module on first access, then cached in the package.
    submodules : sequence of str
        Subpackages/modules reachable as attributes (``jointid.physics``) without an
        explicit import; not part of ``__all__``.

    Returns
    -------
    __getattr__, __dir__ : callables
    __all__ : list of str
        Every re-exported name, in the order given.
    """
    where: dict[str, str] = {}
    for module, names in exports.items():
        for name in names:
            if name in where:
                raise ValueError(f"{package}: {name!r} re-exported from both {where[name]} and {module}")
            where[name] = module
    subs = frozenset(submodules)

    def __getattr__(name: str) -> object:
        if name in where:
            value = getattr(importlib.import_module(where[name], package), name)
        elif name in subs:
            value = importlib.import_module(f".{name}", package)
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where) | subs)

    return __getattr__, __dir__, list(where)
