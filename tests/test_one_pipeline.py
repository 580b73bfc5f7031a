"""One model of any structure: the beam is one free structure among others, through one pipeline.

* no study-kind switch and no ``*_structure`` twin in the package; no import cycle between its packages;
* the benchmark beam and the same beam given as matrix files run through the same functions and agree;
* accelerometer masses on a ``[structure]`` study: a frame with 5 g sensors, identified with and without
  them in the free model (as the beam's accelerometer study does).
"""

from __future__ import annotations

import ast
import dataclasses
import re
import textwrap

import numpy as np
import pytest

import jointid
from jointid import pipeline
from jointid.benchmark import benchmark_study
from jointid.dofs import DofArray
from jointid.frequency import Frequency
from jointid.io.matrix_files import write_free_matrices
from jointid.methods.estimate import JointEstimate
from jointid.physics import build_frame
from jointid.physics.sparse_model import SparseModel
from jointid.physics.structure import Structure
from jointid.study import load_study
from test_frame_mounts import COMP, EXCITED, OBSERVED, _labels, fixture_frame
from test_layers import MODULES, SRC, imports
from test_structure_study import MOUNT_A, _list


# --------------------------------------------------------------------------- the package's shape
def test_no_study_kind_switch_and_no_structure_twin():
    """No ``is_structure`` anywhere; no public module or function named ``*_structure``."""
    offenders = []
    for module, path in MODULES:
        text = path.read_text(encoding="utf-8")
        if "is_structure" in text:
            offenders.append(f"{module}: is_structure")
        if module.rsplit(".", 1)[-1].endswith("_structure"):
            offenders.append(f"{module}: a *_structure module")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_") and node.name.endswith("_structure"):
                offenders.append(f"{module}: {node.name}")
    assert offenders == []


def _unit(module: str) -> str:
    """The package (or top-level module) a module belongs to: ``jointid.methods.receptance.coupling`` -> ``jointid.methods``."""
    parts = module.split(":")[0].split(".")
    return ".".join(parts[:2])


def _import_graph(unit) -> dict[str, set[str]]:
    """Edges ``unit(module) -> unit(imported)`` over every import of the package (lazy ones included, ``plot*`` excepted)."""
    edges: dict[str, set[str]] = {}
    for module, path in MODULES:
        a = unit(module)
        for _, target, function in imports(module, path):
            b = unit(target.split(":")[0])
            if b == a or b == "jointid" or (function or "").startswith("plot") and target.startswith("jointid.plots"):
                continue
            edges.setdefault(a, set()).add(b)
    return edges


def _cycle(edges: dict[str, set[str]]) -> list[str]:
    """One cycle of the directed graph (empty: acyclic), by depth-first search."""
    state: dict[str, int] = {}
    found: list[str] = []

    def visit(node: str, trail: list[str]) -> bool:
        state[node] = 1
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                found.extend((trail + [node])[(trail + [node]).index(nxt):] + [nxt])
                return True
            if state.get(nxt) is None and visit(nxt, trail + [node]):
                return True
        state[node] = 2
        return False

    for node in sorted(edges):
        if state.get(node) is None and visit(node, []):
            break
    return found


def test_no_import_cycle_between_modules():
    """Not even inside a package: every module's imports (lazy ones included, ``plot*`` excepted) form no circle."""
    assert _cycle(_import_graph(lambda m: m)) == []
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]  # the search itself finds one


def test_no_import_cycle_between_packages_and_top_level_modules():
    """The graph of imports between jointid's packages and top-level modules (lazy ones included, ``plot*`` excepted) is acyclic."""
    cycle = _cycle(_import_graph(_unit))
    assert cycle == [], " -> ".join(cycle)


def test_the_unit_of_a_module_is_its_package():
    """The checker itself: a module of a package counts as the package, a top-level module as itself."""
    assert _unit("jointid.methods.receptance.coupling") == "jointid.methods" and _unit("jointid.pipeline") == "jointid.pipeline"


def test_no_module_imports_another_modules_private_name():
    """``from .x import _name`` across modules is a private helper used outside its module: make it public or move it."""
    pattern = re.compile(r"^\s*from\s+\S+\s+import\s+\(?([^)\n]*)", re.M)
    offenders = []
    for module, path in MODULES:
        for m in pattern.finditer(path.read_text(encoding="utf-8")):
            names = [n.strip().split(" as ")[0] for n in m.group(1).split(",")]
            offenders += [f"{module}: {n}" for n in names if n.startswith("_") and not n.startswith("__")]
    assert offenders == []


