"""The one schema mechanism (jointid.schema) behind the study file and ``reproduce --config``."""

from __future__ import annotations

import pytest

from jointid import schema
from jointid.errors import StudyError
from jointid.schema import Field, section, table, typed
from jointid.reproduce.config import load_config


def test_section_types_defaults_and_messages():
    fields = {"n": Field("int", True), "x": Field("number", False, 2.0, unit="m", check=schema.positive),
              "levels": Field("number_list")}
    assert section({"n": 3, "levels": [1, 0.5]}, "t", fields) == {"n": 3, "x": 2.0, "levels": (1.0, 0.5)}
    cases = [
        ({"n": 2.5}, "[t].n: expected an integer, got 2.5"),
        ({"n": 1, "x": -1}, "[t].x: expected a positive number (m), got -1.0"),
        ({}, "[t]: missing key 'n'"),
        ({"n": 1, "y": 0}, "[t]: unknown key 'y'; expected one of: n, x, levels"),
        ({"n": 1, "levels": [1, 1]}, "[t].levels: repeated entries in [1, 1]; list each once"),
        ({"n": 1, "levels": [1, True]}, "[t].levels: expected a list of numbers, got [1, True]"),
    ]
    for data, message in cases:
        with pytest.raises(StudyError) as e:
            section(data, "t", fields)
        assert str(e.value) == message
    with pytest.raises(StudyError, match=r"^\[t\] must be a table, got 3$"):
        section(3, "t", fields)
    with pytest.raises(StudyError, match=r"^\[t\]: expected a table, got 3$"):
        table("[t]", 3)


def test_expected_is_one_message_for_type_and_check():
    f = Field("int_list", check=lambda v: None if all(1 <= x <= 5 for x in v) else "out of range",
              expected="a list of nodes 1..5")
    for bad in ([1, 9], "1", [1.0]):
        with pytest.raises(StudyError) as e:
            typed(None, "nodes", f, bad)
        assert str(e.value) == f"nodes: expected a list of nodes 1..5, got {bad!r}"
    assert typed(None, "nodes", f, [5, 1]) == (5, 1)
    with pytest.raises(StudyError, match=r"^nodes: repeated entries in \[1, 1\]; list each once$"):
        typed(None, "nodes", f, [1, 1])


@pytest.mark.parametrize(
    "text, message",
    [
        ("[noise_robustness]\nlevels = [0.01, \"x\"]\n",
         "[noise_robustness].levels: expected a non-empty list of positive numbers (relative noise rms), got [0.01, 'x']"),
        ("[noise_robustness]\nlayouts = [\"model_9\"]\n",
         "[noise_robustness].layouts: expected a non-empty list of layout names out of model_1, model_2, model_3, got ['model_9']"),
        ("[layouts.model_4]\nobserved = [2, 3]\n", "[layouts.model_4].excited: expected a non-empty list of beam nodes 1..19, got []"),
        ("[accelerometers]\nmass = \"5 g\"\n", "[accelerometers].mass: expected a non-negative number, got '5 g'"),
        ("[materials.A]\nshear_modulus = 1e6\n",
         "[materials.A]: unknown key 'shear_modulus'; expected elastic_modulus, loss_factor, density"),
    ],
)
def test_reproduce_config_through_the_schema(tmp_path, text, message):
    p = tmp_path / "c.toml"
    p.write_text(text)
    with pytest.raises(StudyError) as e:
        load_config(p)
    assert str(e.value) == f"{p}: {message}"


def test_reproduce_config_robustness_values(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[noise_robustness]\nlevels = [0.03, 0.01]\nseeds = 2\njoint_nodes = [1]\n")
    c = load_config(p)
    assert (c.robustness_levels, c.robustness_seeds, c.robustness_joint_nodes) == ((0.01, 0.03), 2, (1,))


def test_label_names_an_array_of_tables_entry_and_lists_may_repeat_values():
    from jointid.schema import Field, positive, section

    where = "[[joint]] 'front' [joint.model]"
    fields = {"stiffness": Field("number_list", True, check=lambda v: None if all(x > 0 for x in v) else "positive values", unique=False),
              "growth": Field("number", default=0.0, check=positive)}
    assert section({"stiffness": [2e6, 2e6]}, "joint.model", fields, label=where) == {"stiffness": (2e6, 2e6), "growth": 0.0}
    with pytest.raises(StudyError) as exc:
        section({"stiffness": [1.0], "growth": -1}, "joint.model", fields, label=where)
    assert str(exc.value) == f"{where}.growth: expected a positive number, got -1.0"
    with pytest.raises(StudyError) as exc:
        section({"stiffness": [1.0], "grow": 1}, "joint.model", fields, label=where)
    assert str(exc.value) == f"{where}: unknown key 'grow'; expected one of: stiffness, growth"
    with pytest.raises(StudyError) as exc:
        section({}, "joint.model", fields, label=where)
    assert str(exc.value) == f"{where}: missing key 'stiffness'"
