"""Plan files: versioned, documented, tamper-evident JSON (schema in docs/plan-format.md).

A plan is what the planner hands to a controller (or to ``qsplan validate``): per waypoint the
command of the velocity-controlled joint, the torque of the effort-controlled joint with its
guaranteed band (eq. 28 over the friction interval, Figure 13) and margin, the predicted mode and
the rival modes.  It embeds the hand description it was made for, so a plan is self-contained.

Safety: files are written atomically (:mod:`planner.files.atomic`); loading goes through the one
JSON reader (:func:`planner.files.reader.read_json`: size and depth caps, strict JSON, no pickle,
no eval), checks ``format`` and ``version``, every field's type and shape, unknown keys, the
embedded hand (:func:`planner.files.hand_file.hand_from_plan`) and a SHA-256 digest of the
canonical content, so a hand-edited or truncated plan is rejected with
:class:`planner.errors.FileFormatError` naming the problem.  Infinite band ends are stored as
``null``.  JSON Schema: ``planner/files/schemas/plan.schema.json``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, InputError
from planner.files.atomic import atomic_write_text
from planner.files.fields import check_keys, friction_values
from planner.files.hand_file import HandSetup, hand_from_plan
from planner.files.reader import parse_json, read_json
from planner.model.validation import FrictionValue

PLAN_FORMAT = "qsplan-plan"
PLAN_VERSION = 1

#: Keys of a plan file (docs/plan-format.md); any other key is an error naming it.
PLAN_KEYS = ("format", "version", "claim", "control", "mu", "policy", "event", "exact", "notes",
             "extra", "hand", "waypoints", "digest")
WAYPOINT_KEYS = ("t", "pose", "angles", "velocity_command", "torque_command", "band", "margin",
                 "predicted", "rivals")
#: Optional waypoint keys of version-2 segments (any number of velocity and effort joints).
WAYPOINT_LISTS = ("velocity_commands", "torque_commands")


@dataclass(frozen=True)
class Waypoint:
    """One waypoint; commands are held until the next waypoint.

    ``t`` s; ``pose`` workpiece ``(x, y, phi)`` (m, m, rad); ``angles`` finger joint angles
    (rad); ``velocity_command`` rad/s of the velocity-controlled joint; ``torque_command`` N m of
    the effort-controlled joint; ``band`` ``(lower, upper)`` N m of the guaranteed piece used
    (``+-inf`` allowed); ``margin`` N m from the command to the nearest end of ``band`` over the
    hold interval (negative = outside); ``predicted`` mode labels the planner predicts at the
    command; ``rivals`` labels of the other modes that are possible for some torque here.
    Version-2 segments (:mod:`planner.plan.task_file`) with any control partition also give
    ``velocity_commands`` (one per velocity-controlled joint, in joint order) and
    ``torque_commands`` (one per effort-controlled joint); the scalar fields then hold the first
    of each (0 when there is none), and ``band`` is ``torque_command -+ margin``.
    """

    t: float
    pose: tuple[float, float, float]
    angles: tuple[float, ...]
    velocity_command: float
    torque_command: float
    band: tuple[float, float]
    margin: float
    predicted: tuple[str, ...]
    rivals: tuple[str, ...]
    velocity_commands: tuple[float, ...] = ()
    torque_commands: tuple[float, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        extra: dict[str, Any] = {}
        if self.velocity_commands or self.torque_commands:  # version-2 segments, any partition
            extra = {"velocity_commands": list(self.velocity_commands),
                     "torque_commands": list(self.torque_commands)}
        return {**extra,
            "t": self.t,
            "pose": list(self.pose),
            "angles": list(self.angles),
            "velocity_command": self.velocity_command,
            "torque_command": self.torque_command,
            "band": [_enc(self.band[0]), _enc(self.band[1])],
            "margin": _enc(self.margin),
            "predicted": list(self.predicted),
            "rivals": list(self.rivals),
        }


@dataclass(frozen=True)
class Plan:
    """An offline plan for one quasistatic segment of a hand (Section 5.2).

    ``hand``: the hand file content it was made for; ``claim``: the mode label the plan
    guarantees (e.g. ``"S+1 S+2 S-3 S-4"``); ``control``: per joint ``"velocity"`` or
    ``"effort"`` (Section 3.2 partition); ``mu_model`` (``common``/``independent``) and
    ``mu_intervals`` (per contact ``(lo, hi)``); ``validate_mu``: friction values the plan is
    meant to be validated at (a coefficient for every contact, or a per-contact tuple);
    ``policy``: how torques were chosen; ``event``: why the segment ends (``kind``,
    ``detail``, ``t``); ``exact``: bounds from the exact mu-dependence; ``notes``: free text.
    """

    hand: Mapping[str, Any]
    claim: str
    control: tuple[str, ...]
    mu_model: str
    mu_intervals: tuple[tuple[float, float], ...]
    validate_mu: tuple[FrictionValue, ...]
    policy: str
    event: Mapping[str, Any]
    waypoints: tuple[Waypoint, ...]
    exact: bool = True
    notes: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def velocity_joint(self) -> int:
        return self.control.index("velocity")

    @property
    def effort_joint(self) -> int:
        return self.control.index("effort")

    @cached_property
    def hand_model(self) -> HandSetup:
        """The typed hand and its initial configuration, ``(hand, q0)``, parsed once per plan
        from :attr:`hand` (:func:`planner.files.hand_file.hand_from_plan`)."""
        return hand_from_plan(self.hand)

    def times(self) -> np.ndarray:
        return np.array([w.t for w in self.waypoints])

    def poses(self) -> np.ndarray:
        return np.array([w.pose for w in self.waypoints])

    def torques(self) -> np.ndarray:
        return np.array([w.torque_command for w in self.waypoints])

    def velocities(self) -> np.ndarray:
        return np.array([w.velocity_command for w in self.waypoints])

    def bands(self) -> np.ndarray:
        return np.array([w.band for w in self.waypoints])

    def margins(self) -> np.ndarray:
        return np.array([w.margin for w in self.waypoints])

    def travel(self) -> float:
        p = self.poses()
        return float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)))

    def body(self) -> dict[str, Any]:
        """The JSON content without the digest (what the digest covers)."""
        return {
            "format": PLAN_FORMAT,
            "version": PLAN_VERSION,
            "claim": self.claim,
            "control": list(self.control),
            "mu": {"model": self.mu_model,
                   "intervals": [list(iv) for iv in self.mu_intervals],
                   "validate": [m if isinstance(m, float) else list(m)
                                for m in self.validate_mu]},
            "policy": self.policy,
            "event": dict(self.event),
            "exact": self.exact,
            "notes": self.notes,
            "extra": dict(self.extra),
            "hand": self.hand,
            "waypoints": [w.to_dict() for w in self.waypoints],
        }

    def to_dict(self) -> dict[str, Any]:
        body = self.body()
        body["digest"] = {"algorithm": "sha256", "value": digest(body)}
        return body


def _enc(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def canonical(obj: Any) -> str:
    """Canonical JSON text: sorted keys, no spaces, no NaN (what the digest hashes)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def digest(body: Mapping[str, Any]) -> str:
    return hashlib.sha256(canonical(body).encode("utf-8")).hexdigest()


