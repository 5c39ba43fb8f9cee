"""Plan files that hold every segment of a task (``qsplan-plan`` version 2; docs/plan-format.md).

Version 2 keeps what version 1 (:mod:`planner.plan.plan_file`) says per segment and adds the
chain: the top level holds the hand file (``hand``, with its ``goal``), the friction set
(``mu``), whether the goal is ``reached``, the ``diagnosis`` of a partial plan and a digest;
``segments`` lists every segment in order with its ``claim``, ``control`` (per joint
``velocity``/``effort``, any number of effort joints), ``contacts`` (the contact set it keeps
closed, hand-file contact objects), ``released`` (contacts of the previous set it opens),
``event`` and ``waypoints`` (segment-local time from 0; ``velocity_commands`` and
``torque_commands`` one per velocity-/effort-controlled joint).

:func:`load_task_plan` reads either version: a version-1 file is a task of one segment (no
goal).  Each segment comes back as a version-1 :class:`planner.plan.plan_file.Plan` whose
``hand`` is the hand file with that segment's contacts and start configuration
(:func:`segment_hand`), so anything that runs a single-segment plan runs each segment.
JSON Schema: ``planner/files/schemas/plan.schema.json`` (both versions).
"""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, InputError
from planner.files.atomic import atomic_write_text
from planner.files.fields import check_keys
from planner.files.hand_file import load_hand_file
from planner.files.hand_goal import Goal
from planner.files.reader import read_json
from planner.model.hand import Hand
from planner.model.modes import Mode
from planner.model.validation import FrictionValue, friction_interval, validation_frictions
from planner.plan.plan_file import (
    PLAN_FORMAT,
    PLAN_VERSION,
    Plan,
    Waypoint,
    check_digest,
    digest,
    plan_from_body,
    plan_from_dict,
)
from planner.plan.region_planner import plan_regions
from planner.plan.task import TaskOptions, TaskPlan, TaskStep, plan_task
from planner.plan.task_contacts import after_event, contact_dict

TASK_PLAN_VERSION = 2
TASK_KEYS = ("format", "version", "mu", "policy", "exact", "notes", "extra", "hand", "reached",
             "diagnosis", "segments", "digest")
SEGMENT_KEYS = ("claim", "control", "contacts", "released", "event", "exact", "waypoints")


def segment_hand(hand: Mapping[str, Any], contacts: list[Any], q: Any) -> dict[str, Any]:
    """The hand file ``hand`` with contact list ``contacts`` and start configuration ``q``
    ``(x, y, phi, joint coordinates)`` (finger ``angle``, or each link's ``position``); its
    ``goal`` is dropped (a segment has none)."""
    d = copy.deepcopy(dict(hand))
    d.pop("goal", None)
    d["contacts"] = copy.deepcopy(list(contacts))
    q = [float(x) for x in q]
    d["workpiece"] = {**d["workpiece"], "pose": q[:3]}
    k = 3
    for f in d["fingers"]:
        if "links" in f:
            for link in f["links"]:
                link["position"] = q[k]
                k += 1
        else:
            f["angle"] = q[k]
            k += 1
    return d


@dataclass(frozen=True, eq=False)
class TaskPlanFile:
    """A whole-task plan: ``hand`` (the hand file content), ``segments`` (one version-1
    :class:`Plan` per segment, each embedding its :func:`segment_hand`), ``contacts`` and
    ``released`` per segment (hand-file contact objects), ``reached``, ``diagnosis`` (a
    partial plan's: where and why it stops; None when reached), the friction set, ``policy``,
    ``exact``, ``notes`` and ``extra``."""

    hand: Mapping[str, Any]
    segments: tuple[Plan, ...]
    contacts: tuple[tuple[dict[str, Any], ...], ...]
    released: tuple[tuple[dict[str, Any], ...], ...]
    reached: bool
    diagnosis: Mapping[str, Any] | None
    mu_model: str
    mu_intervals: tuple[tuple[float, float], ...]
    validate_mu: tuple[FrictionValue, ...]
    policy: str = "chebyshev"
    exact: bool = True
    notes: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)

    def start_times(self) -> np.ndarray:
        """(n_segments,) start of each segment on the task's clock (s)."""
        durations = [p.waypoints[-1].t for p in self.segments]
        return np.concatenate([[0.0], np.cumsum(durations)[:-1]])

    def duration(self) -> float:
        return float(sum(p.waypoints[-1].t for p in self.segments))

    def body(self) -> dict[str, Any]:
        segs = []
        for p, c, r in zip(self.segments, self.contacts, self.released):
            segs.append({"claim": p.claim, "control": list(p.control), "contacts": list(c),
                         "released": list(r), "event": dict(p.event), "exact": p.exact,
                         "waypoints": [w.to_dict() for w in p.waypoints]})
        return {"format": PLAN_FORMAT, "version": TASK_PLAN_VERSION,
                "mu": {"model": self.mu_model, "intervals": [list(iv) for iv in self.mu_intervals],
                       "validate": [m if isinstance(m, float) else list(m)
                                    for m in self.validate_mu]},
                "policy": self.policy, "exact": self.exact, "notes": self.notes,
                "extra": dict(self.extra), "hand": self.hand, "reached": self.reached,
                "diagnosis": None if self.diagnosis is None else dict(self.diagnosis),
                "segments": segs}

    def to_dict(self) -> dict[str, Any]:
        body = self.body()
        body["digest"] = {"algorithm": "sha256", "value": digest(body)}
        return body


