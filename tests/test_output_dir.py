"""OutputSet: jointid replaces only what it wrote, all at once, with umask permissions, one run at a time."""

import json
import os
import stat
from pathlib import Path

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


def signal_at_rename(monkeypatch, name, signum):
    """Deliver ``signum`` to this process as output ``name`` is renamed into place (a signal between two renames)."""
    import signal

    from jointid.io import output_dir

    real_replace = os.replace

    def replace(src, dst):
        if os.path.basename(dst) == name:
            signal.raise_signal(signum)
        real_replace(src, dst)

    monkeypatch.setattr(output_dir.os, "replace", replace)


def replace_failing(monkeypatch, fails):
    """The writer's renames raise ``OSError(*fails(src, dst), dst)`` where ``fails`` returns (errno, text), else rename."""
    from jointid.io import output_dir

    real_replace = os.replace

    def replace(src, dst):
        err = fails(str(src), os.path.basename(dst))
        if err:
            raise OSError(*err, str(dst))
        real_replace(src, dst)

    monkeypatch.setattr(output_dir.os, "replace", replace)


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
    assert str(e.value) == f"--out {tmp_path / 'f' / 'sub'}: cannot create the directory: Not a directory; give another --out"


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
    (d / ".jointid-staging-dead" / ".jointid-staging").write_text("")  # the mark every staging area gets
    (d / ".jointid-staging-dead" / "x.csv").write_text("half")
    (d / ".jointid-staging-notes").mkdir()  # a user's directory of that name (no mark): kept
    (d / ".jointid-staging-notes" / "mine.txt").write_text("mine")
    (d / ("." + MANIFEST_NAME + ".1f2e3d4c5b6a.json")).write_text("{")  # the manifest's temporary file, SIGKILLed
    write_set(d, **{"a.csv": "1"})
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, ".jointid-staging-notes", "a.csv"]
    assert (d / ".jointid-staging-notes" / "mine.txt").read_text() == "mine"


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


def _forge(d, names, dirs=()):
    """Add ``names`` (name -> the file whose real SHA-256 it gets) and ``dirs`` to the manifest's 'cmd' set: an edited
    manifest."""
    import hashlib

    m = json.loads((d / MANIFEST_NAME).read_text())
    for name, path in names.items():
        m["sets"]["cmd"][name] = [hashlib.sha256(open(path, "rb").read()).hexdigest()]
    m["directories"] += list(dirs)
    (d / MANIFEST_NAME).write_text(json.dumps(m))


def test_an_edited_manifest_cannot_make_jointid_touch_anything_outside_dir(tmp_path):
    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1"})
    victim, absolute, empty = tmp_path / "victim.txt", tmp_path / "abs.txt", tmp_path / "empty_dir"
    victim.write_text("mine")
    absolute.write_text("mine too")
    empty.mkdir()
    _forge(d, {"../victim.txt": victim, str(absolute): absolute, ".jointid.lock/../../victim.txt": victim},
           dirs=["../empty_dir", str(empty)])
    before = snapshot(tmp_path / "victim.txt"), victim.read_text(), absolute.read_text()
    write_set(d, **{"b.txt": "2"})  # a.txt and the forged names are this command's stale set now
    assert (victim.read_text(), absolute.read_text()) == before[1:] and empty.is_dir()
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, "b.txt"]


def test_a_symlinked_subdirectory_is_refused_and_what_it_points_to_untouched(tmp_path):
    d = tmp_path / "d"
    write_set(d, **{"figures__a.png": "1", "figures__b.png": "2"})
    archive = tmp_path / "archive"
    os.rename(d / "figures", archive)
    os.symlink(archive, d / "figures")
    before = snapshot(tmp_path)
    with pytest.raises(OutputError) as e:
        write_set(d, **{"figures__a.png": "new"})
    assert str(e.value) == (f"{d / 'figures'} is a symbolic link and jointid would write {d / 'figures' / 'a.png'} through it "
                            "(jointid writes only into real directories of --out); replace it by a directory or choose another --out")
    write_set(d, **{"c.txt": "3"})  # its stale figures/a.png, b.png behind the link: not removed
    after = snapshot(tmp_path)
    assert {k: v for k, v in after.items() if k.startswith("archive")} == {k: v for k, v in before.items() if k.startswith("archive")}


def test_a_directory_not_writable_is_found_before_the_first_rename(tmp_path, monkeypatch):
    """figures/ not writable (os.access says so, as for a user without root): the set is refused before any rename,
    naming the directory, and DIR is as before (a.txt, renamed first, was the half-new set the audit found)."""
    from jointid.io import output_dir

    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1", "figures__p.png": "1"})
    before = snapshot(d)
    real_access = os.access
    monkeypatch.setattr(output_dir.os, "access", lambda p, mode: False if os.path.basename(p) == "figures" else real_access(p, mode))
    with pytest.raises(OutputError) as e:
        write_set(d, **{"a.txt": "2", "figures__p.png": "2", "figures__q.png": "2"})
    assert str(e.value) == f"cannot write into {d / 'figures'}: permission denied; make it writable or choose another --out"
    assert snapshot(d) == before


def test_a_rename_that_fails_midway_is_undone(tmp_path, monkeypatch):
    """The third of three renames fails (whatever the cause): the two placed files are put back as they were."""
    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1", "b.txt": "1"})
    before = snapshot(d)
    replace_failing(monkeypatch, lambda src, name: (28, "No space left on device") if name == "c.txt" else None)
    with pytest.raises(OutputError, match=r"No space left on device .*c\.txt\); the previous files are back; fix that and run again$"):
        write_set(d, **{"a.txt": "2", "b.txt": "2", "c.txt": "2"})
    monkeypatch.undo()
    assert snapshot(d) == before


