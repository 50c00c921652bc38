"""A command's output folder, written as one set: all of a run's files or none of them, in a
folder that stays the user's.

**Which folders a run may take**: a new or empty folder, or one holding an earlier run of the
same command and nothing else (its manifest lists every file), whose files the new run
replaces as a set. Any other non-empty folder is refused, as is a folder this process cannot
write, before the run computes anything (:class:`OutputFolderError`, naming the option, the
folder as the user gave it, and what is wrong): a command never writes beside files it did
not write, nor removes them.

**The folder stays the user's.** An existing folder is written in place: it keeps its inode,
mode and owner (a shell sitting in it stays in it), and a symbolic link given as the folder is
followed (the link stays, its target receives the files; a dangling link's target is created).
Only a new folder is made, with the permissions a new folder gets under the umask.

**As a set.** A run writes into a staging folder, ``.partial-<random>`` inside an existing
folder, ``.<name>.partial-<random>`` beside a new one; nothing of the run is visible before
:meth:`OutputSet.commit`. A new folder appears by one rename of its staging folder. In an
existing folder the commit first writes a manifest listing the earlier run's files and the
new ones (``"complete": false``), moves the new files in (each an atomic rename), removes the
earlier run's files the new run did not write, and writes the final manifest (``"files"``
exactly the new set, ``"complete": true``): at every instant the manifest lists every file of
the folder, so a run killed halfway leaves a folder that the next run of the command takes,
and a reader that finds ``"complete": true`` reads one run's files. A run that fails removes
its staging folder and any parent folder it created (:meth:`OutputSet.discard`, or the
context manager on an exception).

**What killed runs leave** (SIGKILL, a power cut): their staging folders. Each run holds an
advisory lock (``flock``) on its staging folder while it lives, released by the kernel however
the process ends; the next run into the same folder or beside it removes the stagings whose
lock it can take (and the ``.<name>.old-*`` folders of earlier versions), and refuses a folder
another live run is writing into.

Errors name the option and the folder as given, never the staging folder:
:class:`OutputFolderError` (a definition error: the folder given) before the run,
:class:`OutputWriteError` (the disk: full, removed, made read-only meanwhile) while it writes.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from planner.errors import AnthropoidError, DefinitionError
from planner.files import new_folder_mode

try:  # POSIX advisory locks; elsewhere stagings are not locked (and not cleaned)
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

#: The manifest a run leaves in its folder.
MANIFEST = "manifest.json"
FORMAT = "anthropoid-planner output 1"
#: Staging folders: inside an existing folder, and beside a new one (mkdtemp's suffixes);
#: the folders earlier versions moved an earlier run aside into.
_INSIDE = re.compile(r"^\.partial-[A-Za-z0-9_]{8}$")
_BESIDE = re.compile(r"^\..+\.(partial|old)-[A-Za-z0-9_]{8}$")


class OutputFolderError(DefinitionError):
    """An output folder a command may not write to (another command's, foreign files, a
    folder this process cannot write, one another run is writing into)."""


class OutputWriteError(AnthropoidError):
    """Writing a run's files into its output folder failed (a full disk, a folder removed or
    made read-only meanwhile)."""


def _manifest(folder: Path) -> dict[str, Any] | None:
    path = folder / MANIFEST
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) and document.get("format") == FORMAT else None


def destination(folder: Path) -> Path:
    """The folder a run writes into for ``folder`` as given: absolute, a symbolic link
    followed (to its target, existing or not)."""
    folder = Path(folder)
    if folder.is_symlink():
        return Path(os.path.realpath(folder))
    return Path(os.path.abspath(folder))


def _locked_by_a_live_run(staging: Path) -> bool | None:
    """Whether a live run holds ``staging``'s lock (None: it is gone, or cannot be opened)."""
    if fcntl is None:
        return True
    try:
        handle = os.open(staging, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return None
    finally:
        os.close(handle)  # releases the lock taken to look
    return False


def _stagings(folder: Path, pattern: re.Pattern) -> list[Path]:
    try:
        with os.scandir(folder) as entries:
            return [Path(e.path) for e in entries
                    if pattern.match(e.name) and e.is_dir(follow_symlinks=False)]  # fmt: skip
    except OSError:
        return []


def _looks_staged(folder: Path) -> bool:
    """Whether ``folder`` holds what a run stages: files only (or, an earlier version's
    ``.old-*``, the folder ``run`` it moved an earlier run into). A folder of the user's that
    happens to match the names (``.notes.old-20231201``) holds other things and is kept."""
    try:
        with os.scandir(folder) as entries:
            for entry in entries:
                if entry.is_symlink():
                    return False
                if entry.is_dir() and not (entry.name == "run" and ".old-" in folder.name):
                    return False
    except OSError:
        return False
    return True


def clean_stale(folder: Path) -> None:
    """Remove the staging folders killed runs left inside ``folder`` and beside it (those
    whose lock no live run holds, and that hold what a run stages); see the module."""
    for staging in [*_stagings(folder, _INSIDE), *_stagings(folder.parent, _BESIDE)]:
        if _locked_by_a_live_run(staging) is False and _looks_staged(staging):
            shutil.rmtree(staging, ignore_errors=True)


def check_folder(
    folder: Path, command: str, option: str = "--output-dir", shown=None, own: Path | None = None
) -> None:
    """Refuse ``folder`` unless it is new, empty, or an earlier run of ``command`` (see the
    module); ``shown``: the folder as the user gave it, for the messages (default
    ``folder``); ``own``: the caller's own staging folder in it (not another run's)."""
    folder = Path(folder)
    shown = str(folder if shown is None else shown)
    if folder.exists() and not folder.is_dir():
        raise OutputFolderError(f"{option}: {shown!r} exists and is not a folder")
    existing = Path(os.path.abspath(folder))
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():  # a file where a parent folder would go
        raise OutputFolderError(f"{option}: cannot create {shown!r}: Not a directory")
    if not folder.exists():
        return
    try:
        entries = sorted(os.listdir(folder))
    except OSError as error:
        raise OutputFolderError(
            f"{option}: cannot read {shown!r} ({error.strerror}); give a folder you can write"
        ) from None
    mine = None if own is None else own.name
    live = [name for name in entries if _INSIDE.match(name) and name != mine
            and _locked_by_a_live_run(folder / name)]  # fmt: skip
    if live:
        raise OutputFolderError(
            f"{option}: another run is writing into {shown!r} now; wait for it to end or give "
            "another folder"
        )
    contents = [name for name in entries if not _INSIDE.match(name)]
    if not contents:
        return
    manifest = _manifest(folder)
    if manifest is None or manifest.get("command") != command:
        owner = "no manifest" if manifest is None else f"the output of {manifest.get('command')!r}"
        raise OutputFolderError(
            f"{option}: {shown!r} is not empty ({_listed(contents)}) and is not an "
            f"earlier {command!r} run's folder ({owner}); a run replaces only its own "
            "command's files: give a new or empty folder"
        )
    listed = {*manifest.get("files", ()), MANIFEST}
    others = [name for name in contents if name not in listed or not (folder / name).is_file()]
    if others:
        raise OutputFolderError(
            f"{option}: {shown!r} holds an earlier {command!r} run and files it did not "
            f"write ({_listed(others)}); a run replaces only its own files: move those away or "
            "give another folder"
        )


def _listed(names: list[str]) -> str:
    return ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")


class OutputSet:
    """The files of one run of ``command``, staged and then committed to ``folder``.

    >>> with OutputSet(Path("walk_out"), "walk") as output:
    ...     profile.save(output.path("torques.csv"))
    ...     output.commit({"argv": argv})      # or an exception: nothing is left

    Checked when made (nothing written): the folder rules, and that the folder (or the
    nearest existing parent of a new one) can be written. ``folder`` stays as given (the
    paths :meth:`commit` returns are under it); :attr:`target` is where the files go.
    """

    def __init__(self, folder: Path, command: str, option: str = "--output-dir") -> None:
        self.folder = Path(folder)
        self.command = command
        self.option = option
        self.target = destination(self.folder)
        clean_stale(self.target)
        check_folder(self.target, command, option, shown=self.folder)
        self._check_writable()
        self._staging: Path | None = None
        self._lock: int | None = None
        self._created: list[Path] = []
        self.committed = False

    def _refuse(self, error: OSError, doing: str) -> OutputFolderError:
        return OutputFolderError(
            f"{self.option}: cannot {doing} {str(self.folder)!r} ({error.strerror or error}); "
            "give a folder you can write"
        )

    def _check_writable(self) -> None:
        """A folder made and removed where the staging folder will go: the permissions, a
        read-only file system, a full inode table, found before the run computes."""
        where, child = self.target, None
        while not where.exists():
            where, child = where.parent, where.name
        prefix = ".partial-" if child is None else f".{child}.partial-"  # cleaned if left
        try:
            probe = tempfile.mkdtemp(dir=where, prefix=prefix)
        except OSError as error:
            doing = "write into" if where == self.target else "create"
            raise self._refuse(error, doing) from None
        with contextlib.suppress(OSError):  # a run cleaning stagings may have taken it
            os.rmdir(probe)

    def _failed(self, error: OSError, doing: str) -> OutputWriteError:
        name = error.filename
        what = ""
        if name is not None:
            with contextlib.suppress(ValueError):
                relative = Path(os.fsdecode(name)).relative_to(self._staging or self.target)
                what = f" {relative}" if str(relative) != "." else ""
        return OutputWriteError(
            f"{self.option}: {doing}{what} in {str(self.folder)!r} failed "
            f"({error.strerror or error})"
        )

    @property
    def staging(self) -> Path:
        """The staging folder (made on first use: inside an existing folder, beside a new
        one with the new one's missing parents), locked while this run lives."""
        if self._staging is None:
            try:
                self._staging = self._make_staging()
            except OSError as error:
                self.discard()
                raise self._failed(error, "staging the files") from None
        return self._staging

    def _make_staging(self) -> Path:
        if self.target.is_dir():
            parent, prefix = self.target, ".partial-"
        else:
            parent, prefix = self.target.parent, f".{self.target.name}.partial-"
            missing = []
            while not parent.exists():
                missing.append(parent)
                parent = parent.parent
            for path in reversed(missing):
                path.mkdir()
                self._created.append(path)
            parent = self.target.parent
        while True:
            staging = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
            if fcntl is None:
                return staging
            handle = os.open(staging, os.O_RDONLY)
            fcntl.flock(handle, fcntl.LOCK_EX)
            # A run cleaning stale stagings may have taken this one before it was locked.
            with contextlib.suppress(FileNotFoundError):
                if os.stat(staging).st_ino == os.fstat(handle).st_ino:
                    self._lock = handle
                    return staging
            os.close(handle)

    def path(self, name: str) -> Path:
        """Where a file of the run is written (in the staging folder)."""
        return self.staging / name

    def files(self) -> list[str]:
        """The names written so far."""
        if self._staging is None:
            return []
        return sorted(p.name for p in self._staging.iterdir() if not p.name.startswith("."))

    def commit(self, details: dict[str, Any] | None = None) -> list[Path]:
        """Write the manifest and put the run's files in place as a set; returns their
        paths under the folder as given (the manifest last)."""
        files = self.files()
        manifest = {
            "format": FORMAT,
            "command": self.command,
            "files": files,
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            **(details or {}),
            "complete": True,
        }
        staging = self.staging
        try:
            if not self.target.exists():
                with contextlib.suppress(FileExistsError):
                    self._commit_new(staging, manifest)
            if not self.committed:
                check_folder(self.target, self.command, self.option, self.folder, own=staging)
                self._commit_in_place(staging, files, manifest)
        except OSError as error:
            raise self._failed(error, "putting the files") from None
        self._release()
        self._created = []
        return [self.folder / name for name in files] + [self.folder / MANIFEST]

    def _commit_new(self, staging: Path, manifest: dict[str, Any]) -> None:
        """A new folder: its staging folder, with the manifest, renamed into place."""
        self._write_manifest(staging, manifest, MANIFEST)
        os.chmod(staging, new_folder_mode())
        try:
            os.rename(staging, self.target)
        except OSError as error:
            if error.errno not in (errno.EEXIST, errno.ENOTEMPTY):
                raise
            os.unlink(staging / MANIFEST)  # the folder appeared meanwhile: in place
            raise FileExistsError from error
        self._staging = None
        self.committed = True

    def _commit_in_place(self, staging: Path, files: list[str], manifest: dict[str, Any]) -> None:
        """An existing folder: see the module (the manifest always lists every file)."""
        earlier = _manifest(self.target)
        earlier_files = [] if earlier is None else [n for n in earlier.get("files", ())
                                                    if n != MANIFEST]  # fmt: skip
        both = sorted({*earlier_files, *files})
        self._write_manifest(staging, {**manifest, "files": both, "complete": False})
        for name in files:
            os.replace(staging / name, self.target / name)
        for name in set(earlier_files) - set(files):
            with contextlib.suppress(FileNotFoundError):
                (self.target / name).unlink()
        self._write_manifest(staging, manifest)
        self.committed = True
        shutil.rmtree(staging, ignore_errors=True)
        self._staging = None

    def _write_manifest(self, staging: Path, manifest: dict[str, Any], name=".manifest") -> None:
        """The manifest written in the staging folder and, unless ``name`` is its final name
        there, renamed over the folder's (one atomic step)."""
        path = staging / name
        with open(path, "w", encoding="utf-8") as out:
            out.write(json.dumps(manifest, indent=1) + "\n")
            out.flush()
            os.fsync(out.fileno())
        if name != MANIFEST:
            os.replace(path, self.target / MANIFEST)

    def _release(self) -> None:
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def discard(self) -> None:
        """Remove what the run staged, and the parent folders it created."""
        if self._staging is not None:
            shutil.rmtree(self._staging, ignore_errors=True)
            self._staging = None
        self._release()
        for path in reversed(self._created):
            with contextlib.suppress(OSError):
                path.rmdir()
        self._created = []

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if self.committed:
            return
        # A file of the run that could not be written is named in the folder as given.
        error = self._failed(value, "writing") if self._staged(value) else None
        self.discard()
        if error is not None:
            raise error from value

    def _staged(self, value) -> bool:
        """Whether ``value`` is an OSError about a path in the staging folder."""
        if not isinstance(value, OSError) or value.filename is None or self._staging is None:
            return False
        return Path(os.fsdecode(value.filename)).is_relative_to(self._staging)


__all__ = [
    "MANIFEST",
    "OutputFolderError",
    "OutputSet",
    "OutputWriteError",
    "check_folder",
    "clean_stale",
    "destination",
]
