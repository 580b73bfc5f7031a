"""jointid.cli: the ``jointid`` command, one module per subcommand, thin over the Python API.

The entry point is ``jointid.cli.main.main(argv) -> int`` (0 ok, 2 bad input, 3 internal
error); it is not re-exported here because its name is also that of its module
(``jointid.cli.main``), which the import system binds on the package. Re-exported
(imported on first use): ``build_parser`` (the argparse parser with every subcommand)
and ``COMMANDS`` (subcommand modules in help order)::

    from jointid.cli.main import main
    main(["modes", "--out", "modes"])
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {".main": ("build_parser", "COMMANDS")},
    submodules=("main", "common", "design", "direct", "experiment", "frf", "identify", "modes", "reproduce", "simulate"),
)
