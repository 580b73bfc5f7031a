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
    seeds = 3              # noise realizations per level and case
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

import math
import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from ..benchmark import benchmark_study
from ..errors import StudyError
from ..frequency import Frequency
from ..study import BeamSpec

if TYPE_CHECKING:
    from ..physics.elastomer_joint import ElastomerMaterial

__all__ = ["Layout", "ReproduceConfig", "load_config", "STUDY_NAMES"]

#: Study names in report order (``--only`` takes a comma-separated subset).
STUDY_NAMES = ("direct", "conditioning", "verification", "model-error", "accelerometers", "experiment", "noise-robustness")


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
    robustness_seeds: int = 3
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


def _num(where: str, v: Any, positive: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0) or v < 0:
        raise StudyError(f"{where}: expected a {'positive' if positive else 'non-negative'} number, got {v!r}")
    return float(v)


def load_config(path: str | os.PathLike | None = None, seed: int | None = None) -> ReproduceConfig:
    """The benchmark configuration, overridden by the TOML file at ``path`` (keys as in the module doc).

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
    return cfg


def _table(where: str, v: Any) -> Mapping[str, Any]:
    if not isinstance(v, Mapping):
        raise StudyError(f"{where}: expected a table, got {v!r}")
    return v


def _apply(cfg: ReproduceConfig, data: Mapping[str, Any]) -> ReproduceConfig:
    allowed = {"seed", "frequency", "layouts", "materials", "noise", "noise_robustness", "accelerometers", "direct"}
    for key in data:
        if key not in allowed:
            raise StudyError(f"unknown key {key!r}; expected one of: {', '.join(sorted(allowed))}")
        if key != "seed":
            _table(f"[{key}]", data[key])
    for key in ("layouts", "materials"):
        for name, value in data.get(key, {}).items():
            _table(f"[{key}.{name}]", value)
    changes: dict[str, Any] = {}
    if "seed" in data:
        if not isinstance(data["seed"], int) or isinstance(data["seed"], bool) or data["seed"] < 0:
            raise StudyError(f"seed: expected an integer >= 0, got {data['seed']!r}")
        changes["seed"] = data["seed"]
    fr = data.get("frequency", {})
    for k in fr:
        if k not in ("start", "stop", "step"):
            raise StudyError(f"[frequency]: unknown key {k!r}; expected start, stop, step")
        changes[k] = _num(f"[frequency].{k}", fr[k])  # start > 0: the free beam is singular at 0 Hz
    if changes.get("start", cfg.start) >= changes.get("stop", cfg.stop):
        raise StudyError("[frequency]: start must be below stop")
    n_nodes = cfg.beam.nodes
    if "layouts" in data:
        layouts = dict(cfg.layouts)
        for name, lay in data["layouts"].items():
            for k in lay:
                if k not in ("observed", "excited"):
                    raise StudyError(f"[layouts.{name}]: unknown key {k!r}; expected observed, excited")
            base = layouts.get(name, Layout(name.replace("_", " ").title(), (), ()))
            new = {}
            for k in ("observed", "excited"):
                v = lay.get(k, getattr(base, k))
                if not isinstance(v, (list, tuple)) or not v or not all(isinstance(x, int) and 1 <= x <= n_nodes for x in v):
                    raise StudyError(f"[layouts.{name}].{k}: expected a non-empty list of beam nodes 1..{n_nodes}, got {v!r}")
                new[k] = tuple(v)
            layouts[name] = Layout(base.name, new["observed"], new["excited"])
        changes["layouts"] = layouts
    if "materials" in data:
        mats = dict(cfg.materials)
        for name, m in data["materials"].items():
            for k in m:
                if k not in ("elastic_modulus", "loss_factor", "density"):
                    raise StudyError(f"[materials.{name}]: unknown key {k!r}; expected elastic_modulus, loss_factor, density")
            base = mats.get(name)
            vals = {k: _num(f"[materials.{name}].{k}", m[k], positive=k != "loss_factor") for k in m}
            if base is None and len(vals) < 3:
                raise StudyError(f"[materials.{name}]: a new material needs elastic_modulus, loss_factor and density")
            if base is None:
                from ..physics.elastomer_joint import ElastomerMaterial

                mats[name] = ElastomerMaterial(**vals)  # values checked above: no ModelError left
            else:
                mats[name] = replace(base, **vals)
        changes["materials"] = mats
    noise = data.get("noise", {})
    for k in noise:
        if k not in ("conditioning", "experiment"):
            raise StudyError(f"[noise]: unknown key {k!r}; expected conditioning, experiment")
        changes[f"{k}_noise"] = _num(f"[noise].{k}", noise[k], positive=False)
    changes.update(_robustness(data.get("noise_robustness", {}), changes.get("layouts", cfg.layouts), n_nodes))
    acc = data.get("accelerometers", {})
    for k in acc:
        if k not in ("mass", "rotary_inertia"):
            raise StudyError(f"[accelerometers]: unknown key {k!r}; expected mass, rotary_inertia")
        changes[f"accelerometer_{k}"] = _num(f"[accelerometers].{k}", acc[k], positive=False)
    direct = data.get("direct", {})
    for k in direct:
        if k not in ("start", "stop", "step", "amplitude_pp", "parallel_joints"):
            raise StudyError(f"[direct]: unknown key {k!r}; expected start, stop, step, amplitude_pp, parallel_joints")
        if k == "parallel_joints":
            v = direct[k]
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise StudyError(f"[direct].parallel_joints: expected an integer >= 1, got {v!r}")
            changes[k] = v
        else:
            changes[f"direct_{k}"] = _num(f"[direct].{k}", direct[k])
    if changes.get("direct_start", cfg.direct_start) >= changes.get("direct_stop", cfg.direct_stop):
        raise StudyError("[direct]: start must be below stop")
    return replace(cfg, **changes)


def _robustness(section: Mapping[str, Any], layouts: Mapping[str, Layout], n_nodes: int) -> dict[str, Any]:
    """The ``[noise_robustness]`` keys as ReproduceConfig changes."""
    changes: dict[str, Any] = {}
    for k, v in section.items():
        where = f"[noise_robustness].{k}"
        if k == "levels":
            if not isinstance(v, list) or not v:
                raise StudyError(f"{where}: expected a non-empty list of positive numbers (relative noise rms), got {v!r}")
            changes["robustness_levels"] = tuple(sorted({_num(where, x) for x in v}))
        elif k == "seeds":
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise StudyError(f"{where}: expected an integer >= 1, got {v!r}")
            changes["robustness_seeds"] = v
        elif k == "layouts":
            if not isinstance(v, list) or not v or not all(isinstance(x, str) and x in layouts for x in v):
                raise StudyError(f"{where}: expected a non-empty list of layout names out of {', '.join(layouts)}, got {v!r}")
            changes["robustness_layouts"] = tuple(dict.fromkeys(v))
        elif k == "joint_nodes":
            if not isinstance(v, list) or not v or not all(isinstance(x, int) and not isinstance(x, bool) and 1 <= x <= n_nodes for x in v):
                raise StudyError(f"{where}: expected a non-empty list of beam nodes 1..{n_nodes}, got {v!r}")
            changes["robustness_joint_nodes"] = tuple(dict.fromkeys(v))
        else:
            raise StudyError(f"[noise_robustness]: unknown key {k!r}; expected levels, seeds, layouts, joint_nodes")
    return changes