def save_plan(plan: Plan, path: str | os.PathLike[str]) -> Path:
    """Write ``plan`` atomically as indented JSON with its digest; returns the path."""
    if not isinstance(plan, Plan):
        raise InputError(f"save_plan: expected a Plan, got {type(plan).__name__}")
    try:
        text = json.dumps(plan.to_dict(), indent=1, allow_nan=False) + "\n"
    except (ValueError, TypeError) as exc:
        raise InputError(f"save_plan: expected JSON-serialisable finite content ({exc})") from None
    return atomic_write_text(path, text)


def load_plan(path: str | os.PathLike[str]) -> Plan:
    """Read and verify a plan file (through :func:`planner.files.reader.read_json`).  Raises
    :class:`FileFormatError` (missing, not a regular file, too large, malformed, wrong version,
    tampered)."""
    data = read_json(path, "plan file")
    return _checked(data, f"plan file {str(path)!r}")


def plan_from_json(text: str | bytes, source: str = "<string>") -> Plan:
    """Parse and verify plan text (the rules of :func:`load_plan` minus the file checks)."""
    return _checked(parse_json(text, f"plan file {source}"), f"plan file {source}")


def _checked(data: Any, source: str) -> Plan:
    try:
        return plan_from_dict(data)
    except FileFormatError as exc:
        raise FileFormatError(f"{source}: {exc}") from None


# ---- validation of the parsed content ------------------------------------------------------
def _get(d: Any, key: str, where: str) -> Any:
    if not isinstance(d, dict):
        raise FileFormatError(f"{where}: expected an object, got {type(d).__name__}")
    if key not in d:
        raise FileFormatError(f"{where}: expected key {key!r}, got keys {sorted(d)[:12]}")
    return d[key]


def _num(v: Any, where: str, *, allow_none: bool = False) -> float:
    if v is None and allow_none:
        return math.nan
    try:
        ok = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
    except OverflowError:  # an integer literal beyond the float range
        ok = False
    if not ok:
        raise FileFormatError(f"{where}: expected a finite number, got {_short(v)}")
    return float(v)


