"""Single CasADi Functions compiled to native code, kept in the disk cache of the compiled
NLPs (:mod:`planner.native_cache`).

For a function that a Python loop calls one state at a time, CasADi's virtual machine is the
cost: a hybrid simulation's exact Jacobian of one control period is about 70 000 instructions
for the six-link walker, about 0.55 ms interpreted and some 12 times faster compiled at ``-O1``
(scratch timings of 300 calls, not a repo benchmark; ``examples/benchmarks/gait_library.py``
measures what it does to a library's build). Its compilation takes about 40 s, so it pays only
for a function kept in the cache and used again: nothing here compiles unasked.

* **Key**: ``fn-`` and the SHA-256 of the serialised Function (the same expression graph
  gives the same code; a Function built again the same way in another process has the same
  key). The library ``fn-<key>.so`` sits beside the NLP libraries, published with its record
  and checked against it before it loads, as theirs are.
* :func:`native` ``(function, how)``: ``"never"``: the function itself; ``"auto"``: the
  cache's library when it holds one, else the function itself; ``"now"``: compiled first when
  the cache does not hold it (waiting; :class:`planner.errors.DefinitionError` without a C
  compiler or when it fails on the code). A library that does not match its record or does not
  load is removed, said once, and the function runs interpreted; a cache folder this process
  cannot write means interpreted, said once. The compiled Function has the same name, inputs
  and outputs as the one given.
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

import casadi as ca

from planner import native_cache, native_nlp
from planner.errors import DefinitionError

#: the ways :func:`native` takes
HOWS = ("never", "auto", "now")
#: the compiler's optimisation, the NLPs' (:data:`planner.native_nlp.OPTIMISATION`): ``-O1``
#: runs the walker's period Jacobian 12 times faster than interpreted and ``-O0`` only twice
#: (scratch timings: 85 and 508 us against 1000 us on a busy machine), for 42 s of compilation
#: against 6 s
OPTIMISATION = native_nlp.OPTIMISATION

_loaded: dict[str, ca.Function] = {}
_lock = threading.Lock()


def key(function: ca.Function) -> str:
    """The cache key of ``function``: ``fn-`` and the SHA-256 of its serialisation."""
    return "fn-" + hashlib.sha256(function.serialize().encode("utf-8")).hexdigest()


def native(function: ca.Function, how: str = "auto") -> ca.Function:
    """``function`` compiled when the cache holds it (``how`` "auto") or after compiling it
    now ("now"), else ``function`` itself (see the module)."""
    return _native(key(function), function.name(), lambda: function, how)


def native_derived(source: ca.Function, tag: str, name: str, derive, how: str = "auto"):
    """``derive(source)``, a Function named ``name``, as :func:`native` gives it, keyed by
    ``source`` and ``tag`` instead of by the derived function: the caller's promise that the
    same source and tag derive the same function (``tag`` names the derivation and its
    version). Neither the derived function nor its key is built when the cache holds it: a
    period Jacobian of 70 000 instructions costs 0.1 s to build and 0.2 s to serialise, its
    RK4 step of 3 000 a hundredth of that."""
    if not isinstance(tag, str) or not tag:
        raise DefinitionError(f"`tag`: a non-empty string naming the derivation, got {tag!r}")
    digest = hashlib.sha256(f"{key(source)}|{tag}|{name}".encode()).hexdigest()
    return _native(f"fn-{digest}", name, lambda: derive(source), how)


def _native(name_key: str, name: str, build, how: str) -> ca.Function:
    if how not in HOWS:
        raise DefinitionError(f"`how`: one of {HOWS}, got {how!r}")
    if how == "never":
        return build()
    with _lock:
        loaded = _loaded.get(name_key)
    if loaded is not None:
        return loaded
    library = _ready(name_key)
    function = None
    if library is None and how == "now":
        function = build()
        if function.name() != name:
            raise DefinitionError(
                f"`name`: the derived function is named {function.name()!r}, not {name!r}"
            )
        library = _compile(function, name_key)
    if library is None:
        return function if function is not None else build()
    try:
        loaded = ca.external(name, str(library))
    except RuntimeError:
        native_cache.discard(library, "it does not load (built for another machine, or damaged)")
        return function if function is not None else build()
    with _lock:
        _loaded[name_key] = loaded
    return loaded


def _ready(name: str) -> Path | None:
    """The checked library of ``name`` in the cache, or None."""
    if not native_cache.access().read:
        return None
    return native_cache.checked(native_cache.library_path(name))


def _compile(function: ca.Function, name: str) -> Path | None:
    """Generate ``function``'s C code, compile it and publish it as the library of ``name``
    (under the key's lock: processes that want it at once compile it once). None, said once,
    when the cache cannot take it."""
    cc = native_nlp.compiler()
    if cc is None:
        raise DefinitionError(
            f"`compiled`: no C compiler found to compile {function.name()!r} (set $CC, or "
            "install cc, gcc or clang); run with compiled=None or False to run interpreted"
        )
    access = native_cache.access()
    if not access.write:
        if access.read:
            native_cache.cannot_write(access.reason)
        return None
    target = native_cache.library_path(name)
    try:
        with native_cache.file_lock(target.with_suffix(".lock")):
            found = native_cache.checked(target)  # compiled while this one waited
            if found is not None:
                return found
            # work folders of this key that a killed compilation left (the lock is ours)
            for stale in target.parent.glob(f".{name}.work.*"):
                shutil.rmtree(stale, ignore_errors=True)
            with tempfile.TemporaryDirectory(dir=target.parent, prefix=f".{name}.work.") as work:
                generator = ca.CodeGenerator("function.c", {"with_header": False})
                generator.add(function)
                # written here, not by CasADi's generate(), whose stream does not report a
                # failed write (a full disk would hand a cut C file to the compiler)
                code = Path(work) / "function.c"
                code.write_text(generator.dump(), encoding="utf-8")
                built = Path(work) / target.name
                done = subprocess.run(
                    native_nlp.compile_command(cc, code, built), capture_output=True, text=True
                )
                if done.returncode != 0:
                    said = " / ".join((done.stderr or done.stdout).strip().splitlines()[-3:])
                    if any(text in said for text in native_nlp.WRITE_ERRORS):
                        native_cache.cannot_write(f"compiling into it: {said}")
                        return None
                    raise DefinitionError(
                        f"`compiled`: compiling {function.name()!r} with {cc} failed ({said}); "
                        "run with compiled=False to run interpreted"
                    )
                native_cache.publish(built, target)
    except OSError as error:
        native_cache.cannot_write(f"compiling {function.name()!r}: {error.strerror or error}")
        return None
    return native_cache.checked(target)


def forget() -> None:
    """Forget the libraries this process loaded (tests: a cache folder changed under it)."""
    with _lock:
        _loaded.clear()


__all__ = ["HOWS", "OPTIMISATION", "forget", "key", "native", "native_derived"]
