"""The built-in benchmark: beam, joint location, coordinates and frequency grid.

Aluminium beam, 36 in (0.9144 m) long, 0.5 in x 0.5 in (12.7 mm) square
section, E = 69 GPa, rho = 2700 kg/m^3, loss factor 0.006, nu = 0.33,
kappa = 5/6, 19 equally spaced nodes; joint at mid-span (node 10); Model 3
coordinates (observed 1, 3, 6, 9, 12, 15, 19; excited 3, 9, 15); 5-1000 Hz.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .study import Study, load_study

__all__ = ["benchmark_study", "benchmark_study_path", "benchmark_beam"]


def benchmark_study_path() -> Path:
    """Path of the packaged benchmark study file (TOML)."""
    return Path(str(resources.files("jointid") / "data" / "benchmark.toml"))


def benchmark_study() -> Study:
    """The built-in benchmark study (validated)."""
    return load_study(benchmark_study_path())


def benchmark_beam():
    """The benchmark's free-free beam as a :class:`~jointid.physics.structure.Structure`."""
    return benchmark_study().beam.structure()
