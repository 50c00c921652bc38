"""The errors of trajectories: a query a trajectory cannot answer, a file it cannot read or
write. All derive from :class:`planner.errors.AnthropoidError` (and the matching built-in
exception), so one ``except`` clause catches the library's own failures."""

from __future__ import annotations

from planner.errors import AnthropoidError


class TrajectoryError(AnthropoidError, ValueError):
    """A query a trajectory cannot answer: a time outside its range, or a linkage channel
    (psi, torques, ...) asked of a trajectory that does not follow the linkage convention."""


class TrajectoryFileError(TrajectoryError):
    """A trajectory file that cannot be written or read: the message names the file, the
    line or column when there is one, and the fix."""


class TrajectoryFileNotFoundError(TrajectoryFileError, FileNotFoundError):
    """The file to load, or the folder to save into, does not exist."""


class TrajectoryWriteError(TrajectoryFileError, OSError):
    """The system refused to write a trajectory file (no write permission, a full disk, a
    file-size limit). The message names the file; ``errno``, ``strerror`` and ``filename``
    (the destination, never the temporary file) are the system's."""

    def __init__(self, message: str, errno=None, strerror=None, filename=None) -> None:
        OSError.__init__(self, errno, strerror, filename)
        self.args = (message,)
        self._message = message

    def __str__(self) -> str:
        return self._message


__all__ = [
    "TrajectoryError",
    "TrajectoryFileError",
    "TrajectoryFileNotFoundError",
    "TrajectoryWriteError",
]