def _segment_plan(step: TaskStep, root: Hand, hand: Mapping[str, Any], mu_model: str,
                  mu_iv: tuple[tuple[float, float], ...], validate: tuple[FrictionValue, ...]
                  ) -> tuple[Plan, tuple[dict[str, Any], ...], tuple[dict[str, Any], ...]]:
    rp = step.plan
    n = root.n_joints
    control = tuple("velocity" if j in rp.velocity_joints else "effort" for j in range(n))
    contacts = tuple(contact_dict(root, c) for c in step.hand.contacts)
    released = tuple(contact_dict(root, c) for c in step.released)
    wps = []
    for w in rp.waypoints:
        vel = tuple(float(x) for x in w.velocity_commands)
        tau = tuple(float(x) for x in w.torque_command)
        t0 = tau[0] if tau else 0.0
        wps.append(Waypoint(
            t=float(w.t), pose=(float(w.q[0]), float(w.q[1]), float(w.q[2])),
            angles=tuple(float(x) for x in w.q[3:]), velocity_command=vel[0],
            torque_command=t0, band=(t0 - w.margin, t0 + w.margin), margin=float(w.margin),
            predicted=(rp.claim,), rivals=tuple(w.region.rivals),
            velocity_commands=vel, torque_commands=tau))
    ev = rp.segment.event
    # Each segment's intervals are the task's: one per contact of its own set.
    ivs = tuple(mu_iv[0] for _ in step.hand.contacts) if len(set(mu_iv)) == 1 else mu_iv
    plan = Plan(hand=segment_hand(hand, list(contacts), rp.waypoints[0].q), claim=rp.claim,
                control=control, mu_model=mu_model, mu_intervals=ivs, validate_mu=validate,
                policy="chebyshev", event={"kind": ev.kind, "detail": ev.detail, "t": ev.t},
                waypoints=tuple(wps), exact=rp.exact)
    return plan, contacts, released


def task_plan_file(tp: TaskPlan, hand: Hand, data: Mapping[str, Any], mu_lo: Any, mu_hi: Any,
                   validate_mu: tuple[FrictionValue, ...] = (), notes: str = ""
                   ) -> TaskPlanFile:
    """The file content of a :class:`TaskPlan` for the hand file ``data`` (its ``hand``)
    planned over the friction interval ``[mu_lo, mu_hi]`` (one value, as the task planner's
    contact sets change; per-contact intervals are not carried across sets)."""
    ivs = tuple((float(a), float(b)) for a, b in zip(mu_lo, mu_hi))
    if len(set(ivs)) == 1:
        ivs = ivs[:1]
    elif any(len(s.hand.contacts) != len(ivs) for s in tp.steps):
        raise InputError("task plan files: expected one friction interval for every contact "
                         "when the contact set changes, got one per contact "
                         f"({len(ivs)} intervals)")
    model = "common" if all(s.plan.mu_model == "common" for s in tp.steps) else "independent"
    parts = [_segment_plan(s, hand, data, model, ivs, validate_mu) for s in tp.steps]
    diag = None
    if not tp.reached:
        fail = tp.partial
        sf = fail.shortfall if fail is not None else None
        diag = {"distance_to_goal": tp.distance, "notes": list(tp.notes),
                "after_segments": len(tp.steps),
                "failed": None if fail is None else {
                    "what": fail.what, "why": fail.why,
                    "t": None if sf is None else sf.t,
                    "rival": None if sf is None else sf.rival,
                    "mu": None if sf is None else [list(m) for m in sf.mu],
                    "widest_mu": None if sf is None or sf.widest_mu is None
                    else [list(sf.widest_mu[0]), list(sf.widest_mu[1])]}}
    return TaskPlanFile(
        hand=dict(data), segments=tuple(p for p, _, _ in parts),
        contacts=tuple(c for _, c, _ in parts), released=tuple(r for _, _, r in parts),
        reached=tp.reached, diagnosis=diag, mu_model=model, mu_intervals=ivs,
        validate_mu=tuple(validate_mu), exact=all(p.exact for p, _, _ in parts), notes=notes,
        extra={"expansions": tp.expansions, "segments_integrated": tp.segments_integrated,
               "rejections": [{"after_segments": r.depth, "what": r.what, "why": r.why}
                              for r in tp.rejections]})


