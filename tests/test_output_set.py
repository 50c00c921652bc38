"""problems.cli.output_set: a command's files written as one set, or none of them."""

from __future__ import annotations

import json
import os

import pytest

from problems.cli.output_set import MANIFEST, OutputFolderError, OutputSet, check_folder


def _run(folder, command="walk", files=("a.csv", "b.png"), fail=False):
    with OutputSet(folder, command) as output:
        for name in files:
            output.path(name).write_text(name)
        if fail:
            raise RuntimeError("the run failed")
        return output.commit({"note": 1})


def test_a_run_commits_its_files_and_a_manifest(tmp_path):
    folder = tmp_path / "deep" / "out"
    paths = _run(folder)
    assert sorted(p.name for p in folder.iterdir()) == ["a.csv", "b.png", MANIFEST]
    assert [p.name for p in paths] == ["a.csv", "b.png", MANIFEST]
    manifest = json.loads((folder / MANIFEST).read_text())
    assert manifest["command"] == "walk" and manifest["files"] == ["a.csv", "b.png"]
    assert manifest["note"] == 1
    # a new folder gets the usual permissions, not mkdtemp's private ones
    umask = os.umask(0)
    os.umask(umask)
    assert folder.stat().st_mode & 0o777 == 0o777 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["deep"]  # no staging left


def test_a_second_run_replaces_the_first_as_a_set(tmp_path):
    folder = tmp_path / "out"
    _run(folder, files=("a.csv", "old.gif"))
    _run(folder, files=("a.csv",))  # no GIF this time: the old one does not stay beside
    assert sorted(p.name for p in folder.iterdir()) == ["a.csv", MANIFEST]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_failed_run_leaves_nothing_of_itself(tmp_path):
    folder = tmp_path / "new" / "out"
    with pytest.raises(RuntimeError, match="the run failed"):
        _run(folder, fail=True)
    assert list(tmp_path.iterdir()) == []  # the parents it made are gone too
    _run(tmp_path / "kept", files=("a.csv",))
    with pytest.raises(RuntimeError):
        _run(tmp_path / "kept", files=("a.csv", "b.png"), fail=True)
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == ["a.csv", MANIFEST]
    assert (tmp_path / "kept" / "a.csv").read_text() == "a.csv"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept"]


def test_foreign_folders_are_refused_before_anything_is_written(tmp_path):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(OutputFolderError, match=r"is not empty \(notes.txt\) and is not an "):
        OutputSet(foreign, "walk")
    _run(tmp_path / "other", command="torques")
    with pytest.raises(OutputFolderError, match=r"the output of 'torques'"):
        OutputSet(tmp_path / "other", "walk")
    # an earlier run of the same command with a file it did not write: refused, not removed
    _run(tmp_path / "mixed")
    (tmp_path / "mixed" / "torques.json").mkdir()  # a folder in the way
    with pytest.raises(OutputFolderError, match=r"files it did not write \(torques.json\)"):
        OutputSet(tmp_path / "mixed", "walk")
    assert (tmp_path / "mixed" / "torques.json").is_dir()
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputFolderError, match="exists and is not a folder"):
        check_folder(tmp_path / "file", "walk")
    with pytest.raises(OutputFolderError, match="Not a directory"):
        check_folder(tmp_path / "file" / "below", "walk")
    assert (foreign / "notes.txt").read_text() == "mine"
    empty = tmp_path / "empty"
    empty.mkdir()
    _run(empty)  # an empty folder is taken
    assert (empty / MANIFEST).exists()
