"""Field readers and checks of plan files (docs/plan-format.md): each checks one value's type and
shape, or a built segment against its embedded hand, and raises
:class:`planner.errors.FileFormatError` naming the field, what was expected and what came.  Used
by :mod:`planner.plan.plan_file` (version 3) and :mod:`planner.plan.plan_versions` (versions 1
and 2)."""

from __future__ import annotations

import math
from typing import Any

from planner.errors import FileFormatError, InputError
from planner.files.fields import check_keys, friction_values, short
from planner.files.hand_file import contact_spec
from planner.model.modes import Mode
from planner.model.validation import FrictionValue
from planner.plan.model import EVENT_KINDS, Event, Segment, segment_hand

MU_MODELS = ("common", "independent")


def get(d: Any, key: str, where: str) -> Any:
    """``d[key]``; ``d`` must be an object holding ``key``."""
    if not isinstance(d, dict):
        raise FileFormatError(f"{where}: expected an object, got {type(d).__name__}")
    if key not in d:
        raise FileFormatError(f"{where}: expected key {key!r}, got keys {sorted(d)[:12]}")
    return d[key]


def num(v: Any, where: str, *, allow_none: bool = False) -> float:
    """A finite number (``None`` -> NaN when ``allow_none``: an unbounded band end)."""
    if v is None and allow_none:
        return math.nan
    try:
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
    except OverflowError:  # an integer literal beyond the float range
        ok = False
    if not ok:
        raise FileFormatError(f"{where}: expected a finite number, got {short(v)}")
    return float(v)


def nums(v: Any, where: str, n: int | None = None) -> tuple[float, ...]:
    """A list of ``n`` finite numbers (any length when ``n`` is None)."""
    if not isinstance(v, list) or (n is not None and len(v) != n):
        want = f"a list of {n} numbers" if n is not None else "a list of numbers"
        raise FileFormatError(f"{where}: expected {want}, got {short(v)}")
    return tuple(num(x, f"{where}[{i}]") for i, x in enumerate(v))


def strs(v: Any, where: str) -> tuple[str, ...]:
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise FileFormatError(f"{where}: expected a list of strings, got {short(v)}")
    return tuple(v)


def text(v: Any, where: str) -> str:
    if not isinstance(v, str):
        raise FileFormatError(f"{where}: expected a string, got {short(v)}")
    return v


def flag(v: Any, where: str) -> bool:
    if not isinstance(v, bool):
        raise FileFormatError(f"{where}: expected true or false, got {short(v)}")
    return v


def obj(v: Any, where: str) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise FileFormatError(f"{where}: expected an object, got {short(v)}")
    return v


def band(v: Any, where: str) -> tuple[float, float]:
    """``[lower, upper]`` (``null`` = unbounded), ``lower <= upper``."""
    if not isinstance(v, list) or len(v) != 2:
        raise FileFormatError(
            f"{where}: expected [lower, upper] (null = unbounded), got {short(v)}"
        )
    lo = num(v[0], f"{where}[0]", allow_none=True)
    hi = num(v[1], f"{where}[1]", allow_none=True)
    lo = -math.inf if math.isnan(lo) else lo
    hi = math.inf if math.isnan(hi) else hi
    if lo > hi:
        raise FileFormatError(f"{where}: expected lower <= upper, got {[lo, hi]}")
    return lo, hi


def margin(v: Any, where: str) -> float:
    """A margin (``null`` = unbounded)."""
    m = num(v, where, allow_none=True)
    return math.inf if math.isnan(m) else m


def mu_section(mu: Any, n_contacts: int | None = None
               ) -> tuple[str, tuple[tuple[float, float], ...], tuple[FrictionValue, ...]]:
    """``(model, intervals, validate)`` of a plan's ``mu`` object; ``n_contacts`` the contacts
    a per-contact ``validate`` entry must cover (default: one per interval)."""
    model = text(get(mu, "model", "mu"), "mu.model")
    check_keys(mu, "mu", required=("model", "intervals", "validate"))
    if model not in MU_MODELS:
        raise FileFormatError(f"mu.model: expected 'common' or 'independent', got {model!r}")
    raw = get(mu, "intervals", "mu")
    if not isinstance(raw, list) or not raw:
        raise FileFormatError(f"mu.intervals: expected a list of [lo, hi], got {short(raw)}")
    ivs = tuple(nums(iv, f"mu.intervals[{i}]", 2) for i, iv in enumerate(raw))
    if any(lo < 0 or lo > hi for lo, hi in ivs):
        raise FileFormatError(f"mu.intervals: expected 0 <= lo <= hi, got {short(raw)}")
    val = friction_values(get(mu, "validate", "mu"), "mu.validate",
                          n_contacts if n_contacts is not None else len(ivs))
    return model, ivs, val  # type: ignore[return-value]


def event(v: Any, where: str = "event") -> Event:
    """``{kind, detail, t}``: why a segment ends."""
    if not isinstance(v, dict):
        raise FileFormatError(f"{where}: expected an object, got {short(v)}")
    check_keys(v, where, required=("kind", "detail", "t"))
    kind = text(v["kind"], f"{where}.kind")
    if kind not in EVENT_KINDS:
        raise FileFormatError(f"{where}.kind: expected one of {EVENT_KINDS}, got {kind!r}")
    return Event(kind, text(v["detail"], f"{where}.detail"), num(v["t"], f"{where}.t"))


def controls(v: Any, where: str = "control") -> tuple[str, ...]:
    """Per joint ``velocity`` or ``effort``, at least one ``velocity``."""
    c = strs(v, where)
    if "velocity" not in c or set(c) - {"effort", "velocity"}:
        raise FileFormatError(f"{where}: expected 'velocity' or 'effort' per joint, at least "
                              f"one 'velocity', got {list(c)}")
    return c