def negative_control(plan: TaskPlanFile) -> TaskPlanFile:
    """A negative control: the same plan with every effort-controlled joint's torque reversed
    (the finger pulls away instead of pressing), still claiming every segment's mode; a
    validation must reject it.  ``policy`` becomes ``negative:reversed-torque``."""
    segs = []
    for p in plan.segments:
        wps = tuple(replace(w, torque_command=-w.torque_command,
                            band=(-w.band[1], -w.band[0]),
                            torque_commands=tuple(-x for x in w.torque_commands))
                    for w in p.waypoints)
        segs.append(replace(p, waypoints=wps, policy="negative:reversed-torque"))
    return replace(plan, segments=tuple(segs), policy="negative:reversed-torque",
                   notes=plan.notes + "; negative control: torques reversed")


def save_task_plan(plan: TaskPlanFile, path: str | os.PathLike[str]) -> Path:
    """Write a version-2 plan atomically with its digest."""
    try:
        text = json.dumps(plan.to_dict(), indent=1, allow_nan=False) + "\n"
    except (ValueError, TypeError) as exc:
        raise InputError(f"save_task_plan: expected JSON-serialisable finite content ({exc})"
                         ) from None
    return atomic_write_text(path, text)


def load_task_plan(path: str | os.PathLike[str]) -> TaskPlanFile:
    """Read a plan file of either version (module docstring); :class:`FileFormatError` names the
    file and the field."""
    data = read_json(path, "plan file")
    try:
        return task_plan_from_dict(data)
    except FileFormatError as exc:
        raise FileFormatError(f"plan file {str(path)!r}: {exc}") from None


def task_plan_from_dict(data: Any) -> TaskPlanFile:
    """Verify parsed plan content of version 1 or 2 and build the :class:`TaskPlanFile`."""
    if isinstance(data, dict) and data.get("version") == PLAN_VERSION:
        p = plan_from_dict(data)
        ctr = tuple(data["hand"].get("contacts", []))
        return TaskPlanFile(hand=p.hand, segments=(p,), contacts=(ctr,), released=((),),
                            reached=True, diagnosis=None, mu_model=p.mu_model,
                            mu_intervals=p.mu_intervals, validate_mu=p.validate_mu,
                            policy=p.policy, exact=p.exact, notes=p.notes, extra=p.extra)
    if not isinstance(data, dict):
        raise FileFormatError(f"expected a JSON object, got {type(data).__name__}")
    check_keys(data, "plan", required=TASK_KEYS)
    if data["format"] != PLAN_FORMAT or data["version"] != TASK_PLAN_VERSION:
        raise FileFormatError(f"expected format {PLAN_FORMAT!r} version {PLAN_VERSION} or "
                              f"{TASK_PLAN_VERSION}, got {data['format']!r} version "
                              f"{data['version']!r}")
    check_digest(data)
    for key, kind, name in (("reached", bool, "true or false"), ("exact", bool, "true or false"),
                            ("notes", str, "a string"), ("policy", str, "a string"),
                            ("extra", dict, "an object"), ("mu", dict, "an object")):
        if not isinstance(data[key], kind):
            raise FileFormatError(f"{key}: expected {name}, got {type(data[key]).__name__}")
    if (data["diagnosis"] is None) is not data["reached"] or not isinstance(
            data["diagnosis"], (dict, type(None))):
        raise FileFormatError("diagnosis: expected null for a plan that reaches its goal and "
                              "an object for a partial plan, got "
                              f"{type(data['diagnosis']).__name__} with reached "
                              f"{data['reached']}")
    segs_raw = data["segments"]
    if not isinstance(segs_raw, list) or not segs_raw:
        raise FileFormatError("segments: expected a non-empty list of segments, got "
                              f"{type(segs_raw).__name__}")
    hand = data["hand"]
    if not isinstance(hand, dict):
        raise FileFormatError(f"hand: expected an object, got {type(hand).__name__}")
    segs, contacts, released = [], [], []
    for i, s in enumerate(segs_raw):
        if not isinstance(s, dict):
            raise FileFormatError(f"segments[{i}]: expected an object, got {type(s).__name__}")
        check_keys(s, f"segments[{i}]", required=SEGMENT_KEYS)
        if not (isinstance(s["contacts"], list) and isinstance(s["released"], list)):
            raise FileFormatError(f"segments[{i}].contacts/released: expected lists")
        wps = s["waypoints"]
        first = wps[0] if isinstance(wps, list) and wps and isinstance(wps[0], dict) else {}
        q = [*first.get("pose", [0.0, 0.0, 0.0]), *first.get("angles", [])]
        mu = dict(data["mu"])
        if isinstance(mu.get("intervals"), list) and len(mu["intervals"]) == 1:
            mu["intervals"] = mu["intervals"] * len(s["contacts"])
        try:
            body = {**{k: s[k] for k in ("claim", "control", "event", "exact", "waypoints")},
                    "mu": mu, "policy": data["policy"], "notes": "", "extra": {},
                    "hand": segment_hand(hand, s["contacts"], q)}
            segs.append(plan_from_body(body, any_control=True))
        except FileFormatError as exc:
            raise FileFormatError(f"segments[{i}]: {exc}") from None
        except (TypeError, KeyError, IndexError, ValueError) as exc:
            raise FileFormatError(f"segments[{i}]: expected a segment ({exc})") from None
        try:
            Mode.parse(segs[-1].claim, segs[-1].hand_model.hand.n_contacts)
        except InputError as exc:
            raise FileFormatError(f"segments[{i}].claim: {exc}") from None
        contacts.append(tuple(s["contacts"]))
        released.append(tuple(s["released"]))
    return TaskPlanFile(hand=hand, segments=tuple(segs), contacts=tuple(contacts),
                        released=tuple(released), reached=data["reached"],
                        diagnosis=data["diagnosis"], mu_model=segs[0].mu_model,
                        mu_intervals=segs[0].mu_intervals if len(data["mu"]["intervals"]) > 1
                        else segs[0].mu_intervals[:1],
                        validate_mu=segs[0].validate_mu, policy=data["policy"],
                        exact=data["exact"], notes=data["notes"], extra=data["extra"])


