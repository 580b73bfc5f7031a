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


@pytest.mark.parametrize("extra, message", [
    (["--observed", "1"], "observed: 1 node cannot identify the 2 joint DOFs; choose at least 2"),
    (["--search-lines", "3"], "search lines: expected an integer >= 8, got 3"),
    (["--target", "K_rot=5"], "targets: unknown term 'K_rot'; expected one of K_w_w, K_w_theta, K_theta_theta"),
    (["--target", "K_w_w=0.002"], "--target: K_w_w=0.002 would be 0.002 %, below 0.01 %: --target is in percent (0.2 means "
                                  "0.2 %); [identification.targets] is a fraction; for 0.2 % give K_w_w=0.2"),
    (["--target", "K_w_w=5,K_theta_theta=101"], "--target: K_theta_theta=101; expected a percentage in (0, 100], e.g. K_theta_theta=5"),
    (["--target", "K_w_w=0"], "--target: K_w_w=0; expected a percentage in (0, 100], e.g. K_w_w=5"),
])
def test_design_option_errors_print_nothing_on_stdout(tmp_path, capsys, extra, message):
    out = tmp_path / "out"
    assert main(["design", "--out", str(out), *extra]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == f"jointid design: error: {message}\n"
    assert not out.exists()


def test_design_out_that_is_a_file_prints_nothing_on_stdout(tmp_path, capsys):
    (tmp_path / "afile").write_text("mine\n")
    assert main(["design", "--out", str(tmp_path / "afile")]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == f"jointid design: error: --out {tmp_path / 'afile'} is a file; give a directory\n"
    assert (tmp_path / "afile").read_text() == "mine\n"


def test_design_percent_targets_0_01_is_accepted_and_converted_to_fractions():
    from jointid.cli.design import MIN_TARGET_PERCENT, parse_targets

    assert MIN_TARGET_PERCENT == 0.01
    assert parse_targets("K_w_w=0.01,K_theta_theta=100") == {"K_w_w": 0.0001, "K_theta_theta": 1.0}


def test_design_header_after_the_checks_states_the_targets_in_percent(tmp_path, capsys):
    from jointid.benchmark import benchmark_study_path

    text = benchmark_study_path().read_text(encoding="utf-8")
    study = tmp_path / "study.toml"
    study.write_text(text.replace("start = 5.0", "start = 100.0").replace("step = 1.0", "step = 20.0"), encoding="utf-8")
    assert main(["design", str(study), "--out", str(tmp_path / "d"), "--observed", "3", "--excited", "2", "--candidates",
                 "1,4..7,10,13,16,19", "--search-lines", "8", "--target", "K_theta_theta=5", "--no-plots"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "design: searching 3 observed x 2 excited for targets K_theta_theta 5 % ..."
    assert lines[1].startswith("  greedy observed: ")
    assert any(line.startswith("  K_theta_theta    target 5 %: chosen ") for line in lines)
