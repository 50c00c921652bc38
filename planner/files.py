"""Writing files so that nothing is ever half-written on disk.

Every file the planner writes (trajectory exports, GIF animations) goes through
:func:`atomic_path`: the content is written to a temporary file in the destination folder and
renamed over the destination only when complete. ``os.replace`` within one file system is
atomic, so a reader sees either the old file or the new one, never a partial one; on any
failure the temporary file is removed and the error propagates. An OSError (a folder without
write permission, a full disk, a file-size limit) propagates naming the destination, not the
hidden temporary file (nor no file at all, as a full disk's error does).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

_UMASK: list[int] = []


def _umask() -> int:
    if not _UMASK:
        # os.umask can only be read by setting it; done once, restored at once.
        current = os.umask(0o022)
        os.umask(current)
        _UMASK.append(current)
    return _UMASK[0]


def new_file_mode() -> int:
    """Permissions of a newly created file under the process umask (mkstemp uses 0600)."""
    return 0o666 & ~_umask()


def new_folder_mode() -> int:
    """Permissions of a newly created folder under the process umask (mkdtemp uses 0700)."""
    return 0o777 & ~_umask()


@contextmanager
def atomic_path(path: Path, suffix: str = ".tmp") -> Iterator[str]:
    """Yield a temporary path beside ``path``; on success rename it over ``path``.

    The final file keeps the permissions of the file it replaces, or gets the usual
    permissions of a new file. ``suffix`` lets writers that choose a format by extension
    (matplotlib's) see the right one.
    """
    path = Path(path)
    try:
        descriptor, temporary = tempfile.mkstemp(
            dir=path.parent, prefix=f".{path.name}.", suffix=suffix
        )
    except OSError as error:
        raise naming(error, path) from None
    os.close(descriptor)
    try:
        yield temporary
        mode = path.stat().st_mode & 0o7777 if path.exists() else new_file_mode()
        os.chmod(temporary, mode)
        os.replace(temporary, path)
    except BaseException as error:
        try:
            os.unlink(temporary)
        except FileNotFoundError:
            pass
        if isinstance(error, OSError) and error.filename in (None, temporary):
            raise naming(error, path) from error
        raise


def naming(error: OSError, path: Path) -> OSError:
    """The same OSError (type, errno, strerror) with ``path`` as its file name."""
    strerror = error.strerror or str(error) or type(error).__name__
    try:
        return type(error)(error.errno, strerror, str(path))
    except TypeError:  # a subclass with another constructor: keep it as it is
        return error


def write_text_atomically(path: Path, text: str) -> Path:
    """``text`` into ``path``, whole or not at all (:func:`atomic_path`)."""
    path = Path(path)
    with atomic_path(path, suffix=path.suffix) as temporary:
        Path(temporary).write_text(text)
    return path
