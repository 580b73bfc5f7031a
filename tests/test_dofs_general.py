"""3-D and scalar-point DOFs, component codes, and the vectorized partition of large DOF sets."""

import numpy as np
import pytest

from jointid.dofs import (
    COMPONENT_CODES,
    Dof,
    DofArray,
    pack_dof_keys,
    parse_component,
    parse_dof,
    parse_dofs,
    partition_indices,
)
from jointid.errors import DofError


def test_3d_and_scalar_labels_parse_print_and_carry_units():
    assert parse_dofs(["101z", "101rx", "1995001s", "7:ry", "8_y"]) == (
        Dof(101, "z"), Dof(101, "rx"), Dof(1995001, "s"), Dof(7, "ry"), Dof(8, "y"))
    assert [str(d) for d in parse_dofs(["101z", "101rx", "1995001s"])] == ["101z", "101rx", "1995001s"]
    assert [Dof(1, c).unit for c in ("x", "y", "z", "rx", "ry", "rz", "s")] == ["m"] * 3 + ["rad"] * 3 + ["1"]
    assert [Dof(1, c).force_unit for c in ("x", "rz", "s")] == ["N", "N*m", "1"]
    assert [Dof(1, c).code for c in ("s", "x", "y", "z", "rx", "ry", "rz", "w", "theta")] == list(range(9))
    assert parse_dof((5, 3)) == Dof(5, "z") and parse_dof((5, 0)) == Dof(5, "s") and parse_dof((5, "rx")) == Dof(5, "rx")


def test_beam_labels_unchanged():
    assert Dof(10) == Dof(10, "w") == parse_dof("10w") == parse_dof(10)
    assert parse_dof("10theta").unit == "rad" and str(parse_dof("10 : theta")) == "10theta"
    with pytest.raises(DofError, match=r"cannot read a DOF from '10q'; write it as '<node><direction>', e.g. '10w', '10theta', '101z'"):
        parse_dof("10q")
    with pytest.raises(DofError, match=r"DOF node must be an integer >= 1, got 0"):
        Dof(0, "x")
    with pytest.raises(DofError, match=r"DOF direction must be one of \('w', 'theta'\) \(beam\) or \('x', 'y', 'z', 'rx', 'ry', 'rz', 's'\)"):
        Dof(3, "t1")


@pytest.mark.parametrize("value, name", [("x", "x"), ("RX", "rx"), (" rz ", "rz"), ("3", "z"), (6, "rz"), (0, "s"), ("0", "s")])
def test_parse_component_names_and_codes(value, name):
    assert parse_component(value) == name


def test_parse_component_refuses_out_of_range():
    with pytest.raises(DofError, match=r"^cannot read a DOF component from 7; use x, y, z, rx, ry, rz, 1-6, or 0 for a scalar point$"):
        parse_component(7)
    with pytest.raises(DofError, match=r"cannot read a DOF component from 'T1'"):
        parse_component("T1")


def test_partition_of_a_large_model_matches_a_dict_lookup_and_is_fast():
    rng = np.random.default_rng(3)
    nodes = rng.permutation(np.arange(1, 20001))
    node = np.repeat(nodes, 6)
    code = np.tile(np.arange(1, 7), nodes.size)
    dofs = DofArray(node, code)
    assert len(dofs) == 120000 and dofs.duplicates() == ()
    want = ["17z", "3rx", "20000x", "5y"]
    idx = dofs.indices(want)
    lookup = {(int(n), int(c)): i for i, (n, c) in enumerate(zip(node, code))}
    assert idx.tolist() == [lookup[(17, 3)], lookup[(3, 4)], lookup[(20000, 1)], lookup[(5, 2)]]
    # a pair of arrays selects in bulk: every z of the first 1000 nodes
    sel = dofs.indices((np.arange(1, 1001), np.full(1000, COMPONENT_CODES["z"])))
    assert np.array_equal(node[sel], np.arange(1, 1001)) and np.all(code[sel] == 3)
    assert partition_indices(node, code, ["17z"]).tolist() == [lookup[(17, 3)]]
    assert dofs.to_dofs()[idx[0]] == Dof(17, "z")
    assert np.array_equal(dofs.keys, pack_dof_keys(node, code))


def test_partition_names_missing_dofs_in_one_line():
    dofs = DofArray([1, 1, 2, 3], [1, 2, 1, 0])
    with pytest.raises(DofError, match=r"^DOF 2y is not in the model \(it has 4 DOFs, nodes 1..3\)$"):
        dofs.indices(["1x", "2y"])
    with pytest.raises(DofError, match=r"^DOFs 2y, 9x, 9y, 9z, 9rx and 2 more are not in the structure \(it has 4 DOFs, nodes 1..3\)$"):
        dofs.indices(["2y", "9x", "9y", "9z", "9rx", "9ry", "9rz"], what="structure")
    assert dofs.indices(["3s"]).tolist() == [3]


def test_dof_array_validates_its_arrays():
    assert DofArray([4, 4, 5], [1, 1, 3]).duplicates() == (Dof(4, "x"),)
    with pytest.raises(DofError, match=r"^DOF arrays differ in length: 2 nodes, 1 component codes$"):
        DofArray([1, 2], [1])
    with pytest.raises(DofError, match=r"^DOF component code must be 0..8 \(s, x, y, z, rx, ry, rz, w, theta\), got 9$"):
        DofArray([1, 2], [1, 9])
    with pytest.raises(DofError, match=r"^DOF node must be an integer >= 1, got 0$"):
        DofArray([0, 2], [1, 1])
    assert DofArray.from_dofs(["10w", "10theta"]).code.tolist() == [7, 8]
