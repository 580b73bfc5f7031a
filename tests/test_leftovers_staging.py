"""Staging folders of an older jointid (no mark file): removed only when they hold nothing but jointid's outputs."""

from __future__ import annotations

import os

from jointid.io.output_dir import MANIFEST_NAME, OutputSet
from jointid.io.staging import KNOWN_OUTPUT_NAMES, STAGING_MARK, unknown_entry


def write_set(d, command="cmd", **files):
    with OutputSet(d, command) as o:
        for name, text in files.items():
            o.write_text(name.replace("__", "/"), text)


def test_unmarked_staging_holding_only_jointids_files_is_removed(tmp_path, capsys):
    d = tmp_path / "d"
    write_set(d, **{"a.csv": "1", "figures__x.png": "png"})  # the manifest lists a.csv and figures/x.png
    old = d / ".jointid-staging-k3j_9x0a"  # an older jointid's staging (no mark), SIGKILLed while staging
    (old / "figures").mkdir(parents=True)
    (old / "figures" / "x.png").write_text("half")
    (old / "a.csv").write_text("half")
    (old / "report.html").write_text("half")  # a name every report command writes, not (yet) in the manifest
    (old / "data").mkdir()  # an empty subdirectory it made
    write_set(d, **{"a.csv": "2", "figures__x.png": "png"})
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, "a.csv", "figures"]
    assert capsys.readouterr().err == ""


def test_unmarked_staging_with_a_file_jointid_does_not_write_is_left_and_named_once(tmp_path, capsys):
    d = tmp_path / "d"
    write_set(d, **{"a.csv": "1"})
    old = d / ".jointid-staging-abcd1234"
    (old / "sub").mkdir(parents=True)
    (old / "a.csv").write_text("half")
    (old / "sub" / "notes.txt").write_text("mine")
    write_set(d, "identify", **{"b.csv": "2"})
    write_set(d, "identify", **{"b.csv": "3"})  # a second run in this process: not said again
    assert (old / "sub" / "notes.txt").read_text() == "mine" and (old / "a.csv").read_text() == "half"
    assert capsys.readouterr().err == (
        f"jointid identify: note: left {old}: it is named like the staging folder of a stopped run of an older jointid, "
        "but holds sub/notes.txt, which jointid does not write there; look inside, then move or remove it yourself\n")


def test_unmarked_staging_with_a_link_or_another_name_is_left(tmp_path, capsys):
    d = tmp_path / "d"
    d.mkdir()
    elsewhere = tmp_path / "elsewhere.csv"
    elsewhere.write_text("mine")
    linked = d / ".jointid-staging-linked00"
    linked.mkdir()
    os.symlink(elsewhere, linked / "report.html")  # a link named like an output: not a file jointid wrote
    named = d / ".jointid-staging-mine"  # not mkdtemp's 8 characters: not a staging folder at all
    named.mkdir()
    (named / "report.html").write_text("mine")
    write_set(d, **{"a.csv": "1"})
    assert os.path.islink(linked / "report.html") and elsewhere.read_text() == "mine"
    assert (named / "report.html").read_text() == "mine"
    err = capsys.readouterr().err.splitlines()
    assert err == [f"jointid cmd: note: left {linked}: it is named like the staging folder of a stopped run of an older "
                   "jointid, but holds report.html, which jointid does not write there; look inside, then move or remove "
                   "it yourself"]


def test_marked_staging_is_removed_whatever_it_holds(tmp_path, capsys):
    d = tmp_path / "d"
    old = d / ".jointid-staging-whatever"
    old.mkdir(parents=True)
    (old / STAGING_MARK).write_text("")
    (old / "anything.bin").write_text("staged")
    write_set(d, **{"a.csv": "1"})
    assert sorted(p.name for p in d.iterdir()) == [MANIFEST_NAME, "a.csv"]
    assert capsys.readouterr().err == ""


def test_unknown_entry_walks_the_folder(tmp_path):
    (tmp_path / "s" / "figures").mkdir(parents=True)
    (tmp_path / "s" / "figures" / "x.png").write_text("")
    (tmp_path / "s" / "summary.json").write_text("")
    assert "summary.json" in KNOWN_OUTPUT_NAMES
    assert unknown_entry(tmp_path / "s", {"figures/x.png", "summary.json"}) == (None, ["summary.json", "figures/x.png"],
                                                                               ["figures"])
    assert unknown_entry(tmp_path / "s", {"summary.json"})[0] == "figures/x.png"
