"""NLP functions compiled to native code by the system's C compiler, kept in a disk cache.

IPOPT calls five functions of the NLP every iteration: the objective, the constraints, the
objective's gradient, the constraints' Jacobian and the Lagrangian's Hessian. CasADi
evaluates them in its virtual machine; generated as C and compiled, the same functions run
in about half the time on the walking step (``examples/benchmarks/solve_breakdown.py``). A
compilation takes seconds (the six-link walking step, Hermite-Simpson N = 30: about 11 s at
``-O1``), so it pays only for a structure solved more than once, and it is kept on disk.

* **Key**: the NLP's :attr:`planner.transcription.Transcription.structure_key` (SHA-256 of the
  serialised NLP function: the same key computes the same f and g from the same (w, p), and
  its Jacobian's AD mode follows from the structure) and the CasADi version (the folder).
  Bounds, scales, durations and guesses are arguments of the NLP, not part of the code.
* **Where**: the disk cache of :mod:`planner.native_cache` (``$ANTHROPOID_CACHE``, else
  ``$XDG_CACHE_HOME/anthropoid-planner``, else ``~/.cache/anthropoid-planner``; one
  ``<key>.so`` per structure, with its publication record, under
  ``nlp-casadi-<version>-<platform>-<machine>/``). Deleting the folder is always safe; a
  library is checked against its record before it loads, and one that does not match or
  does not load is removed and the solve runs interpreted; a folder this process cannot use
  means interpreted solves, said once. The cache never makes a solve fail.
* **How**: in a separate Python process (``python -m planner.native_nlp``), from the
  serialised NLP: CasADi generates the derivatives and the C code there, the compiler builds
  a shared library in a work folder, and :func:`planner.native_cache.publish` puts it in
  place with its record (atomic renames). A lock file makes processes that want the same
  structure at once (the workers of a study) wait for one compilation instead of each
  running its own; a reader never sees a half-written library. Nothing of it runs in the
  solving process, so a compilation in the background does not hold up the solves
  meanwhile. A compilation that cannot write (a full disk, a file-size limit) leaves nothing
  and the solve runs interpreted, said once.
* **When** (:func:`planner.solver.solve`'s ``compiled``): ``True`` compiles now (waiting) and
  solves with the library; ``False`` never; ``None`` (default) follows
  ``$ANTHROPOID_COMPILE``: ``auto`` (the default) uses a library the cache already holds,
  and, with a C compiler at hand, starts compiling in the background once a process has
  spent about as long solving a structure as compiling it would take
  (:func:`worth_compiling`); the solves after it is ready use it. ``never`` turns it off.
  Without a compiler everything works as before, interpreted.
* **Compiler**: ``$CC`` if set, else ``cc``, ``gcc`` or ``clang`` on the PATH.
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

import casadi as ca

from planner import native_cache
from planner.errors import DefinitionError

logger = logging.getLogger(__name__)

#: The compiler's optimisation: ``-O1`` runs the walking step's functions as fast as ``-O2``
#: (6 ms per IPOPT iteration either way, measured) and compiles in 11 s instead of 17 s;
#: ``-O0`` compiles in 3 s but runs at 8 ms.
OPTIMISATION = "-O1"
#: A compilation's expected seconds per second of building the interpreted solver (CasADi
#: generating the derivatives): measured 140 on the six-link walking step (11 s against
#: 0.08 s), 52 on the fixed-base gait (4.8 s against 0.09 s); and the least it takes.
COMPILE_PER_BUILD, MINIMUM_COMPILE_SECONDS = 100.0, 0.5
#: Environment variables: the cache folder, and the automatic mode (auto, never).
CACHE_ENV, MODE_ENV = native_cache.CACHE_ENV, "ANTHROPOID_COMPILE"
MODES = ("auto", "never")
#: The NLP's functions the library holds (nlpsol loads them by these names).
ORACLE = "nlp"
#: The compiling process's exit status when the cache could not take the library (a full
#: disk, a file-size limit, a folder it cannot write): the solve runs interpreted.
CACHE_FAILURE = 3
#: What the compiler and linker say when they cannot write (errno texts).
WRITE_ERRORS = tuple(os.strerror(code) for code in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT))

_pending: dict[str, subprocess.Popen] = {}
_failed: set[str] = set()
_lock = threading.Lock()


def worth_compiling(entry) -> bool:
    """Whether the automatic mode compiles a structure now: once the process has spent as
    long solving it interpreted as its compilation is expected to take (the rule of renting
    skis until their price is paid: never more than twice the best choice's time, whatever
    the number of solves to come). A study that solves each structure a few times stays
    interpreted; a refinement, a continuation or a long study of one structure compiles.
    ``entry``: the :class:`planner.solver_cache.CachedSolver` (its build and solve seconds)."""
    expected = max(MINIMUM_COMPILE_SECONDS, COMPILE_PER_BUILD * entry.build_seconds)
    return entry.uses >= 1 and entry.solve_seconds >= expected


def compiler() -> str | None:
    """The C compiler's path: ``$CC`` if set (a name on the PATH or a path), else ``cc``,
    ``gcc`` or ``clang``; None when none is there."""
    given = os.environ.get("CC")
    for name in [given] if given else ["cc", "gcc", "clang"]:
        found = shutil.which(name)
        if found:
            return found
    return None


def mode() -> str:
    """The automatic mode from ``$ANTHROPOID_COMPILE`` (auto by default)."""
    value = os.environ.get(MODE_ENV, "auto").strip().lower() or "auto"
    if value not in MODES:
        raise DefinitionError(
            f"`{MODE_ENV}`: unknown value {value!r}; use one of {MODES} (or leave it unset)"
        )
    return value


def cache_folder() -> Path:
    """The folder of the compiled libraries of this CasADi version
    (:func:`planner.native_cache.folder`)."""
    return native_cache.folder()


def library_path(key: str) -> Path:
    """Where the library of the NLP structure ``key`` is published."""
    return native_cache.library_path(key)


def discard(path: Path) -> None:
    """Remove a published library that does not load (built for another machine, or damaged
    past its record), saying so once; the automatic mode compiles the structure again when
    it pays."""
    native_cache.discard(path, "it does not load (built for another machine, or damaged)")


def ready(key: str) -> Path | None:
    """The library of ``key`` when the cache holds it, checked against its publication
    record (:func:`planner.native_cache.checked`), else None (also when this process cannot
    read the cache folder)."""
    if not native_cache.access().read:
        return None
    return native_cache.checked(library_path(key))


def pending(key: str) -> bool:
    """Whether this process is compiling ``key`` in the background."""
    with _lock:
        process = _pending.get(key)
        if process is None:
            return False
        if process.poll() is None:
            return True
        del _pending[key]
        failed = process.returncode
        if failed != 0:
            _failed.add(key)
    if failed == CACHE_FAILURE:
        native_cache.cannot_write("a compilation in the background could not write")
    elif failed != 0:
        logger.warning("compiling the NLP %s failed (exit %s)", key, failed)
    return False


def library_for(key: str, how: str, entry, oracle: Callable[[], ca.Function]) -> Path | None:
    """The library to solve ``key`` with now, for a solver ``entry`` that runs interpreted
    (a :class:`planner.solver_cache.CachedSolver`): the cache's when it holds one; with
    ``how`` "now", compiled first (waiting); with "auto", None, after starting a background
    compilation when :func:`worth_compiling` says so; with "never", None. ``oracle`` makes
    the NLP Function to compile (only when one is compiled)."""
    found = ready(key)
    if found is not None or how == "never":
        return found
    if how == "now":
        return compile_library(oracle(), key, wait=True)
    if worth_compiling(entry) and not pending(key):
        compile_library(oracle(), key, wait=False)
    return None


def compile_library(oracle: ca.Function, key: str, *, wait: bool) -> Path | None:
    """Compile ``oracle`` (the NLP (x, p) -> (f, g) that nlpsol is given, named ``nlp``) and
    the derivatives IPOPT asks for into the cache as the library of ``key``.

    ``wait``: compile now and return the library (raise DefinitionError when no compiler is
    there or the compiler fails on the code); else start a background compilation (once per
    key and process; none without a compiler or after a failure) and return None. Either
    way None, said once, when the cache cannot take the library (a folder this process
    cannot write, a full disk): the solve runs interpreted.
    """
    found = ready(key)
    if found is not None:
        return found
    cc = compiler()
    if cc is None:
        if wait:
            raise DefinitionError(
                "`compiled`: no C compiler found (set $CC, or install cc, gcc or clang); "
                "solve with compiled=None or False to run interpreted"
            )
        return None
    with _lock:
        if not wait and (key in _pending or key in _failed):
            return None
    access = native_cache.access()
    if not access.write:
        if access.read:  # else access() said so already
            native_cache.cannot_write(access.reason)
        return None
    folder = cache_folder()
    try:
        handle, source = tempfile.mkstemp(dir=folder, prefix=f".{key}.", suffix=".casadi")
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as out:
                json.dump({"nlp": oracle.serialize(), "key": key}, out)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(source)
            raise
    except OSError as error:
        native_cache.cannot_write(f"writing the NLP for the compiler: {error.strerror or error}")
        return None
    command = [sys.executable, "-m", "planner.native_nlp", source, cc]
    environment = {**os.environ, "PYTHONPATH": _package_root()}
    if not wait:
        process = subprocess.Popen(
            command,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=environment,
        )
        with _lock:
            _pending[key] = process
        logger.info("compiling the NLP %s in the background", key)
        return None
    done = subprocess.run(command, capture_output=True, text=True, env=environment)
    said = " / ".join((done.stderr or done.stdout).strip().splitlines()[-3:])
    if done.returncode == CACHE_FAILURE:
        native_cache.cannot_write(f"compiling into it: {said}")
        return None
    found = ready(key)
    if done.returncode != 0 or found is None:
        raise DefinitionError(
            f"`compiled`: compiling the NLP with {cc} failed ({said}); solve with "
            "compiled=False to run interpreted"
        )
    return found


def _package_root() -> str:
    """The folder holding the ``planner`` package, first on the child's path, so that the
    child compiles with this very code."""
    root = str(Path(__file__).resolve().parent.parent)
    rest = os.environ.get("PYTHONPATH")
    return root + (os.pathsep + rest if rest else "")


# ---- the compiling process --------------------------------------------------------------
def _build(source: Path, cc: str) -> None:
    """Generate and compile the library of the serialised NLP in ``source`` (deleted) and
    publish it (:func:`planner.native_cache.publish`)."""
    spec = json.loads(source.read_text(encoding="utf-8"))
    source.unlink()
    key = spec["key"]
    target = library_path(key)
    target.parent.mkdir(parents=True, exist_ok=True)
    with native_cache.file_lock(target.with_suffix(".lock")):
        if native_cache.checked(target) is not None:  # compiled while this one waited
            return
        # Work folders of this key that a killed compilation left (the lock is ours, so
        # none of them is in use).
        for stale in target.parent.glob(f".{key}.work.*"):
            shutil.rmtree(stale, ignore_errors=True)
        oracle = ca.Function.deserialize(spec["nlp"])
        # The same oracle (its AD options serialised with it) and the derivatives IPOPT asks
        # for (exact Hessian); the solver's own options play no part in the code.
        solver = ca.nlpsol(ORACLE, "ipopt", oracle, {"print_time": False, "calc_lam_p": False})
        with tempfile.TemporaryDirectory(dir=target.parent, prefix=f".{key}.work.") as work:
            generator = ca.CodeGenerator(f"{ORACLE}.c", {"with_header": False})
            generator.add(solver.oracle())
            for name in solver.get_function():
                generator.add(solver.get_function(name))
            # Written here, not by CasADi's generate(), whose stream does not report a
            # failed write (a full disk would leave a cut C file to the compiler).
            code = Path(work) / f"{ORACLE}.c"
            code.write_text(generator.dump(), encoding="utf-8")
            library = Path(work) / target.name
            subprocess.run(
                compile_command(cc, code, library), check=True, capture_output=True, text=True
            )
            native_cache.publish(library, target)


def compile_command(cc: str, code: Path, library: Path) -> list[str]:
    """The compiler's command that builds the shared ``library`` from CasADi's C ``code``
    (:data:`OPTIMISATION`)."""
    return [
        cc,
        "-shared",
        "-fPIC",
        OPTIMISATION,
        # CasADi's code copies empty blocks through integer 0 pointers, which newer
        # compilers refuse by default; those copies never run.
        "-Wno-int-conversion",
        str(code),
        "-o",
        str(library),
        "-lm",
    ]


def _main(source: Path, cc: str) -> int:
    """The compiling process: 0 when the library is published, :data:`CACHE_FAILURE` when
    the cache could not take it (said on stderr), 1 when the compiler failed on the code."""
    try:
        _build(source, cc)
    except OSError as error:
        where = f": {os.fsdecode(error.filename)!r}" if error.filename else ""
        print(f"{error.strerror or error}{where}", file=sys.stderr)
        return CACHE_FAILURE
    except subprocess.CalledProcessError as error:
        said = (error.stderr or "").strip()
        print(said, file=sys.stderr)
        return CACHE_FAILURE if any(text in said for text in WRITE_ERRORS) else 1
    return 0


if __name__ == "__main__":
    sys.exit(_main(Path(sys.argv[1]), sys.argv[2]))
