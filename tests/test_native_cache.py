"""The compiled-NLP cache cannot break a solve (planner.native_cache): a library is loaded only
when it matches the record published with it, so a truncated, damaged, unrecorded or foreign
one is removed and the solve runs interpreted, said once; a folder this process cannot read,
write or create, or a disk that fills up while compiling, means interpreted solves with one
warning naming ANTHROPOID_CACHE and the fix.

The solves that could crash run in child processes: before publication records, a library
truncated to half its size was loaded and killed every process that solved its structure
with SIGBUS (exit 135), the random-bytes case aside (the loader refuses those)."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from privileges import needs_permissions
from privileges import run as run_unprivileged
from test_native_nlp import needs_compiler, swing_up

from planner import native_cache, native_nlp, solve
from planner.solver import nlp_oracle
from planner.solver_cache import SOLVERS
from planner.transcription import Transcription

TESTS = str(Path(__file__).resolve().parent)

#: A child that solves the swing-up ``solves`` times (``weight`` picks the structure) and
#: prints what it found as JSON; the cache's warnings go to stderr, one line each.
CHILD = """
import json, logging, sys
sys.path.insert(0, {tests!r})
logging.basicConfig(level=logging.WARNING, format="WARNING %(name)s: %(message)s")
from test_native_nlp import swing_up
from planner import solve
found = []
for _ in range({solves}):
    solution = solve(swing_up(weight={weight!r}), compiled={compiled!r}, progress=False)
    found.append({{"compiled": solution.stats["compiled"], "success": solution.success,
                   "cost": solution.cost}})
print(json.dumps(found))
"""


@pytest.fixture(scope="module")
def reference_cost():
    return solve(swing_up(), compiled=False, progress=False).cost


def child(root, *, solves=1, compiled=None, weight=1.0, unprivileged=False, limit=None):
    """Run :data:`CHILD` with the cache at ``root``; (exit status, results, warning lines)."""
    environment = {
        **os.environ,
        native_cache.CACHE_ENV: str(root),
        native_nlp.MODE_ENV: "auto",
        "PYTHONPATH": os.pathsep.join(sys.path),
    }
    code = CHILD.format(tests=TESTS, solves=solves, compiled=compiled, weight=weight)
    argv = [sys.executable, "-c", code]
    kwargs = {"capture_output": True, "text": True, "env": environment, "timeout": 300}
    if limit is not None:
        # A disk that fills up: every file the child (and the compiler it runs) writes
        # stops at ``limit`` bytes (EFBIG, as ENOSPC for a full disk).
        kwargs["preexec_fn"] = lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    done = (run_unprivileged if unprivileged else subprocess.run)(argv, **kwargs)
    results = json.loads(done.stdout) if done.returncode == 0 else None
    warnings = [line for line in done.stderr.splitlines() if line.startswith("WARNING")]
    return done.returncode, results, warnings


def published(root) -> Path:
    """Compile the swing-up into ``root``'s cache (in this process) and return the library."""
    transcription = Transcription(swing_up())
    library = native_nlp.compile_library(
        nlp_oracle(transcription), transcription.structure_key, wait=True
    )
    record = native_cache.record_path(library)
    assert library is not None and record.is_file()
    assert Path(str(native_cache.folder())).parent == root
    # the record is as readable as a new file (a cache shared read-only checks against it)
    umask = os.umask(0o022)
    os.umask(umask)
    assert record.stat().st_mode & 0o777 == 0o666 & ~umask
    return library


def leftovers(root) -> list[str]:
    """Files of the cache other than lock files (a half-written library, a temporary)."""
    return sorted(p.name for p in Path(root).rglob("*") if p.is_file() and p.suffix != ".lock")


def assert_interpreted_and_right(status, results, reference, count=1):
    assert status == 0, "the child died"
    assert len(results) == count
    for result in results:
        assert result["success"] and result["compiled"] is False
        assert result["cost"] == pytest.approx(reference, rel=1e-9)


