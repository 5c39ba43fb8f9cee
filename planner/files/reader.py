"""The one JSON reader: every file qsplan reads (system, hand, plan, summaries) comes through here.

One set of rules for every format:

* the path must name an existing **regular file** (a missing path, a directory, a FIFO, a device
  or a socket is refused without being opened for reading in a way that could block);
* at most :data:`MAX_JSON_BYTES` bytes (refused before parsing);
* UTF-8 text (a leading byte-order mark is allowed and dropped);
* strict JSON: the non-standard constants ``NaN``, ``Infinity``, ``-Infinity``, numbers that
  overflow to infinity (``1e999``) and duplicate keys in one object are refused;
* nesting at most :data:`MAX_JSON_DEPTH` containers deep;
* within the memory budget, checked before anything is allocated: parsing is refused when the
  file's size times :data:`PARSE_BYTES_PER_BYTE` (the most memory a JSON text of that size can
  take while parsed, measured) exceeds :func:`memory_budget`; and a loader that passes
  ``cost=`` to :func:`read_json` has what it will allocate from the parsed value (dense
  matrices, grids) checked before it builds anything.

The memory budget of the process (:func:`memory_budget`): set by the command line from
``--memory-gib`` (:func:`set_memory_budget`), else ``$QSPLAN_MEMORY_GIB`` [GiB], else
:data:`DEFAULT_MEMORY_GIB`.  :func:`check_memory` refuses a request beyond it, saying how much
it would need; every refusal is an :class:`planner.errors.InputError` (exit 2), raised before
the allocation, never a ``MemoryError`` after it.

Every problem raises :class:`planner.errors.FileFormatError` (an :class:`InputError`, so the
command line exits with code 2) whose message names the file, what was expected and what came.
Parsing is plain :mod:`json`: nothing in a file is ever executed.
"""

from __future__ import annotations

import json
import math
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

from planner.errors import FileFormatError, InputError

#: Largest file any loader accepts (bytes): 64 MiB.
MAX_JSON_BYTES = 64 * 1024 * 1024

#: Deepest nesting of arrays/objects accepted (the formats need at most 7).
MAX_JSON_DEPTH = 64

_UTF8_BOM = b"\xef\xbb\xbf"

GIB = 2 ** 30
DEFAULT_MEMORY_GIB = 4.0
"""Default memory budget of one command in GiB (``--memory-gib`` or ``QSPLAN_MEMORY_GIB``)."""
MEMORY_ENV = "QSPLAN_MEMORY_GIB"
PARSE_BYTES_PER_BYTE = 50
"""Peak memory of parsing JSON per byte of text, an upper bound: measured with tracemalloc on
200,000-element arrays (docs/robustness.md): 9 for floats, 9 for a system file, 23 for
``[0.5, 0.5]`` pairs, 43-49 for arrays of ``[1]``, ``[]`` or ``{}`` (a small container per
2-3 bytes of text), the worst JSON has."""

_BUDGET: list[int | None] = [None]  # set by set_memory_budget (the command line)


def set_memory_budget(n_bytes: int | None) -> None:
    """The process's memory budget in bytes (None: back to ``$QSPLAN_MEMORY_GIB`` or the
    default)."""
    _BUDGET[0] = None if n_bytes is None else int(n_bytes)


def memory_budget() -> int:
    """The memory budget in bytes: :func:`set_memory_budget`'s, else ``$QSPLAN_MEMORY_GIB``
    [GiB], else :data:`DEFAULT_MEMORY_GIB`."""
    if _BUDGET[0] is not None:
        return _BUDGET[0]
    env = os.environ.get(MEMORY_ENV, "").strip()
    if not env:
        return int(DEFAULT_MEMORY_GIB * GIB)
    try:
        gib = float(env)
    except ValueError:
        gib = math.nan
    if not 0.0 <= gib <= 1e6:
        raise InputError(f"{MEMORY_ENV}: expected a number in [0, 1e+06], got {env!r}")
    return int(gib * GIB)