def check_times(ts: list[float], where: str) -> None:
    if ts[0] != 0.0 or any(b <= a for a, b in zip(ts, ts[1:])):
        raise FileFormatError(f"{where}: expected times starting at 0 and strictly increasing")


def check_plan_top(data: dict[str, Any], keys: tuple[str, ...]) -> None:
    """Keys and types of the top level shared by versions 2 and 3."""
    check_keys(data, "plan", required=keys)
    for key, check in (("reached", flag), ("notes", text), ("policy", text),
                       ("extra", obj), ("mu", obj), ("hand", obj)):
        check(data[key], key)
    if (data["diagnosis"] is None) is not data["reached"] or not isinstance(
            data["diagnosis"], (dict, type(None))):
        raise FileFormatError("diagnosis: expected null for a plan that reaches its goal and "
                              "an object for a partial plan, got "
                              f"{type(data['diagnosis']).__name__} with reached "
                              f"{data['reached']}")
    segs = data["segments"]
    if not isinstance(segs, list) or (not segs and data["reached"]):
        raise FileFormatError("segments: expected a list of segments (empty only for a partial "
                              f"plan that stops before its first), got {short(segs)}")


def segment_intervals(ivs: tuple[tuple[float, float], ...], n_contacts: int, where: str
                      ) -> tuple[tuple[float, float], ...]:
    """A segment's per-contact intervals from the plan's: one shared pair, or one per contact."""
    if len(ivs) == 1:
        return ivs * n_contacts
    if len(ivs) != n_contacts:
        raise FileFormatError(f"{where}: expected {n_contacts} friction intervals (one per "
                              f"contact) or one for all, got {len(ivs)}")
    return ivs


def checked_segment(seg: Segment, where: str) -> Segment:
    """Check a built segment against its embedded hand: joints per control entry and
    waypoint, the claim's contacts, the ``released`` contact objects, the commands per
    partition and each waypoint's margin against its bands (:func:`check_margin`).
    ``where``: the segment's name in messages (``""`` for a version-1 plan)."""
    at = f"{where}." if where else ""
    try:
        hand = seg.hand_model.hand
    except FileFormatError as exc:
        raise FileFormatError(f"{where}: {exc}" if where else str(exc)) from None
    n_j, n_c = hand.n_joints, hand.n_contacts
    if n_j != len(seg.control) or n_c != len(seg.mu_intervals):
        raise FileFormatError(
            f"{at}hand: expected {len(seg.control)} joints (one per control entry) and "
            f"{len(seg.mu_intervals)} contacts (one per mu interval), got {n_j} joints and "
            f"{n_c} contacts")
    try:
        Mode.parse(seg.claim, n_c)
    except InputError as exc:
        raise FileFormatError(f"{at}claim: {exc}") from None
    for i, c in enumerate(seg.released):
        contact_spec(c, i, hand, f"{at}released")
    n_v, n_e = len(seg.velocity_joints), len(seg.effort_joints)
    for k, w in enumerate(seg.waypoints):
        wat = f"{at}waypoints[{k}]"
        if len(w.angles) != n_j:
            raise FileFormatError(f"{wat}.angles: expected a list of {n_j} numbers, got "
                                  f"{len(w.angles)}")
        if (len(w.velocity_commands), len(w.torque_commands), len(w.bands)) != (n_v, n_e, n_e):
            raise FileFormatError(
                f"{wat}: expected {n_v} velocity_commands and {n_e} torque_commands and bands "
                f"(one per velocity-/effort-controlled joint), got {len(w.velocity_commands)}, "
                f"{len(w.torque_commands)} and {len(w.bands)}")
        check_margin(w.margin, w.torque_commands, w.bands, wat)
    return seg


#: Relative rounding allowed between a margin and its bands: the planner computes both from the
#: same region in float64 (a Chebyshev ball and its axis slices), far below this.
MARGIN_RTOL = 1e-9


def check_margin(margin: float, taus: tuple[float, ...], bands: tuple[tuple[float, float], ...],
                 where: str) -> None:
    """A waypoint's ``margin`` against its commands and ``bands`` (docs/plan-format.md): a
    margin ``m >= 0`` is the radius of a ball of commands around ``torque_commands`` inside the
    guaranteed region, so its slice along joint ``j`` lies in ``bands[j]``:
    ``lower_j <= tau_j - m`` and ``tau_j + m <= upper_j``.  A negative margin (the command
    outside at an end of the hold interval) is not bounded by the bands: the band may be the
    one end's own."""
    if not taus or not margin >= 0:
        return
    for j, (tau, (lo, hi)) in enumerate(zip(taus, bands)):
        room = min(tau - lo, hi - tau)
        scale = max(abs(x) for x in (tau, lo, hi, margin, 1e-300) if math.isfinite(x))
        if margin > room + MARGIN_RTOL * scale:
            raise FileFormatError(
                f"{where}.margin: expected at most {room:.6g}, the room torque_commands[{j}] = "
                f"{tau:.6g} has inside bands[{j}] = [{lo:.6g}, {hi:.6g}] (a ball of radius "
                f"margin around the command lies inside every band), got {margin:.6g}")


def embedded_hand(hand: dict[str, Any], contacts: list[Any], q: Any, where: str,
                  mode: str | None = None) -> dict[str, Any]:
    """:func:`planner.plan.model.segment_hand`, its failures on a malformed hand named."""
    try:
        return segment_hand(hand, contacts, q, mode)
    except (TypeError, KeyError, IndexError, ValueError, AttributeError) as exc:
        raise FileFormatError(f"{where}: expected a hand file with 'workpiece' and "
                              f"'fingers' to embed the segment in ({type(exc).__name__}: "
                              f"{short(exc)})") from None
