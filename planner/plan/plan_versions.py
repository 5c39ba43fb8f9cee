"""Plan files of versions 1 and 2, read into the plan model (docs/plan-format.md, "Versions").

* Version 1: one segment of a hand with one velocity- and one effort-controlled joint; its
  waypoints give ``velocity_command``, ``torque_command`` and ``band`` (the guaranteed band
  over the hold interval).  It becomes a plan of one segment: the rate and the effort are the
  one-element ``velocity_commands`` and ``torque_commands``, the band the one ``bands`` entry.
* Version 2: a whole task; its waypoints give ``velocity_commands``, ``torque_commands``, the
  first of each again as ``velocity_command``/``torque_command`` (checked to be equal) and
  ``band`` = the first effort's command ``-+ margin``.  Each effort joint's band becomes its
  command ``-+ margin`` (the Chebyshev ball's extent along that joint: inside the guaranteed
  region).

Both are verified as version 3 is (:func:`planner.plan.plan_file.plan_from_dict` checks the
digest first): unknown or missing keys, every field's type and shape, the embedded hand.
"""

from __future__ import annotations

from typing import Any

from planner.errors import FileFormatError
from planner.files.fields import check_keys, short
from planner.plan import plan_fields as pf
from planner.plan.model import Plan, Segment, Waypoint
from planner.plan.plan_fields import (
    check_plan_top,
    checked_segment,
    embedded_hand,
    segment_intervals,
)

#: Keys of a version-1 plan and waypoint.
V1_KEYS = ("format", "version", "claim", "control", "mu", "policy", "event", "exact", "notes",
           "extra", "hand", "waypoints", "digest")
V1_WAYPOINT_KEYS = ("t", "pose", "angles", "velocity_command", "torque_command", "band",
                    "margin", "predicted", "rivals")
#: Keys of a version-2 plan, segment and waypoint.
V2_KEYS = ("format", "version", "mu", "policy", "exact", "notes", "extra", "hand", "reached",
           "diagnosis", "segments", "digest")
V2_SEGMENT_KEYS = ("claim", "control", "contacts", "released", "event", "exact", "waypoints")
V2_WAYPOINT_KEYS = (*V1_WAYPOINT_KEYS, "velocity_commands", "torque_commands")


def from_version_1(data: dict[str, Any]) -> Plan:
    """A version-1 plan (digest already checked) as a plan of one segment."""
    check_keys(data, "plan", optional=V1_KEYS)
    control = pf.strs(pf.get(data, "control", "plan"), "control")
    if sorted(set(control)) != ["effort", "velocity"] or control.count("effort") != 1:
        raise FileFormatError(
            f"control: expected one 'effort' joint and the rest 'velocity', got {list(control)}"
        )
    model, ivs, val = pf.mu_section(pf.get(data, "mu", "plan"))
    hand = pf.obj(pf.get(data, "hand", "plan"), "hand")
    ev = pf.event(pf.get(data, "event", "plan"))
    raw = pf.get(data, "waypoints", "plan")
    if not isinstance(raw, list) or len(raw) < 2:
        raise FileFormatError(f"waypoints: expected a list of >= 2 waypoints, got {short(raw)}")
    wps = tuple(_waypoint(w, f"waypoints[{i}]", V1_WAYPOINT_KEYS, control)
                for i, w in enumerate(raw))
    pf.check_times([w.t for w in wps], "waypoints")
    seg = Segment(
        claim=pf.text(pf.get(data, "claim", "plan"), "claim"), control=control, waypoints=wps,
        hand=hand, mu_intervals=ivs, event=ev,
        policy=pf.text(pf.get(data, "policy", "plan"), "policy"),
        exact=pf.flag(data.get("exact", True), "exact"),
        notes=pf.text(data.get("notes", ""), "notes"),
        extra=pf.obj(data.get("extra", {}), "extra"))
    return Plan(hand=hand, segments=(checked_segment(seg, ""),), mu_model=model,
                mu_intervals=ivs, validate_mu=val)


