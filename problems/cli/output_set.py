"""A command's output folder, written as one set: all of a run's files or none of them.

A run writes into a staging folder beside the destination (``.<name>.partial-<random>``);
:meth:`OutputSet.commit` writes the manifest (``manifest.json``: the command, the files, when)
and then puts the staging folder in the destination's place, an earlier run's folder moved
aside and removed after: a reader sees the earlier run's files or this run's, never a mix,
and nothing of a run that failed (:meth:`OutputSet.discard`, or the context manager on an
exception, removes the staging folder and any parent folder it created).

Which folders a run may take: a new or empty folder, or one holding an earlier run of the
same command and nothing else (its manifest lists every file), whose files the new run
replaces as a set. Any other non-empty folder is refused before the run computes anything
(:class:`OutputFolderError`, naming what is there): a command never writes beside files it
did not write, nor removes them.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from planner.errors import DefinitionError

#: The manifest a run leaves in its folder.
MANIFEST = "manifest.json"
FORMAT = "anthropoid-planner output 1"


class OutputFolderError(DefinitionError):
    """An output folder a command may not write to (another command's, or foreign files)."""


def _manifest(folder: Path) -> dict[str, Any] | None:
    path = folder / MANIFEST
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) and document.get("format") == FORMAT else None


def check_folder(folder: Path, command: str, option: str = "--output-dir") -> None:
    """Refuse ``folder`` unless it is new, empty, or an earlier run of ``command``."""
    if folder.exists() and not folder.is_dir():
        raise OutputFolderError(f"{option}: {str(folder)!r} exists and is not a folder")
    existing = folder.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():  # a file where a parent folder would go
        raise OutputFolderError(f"{option}: cannot create {str(folder)!r}: Not a directory")
    if not folder.exists():
        return
    contents = sorted(p.name for p in folder.iterdir())
    if not contents:
        return
    manifest = _manifest(folder)
    if manifest is None or manifest.get("command") != command:
        owner = "no manifest" if manifest is None else f"the output of {manifest.get('command')!r}"
        raise OutputFolderError(
            f"{option}: {str(folder)!r} is not empty ({_listed(contents)}) and is not an "
            f"earlier {command!r} run's folder ({owner}); a run replaces only its own "
            "command's files: give a new or empty folder"
        )
    listed = {*manifest.get("files", ()), MANIFEST}
    others = [name for name in contents if name not in listed or not (folder / name).is_file()]
    if others:
        raise OutputFolderError(
            f"{option}: {str(folder)!r} holds an earlier {command!r} run and files it did not "
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
    """

    def __init__(self, folder: Path, command: str, option: str = "--output-dir") -> None:
        self.folder = Path(folder)
        self.command = command
        check_folder(self.folder, command, option)
        self._staging: Path | None = None
        self._created: list[Path] = []
        self.committed = False

    @property
    def staging(self) -> Path:
        """The staging folder (made on first use, with the destination's missing parents)."""
        if self._staging is None:
            parent = self.folder.absolute().parent
            missing = []
            while not parent.exists():
                missing.append(parent)
                parent = parent.parent
            for path in reversed(missing):
                path.mkdir()
                self._created.append(path)
            self._staging = Path(
                tempfile.mkdtemp(prefix=f".{self.folder.name}.partial-", dir=self.folder.parent)
            )
            # mkdtemp makes it private (0700); the output folder gets a new folder's mode
            umask = os.umask(0o022)
            os.umask(umask)
            os.chmod(self._staging, 0o777 & ~umask)
        return self._staging

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
        final paths (the manifest last)."""
        files = self.files()
        manifest = {
            "format": FORMAT,
            "command": self.command,
            "files": files,
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            **(details or {}),
        }
        staging = self.staging
        (staging / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
        old = None
        if self.folder.exists():
            check_folder(self.folder, self.command)  # nobody else wrote there meanwhile
            old = Path(tempfile.mkdtemp(prefix=f".{self.folder.name}.old-", dir=self.folder.parent))
            os.replace(self.folder, old / "run")
        try:
            os.replace(staging, self.folder)
        except OSError:
            if old is not None:  # put the earlier run back
                os.replace(old / "run", self.folder)
                shutil.rmtree(old, ignore_errors=True)
            raise
        self._staging = None
        self.committed = True
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return [self.folder / name for name in files] + [self.folder / MANIFEST]

    def discard(self) -> None:
        """Remove what the run staged, and the parent folders it created."""
        if self._staging is not None:
            shutil.rmtree(self._staging, ignore_errors=True)
            self._staging = None
        for path in reversed(self._created):
            with contextlib.suppress(OSError):
                path.rmdir()
        self._created = []

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if not self.committed:
            self.discard()


__all__ = ["MANIFEST", "OutputFolderError", "OutputSet", "check_folder"]
