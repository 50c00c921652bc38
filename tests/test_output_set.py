"""problems.cli.output_set: a command's files written as one set, or none of them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from privileges import needs_permissions
from privileges import run as run_unprivileged

from problems.cli.output_set import (
    MANIFEST,
    OutputFolderError,
    OutputSet,
    OutputWriteError,
    check_folder,
)


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


# ---- the folder stays the user's ---------------------------------------------------------------
def test_an_existing_folder_is_written_in_place_keeping_inode_mode_and_owner(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir(mode=0o700)
    folder.chmod(0o700)  # whatever the umask
    before = folder.stat()
    handle = os.open(folder, os.O_RDONLY)  # a shell sitting in it
    try:
        _run(folder, files=("a.csv", "old.gif"))
        _run(folder, files=("a.csv",))
        after = folder.stat()
        assert (after.st_ino, after.st_dev) == (before.st_ino, before.st_dev)
        assert after.st_mode == before.st_mode and after.st_uid == before.st_uid
        # what sits in it sees the files of the second run, no staging folder
        assert sorted(os.listdir(handle)) == ["a.csv", MANIFEST]
    finally:
        os.close(handle)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]
    manifest = json.loads((folder / MANIFEST).read_text())
    assert manifest["files"] == ["a.csv"] and manifest["complete"] is True


def test_a_symbolic_link_is_followed_and_stays_a_link(tmp_path):
    target = tmp_path / "target"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target)
    paths = _run(link)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert sorted(p.name for p in target.iterdir()) == ["a.csv", "b.png", MANIFEST]
    assert [str(p.parent) for p in paths] == [str(link)] * 3  # the folder as given
    _run(link, files=("a.csv",))  # again: in place, through the link
    assert link.is_symlink() and sorted(p.name for p in target.iterdir()) == ["a.csv", MANIFEST]
    # a dangling link: its target is made
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "made" / "here")
    _run(dangling)
    assert dangling.is_symlink()
    assert sorted(p.name for p in (tmp_path / "made" / "here").iterdir()) == [
        "a.csv", "b.png", MANIFEST]  # fmt: skip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dangling", "link", "made", "target"]


def test_the_working_folder_itself_can_be_the_output(tmp_path, monkeypatch):
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    _run(Path("."))
    assert sorted(p.name for p in here.iterdir()) == ["a.csv", "b.png", MANIFEST]
    _run(Path("."), files=("a.csv",))  # and again, in place
    assert sorted(p.name for p in here.iterdir()) == ["a.csv", MANIFEST]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here"]


def test_stagings_of_killed_runs_are_removed_by_the_next_run_and_live_ones_kept(tmp_path):
    """A run killed with SIGKILL (a process that cannot clean up) leaves its staging folder,
    beside a new folder or inside an existing one; the next run into the same folder or
    beside it removes those no live run holds, and refuses to write where a live run is."""
    existing = tmp_path / "existing"
    _run(existing)
    killed = [_staging_child(tmp_path / "new"), _staging_child(existing)]
    for process, _ in killed:
        process.kill()
        process.wait()
    left = sorted(p.name for p in tmp_path.iterdir())
    assert len(left) == 2 and left[0].startswith(".new.partial-") and left[1] == "existing"
    assert any(p.name.startswith(".partial-") for p in existing.iterdir())
    live, staging = _staging_child(tmp_path / "busy")
    try:
        _run(tmp_path / "other")  # a run beside them: the killed ones' stagings go
        assert sorted(p.name for p in tmp_path.iterdir()) == [staging.name, "existing", "other"]
        assert staging.is_dir()  # the live run's is kept
        _run(existing, files=("a.csv",))  # into the folder: its own leftover goes
        assert sorted(p.name for p in existing.iterdir()) == ["a.csv", MANIFEST]
        # a live run writing into an existing folder: another run is refused, nothing touched
        busy, inside = _staging_child(existing)
        try:
            with pytest.raises(OutputFolderError, match=r"another run is writing into .*existing"):
                OutputSet(existing, "walk")
            assert inside.is_dir()
        finally:
            busy.kill()
            busy.wait()
    finally:
        live.kill()
        live.wait()


def _staging_child(folder):
    """A child process that stages a run into ``folder`` (a 1 MB file) and waits to be
    killed; returns (the process, its staging folder)."""
    code = (
        "import sys, time\n"
        "from pathlib import Path\n"
        "from problems.cli.output_set import OutputSet\n"
        f"output = OutputSet(Path({str(folder)!r}), 'walk')\n"
        "output.path('torques.csv').write_bytes(bytes(1 << 20))\n"
        "print(output.staging, flush=True)\n"
        "time.sleep(600)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    staging = Path(process.stdout.readline().strip())
    assert staging.is_dir(), "the child did not stage"
    return process, staging


def test_a_commit_killed_halfway_leaves_a_folder_the_next_run_takes(tmp_path, monkeypatch):
    folder = tmp_path / "out"
    _run(folder, files=("a.csv", "b.png", "c.gif"))
    moved = []
    real_replace = os.replace

    def killed_after_one(source, target):
        if str(target).endswith(("a.csv", "d.txt")) and moved:
            raise KeyboardInterrupt  # the process dies here: nothing after runs
        moved.append(target)
        return real_replace(source, target)

    monkeypatch.setattr(os, "replace", killed_after_one)
    output = OutputSet(folder, "walk")
    for name in ("a.csv", "d.txt"):
        output.path(name).write_text("new " + name)
    with pytest.raises(KeyboardInterrupt):
        output.commit()
    monkeypatch.setattr(os, "replace", real_replace)
    # what a kill leaves: the staging (its lock released by the process's end), a manifest
    # that lists the earlier files and the new ones, incomplete
    output._release()
    manifest = json.loads((folder / MANIFEST).read_text())
    assert manifest["complete"] is False
    assert set(manifest["files"]) == {"a.csv", "b.png", "c.gif", "d.txt"}
    assert {p.name for p in folder.iterdir() if not p.name.startswith(".")} <= {
        *manifest["files"], MANIFEST}  # fmt: skip
    _run(folder, files=("a.csv",))
    assert sorted(p.name for p in folder.iterdir()) == ["a.csv", MANIFEST]
    assert json.loads((folder / MANIFEST).read_text())["complete"] is True


@needs_permissions
@pytest.mark.parametrize("where", ["the folder", "its parent"])
def test_a_folder_that_cannot_be_written_is_refused_before_the_run(tmp_path, where):
    locked = tmp_path / "ro"
    locked.mkdir()
    folder = locked if where == "the folder" else locked / "new"
    locked.chmod(0o555)
    code = (
        "import sys\n"
        "from pathlib import Path\n"
        "from problems.cli.output_set import OutputSet, OutputFolderError\n"
        f"try:\n    OutputSet(Path({str(folder)!r}), 'walk')\n"
        "except OutputFolderError as error:\n    print(error)\n    sys.exit(3)\n"
    )
    try:
        done = run_unprivileged([sys.executable, "-c", code], capture_output=True, text=True)
    finally:
        locked.chmod(0o755)
    assert done.returncode == 3, done.stderr
    doing = "write into" if where == "the folder" else "create"
    assert f"--output-dir: cannot {doing} {str(folder)!r} (Permission denied)" in done.stdout
    assert ".partial" not in done.stdout
    assert list(locked.iterdir()) == []


def test_a_write_that_fails_names_the_folder_as_given_not_the_staging(tmp_path):
    folder = tmp_path / "out"
    with pytest.raises(OutputWriteError) as caught, OutputSet(folder, "walk") as output:
        output.path("a.csv").write_text("a")
        raise OSError(28, "No space left on device", str(output.path("torques.csv")))
    message = str(caught.value)
    assert message == (f"--output-dir: writing torques.csv in {str(folder)!r} failed "
                       "(No space left on device)")  # fmt: skip
    assert list(tmp_path.iterdir()) == []


def test_folders_of_the_users_that_look_like_stagings_are_kept(tmp_path):
    """Only what a run stages is cleaned: a hidden folder of the user's with a matching name
    (a dated backup, a folder with subfolders) stays."""
    backup = tmp_path / ".notes.old-20231201"
    (backup / "drafts").mkdir(parents=True)
    partial = tmp_path / ".thesis.partial-20240101"
    (partial / "chapters").mkdir(parents=True)
    earlier = tmp_path / ".out.old-abcd1234"  # what an earlier version left: kept run files
    (earlier / "run").mkdir(parents=True)
    (earlier / "run" / "torques.csv").write_text("x")
    _run(tmp_path / "out")
    assert backup.is_dir() and partial.is_dir() and not earlier.exists()