@needs_compiler
def test_a_truncated_library_is_removed_and_every_solve_runs_interpreted(nlp_cache, reference_cost):
    library = published(nlp_cache)
    size = library.stat().st_size
    os.truncate(library, size // 2)
    status, results, warnings = child(nlp_cache, solves=2)
    assert_interpreted_and_right(status, results, reference_cost, count=2)
    assert len(warnings) == 1, warnings
    assert f"{size // 2} bytes where {size} were published: truncated" in warnings[0]
    assert "removed, running interpreted" in warnings[0]
    assert not library.exists() and not native_cache.record_path(library).exists()
    # the next process finds nothing to warn about, and compiles it again when asked
    status, results, warnings = child(nlp_cache, compiled=True)
    assert status == 0 and results[0]["compiled"] is True and warnings == []


@needs_compiler
@pytest.mark.parametrize(
    "damage, said",
    [
        ("same size, other bytes", "its SHA-256 differs from the one published"),
        ("no record", "it has no publication record"),
        ("record unreadable", "its publication record cannot be read"),
    ],
)
def test_a_library_unlike_its_record_is_never_loaded(nlp_cache, reference_cost, damage, said):
    library = published(nlp_cache)
    record = native_cache.record_path(library)
    if damage == "same size, other bytes":
        data = bytearray(library.read_bytes())
        data[len(data) // 2 :] = np.random.default_rng(0).bytes(len(data) - len(data) // 2)
        library.write_bytes(bytes(data))
    elif damage == "no record":
        record.unlink()
    else:
        record.write_text("{not json")
    status, results, warnings = child(nlp_cache)
    assert_interpreted_and_right(status, results, reference_cost)
    assert len(warnings) == 1 and said in warnings[0], warnings
    assert not library.exists() and not record.exists()


def test_a_published_library_that_does_not_load_is_removed(nlp_cache, reference_cost, caplog):
    """Random bytes with a record that matches them (another machine's library under the
    same name, say): the loader refuses them; the solve runs interpreted and removes both."""
    key = Transcription(swing_up()).structure_key
    library = native_nlp.library_path(key)
    library.parent.mkdir(parents=True)
    library.write_bytes(np.random.default_rng(1).bytes(4096))
    size, sha = native_cache.digest(library)
    native_cache.record_path(library).write_text(json.dumps({"size": size, "sha256": sha}))
    assert native_nlp.ready(key) == library
    with caplog.at_level("WARNING", logger="planner.native_nlp"):
        solution = solve(swing_up(), progress=False)
    assert solution.success and not solution.stats["compiled"]
    assert solution.cost == pytest.approx(reference_cost, rel=1e-9)
    assert "does not load (built for another machine, or damaged); removed" in caplog.text
    assert not library.exists() and not native_cache.record_path(library).exists()


def test_a_library_is_hashed_once_per_process(nlp_cache, monkeypatch):
    key = Transcription(swing_up()).structure_key
    library = native_nlp.library_path(key)
    library.parent.mkdir(parents=True)
    library.write_bytes(b"\x7fELF" + bytes(1000))
    size, sha = native_cache.digest(library)
    native_cache.record_path(library).write_text(json.dumps({"size": size, "sha256": sha}))
    calls = []
    original = native_cache.digest
    monkeypatch.setattr(native_cache, "digest", lambda path: calls.append(path) or original(path))
    assert [native_nlp.ready(key) for _ in range(3)] == [library] * 3
    assert calls == [library]
    # a file changed since (another inode, size or time) is checked again, and refused
    library.write_bytes(b"\x7fELF" + bytes(999))
    assert native_nlp.ready(key) is None and not library.exists()


@pytest.mark.parametrize("where", ["a file", "below a file", "below /dev/null"])
def test_a_cache_path_that_cannot_be_a_folder_means_interpreted_solves(
    tmp_path, monkeypatch, caplog, reference_cost, where
):
    (tmp_path / "file").write_text("not a folder")
    root = {"a file": tmp_path / "file", "below a file": tmp_path / "file" / "cache",
            "below /dev/null": Path("/dev/null/cache")}[where]  # fmt: skip
    monkeypatch.setenv(native_cache.CACHE_ENV, str(root))
    monkeypatch.setenv(native_nlp.MODE_ENV, "auto")
    native_cache.forget()
    SOLVERS.clear()
    with caplog.at_level("WARNING", logger="planner.native_nlp"):
        solutions = [solve(swing_up(), compiled=compiled, progress=False)
                     for compiled in (None, True, None)]  # fmt: skip
    for solution in solutions:
        assert solution.success and not solution.stats["compiled"]
        assert solution.cost == pytest.approx(reference_cost, rel=1e-9)
    said = [r.getMessage() for r in caplog.records if r.name == "planner.native_nlp"]
    assert len(said) == 1, said
    assert "cannot be used (Not a directory" in said[0]
    assert "set ANTHROPOID_CACHE to a folder you can write (ANTHROPOID_CACHE is set)" in said[0]
    assert (tmp_path / "file").read_text() == "not a folder"
    native_cache.forget()


@needs_permissions
def test_an_unreadable_cache_folder_means_interpreted_solves(nlp_cache, reference_cost):
    library = published(nlp_cache)
    nlp_cache.chmod(0o000)
    try:
        for compiled in (None, True):
            status, results, warnings = child(nlp_cache, solves=2, compiled=compiled,
                                              unprivileged=True)  # fmt: skip
            assert_interpreted_and_right(status, results, reference_cost, count=2)
            assert len(warnings) == 1, warnings
            assert "cannot be used (Permission denied" in warnings[0]
            assert "set ANTHROPOID_CACHE to a folder you can write" in warnings[0]
    finally:
        nlp_cache.chmod(0o755)
    assert library.is_file()  # nothing removed that was fine


@needs_permissions
@needs_compiler
def test_a_read_only_cache_serves_its_libraries_and_compiles_none(nlp_cache, reference_cost):
    published(nlp_cache)
    folder = native_cache.folder()
    folder.chmod(0o555)
    try:
        status, results, warnings = child(nlp_cache, compiled=True, unprivileged=True)
        assert status == 0 and results[0]["compiled"] is True and warnings == []
        # another structure cannot be compiled into it: interpreted, said once
        status, results, warnings = child(nlp_cache, solves=2, compiled=True, weight=2.0,
                                          unprivileged=True)  # fmt: skip
        assert status == 0 and [r["compiled"] for r in results] == [False, False]
        assert len(warnings) == 1 and "cannot take the library (Permission denied" in warnings[0]
    finally:
        folder.chmod(0o755)


@needs_permissions
def test_a_cache_folder_that_cannot_be_created_means_interpreted_solves(tmp_path, reference_cost):
    parent = tmp_path / "read-only"
    parent.mkdir()
    parent.chmod(0o555)
    try:
        status, results, warnings = child(parent / "cache", compiled=True, unprivileged=True)
    finally:
        parent.chmod(0o755)
    assert_interpreted_and_right(status, results, reference_cost)
    assert len(warnings) == 1 and "cannot be used (Permission denied" in warnings[0], warnings
    assert list(parent.iterdir()) == []


@needs_compiler
@pytest.mark.parametrize(
    "limit, stage",
    [(16_000, "writing the NLP for the compiler"), (100_000, "compiling into it")],
)
def test_a_full_disk_while_compiling_leaves_nothing_and_solves_interpreted(
    nlp_cache, reference_cost, limit, stage
):
    """The serialised NLP (40 kB) or the generated C code (235 kB) does not fit: nothing
    half-written stays in the nlp_cache, the solve runs interpreted, said once."""
    status, results, warnings = child(nlp_cache, solves=2, compiled=True, limit=limit)
    assert_interpreted_and_right(status, results, reference_cost, count=2)
    assert len(warnings) == 1, warnings
    assert f"cannot take the library ({stage}" in warnings[0] and "File too large" in warnings[0]
    assert leftovers(nlp_cache) == []
    # with room again, the same structure compiles and serves
    status, results, warnings = child(nlp_cache, compiled=True)
    assert status == 0 and results[0]["compiled"] is True and warnings == []
