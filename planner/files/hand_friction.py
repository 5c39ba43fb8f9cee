"""The friction section of a hand file (``mu``: ``interval``, ``bodies``, ``validate``;
docs/file-formats.md, "Hand file").  Errors are :class:`FileFormatError` naming the field."""

from __future__ import annotations

from typing import Any

from planner.errors import FileFormatError
from planner.files.fields import FREE_KEYS, as_object, check_keys, number, short, type_name
from planner.model.validation import friction_interval


def mu_bodies(raw: Any, names: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    """``mu.bodies``: body name (``palm``, an environment surface's or a finger's name) ->
    ``[lo, hi]``, the friction interval of every contact on that body."""
    obj = as_object(raw, "mu.bodies")
    out = {}
    for key, pair in obj.items():
        if key not in names:
            raise FileFormatError(f"mu.bodies: expected body names among {list(names)} (the "
                                  f"palm, environment surfaces and fingers), got {key!r}")
        if not (isinstance(pair, list) and len(pair) == 2):
            raise FileFormatError(f"mu.bodies.{key}: expected [lo, hi], got {short(pair)}")
        lo, hi = (number(x, f"mu.bodies.{key}", minimum=0.0) for x in pair)
        if hi < lo:
            raise FileFormatError(f"mu.bodies.{key}: expected lo <= hi, got [{lo}, {hi}]")
        out[str(key)] = (lo, hi)
    return out


def mu_section(mu: Any, n_c: int) -> tuple[tuple[tuple[float, float], ...] | None,
                                           tuple[Any, ...]]:
    """The ``mu`` section of a hand file with ``n_c`` contacts: ``(interval, validate)`` --
    ``interval`` one ``(lo, hi)`` or one per contact (None when absent), ``validate`` the
    friction values (numbers; with ``bodies`` also objects body -> coefficient)."""
    mu = as_object(mu, "mu")
    check_keys(mu, "mu", optional=("interval", "validate", "bodies"), free=FREE_KEYS)
    interval = None
    if "interval" in mu:
        raw = mu["interval"]
        pairs = [raw] if isinstance(raw, list) and len(raw) == 2 and not any(
            isinstance(x, list) for x in raw) else raw
        if not isinstance(pairs, list) or len(pairs) not in (1, n_c) or not all(
                isinstance(p, list) and len(p) == 2 for p in pairs):
            raise FileFormatError(
                f"mu.interval: expected [lo, hi] or {n_c} such pairs (one per contact), "
                f"got {short(raw)}"
            )
        out = [(number(p[0], "mu.interval"), number(p[1], "mu.interval")) for p in pairs]
        friction_interval(out if len(out) > 1 else out[0], n_c, "mu.interval")  # signs, order
        interval = tuple(out)
    val = mu.get("validate", [])
    if not isinstance(val, list):
        raise FileFormatError(f"mu.validate: expected a list of numbers, got {type_name(val)}")
    if "bodies" in mu:  # numbers or objects body -> coefficient, checked against mu.bodies
        return interval, tuple(
            _body_values(v, f"mu.validate[{i}]") if isinstance(v, dict)
            else number(v, f"mu.validate[{i}]", minimum=0.0) for i, v in enumerate(val))
    return interval, tuple(number(v, f"mu.validate[{i}]", minimum=0.0) for i, v in enumerate(val))


def _body_values(obj: dict[str, Any], where: str) -> Any:
    """A ``mu.validate`` entry of a file with ``mu.bodies``: body name -> coefficient."""
    return {str(k): number(x, f"{where}.{k}", minimum=0.0) for k, x in obj.items()}


def body_intervals(hand: Any, contacts: list[Any], default: tuple[float, float]
                   ) -> tuple[tuple[float, float], ...] | None:
    """Per contact object of ``contacts`` its body's interval from the hand file content
    ``hand``'s ``mu.bodies`` (``default`` for a body not listed); None without ``mu.bodies``.
    A plan made with ``mu.bodies`` is guaranteed over these intervals, segment by segment."""
    mu = hand.get("mu") if isinstance(hand, dict) else None
    bodies = mu.get("bodies") if isinstance(mu, dict) else None
    if not isinstance(bodies, dict):
        return None
    fingers = hand.get("fingers") or []
    out = []
    for c in contacts:
        kind = c.get("kind")
        if kind == "palm":
            name = "palm"
        elif kind == "surface":
            name = str(c.get("surface"))
        else:
            k = int(c.get("finger", 0))
            name = str(fingers[k].get("name", f"finger{k + 1}")) if k < len(fingers) else ""
        pair = bodies.get(name)
        out.append((float(pair[0]), float(pair[1])) if isinstance(pair, list) and len(pair) == 2
                   else default)
    return tuple(out)