# --------------------------------------------------------------------------- the beam as one structure
def _beam_as_matrix_files(tmp_path):
    """The benchmark study and the same beam (meshed 2 elements per segment) given as matrix files, same joint and layout."""
    beam = benchmark_study()
    beam = dataclasses.replace(
        beam, structure=dataclasses.replace(beam.beam, elements_per_segment=2), accelerometers=None,
        identification=dataclasses.replace(beam.identification, model_accelerometers=False, smoothing="none"),
        frequency=dataclasses.replace(beam.frequency, start=20.0, stop=600.0, step=20.0),
    )
    s = beam.beam.structure()
    files = write_free_matrices(tmp_path / "beam", s.mass.real, s.stiffness.real, DofArray.from_dofs(s.dofs))
    text = textwrap.dedent(f"""
        [structure]
        mass = "{files.mass.name}"
        stiffness = "{files.mass.name}"
        dofs = "{files.dofs.name}"
        loss_factor = {beam.beam.loss_factor}

        [joint]
        name = "joint"
        dofs = ["10w", "10theta"]
        [joint.model]
        type = "elastomer"
        axes = ["w", "theta"]
        material = "A"

        [measurement]
        observed = {_list([str(d) for d in beam.measurement.observed_dofs])}
        excited = {_list([str(d) for d in beam.measurement.excited_dofs])}

        [identification]
        smoothing = "none"

        [frequency]
        start = 20.0
        stop = 600.0
        step = 20.0
        """)
    p = tmp_path / "beam_matrices.toml"
    p.write_text(text)
    return beam, load_study(p)


def test_beam_and_its_matrix_files_run_through_the_same_functions(tmp_path):
    beam, matrices = _beam_as_matrix_files(tmp_path)
    assert isinstance(pipeline.free_model(beam), Structure) and isinstance(pipeline.free_model(matrices), SparseModel)
    assert [j.joint_dofs for j in beam.joints] == [j.joint_dofs for j in matrices.joints]
    a, b = pipeline.simulate(beam), pipeline.simulate(matrices)  # a dense direct solve; the Woodbury coupling on a sparse model
    assert np.allclose(a.truth, b.truth, rtol=1e-12, atol=0)  # one registry builds both joints
    # two exact solutions of the same equations: within cond(D) x eps of each other (cond < 1e8 on these lines)
    assert np.abs(b.frf.data / a.frf.data - 1).max() < 1e-6
    ra, rb = pipeline.identify(beam, a.frf), pipeline.identify(matrices, a.frf)
    assert isinstance(ra, JointEstimate) and type(ra) is type(rb)
    rel = np.abs(ra.stiffness - rb.stiffness) / np.abs(a.truth).max(axis=(1, 2))[:, None, None]
    assert rel.max() < 1e-6
    assert np.abs(ra.stiffness - a.truth).max() / np.abs(a.truth).max() < 1e-6  # exact data, the model that made them


def test_truth_overrides_apply_to_a_structure_study(tmp_path):
    """``[truth]`` on a ``[structure]`` study: the simulated structure's stiffness scale differs from the model's."""
    _, matrices = _beam_as_matrix_files(tmp_path)
    p = tmp_path / "beam_matrices.toml"
    p.write_text(p.read_text() + "\n[truth]\nstiffness_scale = 1.02\n")
    with_truth = load_study(p)
    assert with_truth.true_study().structure.stiffness_scale == 1.02
    f = Frequency.from_range(20.0, 600.0, 20.0)
    plain, shifted = pipeline.simulate_free(matrices, f), pipeline.simulate_free(with_truth, f)
    # the free structure scaled by 1.02 in stiffness: Y(w; 1.02) = Y(w / sqrt(1.02); 1) / 1.02, so the FRFs differ
    assert np.abs(shifted.data / plain.data - 1).max() > 0.05


# --------------------------------------------------------------------------- accelerometers on any structure
@pytest.fixture(scope="module")
def frame():
    nodes, members = fixture_frame()
    return build_frame(nodes, members)


