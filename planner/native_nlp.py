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
* **Where**: :func:`cache_folder`: ``$ANTHROPOID_CACHE``, else
  ``$XDG_CACHE_HOME/anthropoid-planner``, else ``~/.cache/anthropoid-planner``; one
  ``<key>.so`` per structure under ``nlp-casadi-<version>-<platform>-<machine>/``. Deleting
  the folder is always safe; a library that does not load is removed and solved without.
* **How**: in a separate Python process (``python -m planner.native_nlp``), from the
  serialised NLP: CasADi generates the derivatives and the C code there, the compiler builds
  a shared library into a temporary file, and an atomic rename publishes it. A lock file
  makes processes that want the same structure at once (the workers of a study) wait for
  one compilation instead of each running its own; a reader never sees a half-written
  library. Nothing of it runs in the solving process, so a compilation in the background
  does not hold up the solves meanwhile.
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
import json
import logging
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

import casadi as ca

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
CACHE_ENV, MODE_ENV = "ANTHROPOID_CACHE", "ANTHROPOID_COMPILE"
MODES = ("auto", "never")
#: The NLP's functions the library holds (nlpsol loads them by these names).
ORACLE = "nlp"

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


def discard(path: Path) -> None:
    """Remove a library that does not load (damaged, or built elsewhere), saying so; the
    automatic mode compiles the structure again when it pays."""
    logger.warning("the compiled NLP %s does not load; removed, solving interpreted", path.name)
    with contextlib.suppress(OSError):
        path.unlink()


def library_path(key: str) -> Path:
    suffix = ".dll" if sys.platform == "win32" else ".so"
    return cache_folder() / f"{key}{suffix}"


def ready(key: str) -> Path | None:
    """The library of ``key`` when the cache holds it, else None."""
    path = library_path(key)
    return path if path.is_file() else None


def pending(key: str) -> bool:
    """Whether this process is compiling ``key`` in the background."""
    with _lock:
        process = _pending.get(key)
        if process is None:
            return False
        if process.poll() is None:
            return True
        del _pending[key]
        if process.returncode != 0:
            _failed.add(key)
            logger.warning("compiling the NLP %s failed (exit %s)", key, process.returncode)
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
    there or the compilation fails); else start a background compilation (once per key and
    process; none without a compiler or after a failure) and return None.
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
    folder = cache_folder()
    folder.mkdir(parents=True, exist_ok=True)
    handle, source = tempfile.mkstemp(dir=folder, prefix=f".{key}.", suffix=".casadi")
    with os.fdopen(handle, "w", encoding="utf-8") as out:
        json.dump({"nlp": oracle.serialize(), "key": key}, out)
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
    found = ready(key)
    if done.returncode != 0 or found is None:
        said = (done.stderr or done.stdout).strip().splitlines()[-3:]
        raise DefinitionError(
            f"`compiled`: compiling the NLP with {cc} failed ({' / '.join(said)}); solve with "
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
    """Generate and compile the library of the serialised NLP in ``source`` (deleted)."""
    spec = json.loads(source.read_text(encoding="utf-8"))
    source.unlink()
    key = spec["key"]
    target = library_path(key)
    target.parent.mkdir(parents=True, exist_ok=True)
    with _file_lock(target.with_suffix(".lock")):
        if target.is_file():  # another process compiled it while this one waited
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
            generator.generate(work + os.sep)
            library = Path(work) / target.name
            subprocess.run(
                [
                    cc,
                    "-shared",
                    "-fPIC",
                    OPTIMISATION,
                    # CasADi's code copies empty blocks through integer 0 pointers, which
                    # newer compilers refuse by default; those copies never run.
                    "-Wno-int-conversion",
                    str(Path(work) / f"{ORACLE}.c"),
                    "-o",
                    str(library),
                    "-lm",
                ],
                check=True,
                capture_output=True,
            )
            os.replace(library, target)


@contextlib.contextmanager
def _file_lock(path: Path):
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


if __name__ == "__main__":
    _build(Path(sys.argv[1]), sys.argv[2])