def _nums(v: Any, where: str, n: int | None = None) -> tuple[float, ...]:
    if not isinstance(v, list) or (n is not None and len(v) != n):
        want = f"a list of {n} numbers" if n is not None else "a list of numbers"
        raise FileFormatError(f"{where}: expected {want}, got {_short(v)}")
    return tuple(_num(x, f"{where}[{i}]") for i, x in enumerate(v))


def _strs(v: Any, where: str) -> tuple[str, ...]:
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise FileFormatError(f"{where}: expected a list of strings, got {_short(v)}")
    return tuple(v)


def _str(v: Any, where: str) -> str:
    if not isinstance(v, str):
        raise FileFormatError(f"{where}: expected a string, got {_short(v)}")
    return v


def _short(v: Any) -> str:
    try:
        text = repr(v)
    except RecursionError:
        return f"a {type(v).__name__} nested too deeply to print"
    return text if len(text) <= 60 else text[:57] + "..."


def _band(v: Any, where: str) -> tuple[float, float]:
    if not isinstance(v, list) or len(v) != 2:
        raise FileFormatError(
            f"{where}: expected [lower, upper] (null = unbounded), got {_short(v)}"
        )
    lo = _num(v[0], f"{where}[0]", allow_none=True)
    hi = _num(v[1], f"{where}[1]", allow_none=True)
    lo = -math.inf if math.isnan(lo) else lo
    hi = math.inf if math.isnan(hi) else hi
    return lo, hi


def plan_from_dict(data: Any) -> Plan:
    """Verify parsed plan content (format, version, digest, fields) and build the :class:`Plan`."""
    if not isinstance(data, dict):
        raise FileFormatError(f"expected a JSON object, got {type(data).__name__}")
    fmt, ver = data.get("format"), data.get("version")
    if fmt != PLAN_FORMAT:
        raise FileFormatError(f"expected format {PLAN_FORMAT!r}, got {_short(fmt)}")
    if ver != PLAN_VERSION:
        raise FileFormatError(f"expected plan version {PLAN_VERSION}, got {_short(ver)}"
                              + ("; a whole-task plan (segments): read it with planner.plan."
                                 "task_file.load_task_plan" if ver == 2 else ""))
    check_keys(data, "plan", optional=PLAN_KEYS)
    check_digest(data)
    return plan_from_body(data)


def check_digest(data: dict[str, Any]) -> None:
    """Verify the ``digest`` of parsed plan content (any version)."""
    dg = _get(data, "digest", "plan")
    value = _get(dg, "value", "digest")
    check_keys(dg, "digest", required=("algorithm", "value"))
    if _get(dg, "algorithm", "digest") != "sha256" or not isinstance(value, str):
        raise FileFormatError(f"digest: expected a sha256 value, got {_short(dg)}")
    body = {k: v for k, v in data.items() if k != "digest"}
    try:
        actual = digest(body)
    except ValueError as exc:  # NaN sneaked in through a non-standard writer
        raise FileFormatError(f"expected finite numbers ({exc})") from None
    except RecursionError:
        raise FileFormatError("expected a plan, got content nested too deeply") from None
    if actual != value:
        raise FileFormatError(
            "digest mismatch: the plan was modified after it was written "
            f"(expected sha256 {value[:12]}..., content hashes to {actual[:12]}...)"
        )


