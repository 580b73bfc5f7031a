"""User-facing messages: ``direct`` names the data file, ``estimate`` names the study key, ``design`` validates first."""

import re

import numpy as np
import pytest

from jointid.cli.main import main
from jointid.measurement.stepsine import write_stepsine_csv
from jointid.measurement.stepsine_synth import synthesize_stepsine
from jointid.physics.elastomer_joint import ElastomerJoint


def _negated_force_data(path):
    """Step-sine test of Material B with the force sign flipped: every storage stiffness is negative."""
    joint = ElastomerJoint.from_material("B")
    f = np.arange(25.0, 201.0, 25.0)
    blocks = synthesize_stepsine(f, lambda x: -joint.blocked_transfer_stiffness(x), 2.5e-5, seed=0,
                                 displacement_noise=0.0, force_noise=0.0)
    write_stepsine_csv(path, blocks)
    return -joint.blocked_transfer_stiffness(np.array([25.0]))[0].real


def test_direct_negative_static_stiffness_names_the_data_file(tmp_path, capsys):
    expected = _negated_force_data(tmp_path / "neg.csv")
    out = tmp_path / "out"
    assert main(["direct", str(tmp_path / "neg.csv"), "--out", str(out), "--no-plots"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    m = re.fullmatch(rf"jointid direct: error: {re.escape(str(tmp_path / 'neg.csv'))}: line 25 Hz: storage stiffness "
                     r"(\S+) N/m is not positive; check the force sign\n", cap.err)
    assert m is not None, cap.err
    assert float(m.group(1)) == pytest.approx(expected, rel=1e-3) and expected < 0
    assert not out.exists()


def test_direct_too_few_lines_at_amplitude_names_the_data_file(tmp_path, capsys):
    _negated_force_data(tmp_path / "neg.csv")
    assert main(["direct", str(tmp_path / "neg.csv"), "--out", str(tmp_path / "out"), "--amplitude", "1e-4"]) == 2
    assert capsys.readouterr().err == (f"jointid direct: error: {tmp_path / 'neg.csv'}: only 0 of 8 lines reached the commanded "
                                       "amplitude within 5%; check --amplitude (m, peak) or widen --tolerance\n")


def test_layout_messages_name_the_study_keys():
    from jointid.errors import IdentificationError
    from jointid.methods.estimate import check_layout

    with pytest.raises(IdentificationError) as e:
        check_layout(2, ["3w"], ["3w", "9w"])
    assert str(e.value) == ("[measurement].observed: 1 observed coordinate(s) for 2 joint DOFs: the estimation step needs at "
                            "least as many observed coordinates as joint DOFs (|m| >= |n|); observe more points")
    with pytest.raises(IdentificationError) as e:
        check_layout(2, ["3w", "9w"], ["9w"])
    assert str(e.value) == ("[measurement].excited: 1 excited coordinate(s) for 2 joint DOFs: the identification step needs "
                            "at least as many excited coordinates as joint DOFs (|e| >= |n|); excite more points")
    check_layout(2, ["3w", "9w"], ["3w", "9w"])  # enough of both: no error
