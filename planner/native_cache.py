"""The disk cache of compiled NLP libraries (:mod:`planner.native_nlp`): where it is, whether
this process can use it, and libraries published only complete and checked before they load.

A compiled library is loaded into the solving process with ``dlopen``: a file that is not
what the compiler wrote does not fail politely. A library truncated by a full disk or a copy
cut short passes the loader's header checks and dies with ``SIGBUS`` when a page past its end
is touched, killing the process, and every later process that loads it. So nothing is loaded
that has not been checked against what was published.

* **Folder** (:func:`folder`): ``$ANTHROPOID_CACHE``, else ``$XDG_CACHE_HOME/anthropoid-planner``,
  else ``~/.cache/anthropoid-planner``; the libraries of one CasADi version, operating system
  and processor in ``nlp-casadi-<version>-<platform>-<machine>/`` below it. Deleting it is
  always safe.
* **Whether it can be used** (:func:`access`, once per process and folder): created if it is
  missing, listed, and a file created and removed in it. A folder that can be read and
  written serves and receives libraries; one that can be read only serves the libraries it
  holds (a cache a lab shares read-only) and compiles none; one that cannot be read (or
  created, or has a file in its way) is not used: the solves run interpreted, and the process
  says so once (a ``WARNING`` of the ``planner.native_nlp`` logger naming the folder, what
  failed, ``ANTHROPOID_CACHE`` and the fix). A cache never makes a solve fail.
* **Publication** (:func:`publish`, in the compiling process, under the compilation's lock):
  the library's size and SHA-256 go into a record ``<key>.so.sha256`` (JSON) and both are
  renamed into place, the record first: a library in the folder always has its record.
* **Checking** (:func:`checked`, before a library is loaded): its size and SHA-256 against
  its record, once per process and file (its inode, size and modification time are
  remembered: a re-solve does not read it again). A library without a record or unlike it
  (truncated, damaged, overwritten, another version's) is removed with its record, with one
  warning, and the solve runs interpreted; the automatic mode compiles it again when that
  pays. The check costs about 0.6 ms per MB of library: 1.6 ms for the walking step's
  2.8 MB, 5.6 ms for the step on feet's 10 MB, against about 100 ms for loading the library
  in a child process first, the other way to be safe (``examples/benchmarks/cache_checks.py``).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import platform
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from planner.files import new_file_mode

logger = logging.getLogger("planner.native_nlp")

#: The environment variable of the cache's root folder.
CACHE_ENV = "ANTHROPOID_CACHE"
#: The suffix of a library's publication record (beside ``<key>.so``).
RECORD_SUFFIX = ".sha256"
#: Bytes read at a time while hashing a library.
_CHUNK = 1 << 20


@dataclass(frozen=True)
class Access:
    """What this process may do with a cache folder: ``read`` (load the libraries it holds),
    ``write`` (compile into it), and ``reason`` (what failed, for the warning; "" when
    both are allowed)."""

    read: bool
    write: bool
    reason: str = ""


_access: dict[Path, Access] = {}
#: Libraries this process checked: path -> (inode, size, mtime_ns) when checked.
_checked: dict[Path, tuple[int, int, int]] = {}
#: Warnings said once per process (their texts).
_said: set[str] = set()
_lock = threading.Lock()


def folder() -> Path:
    """The folder of the compiled libraries of this CasADi version (see the module)."""
    root = os.environ.get(CACHE_ENV)
    if root:
        base = Path(root).expanduser()
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "anthropoid-planner"
    # Compiled code belongs to its CasADi version, operating system and processor (a home
    # folder shared by machines of other kinds keeps their libraries apart).
    return base / f"nlp-casadi-{ca.__version__}-{sys.platform}-{platform.machine() or 'cpu'}"


def library_path(key: str) -> Path:
    """Where the library of the NLP structure ``key`` is published."""
    suffix = ".dll" if sys.platform == "win32" else ".so"
    return folder() / f"{key}{suffix}"


def record_path(library: Path) -> Path:
    """The publication record of ``library``: its size and SHA-256."""
    return library.with_name(library.name + RECORD_SUFFIX)


def warn_once(message: str) -> None:
    """A warning of the cache, said once per process."""
    with _lock:
        if message in _said:
            return
        _said.add(message)
    logger.warning("%s", message)


def _fix() -> str:
    where = "is set" if os.environ.get(CACHE_ENV) else "is not set (the default folder)"
    return (
        f"running interpreted; set {CACHE_ENV} to a folder you can write ({CACHE_ENV} {where}), "
        "or ANTHROPOID_COMPILE=never to solve interpreted without this warning"
    )


def access() -> Access:
    """Whether this process can read and write the cache folder (checked once per process
    and folder; see the module). Says once what is wrong when it cannot write."""
    path = folder()
    with _lock:
        known = _access.get(path)
    if known is not None:
        return known
    found = _probe(path)
    with _lock:
        _access[path] = found
    if not found.read:
        warn_once(f"the compiled-NLP cache folder {str(path)!r} cannot be used ({found.reason}); "
                  + _fix())  # fmt: skip
    return found


def _probe(path: Path) -> Access:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        return Access(False, False, _said_by(error, path))
    try:
        with os.scandir(path) as entries:
            for _ in entries:
                break
    except OSError as error:
        return Access(False, False, _said_by(error, path))
    try:
        handle, probe = tempfile.mkstemp(dir=path, prefix=".probe.")
        os.close(handle)
        os.unlink(probe)
    except OSError as error:
        return Access(True, False, _said_by(error, path))
    return Access(True, True)


def _said_by(error: OSError, path: Path) -> str:
    """An OSError as "<what> (<file>)", the file named when it is not the folder itself."""
    what = error.strerror or type(error).__name__
    name = error.filename
    if name is not None and Path(os.fsdecode(name)) != path:
        return f"{what}: {os.fsdecode(name)!r}"
    return what


def cannot_write(doing: str) -> None:
    """Say once that the cache folder cannot take a library (it is read-only to this process,
    or a write failed: ``doing`` says which) and that the solve runs interpreted."""
    warn_once(f"the compiled-NLP cache folder {str(folder())!r} cannot take the library "
              f"({doing}); " + _fix())  # fmt: skip


def digest(path: Path) -> tuple[int, str]:
    """(size in bytes, SHA-256 hex) of a file."""
    sha = hashlib.sha256()
    size = 0
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            sha.update(chunk)
            size += len(chunk)
    return size, sha.hexdigest()


def publish(built: Path, library: Path) -> None:
    """Put the complete library ``built`` (in the cache's file system) in place as
    ``library``: its record first, then the library, each by an atomic rename."""
    size, sha = digest(built)
    record = record_path(library)
    handle, temporary = tempfile.mkstemp(dir=library.parent, prefix=f".{record.name}.")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as out:
            json.dump({"size": size, "sha256": sha}, out)
            out.flush()
            os.fsync(out.fileno())
        # readable as the library is (mkstemp makes it private): a cache shared read-only
        # by other users checks its libraries against it
        os.chmod(temporary, new_file_mode())
        os.replace(temporary, record)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    os.replace(built, library)


def checked(library: Path) -> Path | None:
    """``library`` when it is there and matches its publication record; None when it is not
    there. One that does not match (or has no record, or cannot be read) is removed with its
    record, saying so once, and None is returned: the solve runs interpreted."""
    try:
        status = library.stat()
    except FileNotFoundError:
        return None
    except OSError as error:
        said = _said_by(error, library)
        warn_once(f"the compiled library {str(library)!r} cannot be read ({said}); " + _fix())
        return None
    stamp = (status.st_ino, status.st_size, status.st_mtime_ns)
    with _lock:
        if _checked.get(library) == stamp:
            return library
    problem = _mismatch(library, status.st_size)
    if problem is None:
        with _lock:
            _checked[library] = stamp
        return library
    discard(library, problem)
    return None


def _mismatch(library: Path, size: int) -> str | None:
    """What is wrong with ``library`` against its record, or None."""
    try:
        record = json.loads(record_path(library).read_text(encoding="utf-8"))
        expected, expected_sha = int(record["size"]), str(record["sha256"])
    except FileNotFoundError:
        return "it has no publication record: not written by this version, or cut short"
    except (OSError, ValueError, KeyError, TypeError) as error:
        return f"its publication record cannot be read ({error})"
    if size != expected:
        return f"{size} bytes where {expected} were published: truncated or overwritten"
    try:
        _, sha = digest(library)
    except OSError as error:
        return f"it cannot be read ({_said_by(error, library)})"
    if sha != expected_sha:
        return "its SHA-256 differs from the one published: damaged or overwritten"
    return None


def discard(library: Path, problem: str) -> None:
    """Remove a library that must not be loaded (``problem`` says why) and its record, saying
    so once; the automatic mode compiles the structure again when it pays."""
    removed = True
    for path in (library, record_path(library)):
        try:
            path.unlink()
        except FileNotFoundError:
            pass
        except OSError:
            removed = False
    with _lock:
        _checked.pop(library, None)
    action = "removed" if removed else "left in place (the folder is read-only to this process)"
    # a library holds an NLP's functions or one function (planner.native_function): what
    # runs without it is the same, interpreted
    warn_once(f"the compiled library {library.name} is not loaded: {problem}; {action}, "
              "running interpreted")  # fmt: skip


def forget() -> None:
    """Forget what this process learnt of cache folders and libraries (tests; a folder whose
    permissions were changed)."""
    with _lock:
        _access.clear()
        _checked.clear()
        _said.clear()


@contextlib.contextmanager
def file_lock(path: Path):
    """An exclusive lock on ``path`` across processes (POSIX; elsewhere none: the atomic
    rename still keeps readers safe, two processes may then both compile)."""
    try:
        import fcntl
    except ImportError:  # Windows
        yield
        return
    with open(path, "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


__all__ = [
    "CACHE_ENV",
    "Access",
    "access",
    "cannot_write",
    "checked",
    "digest",
    "discard",
    "file_lock",
    "folder",
    "forget",
    "library_path",
    "publish",
    "record_path",
]