def plan_from_body(data: dict[str, Any], *, any_control: bool = False) -> Plan:
    """The :class:`Plan` of checked-digest content (every field but ``format``/``version``/
    ``digest``).  ``any_control``: a version-2 segment, any number of effort joints (at least
    one velocity joint); else exactly one effort joint (version 1)."""
    control = _strs(_get(data, "control", "plan"), "control")
    if any_control:
        if "velocity" not in control or set(control) - {"effort", "velocity"}:
            raise FileFormatError(f"control: expected 'velocity' or 'effort' per joint, at "
                                  f"least one 'velocity', got {list(control)}")
    elif sorted(set(control)) != ["effort", "velocity"] or control.count("effort") != 1:
        raise FileFormatError(
            f"control: expected one 'effort' joint and the rest 'velocity', got {list(control)}"
        )
    mu = _get(data, "mu", "plan")
    model = _str(_get(mu, "model", "mu"), "mu.model")
    check_keys(mu, "mu", required=("model", "intervals", "validate"))
    if model not in ("common", "independent"):
        raise FileFormatError(f"mu.model: expected 'common' or 'independent', got {model!r}")
    ivs_raw = _get(mu, "intervals", "mu")
    if not isinstance(ivs_raw, list) or not ivs_raw:
        raise FileFormatError(f"mu.intervals: expected a list of [lo, hi], got {_short(ivs_raw)}")
    ivs = tuple(_nums(iv, f"mu.intervals[{i}]", 2) for i, iv in enumerate(ivs_raw))
    if any(lo < 0 or lo > hi for lo, hi in ivs):
        raise FileFormatError(f"mu.intervals: expected 0 <= lo <= hi, got {_short(ivs_raw)}")
    val = friction_values(_get(mu, "validate", "mu"), "mu.validate", len(ivs))
    hand = _get(data, "hand", "plan")
    if not isinstance(hand, dict):
        raise FileFormatError(f"hand: expected an object, got {_short(hand)}")
    event = _get(data, "event", "plan")
    if not isinstance(event, dict):
        raise FileFormatError(f"event: expected an object, got {_short(event)}")
    check_keys(event, "event", required=("kind", "detail", "t"))
    _str(event["kind"], "event.kind")
    _str(event["detail"], "event.detail")
    _num(event["t"], "event.t")
    wps_raw = _get(data, "waypoints", "plan")
    if not isinstance(wps_raw, list) or len(wps_raw) < 2:
        raise FileFormatError(
            f"waypoints: expected a list of >= 2 waypoints, got {_short(wps_raw)}"
        )
    n_f = len(control)
    wps = []
    for i, w in enumerate(wps_raw):
        where = f"waypoints[{i}]"
        if isinstance(w, dict):
            check_keys(w, where, required=WAYPOINT_KEYS,
                       optional=WAYPOINT_LISTS if any_control else ())
        lists = (tuple(_nums(w.get("velocity_commands"), f"{where}.velocity_commands",
                             control.count("velocity"))),
                 tuple(_nums(w.get("torque_commands"), f"{where}.torque_commands",
                             control.count("effort")))) if any_control else ((), ())
        band = _band(_get(w, "band", where), f"{where}.band")
        if band[0] > band[1]:
            raise FileFormatError(f"{where}.band: expected lower <= upper, got {list(band)}")
        margin = _num(_get(w, "margin", where), f"{where}.margin", allow_none=True)
        wps.append(Waypoint(
            t=_num(_get(w, "t", where), f"{where}.t"),
            pose=_nums(_get(w, "pose", where), f"{where}.pose", 3),  # type: ignore[arg-type]
            angles=_nums(_get(w, "angles", where), f"{where}.angles", n_f),
            velocity_command=_num(_get(w, "velocity_command", where), f"{where}.velocity_command"),
            torque_command=_num(_get(w, "torque_command", where), f"{where}.torque_command"),
            band=band,
            margin=math.inf if math.isnan(margin) else margin,
            predicted=_strs(_get(w, "predicted", where), f"{where}.predicted"),
            rivals=_strs(_get(w, "rivals", where), f"{where}.rivals"),
            velocity_commands=lists[0],
            torque_commands=lists[1],
        ))
    ts = [w.t for w in wps]
    if ts[0] != 0.0 or any(b <= a for a, b in zip(ts, ts[1:])):
        raise FileFormatError("waypoints: expected times starting at 0 and strictly increasing")
    extra = data.get("extra", {})
    if not isinstance(extra, dict):
        raise FileFormatError(f"extra: expected an object, got {_short(extra)}")
    exact = data.get("exact", True)
    if not isinstance(exact, bool):
        raise FileFormatError(f"exact: expected true or false, got {_short(exact)}")
    plan = Plan(
        hand=hand,
        claim=_str(_get(data, "claim", "plan"), "claim"),
        control=control,
        mu_model=model,
        mu_intervals=ivs,  # type: ignore[arg-type]
        validate_mu=val,
        policy=_str(_get(data, "policy", "plan"), "policy"),
        event=event,
        waypoints=tuple(wps),
        exact=exact,
        notes=_str(data.get("notes", ""), "notes"),
        extra=extra,
    )
    model_hand = plan.hand_model.hand  # checks the embedded hand once; cached on the plan
    if model_hand.n_joints != n_f or model_hand.n_contacts != len(ivs):
        raise FileFormatError(
            f"hand: expected {n_f} joints (one per control entry) and {len(ivs)} contacts "
            f"(one per mu interval), got {model_hand.n_joints} joints and "
            f"{model_hand.n_contacts} contacts"
        )
    return plan


def plans_equal(a: Plan, b: Plan) -> bool:
    """True when two plans have the same canonical content."""
    return canonical(a.body()) == canonical(b.body())


