import csv
import subprocess
import sys

import numpy as np

from jointid.cli.main import main


def test_modes_writes_csv_and_prints(tmp_path, capsys):
    assert main(["modes", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "78.87 Hz" in out and "rigid body" in out
    rows = list(csv.DictReader(open(tmp_path / "modes.csv")))
    f = np.array([float(r["frequency_hz"]) for r in rows])
    assert [r["mode"] for r in rows[:3]] == ["1", "2", "3"]
    assert len(rows) == 38 and np.all(f[:2] < 1e-3)
    assert np.allclose(f[2:6], [78.87, 217.12, 424.81, 700.41], rtol=2e-3)
    assert (tmp_path / "modes_frf.png").stat().st_size > 10000


def test_console_script_error_is_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "jointid.cli.main", "modes", str(tmp_path / "none.toml"), "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "cannot read the study file" in r.stderr