def check_memory(need_bytes: float, what: str, hint: str = "",
                 budget_bytes: int | None = None) -> None:
    """Refuse a request that would need more than the budget (default :func:`memory_budget`),
    saying how much it would need (``what`` describes the request, ``hint`` what to do
    instead)."""
    budget = memory_budget() if budget_bytes is None else budget_bytes
    if need_bytes > budget:
        raise InputError(
            f"expected a request within the memory budget ({budget / GIB:.3g} GiB), got "
            f"{what}, which would need {need_bytes / GIB:.3g} GiB"
            f"{'; ' + hint if hint else ''} (or raise --memory-gib)"
        )


def dense_bytes(*shape: int, itemsize: int = 8) -> int:
    """Bytes of a dense array of ``shape`` (float64 by default), as an exact integer."""
    n = itemsize
    for k in shape:
        n *= max(int(k), 0)
    return n


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


def read_json(path: str | os.PathLike[str], what: str,
              cost: Callable[[Any], tuple[float, str]] | None = None) -> Any:
    """Read and parse the JSON file at ``path`` under the rules of the module docstring.

    ``what`` names the kind of file in messages (e.g. ``"system file"``, ``"plan file"``).
    ``cost(value) -> (bytes, description)``: what the loader will allocate from the parsed
    value (e.g. ``dense_bytes(2 * n_c, 2 * n_c)`` for a Jacobian), checked against the budget
    before the value is returned.  Returns the parsed value (any JSON type; the caller checks
    its shape).
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
    try:
        # O_NONBLOCK: should the path be swapped for a FIFO after the check, open() cannot hang.
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise FileFormatError(f"{name}: expected a readable file, got {exc.strerror}") from None
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fh.fileno())  # the file actually opened
        if not stat.S_ISREG(st.st_mode):
            raise FileFormatError(f"{name}: expected a regular file, got {_kind(st.st_mode)}")
        if st.st_size > MAX_JSON_BYTES:
            raise FileFormatError(
                f"{name}: expected at most {MAX_JSON_BYTES} bytes, got {st.st_size}"
            )
        check_memory(st.st_size * PARSE_BYTES_PER_BYTE,
                     f"{name} of {st.st_size} bytes, whose parsing", "use a smaller file")
        raw = fh.read(st.st_size + 1)  # never more than the file had when opened, plus one
    if len(raw) > st.st_size:
        raise FileFormatError(f"{name}: expected a file that does not grow while read, got "
                              f"more than the {st.st_size} bytes it had when opened")
    data = parse_json(raw, name)
    if cost is not None:
        need, request = cost(data)
        check_memory(need, f"{name}: {request}", "use a smaller problem")
    return data


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
        data = json.loads(text, parse_constant=bad_constant, object_pairs_hook=unique_keys)
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
    depth, finite = _depth_and_finite(data)
    if depth > MAX_JSON_DEPTH:
        raise FileFormatError(
            f"{source}: expected JSON nested at most {MAX_JSON_DEPTH} deep, got depth {depth}"
        )
    if not finite:  # a literal such as 1e999 parses to infinity
        raise FileFormatError(
            f"{source}: expected finite numbers, got a number beyond the float range "
            "(such as 1e999)"
        )
    return data


def json_depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value (a scalar is 0, ``[]`` is 1); iterative."""
    return _depth_and_finite(value)[0]


def _depth_and_finite(value: Any) -> tuple[int, bool]:
    """``(depth, every float finite)`` of a parsed JSON value, iteratively; stops descending
    below :data:`MAX_JSON_DEPTH` (the answer is then already "too deep")."""
    deepest = 0
    finite = True
    isinf = math.isinf
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children: Any = list(node.values())
        elif isinstance(node, list):
            children = node
        else:
            if isinstance(node, float) and isinf(node):
                finite = False
            continue
        depth += 1
        deepest = max(deepest, depth)
        if depth > MAX_JSON_DEPTH:
            continue
        containers = [c for c in children if isinstance(c, (list, dict))]
        if len(containers) != len(children):
            finite = finite and not any(isinstance(c, float) and isinf(c) for c in children)
        stack.extend((c, depth) for c in containers)
    return deepest, finite
