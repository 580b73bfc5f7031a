"""Configuration of ``jointid reproduce``: the built-in benchmark, overridable from TOML.

.. code-block:: toml

    seed = 0
    [frequency]            # grid of the inverse studies, Hz
    start = 1.0
    stop = 1000.0
    step = 1.0
    [layouts.model_1]      # coordinate layouts (beam nodes, transverse w)
    observed = [5, 15]
    excited = [5, 15]
    [materials.A]          # elastomer materials (Pa, -, kg/m^3): ElastomerMaterial
    elastic_modulus = 15e6
    loss_factor = 0.10
    density = 1200.0
    [noise]
    conditioning = 0.005   # relative noise rms on the FRFs of the conditioning study
    experiment = 0.01      # force and response noise of the virtual roving-hammer test
    [noise_robustness]     # the noise-robustness study
    levels = [0.003, 0.01, 0.03]   # relative complex noise rms on every exact FRF value
    seeds = 1              # noise realizations per level and case (`jointid reproduce --seeds N` overrides)
    layouts = ["model_2", "model_3"]
    joint_nodes = [10, 1]  # joint positions (beam nodes): mid-span, beam end
    [accelerometers]
    mass = 0.005           # kg
    rotary_inertia = 2e-7  # kg*m^2
    [direct]               # step-sine tests of the direct characterization
    start = 25.0
    stop = 600.0
    step = 25.0
    amplitude_pp = 5e-5    # m, peak-to-peak
    parallel_joints = 2
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from ..benchmark import benchmark_study
from ..errors import StudyError
from ..frequency import Frequency
from .. import schema
from ..schema import Field, table, typed
from ..study import BeamSpec

if TYPE_CHECKING:
    from ..physics.elastomer_joint import ElastomerMaterial

__all__ = ["Layout", "ReproduceConfig", "load_config", "STUDY_NAMES"]

#: Study names in report order (``--only`` takes a comma-separated subset).
STUDY_NAMES = ("direct", "conditioning", "verification", "model-error", "accelerometers", "experiment", "noise-robustness", "real-world")


@dataclass(frozen=True)
class Layout:
    """A coordinate layout: observed and excited beam nodes (transverse w)."""

    name: str
    observed: tuple[int, ...]
    excited: tuple[int, ...]


def _default_layouts() -> dict[str, Layout]:
    return {
        "model_1": Layout("Model 1", (5, 15), (5, 15)),
        "model_2": Layout("Model 2", (3, 7, 13, 17), (3, 7, 13, 17)),
        "model_3": Layout("Model 3", (1, 3, 6, 9, 12, 15, 19), (3, 9, 15)),
    }


def _default_materials() -> dict[str, "ElastomerMaterial"]:
    """The built-in elastomers, :data:`jointid.physics.elastomer_joint.MATERIALS` (imported on use)."""
    from ..physics.elastomer_joint import MATERIALS

    return dict(MATERIALS)


@dataclass(frozen=True)
class ReproduceConfig:
    """Everything ``jointid reproduce`` varies; the defaults are the built-in benchmark."""

    beam: BeamSpec = field(default_factory=lambda: benchmark_study().beam)
    joint_node: int = 10
    start: float = 1.0
    stop: float = 1000.0
    step: float = 1.0
    layouts: Mapping[str, Layout] = field(default_factory=_default_layouts)
    materials: Mapping[str, "ElastomerMaterial"] = field(default_factory=_default_materials)
    conditioning_noise: float = 0.005
    experiment_noise: float = 0.01
    robustness_levels: tuple[float, ...] = (0.003, 0.01, 0.03)
    robustness_seeds: int = 1  # the quick default; --seeds N / [noise_robustness] seeds for firmer statistics
    robustness_layouts: tuple[str, ...] = ("model_2", "model_3")
    robustness_joint_nodes: tuple[int, ...] = (10, 1)
    accelerometer_mass: float = 0.005
    accelerometer_rotary_inertia: float = 2e-7
    direct_start: float = 25.0
    direct_stop: float = 600.0
    direct_step: float = 25.0
    direct_amplitude_pp: float = 5e-5
    parallel_joints: int = 2
    seed: int = 0

    @property
    def grid(self) -> Frequency:
        """Frequency grid of the inverse studies, Hz."""
        return Frequency.from_range(self.start, self.stop, self.step)

    @property
    def joint_dofs(self):
        """Joint coordinates (node w, node theta)."""
        from ..dofs import Dof

        return (Dof(self.joint_node, "w"), Dof(self.joint_node, "theta"))


def _number(positive: bool = True, unit: str = "", bounds: tuple[float, float] | None = None) -> Field:
    """A positive (or non-negative) number; one message for a wrong type and a wrong sign; ``bounds``: the
    physical range the study files use too (:mod:`jointid.schema`), checked when the config is read."""
    if positive:
        return Field("number", check=schema.positive, expected="a positive number", unit=unit, bounds=bounds)
    return Field("number", check=schema.nonneg, expected="a non-negative number", unit=unit, bounds=bounds)


def _given(data: Mapping[str, Any], name: str, fields: Mapping[str, Field]) -> dict[str, Any]:
    """The keys of table ``[name]`` that ``data`` gives, typed (:func:`jointid.schema.section`)."""
    values = schema.section(data, name, fields, listing="")
    return {k: v for k, v in values.items() if k in data}


_FREQUENCY = {k: _number() for k in ("start", "stop", "step")}  # start > 0: the free beam is singular at 0 Hz
_MATERIAL = {"elastic_modulus": _number(unit="Pa", bounds=schema.MODULUS),
             "loss_factor": _number(positive=False, bounds=schema.LOSS_FACTOR),
             "density": _number(unit="kg/m^3", bounds=schema.DENSITY)}
_NOISE = {k: _number(positive=False) for k in ("conditioning", "experiment")}
_ACCELEROMETERS = {k: _number(positive=False) for k in ("mass", "rotary_inertia")}
_DIRECT = {
    **{k: _number() for k in ("start", "stop", "step", "amplitude_pp")},
    "parallel_joints": Field("int", check=lambda v: None if v >= 1 else "out of range", expected="an integer >= 1"),
}
_SEED = Field("int", check=lambda v: None if v >= 0 else "out of range", expected="an integer >= 0")


def _nodes(n_nodes: int) -> Field:
    """A non-empty list of beam nodes 1..n_nodes, each once."""
    return Field("int_list", check=lambda v: None if v and all(1 <= x <= n_nodes for x in v) else "out of range",
                 expected=f"a non-empty list of beam nodes 1..{n_nodes}")


def load_config(path: str | os.PathLike | None = None, seed: int | None = None, seeds: int | None = None) -> ReproduceConfig:
    """The benchmark configuration, overridden by the TOML file at ``path`` (keys as in the module doc).

    ``seed`` (``--seed``) and ``seeds`` (``--seeds``: noise realizations per level and case of the
    noise-robustness study) override the file's.

    Raises
    ------
    StudyError
        Naming the key that is unknown or invalid.
    """
    cfg = ReproduceConfig()
    if path is not None:
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except OSError as exc:
            raise StudyError(f"{p}: cannot read the configuration ({exc.strerror or exc})") from None
        except tomllib.TOMLDecodeError as exc:
            raise StudyError(f"{p}: not valid TOML ({exc})") from None
        try:
            cfg = _apply(cfg, data)
        except StudyError as exc:
            raise StudyError(f"{p}: {exc}") from None
    if seed is not None:
        if seed < 0:
            raise StudyError(f"--seed: expected an integer >= 0, got {seed}")
        cfg = replace(cfg, seed=int(seed))
    if seeds is not None:
        if seeds < 1:
            raise StudyError(f"--seeds: expected an integer >= 1, got {seeds}")
        cfg = replace(cfg, robustness_seeds=int(seeds))
    return cfg


def _apply(cfg: ReproduceConfig, data: Mapping[str, Any]) -> ReproduceConfig:
    allowed = {"seed", "frequency", "layouts", "materials", "noise", "noise_robustness", "accelerometers", "direct"}
    for key in data:
        if key not in allowed:
            raise StudyError(f"unknown key {key!r}; expected one of: {', '.join(sorted(allowed))}")
        if key != "seed":
            table(f"[{key}]", data[key])
    for key in ("layouts", "materials"):
        for name, value in data.get(key, {}).items():
            table(f"[{key}.{name}]", value)
    changes: dict[str, Any] = {}
    if "seed" in data:
        changes["seed"] = typed(None, "seed", _SEED, data["seed"])
    changes.update(_given(data.get("frequency", {}), "frequency", _FREQUENCY))
    if changes.get("start", cfg.start) >= changes.get("stop", cfg.stop):
        raise StudyError("[frequency]: start must be below stop")
    n_nodes = cfg.beam.nodes
    if "layouts" in data:
        layouts = dict(cfg.layouts)
        fields = {"observed": _nodes(n_nodes), "excited": _nodes(n_nodes)}
        for name, lay in data["layouts"].items():
            base = layouts.get(name, Layout(name.replace("_", " ").title(), (), ()))
            given = _given(lay, f"layouts.{name}", fields)
            new = {k: given.get(k, getattr(base, k)) for k in fields}
            for k, v in new.items():
                if not v:  # a new layout must give both lists
                    typed(f"layouts.{name}", k, fields[k], [])
            layouts[name] = Layout(base.name, new["observed"], new["excited"])
        changes["layouts"] = layouts
    if "materials" in data:
        mats = dict(cfg.materials)
        for name, m in data["materials"].items():
            base = mats.get(name)
            vals = _given(m, f"materials.{name}", _MATERIAL)
            if base is None and len(vals) < 3:
                raise StudyError(f"[materials.{name}]: a new material needs elastic_modulus, loss_factor and density")
            if base is None:
                from ..physics.elastomer_material import ElastomerMaterial

                mats[name] = ElastomerMaterial(**vals)  # values checked above: no ModelError left
            else:
                mats[name] = replace(base, **vals)
        changes["materials"] = mats
    changes.update({f"{k}_noise": v for k, v in _given(data.get("noise", {}), "noise", _NOISE).items()})
    changes.update(_robustness(data.get("noise_robustness", {}), changes.get("layouts", cfg.layouts), n_nodes))
    acc = _given(data.get("accelerometers", {}), "accelerometers", _ACCELEROMETERS)
    changes.update({f"accelerometer_{k}": v for k, v in acc.items()})
    direct = _given(data.get("direct", {}), "direct", _DIRECT)
    changes.update({k if k == "parallel_joints" else f"direct_{k}": v for k, v in direct.items()})
    if changes.get("direct_start", cfg.direct_start) >= changes.get("direct_stop", cfg.direct_stop):
        raise StudyError("[direct]: start must be below stop")
    return replace(cfg, **changes)


def _robustness(section: Mapping[str, Any], layouts: Mapping[str, Layout], n_nodes: int) -> dict[str, Any]:
    """The ``[noise_robustness]`` keys as ReproduceConfig changes."""
    names = ", ".join(layouts)
    fields = {
        "levels": Field("number_list", check=lambda v: None if v else "empty",
                        expected="a non-empty list of positive numbers (relative noise rms)", bounds=(0.0, 1.0)),
        "seeds": Field("int", check=lambda v: None if v >= 1 else "out of range", expected="an integer >= 1"),
        "layouts": Field("str_list", check=lambda v: None if v and all(x in layouts for x in v) else "out of range",
                         expected=f"a non-empty list of layout names out of {names}"),
        "joint_nodes": _nodes(n_nodes),
    }
    given = _given(section, "noise_robustness", fields)
    keys = {"levels": "robustness_levels", "seeds": "robustness_seeds", "layouts": "robustness_layouts",
            "joint_nodes": "robustness_joint_nodes"}
    changes = {keys[k]: v for k, v in given.items()}
    if "robustness_levels" in changes:
        level = _number()
        changes["robustness_levels"] = tuple(sorted(typed("noise_robustness", "levels", level, x) for x in changes["robustness_levels"]))
    return changes
