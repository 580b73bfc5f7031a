"""Study-file validation: the documented layout is accepted, bad input names the key."""

import copy
import subprocess
import sys
import tomllib

import pytest

from jointid.benchmark import benchmark_study_path
from jointid.errors import StudyError
from jointid.study import parse_study

LAYOUT = """
[beam]
length = 0.9144            # m
width = 0.0127             # m
height = 0.0127            # m
elastic_modulus = 69e9     # Pa
density = 2700.0           # kg/m^3
loss_factor = 0.006
poisson_ratio = 0.33
shear_coefficient = 0.8333333333333334
nodes = 19                 # equally spaced, numbered 1..nodes from x = 0

[joint]
node = 10                  # beam node where the joint connects the beam to ground
dofs = ["w", "theta"]

[measurement]
observed = [1, 3, 6, 9, 12, 15, 19]   # beam nodes, transverse w
excited  = [3, 9, 15]                 # beam nodes, transverse force

[frequency]
start = 5.0                # Hz
stop = 1000.0
step = 1.0
"""
BASE = tomllib.loads(LAYOUT)


def test_issue_layout_is_accepted():
    s = parse_study(BASE)
    assert s.beam.nodes == 19 and s.joint.node == 10
    assert [str(d) for d in s.joint.joint_dofs] == ["10w", "10theta"]
    assert s.grid.size == 996 and s.grid.hz[-1] == 1000.0
    assert s.accelerometers is None and not s.identification.symmetric


def _with(section, key, value):
    d = copy.deepcopy(BASE)
    if value is None:
        del d[section][key]
    else:
        d[section][key] = value
    return d


@pytest.mark.parametrize(
    "data, msg",
    [
        (_with("beam", "lenght", 1.0), "[beam]: unknown key 'lenght'; expected one of: length,"),
        (_with("beam", "length", "long"), "[beam].length: expected a number (m), got 'long'"),
        (_with("beam", "length", -0.9), "[beam].length: expected a positive number (m), got -0.9"),
        (_with("beam", "nodes", 19.5), "[beam].nodes: expected an integer, got 19.5"),
        (_with("beam", "density", None), "[beam]: missing key 'density' (kg/m^3)"),
        (_with("joint", "node", 25), "[joint].node: node 25 is out of range; the beam has nodes 1..19"),
        (_with("joint", "dofs", ["w", "u"]), "[joint].dofs: 'u' is not a joint DOF; expected 'w' and/or 'theta'"),
        (_with("measurement", "observed", [1, 3, 40]), "[measurement].observed: node 40 is out of range; the beam has nodes 1..19"),
        (_with("frequency", "start", 2000.0), "[frequency]: start (2000 Hz) must be below stop (1000 Hz)"),
        (_with("frequency", "step", 0.0), "[frequency].step: expected a positive number (Hz), got 0.0"),
        ({**BASE, "beem": {}}, "unknown section [beem]; expected sections:"),
        ({**BASE, "identification": {"estimation": "lu"}}, "[identification].estimation: expected one of"),
        ({**BASE, "identification": {"cond_rtol": 2.0}}, "[identification].cond_rtol: expected a number in [0, 1), got 2.0"),
    ],
)
def test_bad_study_names_the_key(data, msg):
    with pytest.raises(StudyError) as e:
        parse_study(data, "s.toml")
    assert str(e.value).startswith("s.toml: " + msg)


@pytest.mark.parametrize(
    "section, key, value, expected",
    [
        ("beam", "length", -1.0, "[beam].length: expected a positive number (m), got -1.0"),
        ("joint", "node", 0, "[joint].node: node 0 is out of range"),
        ("joint", "dofs", ["x"], "[joint].dofs: 'x' is not a joint DOF"),
        ("frequency", "start", 1000.0, "[frequency]: start (1000 Hz) must be below stop (1000 Hz)"),
    ],
)
def test_cli_bad_study_one_line_nonzero_exit(tmp_path, section, key, value, expected):
    import tomllib as _t
    text = benchmark_study_path().read_text()
    d = _t.loads(text)
    d[section][key] = value
    lines = []
    for sec, table in d.items():
        for k, v in table.items():
            if isinstance(v, dict):
                continue
            lines.append((sec, k, v))
    out = []
    for sec in d:
        out.append(f"[{sec}]")
        for k, v in d[sec].items():
            if isinstance(v, dict):
                continue
            out.append(f"{k} = {_toml(v)}")
    p = tmp_path / "bad.toml"
    p.write_text("\n".join(out) + "\n")
    r = subprocess.run([sys.executable, "-m", "jointid.cli.main", "modes", str(p), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert expected in r.stderr
    assert not (tmp_path / "o" / "modes.csv").exists()


def _toml(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(v)
