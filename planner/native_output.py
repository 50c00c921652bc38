"""Keeping what native code writes on the process's stdout and stderr out of the terminal.

IPOPT prints an option's whole documentation on stdout when it refuses a value, CasADi
writes warnings on stderr, and SUNDIALS its step-size complaints: the library never prints,
so the few calls that can make native code write run inside :func:`captured`, which hands
the text back to the caller (to put in an error message, or to log).

Both the Python streams (``sys.stdout``/``sys.stderr``: CasADi's Python module writes
through them) and the file descriptors 1 and 2 (for what C and C++ write directly) are
redirected while the block runs. This is process-wide, so the block must stay short and
never run user code: a lock serialises the captures of all threads, and text another thread
writes meanwhile ends up in the capture too (the caller logs it).
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import sys
import tempfile
import threading
from collections.abc import Iterator

_LOCK = threading.RLock()
_FILE_DESCRIPTORS = {"stdout": 1, "stderr": 2}


def _flush_c_streams() -> None:
    """fflush(NULL): C's stdout is block-buffered on a pipe or a file, so what IPOPT printed
    would otherwise reach the real stdout later, after the descriptor is restored."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def captured(streams: tuple[str, ...] = ("stdout", "stderr")) -> Iterator[list[str]]:
    """Capture what is written on ``streams`` ("stdout", "stderr") while the block runs.

    Yields a list that receives the captured text (one string, the streams in the order
    given) when the block ends, also when it raises. Without a usable file descriptor (an
    embedding without one) only the Python stream is swapped.
    """
    unknown = [s for s in streams if s not in _FILE_DESCRIPTORS]
    if unknown:
        raise ValueError(f"`streams`: unknown {unknown}; use 'stdout' and/or 'stderr'")
    result: list[str] = []
    with _LOCK, contextlib.ExitStack() as stack:
        buffers: list[io.StringIO] = []
        sinks: list[tuple[int, int, tempfile._TemporaryFileWrapper]] = []
        try:
            for name in streams:
                stream = getattr(sys, name)
                with contextlib.suppress(AttributeError, ValueError, OSError):
                    stream.flush()  # text already written goes out before the switch
                _flush_c_streams()
                descriptor = _FILE_DESCRIPTORS[name]
                try:
                    saved = os.dup(descriptor)
                except OSError:
                    saved = None
                if saved is not None:
                    sink = tempfile.TemporaryFile()
                    os.dup2(sink.fileno(), descriptor)
                    sinks.append((descriptor, saved, sink))
                buffer = io.StringIO()
                buffers.append(buffer)
                redirect = (
                    contextlib.redirect_stdout if name == "stdout" else contextlib.redirect_stderr
                )
                stack.enter_context(redirect(buffer))
            yield result
        finally:
            _flush_c_streams()
            stack.close()
            text = "".join(buffer.getvalue() for buffer in buffers)
            for descriptor, saved, sink in reversed(sinks):
                os.dup2(saved, descriptor)
                os.close(saved)
                sink.seek(0)
                text += sink.read().decode("utf-8", errors="replace")
                sink.close()
            result.append(text)


__all__ = ["captured"]
