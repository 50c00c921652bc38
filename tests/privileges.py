"""Running a child process that obeys file permissions, as an ordinary user does.

Tests of unreadable and read-only folders chmod a folder and run the product in a child
process. A process of an ordinary user obeys the permissions; root's does not (the
capabilities CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH let it read and write anything), and
CI and this machine run the suite as root. So under root the child drops those two
capabilities from its bounding set before it starts the program (Linux ``prctl``
PR_CAPBSET_DROP; the program's root then has them neither permitted nor effective): it stays
root, keeps its files and its Python, and is refused what the permissions refuse.
"""

from __future__ import annotations

import ctypes
import os
import subprocess
import sys
import tempfile

import pytest

#: Linux's PR_CAPBSET_DROP, CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH.
_PR_CAPBSET_DROP, _CAPABILITIES = 24, (1, 2)


def _drop_file_capabilities() -> None:  # runs in the child, between fork and exec
    libc = ctypes.CDLL(None, use_errno=True)
    for capability in _CAPABILITIES:
        if libc.prctl(_PR_CAPBSET_DROP, capability, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


def _preexec():
    return _drop_file_capabilities if os.geteuid() == 0 else None


def permissions_hold() -> bool:
    """Whether a child started by :func:`run` is refused a folder of mode 000 (False where
    neither an ordinary user nor a capability drop is available)."""
    with tempfile.TemporaryDirectory() as folder:
        locked = os.path.join(folder, "locked")
        os.mkdir(locked, 0o000)
        try:
            done = run([sys.executable, "-c", f"import os; os.listdir({locked!r})"],
                       capture_output=True, check=False)  # fmt: skip
        except OSError:
            return False
        finally:
            os.chmod(locked, 0o700)
    return done.returncode != 0


def run(argv, **kwargs) -> subprocess.CompletedProcess:
    """``subprocess.run(argv, **kwargs)`` in a child that obeys file permissions."""
    return subprocess.run(argv, preexec_fn=_preexec(), **kwargs)


needs_permissions = pytest.mark.skipif(
    not permissions_hold(),
    reason="file permissions cannot be made to hold for a child process here",
)