def plan_hand_task(path: str | os.PathLike[str], *, mu: Any = None, model: str = "common",
                   max_expansions: int | None = None, waypoints: int | None = None
                   ) -> TaskPlanFile:
    """Plan a hand file: to its ``goal`` with :func:`planner.plan.task.plan_task` when it has
    one, else its ``segment`` with :func:`planner.plan.region_planner.plan_regions` (any hand,
    any control partition).  ``mu``: ``(lo, hi)`` (default the file's ``mu.interval``); the
    ``segment`` section gives the joint rate magnitude, ``max_time``, ``steps`` and
    ``waypoints``.  Raises :class:`planner.errors.DegenerateError` when a single segment has
    no guaranteed region (with the diagnosis); a task that stops short is a partial plan
    (``reached`` False) instead."""
    hf = load_hand_file(path)
    if mu is None:
        if hf.mu_interval is None:
            raise InputError(f"{Path(path).name}: expected a friction interval (mu.interval in "
                             "the file, or --mu), got none")
        mu = hf.mu_interval[0] if len(hf.mu_interval) == 1 else list(hf.mu_interval)
    lo, hi = friction_interval(mu, hf.hand.n_contacts)
    seg = hf.segment
    n_wp = waypoints or (seg.waypoints if seg is not None else 21)
    if hf.goal is not None:
        opts = TaskOptions(speed=abs(seg.speed) if seg else 0.02, mu=(lo[0], hi[0]),
                           model=model, max_time=seg.max_time if seg else 60.0,
                           steps=seg.steps if seg else 120, waypoints=n_wp,
                           max_expansions=max_expansions or 40)
        tp = plan_task(hf.hand, hf.q0, hf.goal, opts)
    elif seg is not None:
        rp = plan_regions(hf.hand, hf.q0, drive=list(seg.drives), speed=list(seg.speeds),
                          mode=seg.mode, mu=np.stack([lo, hi], 1), max_time=seg.max_time,
                          steps=seg.steps, waypoints=n_wp, model=model)
        step = TaskStep(hf.hand, (), seg.drive, seg.speed, rp,
                        after_event(hf.hand, rp.segment.q[-1], rp.segment.event.kind))
        tp = TaskPlan((step,), True, Goal(None, 1.0, 1.0, ()), 0.0, notes=("one segment",))
    else:
        raise InputError(f"{Path(path).name}: expected a 'goal' or a 'segment' section to "
                         "plan, got neither")
    return task_plan_file(tp, hf.hand, hf.data, lo, hi,
                          validation_frictions(hf.validate_mu, lo, hi),
                          notes=f"source {Path(path).name}; " + "; ".join(tp.notes))
