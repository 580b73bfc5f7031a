"""User input that once gave an internal error (exit 3) is a one-line data error (exit 2)."""

from __future__ import annotations

import pytest

from jointid.cli.main import main
from jointid.errors import DataError
from jointid.measurement.impact_files import read_impact_csv
from jointid.study import MAX_LINES, MAX_NODES

from test_uff_units import STUDY


def _run(capsys, *argv):
    code = main(list(argv))
    cap = capsys.readouterr()
    return code, cap.err.strip()


@pytest.fixture()
def study(tmp_path):
    p = tmp_path / "study.toml"
    p.write_text(STUDY)
    return p


def test_non_utf8_and_semicolon_frf_csv(tmp_path, study, capsys):
    p = tmp_path / "latin.csv"
    p.write_bytes("# kind = accelerance\nfrequency_hz,response,reference,real,imag\n# café\n".encode("latin-1"))
    code, err = _run(capsys, "identify", str(study), "--frf", str(p), "--out", str(tmp_path / "o"))
    assert code == 2 and err == (
        f"jointid identify: error: {p} line 3: not UTF-8 text (byte 0xe9); save the FRF CSV file as UTF-8 "
        "(e.g. 'CSV UTF-8' in a spreadsheet)"
    )
    q = tmp_path / "semi.csv"
    q.write_text("# kind = accelerance\nfrequency_hz;response;reference;real;imag\n5;3w;9w;1,0;2,0\n")
    code, err = _run(capsys, "identify", str(study), "--frf", str(q), "--out", str(tmp_path / "o"))
    assert code == 2 and err == (
        f"jointid identify: error: {q} line 2: the columns are separated by semicolons; jointid reads comma-separated "
        "CSV with '.' as the decimal point: export it so (or replace the separators)"
    )


def test_non_utf8_and_semicolon_stepsine_csv(tmp_path, capsys):
    p = tmp_path / "ss.csv"
    p.write_bytes(b"frequency_hz,time_s,displacement_m,force_n\n1,0,\xb5,1\n")
    code, err = _run(capsys, "direct", str(p), "--out", str(tmp_path / "o"))
    assert code == 2 and err == (
        f"jointid direct: error: {p} line 2: not UTF-8 text (byte 0xb5); save the step-sine CSV file as UTF-8 "
        "(e.g. 'CSV UTF-8' in a spreadsheet)"
    )
    q = tmp_path / "ss2.csv"
    q.write_text("frequency_hz;time_s;displacement_m;force_n\n1;0;0,1;1\n")
    code, err = _run(capsys, "direct", str(q), "--out", str(tmp_path / "o"))
    assert code == 2 and err.startswith(f"jointid direct: error: {q} line 1: the columns are separated by semicolons")


def test_non_utf8_and_semicolon_impact_csv(tmp_path):
    p = tmp_path / "imp.csv"
    p.write_bytes(b"excited_node,hit,time_s,force_n,3w\n9w,0,0,1,\xff\n")
    with pytest.raises(DataError, match=r"imp.csv line 2: not UTF-8 text \(byte 0xff\); save the impact CSV file as UTF-8"):
        read_impact_csv(p)
    q = tmp_path / "imp2.csv"
    q.write_text("excited_node\thit\ttime_s\tforce_n\t3w\n9w\t0\t0\t1\t0\n")
    with pytest.raises(DataError, match=r"imp2.csv line 1: the columns are separated by tabs"):
        read_impact_csv(q)


def test_non_utf8_study_file(tmp_path, capsys):
    p = tmp_path / "s.toml"
    p.write_bytes(STUDY.encode().replace(b"[beam]", b"# \xe9\n[beam]"))
    code, err = _run(capsys, "modes", str(p), "--out", str(tmp_path / "o"))
    assert code == 2 and err == f"jointid modes: error: {p} line 2: not UTF-8 text (byte 0xe9); save the study file as UTF-8"


