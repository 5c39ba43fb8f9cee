"""Standard streams that a closed reader cannot turn into a result.

``qsplan modes x.json | head -1``, ``... | grep -q 4S`` and ``... | true`` close the pipe
behind the command's stdout; the next write then raises ``BrokenPipeError`` (Python ignores
SIGPIPE).  Raised inside a command it would abort the command -- outputs not committed -- and
at exit it would change the exit code.  :class:`GuardedStream` drops what cannot be written
instead (the reader asked for no more) and points the file descriptor at ``os.devnull`` so
that nothing buffered fails later: the command runs to its end and its exit code is its result,
whatever happens to stdout or stderr.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterable, Iterator
from typing import Any, TextIO

_CLOSED = (errno.EPIPE, errno.ECONNRESET, getattr(errno, "ESHUTDOWN", errno.EPIPE))


class GuardedStream:
    """A text stream whose writes and flushes never raise for a closed reader."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.closed_by_reader = False

    def write(self, text: str) -> int:
        if not self.closed_by_reader:
            try:
                return self._stream.write(text)
            except OSError as exc:
                if exc.errno not in _CLOSED:
                    raise
                self._reader_gone()
        return len(text)

    def writelines(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        if not self.closed_by_reader:
            try:
                self._stream.flush()
            except OSError as exc:
                if exc.errno not in _CLOSED:
                    raise
                self._reader_gone()

    def _reader_gone(self) -> None:
        self.closed_by_reader = True
        with contextlib.suppress(OSError, ValueError, AttributeError):
            fd = self._stream.fileno()
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, fd)
            os.close(null)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextlib.contextmanager
def guarded_streams() -> Iterator[None]:
    """``sys.stdout`` and ``sys.stderr`` as :class:`GuardedStream` inside the block (flushed
    at its end); the streams as they were afterwards."""
    import sys

    saved = sys.stdout, sys.stderr
    if sys.stdout is not None and not isinstance(sys.stdout, GuardedStream):
        sys.stdout = GuardedStream(sys.stdout)
    if sys.stderr is not None and not isinstance(sys.stderr, GuardedStream):
        sys.stderr = GuardedStream(sys.stderr)
    try:
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            if isinstance(stream, GuardedStream):
                with contextlib.suppress(OSError, ValueError):
                    stream.flush()
        sys.stdout, sys.stderr = saved