def from_version_2(data: dict[str, Any]) -> Plan:
    """A version-2 plan (digest already checked)."""
    check_plan_top(data, V2_KEYS)
    pf.flag(data["exact"], "exact")
    if not data["segments"]:
        raise FileFormatError("segments: expected a non-empty list of segments, got []")
    first = data["segments"][0]
    n_c = len(first["contacts"]) if isinstance(first, dict) and isinstance(
        first.get("contacts"), list) else 0
    model, ivs, val = pf.mu_section(data["mu"], n_c)
    segs = []
    for i, s in enumerate(data["segments"]):
        where = f"segments[{i}]"
        if not isinstance(s, dict):
            raise FileFormatError(f"{where}: expected an object, got {type(s).__name__}")
        check_keys(s, where, required=V2_SEGMENT_KEYS)
        control = pf.controls(s["control"], f"{where}.control")
        for key in ("contacts", "released"):
            if not isinstance(s[key], list) or not all(isinstance(c, dict) for c in s[key]):
                raise FileFormatError(f"{where}.{key}: expected a list of contact objects, got "
                                      f"{short(s[key])}")
        raw = s["waypoints"]
        if not isinstance(raw, list) or len(raw) < 2:
            raise FileFormatError(f"{where}.waypoints: expected a list of >= 2 waypoints, got "
                                  f"{short(raw)}")
        wps = tuple(_waypoint(w, f"{where}.waypoints[{k}]", V2_WAYPOINT_KEYS, control)
                    for k, w in enumerate(raw))
        pf.check_times([w.t for w in wps], f"{where}.waypoints")
        seg = Segment(
            claim=pf.text(s["claim"], f"{where}.claim"), control=control, waypoints=wps,
            hand=embedded_hand(data["hand"], s["contacts"], wps[0].q, f"{where}.hand"),
            mu_intervals=segment_intervals(ivs, len(s["contacts"]), f"{where}.contacts"),
            event=pf.event(s["event"], f"{where}.event"), released=tuple(s["released"]),
            policy=data["policy"], exact=pf.flag(s["exact"], f"{where}.exact"))
        segs.append(checked_segment(seg, where))
    return Plan(hand=data["hand"], segments=tuple(segs), mu_model=model, mu_intervals=ivs,
                validate_mu=val, reached=data["reached"], diagnosis=data["diagnosis"],
                notes=data["notes"], extra=data["extra"])


def _waypoint(w: Any, where: str, keys: tuple[str, ...], control: tuple[str, ...]) -> Waypoint:
    """A version-1 or -2 waypoint in the plan model (module docstring)."""
    if not isinstance(w, dict):
        raise FileFormatError(f"{where}: expected an object, got {short(w)}")
    check_keys(w, where, required=keys)
    n_v, n_e = control.count("velocity"), control.count("effort")
    band = pf.band(w["band"], f"{where}.band")
    margin = pf.margin(w["margin"], f"{where}.margin")
    vel = pf.num(w["velocity_command"], f"{where}.velocity_command")
    tau = pf.num(w["torque_command"], f"{where}.torque_command")
    if "velocity_commands" in keys:  # version 2
        vels = pf.nums(w["velocity_commands"], f"{where}.velocity_commands", n_v)
        taus = pf.nums(w["torque_commands"], f"{where}.torque_commands", n_e)
        for key, one, first in (("velocity_command", vel, vels[:1]),
                                ("torque_command", tau, taus[:1])):
            if first and one != first[0]:  # the simulator reads the list
                raise FileFormatError(f"{where}.{key}: expected the first of {key}s, "
                                      f"{first[0]!r}, got {one!r}")
        bands = tuple([band] + [(x - margin, x + margin) for x in taus[1:]]) if n_e else ()
    else:
        vels, taus, bands = (vel,), (tau,), (band,)
    return Waypoint(
        t=pf.num(w["t"], f"{where}.t"),
        pose=pf.nums(w["pose"], f"{where}.pose", 3),  # type: ignore[arg-type]
        angles=pf.nums(w["angles"], f"{where}.angles", len(control)),
        velocity_commands=vels, torque_commands=taus, bands=bands, margin=margin,
        predicted=pf.strs(w["predicted"], f"{where}.predicted"),
        rivals=pf.strs(w["rivals"], f"{where}.rivals"))
