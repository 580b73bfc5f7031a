"""Physical bounds at the door, --debug anywhere, warnings as one finding line (issue 28, issue 24 item 9)."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest

from jointid import schema
from jointid.cli import main as cli_main
from jointid.cli.main import main
from jointid.errors import StudyError
from jointid.schema import Field, format_number, typed
from jointid.study import parse_study
from study_texts import beam_study_toml

import tomllib

STUDY = beam_study_toml(stop=100.0)


def test_format_number_is_short_and_exact_for_bounds():
    assert [format_number(x) for x in (1e3, 1e13, 1e-6, 1e4, 0.1, 1.5, 0.0, 1e-300, 3.9e6, 500.0, 2.5e-4)] == [
        "1e3", "1e13", "1e-6", "1e4", "0.1", "1.5", "0", "1e-300", "3.9e6", "500", "2.5e-4"]


def test_a_bound_is_checked_after_the_type_and_sign():
    f = Field("number", unit="Pa", check=schema.positive, bounds=schema.MODULUS)
    assert typed("beam", "elastic_modulus", f, 1e3) == 1e3 and typed("beam", "elastic_modulus", f, 1e13) == 1e13  # inclusive
    for value, message in [
        (1e-300, "[beam].elastic_modulus: 1e-300 Pa is outside 1e3-1e13 Pa; give it in Pa"),
        (1e300, "[beam].elastic_modulus: 1e300 Pa is outside 1e3-1e13 Pa; give it in Pa"),
        (-1.0, "[beam].elastic_modulus: expected a positive number (Pa), got -1.0"),
    ]:
        with pytest.raises(StudyError) as e:
            typed("beam", "elastic_modulus", f, value)
        assert str(e.value) == message
    with pytest.raises(StudyError, match=r"^\[beam\]\.shear_coefficient: 30 is outside 0\.1-1\.5$"):
        typed("beam", "shear_coefficient", Field("number", bounds=schema.SHEAR_COEFFICIENT), 30.0)


def _parse(extra: str = "", **replace):
    text = STUDY
    for key, value in replace.items():
        lines = [f"{key} = {value}" if ln.split("=")[0].strip() == key else ln for ln in text.splitlines()]
        text = "\n".join(lines)
    return parse_study(tomllib.loads(text + extra), "s.toml")


def test_every_beam_value_at_its_bounds_is_accepted_and_beyond_them_refused():
    # the edges of the documented ranges parse (so the bounds are exactly what the README states)
    for key, lo, hi in [("elastic_modulus", 1e3, 1e13), ("density", 1.0, 1e5), ("shear_coefficient", 0.1, 1.5),
                        ("length", 1e-6, 1e4), ("loss_factor", 0.0, 2.0)]:
        for v in (lo, hi):
            assert getattr(_parse(**{key: repr(v)}).beam, key) == v
        for v in (lo * 0.5 if lo > 0 else -1.0, hi * 2):
            with pytest.raises(StudyError, match=rf"^s\.toml: \[beam\]\.{key}: "):
                _parse(**{key: repr(v)})


def test_a_sensor_heavier_than_the_beam_is_refused():
    beam_mass = 2700.0 * 0.0127**2 * 0.9144  # kg: rho A L of the study's beam
    assert _parse("\n[accelerometers]\nmass = 0.39\n").accelerometers.mass == 0.39
    with pytest.raises(StudyError) as e:
        _parse("\n[accelerometers]\nmass = 1e12\n")
    assert str(e.value) == (f"s.toml: [accelerometers].mass: 1e12 kg per sensor is not below the beam's mass "
                            f"({format_number(beam_mass)} kg); give the mass of one sensor in kg")


def test_debug_is_accepted_after_the_subcommand(tmp_path, capsys):
    bad = tmp_path / "s.toml"
    bad.write_text(STUDY.replace("density = 2700.0", "density = 1e300"))
    assert main(["modes", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "[beam].density: 1e300 kg/m^3 is outside 1-1e5 kg/m^3" in capsys.readouterr().err
    for argv in (["--debug", "modes", str(bad), "--out", str(tmp_path / "o")], ["modes", str(bad), "--out", str(tmp_path / "o"), "--debug"]):
        with pytest.raises(StudyError, match=r"density: 1e300 kg/m\^3 is outside"):  # --debug: the exception itself
            main(argv)
    assert not (tmp_path / "o").exists()


def test_debug_keeps_the_exit_codes_of_bad_input_and_of_a_bug(tmp_path):
    """The `jointid` process with --debug: the traceback, and still exit 2 for bad input and 3 for a bug (both were 1,
    a campaign's code)."""
    import subprocess
    import sys

    bad = tmp_path / "s.toml"
    bad.write_text(STUDY.replace("density = 2700.0", "density = 1e300"))
    script = "import sys; from jointid.cli.main import entry_point; sys.argv = ['jointid'] + sys.argv[1:]; entry_point()"
    r = subprocess.run([sys.executable, "-c", script, "--debug", "modes", str(bad), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert "Traceback (most recent call last)" in r.stderr and "density: 1e300 kg/m^3 is outside" in r.stderr
    bug = ("import sys, jointid.cli.modes as m; from jointid.cli.main import entry_point\n"
           "def run(args): raise ZeroDivisionError('a bug')\n"
           "m.run = run; sys.argv = ['jointid', 'modes', '--out', sys.argv[1], '--debug']; entry_point()")
    r = subprocess.run([sys.executable, "-c", bug, str(tmp_path / "o2")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 3 and "ZeroDivisionError: a bug" in r.stderr and "Traceback" in r.stderr


def test_a_warning_during_a_command_becomes_one_finding_line(tmp_path, capsys, monkeypatch):
    """A numerical warning nobody prevented reaches the terminal as one line, not as Python's two-line warning."""
    import jointid.cli.modes as modes

    where = []

    def run(args):
        with np.errstate(over="warn"):
            where.append(sys._getframe().f_lineno + 1)
            np.float64(1e300) * np.float64(1e300)
        np.log(np.zeros(2))
        print("done")
        return 0

    monkeypatch.setattr(modes, "run", run)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # as under `pytest -W error`: main still records them
        code = main(["modes", "--out", str(tmp_path / "o")])
    cap = capsys.readouterr()
    assert code == 0 and cap.out == "done\n"
    assert cap.err.splitlines() == [
        "jointid modes: finding: a numerical problem occurred: RuntimeWarning: overflow encountered in scalar multiply "
        f"in test_physical_checks.py:{where[0]} (and 1 more); the inputs are probably out of range: check their units and values "
        "(rerun with --debug to see the warnings)"
    ]
    assert cli_main._warning_line("x", []) is None


def test_an_input_or_output_option_given_twice_is_a_usage_error(tmp_path, capsys):
    """`--frf a --frf b` read only b, silently (the user may have meant both files)."""
    for extra, text in ((["--frf", "b.uff", "--out", "o"], "--frf given twice (a.uff and b.uff); give it once"),
                        (["--out", "o", "--out", "p"], "--out given twice (o and p); give it once")):
        with pytest.raises(SystemExit) as e:
            main(["identify", "s.toml", "--frf", "a.uff"] + extra)
        assert e.value.code == 2
        assert capsys.readouterr().err == f"jointid identify: error: {text} (see `jointid identify --help`)\n"
