"""OutputSet: jointid replaces only what it wrote, all at once, with umask permissions, one run at a time."""

import json
import os
import stat

import pytest

from jointid.io.atomic import atomic_write_bytes
from jointid.io.output_dir import LOCK_NAME, MANIFEST_NAME, OutputError, OutputSet


def snapshot(root):
    """Every path under ``root`` -> (kind, content or None, mode): a directory's exact state."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = os.path.join(dirpath, name)
            st = os.lstat(p)
            content = open(p, "rb").read() if stat.S_ISREG(st.st_mode) else None
            out[os.path.relpath(p, root)] = (stat.S_IFMT(st.st_mode), content, stat.S_IMODE(st.st_mode))
    return out


def write_set(d, command="cmd", **files):
    with OutputSet(d, command) as o:
        for name, text in files.items():
            o.write_text(name.replace("__", "/"), text)
    return o


def test_first_run_creates_dir_files_and_manifest(tmp_path):
    d = tmp_path / "a" / "b"
    write_set(d, **{"x.txt": "1", "data__y.csv": "2"})
    assert sorted(p.relative_to(d).as_posix() for p in d.rglob("*")) == [MANIFEST_NAME, "data", "data/y.csv", "x.txt"]
    m = json.loads((d / MANIFEST_NAME).read_text())
    assert sorted(m["sets"]["cmd"]) == ["data/y.csv", "x.txt"] and m["directories"] == ["data"]


def test_out_is_a_file_refused_untouched(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("my notes")
    with pytest.raises(OutputError) as e:
        OutputSet(f, "cmd").open()
    assert str(e.value) == f"--out {f} is a file; give a directory"
    assert f.read_text() == "my notes" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_parent_is_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputError) as e:
        OutputSet(tmp_path / "f" / "sub", "cmd").open()
    assert str(e.value) == f"--out {tmp_path / 'f' / 'sub'}: cannot create the directory: Not a directory"


def test_other_files_survive_and_stale_files_go(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "mine.txt").write_text("user")
    (d / "figures").mkdir()  # the user's directory: never removed by jointid
    (d / "figures" / "keep.png").write_bytes(b"user png")
    write_set(d, **{"a.csv": "1", "b.png": "2", "figures__f.png": "3", "plots__g.png": "4"})
    write_set(d, **{"a.csv": "1b"})  # like a re-run with --no-plots
    assert (d / "a.csv").read_text() == "1b"
    assert not (d / "b.png").exists() and not (d / "figures" / "f.png").exists()
    assert not (d / "plots").exists()  # jointid created it, it is empty now
    assert (d / "mine.txt").read_text() == "user" and (d / "figures" / "keep.png").read_bytes() == b"user png"
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, "a.csv", "figures", "mine.txt"]


def test_clash_with_a_file_jointid_did_not_write(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "a.csv").write_text("user data")
    before = snapshot(d)
    with pytest.raises(OutputError) as e:
        write_set(d, **{"b.csv": "1", "a.csv": "2"})
    assert str(e.value) == f"{d / 'a.csv'} exists and was not written by jointid; move it or choose another --out"
    assert snapshot(d) == before


def test_edited_output_is_not_replaced_nor_removed(tmp_path):
    d = tmp_path / "d"
    write_set(d, **{"a.csv": "1", "b.csv": "2"})
    (d / "a.csv").write_text("edited by hand")
    with pytest.raises(OutputError) as e:
        write_set(d, **{"a.csv": "3"})
    assert str(e.value) == f"{d / 'a.csv'} was changed after jointid wrote it; move it or choose another --out"
    assert (d / "a.csv").read_text() == "edited by hand" and (d / "b.csv").read_text() == "2"
    (d / "b.csv").write_text("edited too")
    write_set(d, **{"c.csv": "4"})  # a.csv and b.csv are stale but edited: kept, and no longer jointid's
    assert (d / "a.csv").read_text() == "edited by hand" and (d / "b.csv").read_text() == "edited too"
    assert sorted(json.loads((d / MANIFEST_NAME).read_text())["sets"]["cmd"]) == ["c.csv"]


def test_commands_keep_each_others_files(tmp_path):
    d = tmp_path / "d"
    write_set(d, "simulate", **{"frf.uff": "frf", "true_joint.csv": "t"})
    write_set(d, "identify", **{"joint_stiffness.csv": "k", "true_joint.csv": "t2"})  # takes over true_joint.csv
    write_set(d, "identify", **{"joint_stiffness.csv": "k2"})
    assert (d / "frf.uff").read_text() == "frf" and not (d / "true_joint.csv").exists()
    sets = json.loads((d / MANIFEST_NAME).read_text())["sets"]
    assert sorted(sets["simulate"]) == ["frf.uff"] and sorted(sets["identify"]) == ["joint_stiffness.csv"]


def test_failure_while_computing_leaves_dir_exactly_as_before(tmp_path):
    d = tmp_path / "d"
    write_set(d, **{"a.csv": "1", "data__b.csv": "2"})
    (d / "mine.txt").write_text("user")
    before = snapshot(d)
    with pytest.raises(ZeroDivisionError):
        with OutputSet(d, "cmd") as o:
            o.write_text("a.csv", "new")
            o.write_text("new/c.csv", "new")
            1 / 0
    assert snapshot(d) == before  # no staging, no lock, no .old-* debris, same manifest
    new = tmp_path / "fresh" / "out"
    with pytest.raises(KeyboardInterrupt):
        with OutputSet(new, "cmd") as o:
            o.write_text("a.csv", "x")
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # the directories this run created are gone


def test_write_error_names_the_output_not_the_staging_file(tmp_path):
    d = tmp_path / "d"
    d.mkdir()

    def full_disk(path):
        raise OSError(28, "No space left on device", str(path))

    with pytest.raises(OutputError) as e:
        with OutputSet(d, "cmd") as o:
            o.write_file("frf.uff", full_disk)
    assert str(e.value) == f"cannot write {d / 'frf.uff'}: No space left on device"
    assert list(d.iterdir()) == []


@pytest.mark.parametrize("umask, file_mode, dir_mode", [(0o022, 0o644, 0o755), (0o027, 0o640, 0o750)])
def test_files_get_the_umask_permissions(tmp_path, umask, file_mode, dir_mode):
    old = os.umask(umask)
    try:
        d = tmp_path / "d"
        with OutputSet(d, "cmd") as o:
            o.write_text("a.csv", "1")
            o.write_bytes("figures/b.png", b"2")
        atomic_write_bytes(tmp_path / "api.bin", b"3")  # the API writers' atomic files too
    finally:
        os.umask(old)
    assert stat.S_IMODE((d / "a.csv").stat().st_mode) == file_mode
    assert stat.S_IMODE((d / "figures" / "b.png").stat().st_mode) == file_mode
    assert stat.S_IMODE((d / MANIFEST_NAME).stat().st_mode) == file_mode
    assert stat.S_IMODE((tmp_path / "api.bin").stat().st_mode) == file_mode
    assert stat.S_IMODE(d.stat().st_mode) == dir_mode and stat.S_IMODE((d / "figures").stat().st_mode) == dir_mode


def test_second_run_into_the_same_dir_is_refused(tmp_path):
    d = tmp_path / "d"
    first = OutputSet(d, "cmd").open()
    first.write_text("a.csv", "first")
    with pytest.raises(OutputError) as e:
        OutputSet(d, "cmd").open()
    assert str(e.value) == f"--out {d} is being written by another jointid run; wait for it to finish or choose another --out"
    first.commit()
    first.close()
    assert not (d / LOCK_NAME).exists()
    write_set(d, **{"a.csv": "second"})  # free again
    assert (d / "a.csv").read_text() == "second"


def test_debris_of_a_killed_run_is_cleaned(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / LOCK_NAME).write_text("")  # a lock file nobody holds
    (d / ".jointid-staging-dead").mkdir()
    (d / ".jointid-staging-dead" / "x.csv").write_text("half")
    write_set(d, **{"a.csv": "1"})
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, "a.csv"]


def test_bad_names_are_programming_errors(tmp_path):
    with OutputSet(tmp_path / "d", "cmd") as o:
        for bad in ("../x", "/etc/x", ".jointid-manifest.json", "a//b", ""):
            with pytest.raises(ValueError):
                o.write_text(bad, "x")
        o.write_text("ok.txt", "x")
        with pytest.raises(ValueError, match="written twice"):
            o.write_text("ok.txt", "y")


def test_a_sigterm_during_the_renames_is_held_until_the_set_is_complete(tmp_path, monkeypatch):
    """A signal between two renames would leave half a set: it is handled once every file is in place."""
    import signal

    from jointid.errors import Terminated
    from jointid.io import output_dir

    def on_term(signum, frame):
        raise Terminated(signum)

    previous = signal.signal(signal.SIGTERM, on_term)
    real_replace = os.replace
    calls = []

    def replace_and_signal(src, dst):
        calls.append(os.path.basename(dst))
        if calls[-1] == "a.txt":
            signal.raise_signal(signal.SIGTERM)  # arrives between the renames of a.txt and b.txt
        real_replace(src, dst)

    monkeypatch.setattr(output_dir.os, "replace", replace_and_signal)
    try:
        with pytest.raises(Terminated):
            with OutputSet(tmp_path / "out", "cmd") as out:
                out.write_text("a.txt", "a\n")
                out.write_text("b.txt", "b\n")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert [c for c in calls if c.endswith(".txt")] == ["a.txt", "b.txt"]  # both renames ran before the handler
    assert calls[-1] == ".jointid-manifest.json"  # and the final manifest
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [".jointid-manifest.json", "a.txt", "b.txt"]
    assert (tmp_path / "out" / "b.txt").read_text() == "b\n"


def test_check_refuses_a_users_file_without_staging_it(tmp_path):
    """OutputSet.check: the same one-line refusal as a write, before anything is computed; nothing staged, nothing left."""
    from jointid.io.output_dir import OutputError, OutputSet

    (tmp_path / "report.html").write_text("mine")
    with pytest.raises(OutputError, match=r"report\.html exists and was not written by jointid; move it or choose another --out$"):
        with OutputSet(tmp_path, command="t") as o:
            o.check("data/a.csv")  # a name not there: fine
            o.check("report.html")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"] and (tmp_path / "report.html").read_text() == "mine"