def _frame_with_sensors(tmp_path, frame, model_accelerometers: bool):
    files = write_free_matrices(tmp_path / "frame", frame.mass, frame.stiffness, frame.dofs)
    text = textwrap.dedent(f"""
        [structure]
        mass = "{files.mass.name}"
        stiffness = "{files.mass.name}"
        dofs = "{files.dofs.name}"
        loss_factor = 0.002

        [[joint]]
        name = "front"
        dofs = {_list(_labels([1], COMP))}
        """) + MOUNT_A.format(n=1) + textwrap.dedent(f"""
        [measurement]
        observed = {_list(OBSERVED)}
        excited = {_list(EXCITED)}

        [accelerometers]
        mass = 0.005
        rotary_inertia = 2e-7

        [identification]
        smoothing = "none"
        model_accelerometers = {str(model_accelerometers).lower()}

        [frequency]
        start = 10.0
        stop = 400.0
        step = 20.0
        """)
    p = tmp_path / f"frame_{model_accelerometers}.toml"
    p.write_text(text)
    return load_study(p)


def test_frame_with_5g_accelerometers_identified_with_and_without_them_in_the_model(tmp_path, frame):
    with_sensors = _frame_with_sensors(tmp_path, frame, True)
    without = _frame_with_sensors(tmp_path, frame, False)
    assert with_sensors.accelerometers.nodes == tuple(dict.fromkeys(d.node for d in with_sensors.measurement.observed_dofs))
    # the sensors load the free model: 9 nodes x 5 g more mass in each translation
    M0, M1 = pipeline.free_model(without).mass, pipeline.free_model(with_sensors).mass
    assert (M1 - M0).sum() == pytest.approx(9 * 3 * 0.005 + 9 * 3 * 2e-7)
    test = pipeline.simulate(with_sensors)  # the test article carries its sensors whatever the model says
    exact = pipeline.identify(with_sensors, test.frf)
    ignored = pipeline.identify(without, test.frf)
    d = np.abs(np.diagonal(test.truth, axis1=1, axis2=2))
    scale = np.sqrt(d[:, :, None] * d[:, None, :])
    err_exact = np.median(np.abs(exact.stiffness - test.truth) / scale)
    err_ignored = np.median(np.abs(ignored.stiffness - test.truth) / scale)
    assert err_exact < 1e-7  # exact data and the model that made them: round-off of the Woodbury coupling
    assert err_ignored > 1e3 * err_exact and err_ignored > 1e-4  # 45 g of sensors left out of Do is a model error


# --------------------------------------------------------------------------- a joint given as a table
def test_a_joint_table_simulates_the_joint_it_was_written_from(tmp_path):
    """``[joint.model] type = "matrix"``: the true_joint.csv of one simulation is the joint of another, the same FRFs."""
    from jointid.cli.main import main
    from jointid.io.frf_files import read_frf

    from study_texts import beam_study_toml

    text = beam_study_toml(start=20.0, stop=400.0, step=20.0)
    (tmp_path / "a.toml").write_text(text)
    assert main(["simulate", str(tmp_path / "a.toml"), "--out", str(tmp_path / "sim")]) == 0
    head, tail = text.split("[joint.model]", 1)
    rest = tail.split("\n[", 1)[1]
    (tmp_path / "b.toml").write_text(head + '[joint.model]\ntype = "matrix"\nfile = "sim/true_joint.csv"\n\n[' + rest)
    b = load_study(tmp_path / "b.toml")
    assert b.joint.model.type == "matrix" and b.joint.model.parameters["stiffness"].shape == (20, 2, 2)
    assert main(["simulate", str(tmp_path / "b.toml"), "--out", str(tmp_path / "sim_b")]) == 0
    a_frf, b_frf = read_frf(tmp_path / "sim" / "frf.uff"), read_frf(tmp_path / "sim_b" / "frf.uff")
    # the table holds the joint to the digits the CSV writes (repr of a double: exact), the FRFs as UFF58 text
    assert np.abs(b_frf.data / a_frf.data - 1).max() < 1e-9
    outside = tmp_path / "c.toml"
    outside.write_text((tmp_path / "b.toml").read_text().replace("stop = 400.0", "stop = 600.0"))
    assert main(["simulate", str(outside), "--out", str(tmp_path / "sim_c")]) == 2  # lines beyond the table: refused
