"""Safe file output: every file the project writes goes through here (atomic replace).

A file is written to a temporary sibling, flushed and fsynced, then renamed over the target, so
a reader never sees a half-written plan, summary or report.
"""

from __future__ import annotations

import json
import math
import os
import stat
import tempfile
from pathlib import Path
from typing import Any


def current_umask() -> int:
    """The process umask, read without changing it where the OS allows (Linux /proc)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # elsewhere: read by setting (briefly) and restoring
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; creates parent folders. Returns the path.

    A ``path`` that exists and is not a regular file (a directory, FIFO, device, socket, or a
    symlink to one) raises :class:`planner.errors.InputError` and is left as it is: the rename
    would replace it (``/dev/null`` as root) with a regular file."""
    target = Path(path)
    try:
        mode = os.stat(target).st_mode
    except OSError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        from planner.errors import InputError

        raise InputError(f"output {str(target)!r}: expected a regular file or a new path, got "
                         f"{'a directory' if stat.S_ISDIR(mode) else 'a special file'}; it is "
                         "not replaced")
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        # mkstemp creates 0600; give the file the permissions a plain open() would (umask).
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError) and exc.filename is None and exc.errno is not None:
            # a full disk or a lost permission while writing: name the file (write() does not)
            raise OSError(exc.errno, exc.strerror, str(target)) from exc
        raise
    return target


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as lists and numbers, NaN as null, +-inf as
    "inf"/"-inf" (strict JSON, as :func:`atomic_write_json` writes it)."""
    import numpy as np

    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def atomic_write_json(path: str | os.PathLike[str], data: Any) -> Path:
    """Serialise ``data`` (numpy arrays allowed; NaN -> null, inf -> "inf") and write atomically."""
    text = json.dumps(jsonable(data), indent=2, allow_nan=False)
    return atomic_write_text(path, text + "\n")


def save_figure(fig: Any, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Save a matplotlib figure atomically (format from the suffix)."""
    import io

    buf = io.BytesIO()
    target = Path(path)
    fig.savefig(buf, format=target.suffix.lstrip(".") or "png", **kwargs)
    return atomic_write_bytes(target, buf.getvalue())
