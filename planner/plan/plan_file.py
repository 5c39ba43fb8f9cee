"""Plan files: versioned, documented, tamper-evident JSON (docs/plan-format.md).

:func:`save_plan` writes a :class:`planner.plan.model.Plan` as ``qsplan-plan`` version 3 (the
plan model: segments of waypoints, any control partition).  :func:`load_plan` reads every
version into that model: version 3; version 2 (whole tasks) and version 1 (one segment with one
velocity- and one effort-controlled joint, read as a plan of one segment) through
:mod:`planner.plan.plan_versions`.

Safety: files are written atomically (:mod:`planner.files.atomic`); loading goes through the one
JSON reader (:func:`planner.files.reader.read_json`: size and depth caps, strict JSON, no pickle,
no eval), checks ``format`` and ``version``, every field's type and shape, unknown keys, the
embedded hand of every segment (:func:`planner.files.hand_file.hand_from_plan`) and a SHA-256
digest of the canonical content, so a hand-edited or truncated plan is rejected with
:class:`planner.errors.FileFormatError` naming the problem.  Infinite band ends are stored as
``null``.  JSON Schema: ``planner/files/schemas/plan.schema.json``.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from planner.errors import FileFormatError, InputError
from planner.files.atomic import atomic_write_text
from planner.files.fields import check_keys, short
from planner.files.hand_friction import body_intervals
from planner.files.reader import parse_json, read_json
from planner.plan import plan_fields as pf
from planner.plan.model import Plan, Segment, Waypoint
from planner.plan.plan_fields import (
    check_plan_top,
    checked_segment,
    embedded_hand,
    segment_intervals,
)
from planner.plan.plan_versions import from_version_1, from_version_2

PLAN_FORMAT = "qsplan-plan"
#: The version :func:`save_plan` writes; :data:`READ_VERSIONS` are read.
PLAN_VERSION = 3
READ_VERSIONS = (1, 2, 3)

#: Keys of a version-3 plan, segment and waypoint (docs/plan-format.md); others are errors.
PLAN_KEYS = ("format", "version", "mu", "policy", "notes", "extra", "hand", "reached",
             "diagnosis", "segments", "digest")
SEGMENT_KEYS = ("claim", "control", "contacts", "released", "event", "exact", "notes", "extra",
                "waypoints")
WAYPOINT_KEYS = ("t", "pose", "angles", "velocity_commands", "torque_commands", "bands",
                 "margin", "predicted", "rivals")


def canonical(obj: Any) -> str:
    """Canonical JSON text: sorted keys, no spaces, no NaN (what the digest hashes)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def digest(body: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``body``."""
    return hashlib.sha256(canonical(body).encode("utf-8")).hexdigest()


def plan_body(plan: Plan) -> dict[str, Any]:
    """The version-3 JSON content of ``plan`` without the digest (what the digest covers)."""
    return {
        "format": PLAN_FORMAT, "version": PLAN_VERSION,
        "mu": {"model": plan.mu_model, "intervals": [list(iv) for iv in plan.mu_intervals],
               "validate": [m if isinstance(m, float) else list(m) for m in plan.validate_mu]},
        "policy": plan.policy if plan.segments else "",
        "notes": plan.notes, "extra": dict(plan.extra), "hand": dict(plan.hand),
        "reached": plan.reached,
        "diagnosis": None if plan.diagnosis is None else dict(plan.diagnosis),
        "segments": [{"claim": s.claim, "control": list(s.control),
                      "contacts": [dict(c) for c in s.contacts],
                      "released": [dict(c) for c in s.released], "event": s.event.to_dict(),
                      "exact": s.exact, "notes": s.notes, "extra": dict(s.extra),
                      "waypoints": [w.to_dict() for w in s.waypoints]}
                     for s in plan.segments],
    }


def plan_dict(plan: Plan) -> dict[str, Any]:
    """The version-3 JSON content of ``plan`` with its digest."""
    body = plan_body(plan)
    body["digest"] = {"algorithm": "sha256", "value": digest(body)}
    return body


def plans_equal(a: Plan, b: Plan) -> bool:
    """True when two plans have the same canonical content."""
    return canonical(plan_body(a)) == canonical(plan_body(b))


def save_plan(plan: Plan, path: str | os.PathLike[str]) -> Path:
    """Write ``plan`` atomically as indented version-3 JSON with its digest; returns the path."""
    if not isinstance(plan, Plan):
        raise InputError(f"save_plan: expected a Plan, got {type(plan).__name__}")
    try:
        text = json.dumps(plan_dict(plan), indent=1, allow_nan=False) + "\n"
    except (ValueError, TypeError) as exc:
        raise InputError(f"save_plan: expected JSON-serialisable finite content ({exc})") from None
    return atomic_write_text(path, text)


def load_plan(path: str | os.PathLike[str]) -> Plan:
    """Read and verify a plan file of any version (module docstring).  Raises
    :class:`FileFormatError` (missing, not a regular file, too large, malformed, unknown
    version, tampered) naming the file and the field."""
    return _checked(read_json(path, "plan file"), f"plan file {str(path)!r}")


def plan_from_json(text: str | bytes, source: str = "<string>") -> Plan:
    """Parse and verify plan text (the rules of :func:`load_plan` minus the file checks)."""
    return _checked(parse_json(text, f"plan file {source}"), f"plan file {source}")


def _checked(data: Any, source: str) -> Plan:
    try:
        return plan_from_dict(data)
    except FileFormatError as exc:
        raise FileFormatError(f"{source}: {exc}") from None


def plan_from_dict(data: Any) -> Plan:
    """Verify parsed plan content of any version (format, version, digest, fields) and build
    the :class:`Plan`."""
    if not isinstance(data, dict):
        raise FileFormatError(f"expected a JSON object, got {type(data).__name__}")
    fmt, ver = data.get("format"), data.get("version")
    if fmt != PLAN_FORMAT:
        raise FileFormatError(f"expected format {PLAN_FORMAT!r}, got {short(fmt)}")
    if isinstance(ver, bool) or ver not in READ_VERSIONS:
        raise FileFormatError(f"expected plan version {', '.join(map(str, READ_VERSIONS))}, "
                              f"got {short(ver)}")
    check_digest(data)
    if ver == 1:
        return from_version_1(data)
    if ver == 2:
        return from_version_2(data)
    return _from_version_3(data)


def check_digest(data: dict[str, Any]) -> None:
    """Verify the ``digest`` of parsed plan content (any version)."""
    dg = pf.get(data, "digest", "plan")
    value = pf.get(dg, "value", "digest")
    check_keys(dg, "digest", required=("algorithm", "value"))
    if pf.get(dg, "algorithm", "digest") != "sha256" or not isinstance(value, str):
        raise FileFormatError(f"digest: expected a sha256 value, got {short(dg)}")
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


def waypoint(w: Any, where: str, keys: tuple[str, ...]) -> Waypoint:
    """A version-3 waypoint (``keys`` its keys)."""
    if not isinstance(w, dict):
        raise FileFormatError(f"{where}: expected an object, got {short(w)}")
    check_keys(w, where, required=keys)
    bands = w["bands"]
    if not isinstance(bands, list):
        raise FileFormatError(f"{where}.bands: expected a list of [lower, upper], got "
                              f"{short(bands)}")
    return Waypoint(
        t=pf.num(w["t"], f"{where}.t"),
        pose=pf.nums(w["pose"], f"{where}.pose", 3),  # type: ignore[arg-type]
        angles=pf.nums(w["angles"], f"{where}.angles"),
        velocity_commands=pf.nums(w["velocity_commands"], f"{where}.velocity_commands"),
        torque_commands=pf.nums(w["torque_commands"], f"{where}.torque_commands"),
        bands=tuple(pf.band(b, f"{where}.bands[{i}]") for i, b in enumerate(bands)),
        margin=pf.margin(w["margin"], f"{where}.margin"),
        predicted=pf.strs(w["predicted"], f"{where}.predicted"),
        rivals=pf.strs(w["rivals"], f"{where}.rivals"))


def _from_version_3(data: dict[str, Any]) -> Plan:
    check_plan_top(data, PLAN_KEYS)
    model, ivs, val = pf.mu_section(data["mu"], _contacts_of(data))
    segs = []
    for i, s in enumerate(data["segments"]):
        where = f"segments[{i}]"
        if not isinstance(s, dict):
            raise FileFormatError(f"{where}: expected an object, got {type(s).__name__}")
        check_keys(s, where, required=SEGMENT_KEYS)
        segs.append(_segment(s, where, data, ivs))
    return Plan(hand=data["hand"], segments=tuple(segs), mu_model=model, mu_intervals=ivs,
                validate_mu=val, reached=data["reached"], diagnosis=data["diagnosis"],
                notes=data["notes"], extra=data["extra"])


def _contacts_of(data: dict[str, Any]) -> int:
    """Contacts a per-contact ``mu.validate`` entry covers: the first segment's (every
    segment's when the intervals are per contact), else the hand's."""
    segs = data.get("segments")
    if isinstance(segs, list) and segs and isinstance(segs[0], dict) and isinstance(
            segs[0].get("contacts"), list):
        return len(segs[0]["contacts"])
    contacts = data["hand"].get("contacts")
    return len(contacts) if isinstance(contacts, list) else 0


def _hull(ivs: tuple[tuple[float, float], ...]) -> tuple[float, float]:
    return (min(a for a, _ in ivs), max(b for _, b in ivs)) if ivs else (0.0, 0.0)


def _segment(s: dict[str, Any], where: str, data: dict[str, Any],
             ivs: tuple[tuple[float, float], ...]) -> Segment:
    control = pf.controls(s["control"], f"{where}.control")
    for key in ("contacts", "released"):
        if not isinstance(s[key], list) or not all(isinstance(c, dict) for c in s[key]):
            raise FileFormatError(f"{where}.{key}: expected a list of contact objects, got "
                                  f"{short(s[key])}")
    wps_raw = s["waypoints"]
    if not isinstance(wps_raw, list) or len(wps_raw) < 2:
        raise FileFormatError(f"{where}.waypoints: expected a list of >= 2 waypoints, got "
                              f"{short(wps_raw)}")
    wps = tuple(waypoint(w, f"{where}.waypoints[{k}]", WAYPOINT_KEYS)
                for k, w in enumerate(wps_raw))
    pf.check_times([w.t for w in wps], f"{where}.waypoints")
    claim = pf.text(s["claim"], f"{where}.claim")
    seg = Segment(
        claim=claim, control=control, waypoints=wps,
        hand=embedded_hand(data["hand"], s["contacts"], wps[0].q, f"{where}.hand", claim),
        mu_intervals=body_intervals(data["hand"], s["contacts"], _hull(ivs))
        or segment_intervals(ivs, len(s["contacts"]), f"{where}.contacts"),
        event=pf.event(s["event"], f"{where}.event"), released=tuple(s["released"]),
        policy=data["policy"], exact=pf.flag(s["exact"], f"{where}.exact"),
        notes=pf.text(s["notes"], f"{where}.notes"), extra=pf.obj(s["extra"], f"{where}.extra"))
    return checked_segment(seg, where)