def test_a_signal_during_the_commit_is_raised_after_it_and_the_commit_recorded(tmp_path, monkeypatch):
    import signal

    from jointid.errors import Terminated
    from jointid.io import output_dir

    def on_term(signum, frame):
        raise Terminated(signum)

    previous = signal.signal(signal.SIGTERM, on_term)
    signal_at_rename(monkeypatch, "a.txt", signal.SIGTERM)
    n = len(output_dir.commits())
    try:
        with pytest.raises(Terminated):
            write_set(tmp_path / "out", command="sig", **{"a.txt": "a"})
    finally:
        signal.signal(signal.SIGTERM, previous)
    (last,) = output_dir.commits()[n:]
    assert (last.directory, last.command, last.files) == (tmp_path / "out", "sig", ("a.txt",))


def test_a_file_taken_over_from_another_command_is_recorded(tmp_path):
    from jointid.io import output_dir

    d = tmp_path / "d"
    write_set(d, command="identify", **{"report.html": "i", "joint_stiffness.csv": "k"})
    write_set(d, command="update", **{"report.html": "u"})
    assert output_dir.commits()[-1].taken_over == {"report.html": "identify"}


def test_reserved_names_do_not_act_on_what_they_point_to(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    os.symlink(tmp_path / "outside_lock", d / LOCK_NAME)  # a dangling lock symlink
    with pytest.raises(OutputError, match=r"\.jointid\.lock is a symbolic link \(jointid's lock file name\); remove it"):
        write_set(d, **{"a.txt": "1"})
    assert not os.path.lexists(tmp_path / "outside_lock")


def test_dangling_out_link_and_unreadable_manifest_messages(tmp_path):
    link = tmp_path / "out"
    os.symlink(tmp_path / "gone", link)
    with pytest.raises(OutputError) as e:
        write_set(link, **{"a.txt": "1"})
    assert str(e.value) == f"--out {link} is a symbolic link to {tmp_path / 'gone'}, which does not exist; create that directory or give another --out"
    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1"})
    (d / MANIFEST_NAME).write_text("{ not json")
    with pytest.raises(OutputError) as e:
        write_set(d, **{"a.txt": "2"})
    assert str(e.value) == (f"{d / 'a.txt'} exists, and jointid's record of the files it wrote ({d / MANIFEST_NAME}) cannot be "
                            "read; move the file away or choose another --out")


def test_a_directory_that_cannot_be_made_leaves_no_parent_behind(tmp_path):
    out = tmp_path / "new1" / "new2" / ("x" * 300)  # a name too long for the file system
    with pytest.raises(OutputError, match=r"cannot create the directory: .+; give another --out$"):  # the OS says why
        OutputSet(out, "cmd").open()
    assert list(tmp_path.iterdir()) == []


def test_a_put_back_that_fails_keeps_the_manifest_that_lists_both_contents(tmp_path, monkeypatch):
    """c.txt's rename fails and b.txt's old content cannot be put back: b.txt is new on disk, so the manifest must
    still own it (the transition one: old and new hash), or the next run would refuse it as not jointid's."""
    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1", "b.txt": "1"})
    replace_failing(monkeypatch, lambda src, name: (5, "Input/output error")
                    if name == "c.txt" or (".jointid-previous" in src and name == "b.txt") else None)
    with pytest.raises(OutputError, match=r"some previous files could not be put back \(they are kept in .*/\.jointid-previous-"
                                          r"\w+/files\); fix that and run again$") as e:
        write_set(d, **{"a.txt": "2", "b.txt": "2", "c.txt": "2"})
    monkeypatch.undo()
    kept = Path(str(e.value).split("kept in ")[1].split(")")[0])
    assert (kept / "b.txt").read_text() == "1"  # the previous b.txt is not lost with the staging area
    assert (d / "a.txt").read_text() == "1" and (d / "b.txt").read_text() == "2" and not (d / "c.txt").exists()
    write_set(d, **{"a.txt": "3", "b.txt": "3"})  # b.txt is still jointid's: replaced, not refused
    assert (d / "b.txt").read_text() == "3"


def test_a_failure_after_the_renames_leaves_a_recorded_complete_commit(tmp_path, monkeypatch):
    from jointid.io import output_dir

    d = tmp_path / "d"
    write_set(d, **{"a.txt": "1"})
    real_write = output_dir.write_manifest
    calls = []

    def write(directory, manifest):
        calls.append(1)
        if len(calls) == 2:  # the final manifest, after every rename
            raise OSError(28, "No space left on device")
        real_write(directory, manifest)

    monkeypatch.setattr(output_dir, "write_manifest", write)
    n = len(output_dir.commits())
    with pytest.raises(OutputError, match=r"is complete but its record .* could not be updated: No space left on device$"):
        write_set(d, **{"a.txt": "2"})
    monkeypatch.setattr(output_dir, "write_manifest", real_write)
    assert (d / "a.txt").read_text() == "2" and output_dir.commits()[n:][0].files == ("a.txt",)
    write_set(d, **{"a.txt": "3"})  # the transition manifest owns both contents: the next run goes on
    assert (d / "a.txt").read_text() == "3"