def test_huge_grid_and_mesh_are_refused_naming_the_key(tmp_path, capsys):
    assert MAX_LINES == 1_000_000 and MAX_NODES == 10_000
    grid = tmp_path / "grid.toml"
    grid.write_text(STUDY.replace("step = 5.0", "step = 1e-6"))
    code, err = _run(capsys, "simulate", str(grid), "--out", str(tmp_path / "o"))
    assert code == 2 and err == (
        f"jointid simulate: error: {grid}: [frequency].step: 1e-06 Hz gives 9.95e+08 lines from 5 to 1000 Hz; "
        "at most 1000000 lines are allowed: raise step"
    )
    tiny = tmp_path / "tiny.toml"
    tiny.write_text(STUDY.replace("step = 5.0", "step = 1e-300"))
    code, err = _run(capsys, "simulate", str(tiny), "--out", str(tmp_path / "o"))
    assert code == 2 and "1e-300 Hz gives 9.95e+302 lines" in err  # no overflow, no huge allocation
    mesh = tmp_path / "mesh.toml"
    mesh.write_text(STUDY.replace("nodes = 19", "nodes = 1000000"))
    code, err = _run(capsys, "modes", str(mesh), "--out", str(tmp_path / "o"))
    assert code == 2 and err == f"jointid modes: error: {mesh}: [beam].nodes: expected an integer in 2..10000, got 1000000"
    edge = tmp_path / "edge.toml"  # exactly the limit is fine
    edge.write_text(STUDY.replace("start = 5.0", "start = 0.0").replace("stop = 1000.0", "stop = 999999.0").replace("step = 5.0", "step = 1.0"))
    from jointid.study import load_study

    assert load_study(edge).frequency.stop == 999999.0


@pytest.mark.parametrize("argv, line", [
    (["simulate", "s.toml", "--noise", "abc", "--out", "o"],
     "jointid simulate: error: argument --noise: invalid float value: 'abc' (see `jointid simulate --help`)"),
    (["simulate", "s.toml"], "jointid simulate: error: the following arguments are required: --out (see `jointid simulate --help`)"),
    (["modes", "--out", ""], "jointid modes: error: argument --out: expected a directory, got an empty path (for the "
                             "current directory give '.') (see `jointid modes --help`)"),
    (["campaign", "m.csv", "--out", " "], "jointid campaign: error: argument --out: expected a directory, got an empty path "
                                         "(for the current directory give '.') (see `jointid campaign --help`)"),
    (["nosuch"], "jointid: error: argument COMMAND: invalid choice: 'nosuch' (choose from 'reproduce', 'modes', 'simulate', "
                 "'identify', 'update', 'experiment', 'frf', 'direct', 'design', 'campaign') (see `jointid --help`)"),
])
def test_a_usage_error_is_one_line_exit_2(capsys, argv, line):
    """argparse's errors (a value of the wrong type, a missing option, an unknown command): one line, not the usage
    block before it."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert capsys.readouterr().err.splitlines() == [line]


def test_an_frf_file_outside_the_study_band_names_the_unit_and_the_key(study):
    """FRFs on an axis the study's band does not reach (a kHz axis read as Hz): the error says what to check."""
    import dataclasses

    from jointid.frequency import Frequency
    from jointid.pipeline import simulate, study_frfs
    from jointid.study import load_study

    st = load_study(study)
    frf = simulate(st).frf
    khz = dataclasses.replace(frf, frequency=Frequency(frf.frequency.hz / 1000.0))
    with pytest.raises(DataError) as err:
        study_frfs(st, khz)
    lo, hi = khz.frequency.hz[0], khz.frequency.hz[-1]
    assert str(err.value) == (
        f"the FRF file does not reach the study's band: no FRF line in {max(st.frequency.start, 1e-6)}..{st.frequency.stop} Hz "
        f"(data cover {lo:g}..{hi:g} Hz); check the file's frequency unit (Hz; a kHz or rad/s axis is not converted "
        f"without its label) or [frequency] start/stop in {st.source}")


def test_simulate_with_one_frequency_line_names_the_study_key(tmp_path, capsys):
    p = tmp_path / "one_line.toml"
    text = STUDY.splitlines()
    text = "\n".join("step = 5000.0" if line.strip().startswith("step =") else line for line in text) + "\n"
    p.write_text(text)
    code, err = _run(capsys, "simulate", str(p), "--out", str(tmp_path / "o"))
    assert code == 2 and err.startswith(f"jointid simulate: error: {p}: [frequency] gives 1 line (") and err.endswith(
        "step 5000); a simulated FRF file needs at least 2: lower step or widen start..stop")
    assert not (tmp_path / "o").exists()


def test_matplotlib_notices_do_not_reach_the_terminal(tmp_path):
    """An unwritable matplotlib config directory: matplotlib's two-line notice is not printed (--debug shows it)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "MPLCONFIGDIR": "/proc/nonexistent/mpl", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "jointid.cli.main", "modes", "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0 and r.stderr == "", r.stderr
