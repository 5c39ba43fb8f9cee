"""Option parsing shared by the subcommands: one range syntax, finite numbers, a memory budget,
plain number formatting.

Every parser raises :class:`planner.errors.InputError` whose message names the option, says
what was expected and quotes what came (the CLI maps it to exit 2).
"""

from __future__ import annotations

import contextlib
import math
import sys
import warnings
from collections.abc import Iterator, Sequence

from planner.errors import InputError
from planner.files.reader import GIB, check_memory
from planner.files.reader import memory_budget as process_memory_budget

MU_MAX = 1e6
"""Largest friction coefficient the command line accepts (larger values are typing errors)."""


def parse_number(text: str, what: str, *, lo: float = -math.inf, hi: float = math.inf) -> float:
    """A finite number in ``[lo, hi]``; ``what`` names the option in the message."""
    tok = str(text).strip()
    try:
        value = float(tok)
    except ValueError:
        raise InputError(f"{what}: expected a number, got {tok!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{what}: expected a finite number, got {tok!r}")
    if not lo <= value <= hi:
        raise InputError(f"{what}: expected a number in [{fmt(lo)}, {fmt(hi)}], got {tok!r}")
    return value


def parse_numbers(text: str, what: str, *, lo: float = -math.inf,
                  hi: float = math.inf) -> list[float]:
    """Comma-separated finite numbers in ``[lo, hi]`` (at least one)."""
    parts = [p for p in str(text).split(",")]
    if not str(text).strip() or any(not p.strip() for p in parts):
        raise InputError(f"{what}: expected comma-separated numbers, got {text!r}")
    for p in parts:
        try:
            float(p)
        except ValueError:
            raise InputError(f"{what}: expected comma-separated numbers, got {p.strip()!r}"
                             + (f" in {text!r}" if len(parts) > 1 else "")) from None
    return [parse_number(p, what, lo=lo, hi=hi) for p in parts]


def parse_indices(text: str, what: str, count: int | None = None) -> list[int]:
    """Comma-separated 1-based integers (``1,2``); with ``count``, each in ``1..count``."""
    out = []
    for tok in str(text).split(","):
        tok = tok.strip()
        try:
            value = int(tok)
        except ValueError:
            raise InputError(f"{what}: expected comma-separated 1-based integers, got "
                             f"{text!r}") from None
        if value < 1 or (count is not None and value > count):
            span = f"1..{count}" if count is not None else ">= 1"
            raise InputError(f"{what}: expected indices in {span}, got {value}")
        out.append(value)
    return out


def parse_range(text: str, what: str, *, lo: float = 0.0, hi: float = MU_MAX,
                legacy_comma: bool = False) -> tuple[float, float]:
    """``"LO:HI"`` -> ``(LO, HI)`` with ``lo <= LO <= HI <= hi``, both finite.

    The one range syntax of the command line.  ``legacy_comma=True`` also accepts ``LO,HI``
    (only for options whose help documented it).
    """
    raw = str(text).strip()
    parts = raw.split(":")
    if legacy_comma and len(parts) == 1 and raw.count(",") == 1:
        parts = raw.split(",")
    if len(parts) != 2:
        hint = " (a comma is not a range separator)" if "," in raw else ""
        raise InputError(f"{what}: expected LO:HI, e.g. 0:1, got {raw!r}{hint}")
    a = parse_number(parts[0], what, lo=lo, hi=hi)
    b = parse_number(parts[1], what, lo=lo, hi=hi)
    if a > b:
        raise InputError(f"{what}: expected LO <= HI, got {raw!r}")
    return a, b


def parse_engines(text: str, what: str) -> list[str]:
    """Comma-separated engine names of the settings table, each installed
    (:func:`sim.backends.require_engine`: its message names the choices or the install
    command), without repeats."""
    from sim.backends import ENGINES, require_engine

    names = [e.strip() for e in str(text).split(",")]
    if any(not e for e in names):
        raise InputError(f"{what}: expected one of {', '.join(ENGINES)} or several of them "
                         f"comma-separated, got {text!r}")
    return list(dict.fromkeys(require_engine(e, what) for e in names))


def check_int(value: int, what: str, lo: int, hi: int | None = None) -> int:
    """An integer option in ``[lo, hi]``."""
    if value < lo or (hi is not None and value > hi):
        span = f">= {lo}" if hi is None else f"in {lo}..{hi}"
        raise InputError(f"{what}: expected an integer {span}, got {value}")
    return value


def memory_budget(gib: float | None = None) -> int:
    """The memory budget in bytes: ``gib``, else the process's
    (:func:`planner.files.reader.memory_budget`: ``--memory-gib``, ``$QSPLAN_MEMORY_GIB`` or
    the default)."""
    return process_memory_budget() if gib is None else int(gib * GIB)


def check_budget(need_bytes: float, budget_bytes: int, what: str, hint: str = "") -> None:
    """Refuse a request that would need more than the budget, saying how much it would need
    (``what`` describes the request, ``hint`` what to do instead;
    :func:`planner.files.reader.check_memory`)."""
    check_memory(need_bytes, what, hint, budget_bytes)


def fmt(x: float, spec: str = "g") -> str:
    """A number as text without ``-0`` and without numpy's type wrapper."""
    value = float(x)
    if value == 0.0:
        value = 0.0  # drops the sign of -0.0
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    text = format(value, spec)
    if text.lstrip().startswith("-") and float(text) == 0.0:  # rounds to zero: no sign
        text = text.replace("-", "+" if "+" in spec else "", 1)
    return text


def fmt_list(values: Sequence[float], spec: str = ".4g") -> str:
    """``[a, b, c]`` formatted with :func:`fmt`."""
    return "[" + ", ".join(fmt(v, spec) for v in values) + "]"


@contextlib.contextmanager
def input_warnings(command: str) -> Iterator[None]:
    """Print every :class:`planner.errors.GeometryWarning` raised inside as one line on stderr,
    ``qsplan COMMAND: warning: ...`` (the input is used as given; the message says the fix)."""
    from planner.errors import GeometryWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GeometryWarning)
        yield
    seen = set()
    for w in caught:
        if issubclass(w.category, GeometryWarning) and str(w.message) not in seen:
            seen.add(str(w.message))
            print(f"qsplan {command}: warning: {w.message}", file=sys.stderr)
        elif not issubclass(w.category, GeometryWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
