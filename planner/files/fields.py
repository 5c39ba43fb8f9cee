"""Field checks shared by the file formats: required, optional and unknown keys; short values.

Every check raises :class:`planner.errors.FileFormatError` naming the field (``where``), what was
expected and what came.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from planner.errors import FileFormatError

#: Free-text keys allowed (and ignored) in every object of system and hand files: documentation
#: for people, never read by the planner.
FREE_KEYS: tuple[str, ...] = (
    "name", "description", "reference", "units", "note", "notes", "comment",
)


def short(value: Any) -> str:
    """``repr`` of a value cut to 60 characters (safe for absurdly deep nesting)."""
    try:
        text = repr(value)
    except RecursionError:
        return f"a {type(value).__name__} nested too deeply to print"
    return text if len(text) <= 60 else text[:57] + "..."


def type_name(value: Any) -> str:
    """The JSON name of a parsed value's type (``object``, ``array``, ``string``, ...)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {short(value)}"
    if isinstance(value, str):
        return f"the string {short(value)}"
    if isinstance(value, Mapping):
        return "an object"
    if isinstance(value, list):
        return "an array"
    return type(value).__name__


def as_object(value: Any, where: str) -> Mapping[str, Any]:
    """``value`` when it is a JSON object, else an error."""
    if not isinstance(value, Mapping):
        raise FileFormatError(f"{where}: expected an object, got {type_name(value)}")
    return value


def check_keys(
    obj: Mapping[str, Any],
    where: str,
    required: Iterable[str] = (),
    optional: Iterable[str] = (),
    free: Iterable[str] = (),
) -> None:
    """Every ``required`` key present; no key outside ``required | optional | free``."""
    req = list(required)
    allowed = set(req) | set(optional) | set(free)
    for key in obj:
        if key not in allowed:
            raise FileFormatError(
                f"{where}: unknown key {short(key)}; expected keys: "
                f"{', '.join(sorted(set(req) | set(optional)))}"
            )
    for key in req:
        if key not in obj:
            raise FileFormatError(
                f"{where}: expected key {key!r}, got keys {sorted(obj)[:12]}"
            )


def number(
    value: Any, where: str, *, positive: bool = False, minimum: float | None = None,
) -> float:
    """A finite JSON number (not a boolean); optionally ``> 0`` or ``>= minimum``."""
    try:
        ok = (not isinstance(value, bool) and isinstance(value, (int, float))
              and math.isfinite(value))
    except OverflowError:  # an integer beyond the float range
        ok = False
    if not ok:
        raise FileFormatError(f"{where}: expected a finite number, got {type_name(value)}")
    x = float(value)
    if positive and x <= 0:
        raise FileFormatError(f"{where}: expected a positive number, got {short(value)}")
    if minimum is not None and x < minimum:
        raise FileFormatError(f"{where}: expected a number >= {minimum:g}, got {short(value)}")
    return x


def integer(value: Any, where: str, lo: int, hi: int | None = None) -> int:
    """A JSON integer in ``[lo, hi]`` (``hi`` None: no upper end)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < lo or (
            hi is not None and value > hi):
        span = f"in [{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise FileFormatError(f"{where}: expected an integer {span}, got {type_name(value)}")
    return value


def string(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise FileFormatError(f"{where}: expected a string, got {type_name(value)}")
    return value


def boolean(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise FileFormatError(f"{where}: expected true or false, got {type_name(value)}")
    return value


def friction_values(value: Any, where: str, n_c: int) -> tuple[float | tuple[float, ...], ...]:
    """A list of friction values, each a coefficient ``>= 0`` (every contact) or a list of
    ``n_c`` of them (one per contact), e.g. a plan's ``mu.validate``."""
    if not isinstance(value, list):
        raise FileFormatError(f"{where}: expected a list of numbers or of lists of {n_c} "
                              f"numbers, got {type_name(value)}")
    def coefficient(x: Any, at: str) -> float:
        c = number(x, at)
        if c < 0:
            raise FileFormatError(f"{at}: expected coefficients >= 0, got {short(x)}")
        return c

    out: list[float | tuple[float, ...]] = []
    for i, m in enumerate(value):
        if isinstance(m, list):
            if len(m) != n_c:
                raise FileFormatError(f"{where}[{i}]: expected {n_c} coefficients (one per "
                                      f"contact), got {len(m)}")
            out.append(tuple(coefficient(x, f"{where}[{i}][{k}]") for k, x in enumerate(m)))
        else:
            out.append(coefficient(m, f"{where}[{i}]"))
    return tuple(out)
