"""The one JSON reader: every file qsplan reads (system, hand, plan, summaries) comes through here.

One set of rules for every format:

* the path must name an existing **regular file** (a missing path, a directory, a FIFO, a device
  or a socket is refused without being opened for reading in a way that could block);
* at most :data:`MAX_JSON_BYTES` bytes (refused before parsing);
* UTF-8 text (a leading byte-order mark is allowed and dropped);
* strict JSON: the non-standard constants ``NaN``, ``Infinity``, ``-Infinity``, numbers that
  overflow to infinity (``1e999``) and duplicate keys in one object are refused;
* nesting at most :data:`MAX_JSON_DEPTH` containers deep.

Every problem raises :class:`planner.errors.FileFormatError` (an :class:`InputError`, so the
command line exits with code 2) whose message names the file, what was expected and what came.
Parsing is plain :mod:`json`: nothing in a file is ever executed.
"""

from __future__ import annotations

import json
import math
import os
import stat
from pathlib import Path
from typing import Any

from planner.errors import FileFormatError

#: Largest file any loader accepts (bytes): 64 MiB.
MAX_JSON_BYTES = 64 * 1024 * 1024

#: Deepest nesting of arrays/objects accepted (the formats need at most 7).
MAX_JSON_DEPTH = 64

_UTF8_BOM = b"\xef\xbb\xbf"


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def read_json(path: str | os.PathLike[str], what: str) -> Any:
    """Read and parse the JSON file at ``path`` under the rules of the module docstring.

    ``what`` names the kind of file in messages (e.g. ``"system file"``, ``"plan file"``).
    Returns the parsed value (any JSON type; the caller checks its shape).
    """
    p = Path(path)
    name = f"{what} {str(p)!r}"
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise FileFormatError(f"{name}: expected an existing file, got no such file") from None
    except OSError as exc:
        raise FileFormatError(f"{name}: expected a readable file, got {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise FileFormatError(f"{name}: expected a regular file, got {_kind(st.st_mode)}")
    if st.st_size > MAX_JSON_BYTES:
        raise FileFormatError(
            f"{name}: expected at most {MAX_JSON_BYTES} bytes, got {st.st_size}"
        )
    try:
        # O_NONBLOCK: should the path be swapped for a FIFO after the check, open() cannot hang.
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise FileFormatError(f"{name}: expected a readable file, got {exc.strerror}") from None
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
            raise FileFormatError(f"{name}: expected a regular file, got {_kind(st.st_mode)}")
        raw = fh.read(MAX_JSON_BYTES + 1)
    if len(raw) > MAX_JSON_BYTES:
        raise FileFormatError(f"{name}: expected at most {MAX_JSON_BYTES} bytes, got more")
    return parse_json(raw, name)


def parse_json(text: str | bytes, source: str) -> Any:
    """Parse JSON text (or UTF-8 bytes) strictly; ``source`` names it in messages.

    Same rules as :func:`read_json` minus the file checks.  Raises :class:`FileFormatError`.
    """
    if isinstance(text, bytes):
        if len(text) > MAX_JSON_BYTES:
            raise FileFormatError(
                f"{source}: expected at most {MAX_JSON_BYTES} bytes, got {len(text)}"
            )
        if text.startswith(_UTF8_BOM):
            text = text[len(_UTF8_BOM):]
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise FileFormatError(
                f"{source}: expected UTF-8 text, got byte {text[exc.start]:#04x} at offset "
                f"{exc.start} that is not UTF-8"
            ) from None
    elif text.startswith("\ufeff"):
        text = text[1:]

    def bad_constant(literal: str) -> Any:
        raise FileFormatError(
            f"{source}: expected finite numbers (strict JSON), got the constant {literal}"
        )

    def finite_float(literal: str) -> float:
        value = float(literal)
        if not math.isfinite(value):
            raise FileFormatError(
                f"{source}: expected finite numbers, got {literal[:40]} (beyond the float range)"
            )
        return value

    def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in pairs:
            if key in out:
                raise FileFormatError(
                    f"{source}: expected each key once per object, got {key[:60]!r} twice"
                )
            out[key] = value
        return out

    try:
        data = json.loads(text, parse_constant=bad_constant, parse_float=finite_float,
                          object_pairs_hook=unique_keys)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"{source}: expected valid JSON, got a syntax error at line {exc.lineno} column "
            f"{exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise FileFormatError(
            f"{source}: expected JSON nested at most {MAX_JSON_DEPTH} deep, got deeper nesting"
        ) from None
    except ValueError as exc:  # e.g. an integer literal longer than Python converts
        if isinstance(exc, FileFormatError):
            raise
        raise FileFormatError(f"{source}: expected JSON numbers Python can read ({exc})") from None
    depth = json_depth(data)
    if depth > MAX_JSON_DEPTH:
        raise FileFormatError(
            f"{source}: expected JSON nested at most {MAX_JSON_DEPTH} deep, got depth {depth}"
        )
    return data


def json_depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value (a scalar is 0, ``[]`` is 1); iterative."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children: Any = node.values()
        elif isinstance(node, list):
            children = node
        else:
            continue
        depth += 1
        deepest = max(deepest, depth)
        if depth <= MAX_JSON_DEPTH:  # deeper: the answer is already "too deep"
            stack.extend((c, depth) for c in children)
    return deepest
