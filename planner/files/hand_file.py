"""Hand files (format ``qsplan-hand``, version 1): JSON in, :class:`planner.model.hand.Hand` out.

The format is documented in ``docs/two-finger-task.md`` (keys, defaults) and as a JSON Schema
in ``planner/files/schemas/hand.schema.json``.  Every file is read by
:func:`planner.files.reader.read_json` (one size cap, one depth cap, strict JSON).  A missing
key is an error unless the format gives a default; an unknown key is an error naming it
(free-text keys :data:`planner.files.fields.FREE_KEYS` are allowed in every object).
A finger is either the paper's single revolute link (``pivot``, ``length``, ``width``,
``angle``; Section 5.2) or a chain ``"links": [...]`` of revolute and prismatic joints, each with
its capsule link; fixed surfaces besides the palm (a table) are listed under ``environment``;
an optional ``goal`` says where a whole task should end (:mod:`planner.files.hand_goal`).

Public: :func:`load_hand` / :func:`load_hand_file` (from a path), :func:`hand_from_dict` /
:func:`hand_file_from_dict` (from parsed content), :func:`hand_from_plan` (the hand a plan
embeds: the one entry point for the simulator side) and :func:`contact_spec` (one contact
object against a loaded hand).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from planner.errors import DegenerateError, FileFormatError, InputError
from planner.files.fields import (
    FREE_KEYS,
    as_object,
    check_keys,
    integer,
    number,
    short,
    string,
)
from planner.files.hand_checks import check_hand_contacts
from planner.files.hand_friction import mu_bodies, mu_section
from planner.files.hand_goal import Goal, parse_goal
from planner.files.hand_limits import hand_limits
from planner.files.hand_uncertainty import uncertainty_section
from planner.files.reader import read_json
from planner.model.geometry import rot90
from planner.model.hand import CONTACT_KINDS, JOINT_KINDS, ContactSpec, Finger, Hand, Link, rotation
from planner.model.kinematics import REVOLUTE
from planner.model.modes import check_mode_claim
from planner.model.workpiece import check_convex_ccw

HAND_FORMAT = "qsplan-hand"
HAND_VERSION = 1

#: Documented defaults of optional keys (docs/two-finger-task.md).
FINGER_MASS = 0.05  # kg
WORKPIECE_MASS = 0.1  # kg
SEGMENT_DEFAULTS: Mapping[str, float | int] = {"max_time": 60.0, "waypoints": 41, "steps": 200}
MAX_WAYPOINTS = 10_000
"""Most waypoints a segment may have (``segment.waypoints``, ``qsplan plan --waypoints``) and most
integration steps (``segment.steps``): the adaptive spacing starts from one waypoint per
integration step (:func:`planner.plan.spacing.initial_times`), and every waypoint costs one
guaranteed-set evaluation, about 65 ms for the two-finger hand (200 waypoints in 13 s,
docs/robustness.md), so this bound is a plan of about 11 minutes."""


class HandSetup(NamedTuple):
    """A hand and its initial configuration ``q0 = (x, y, phi, theta_1..theta_F)`` (m, rad),
    closed so every declared contact touches."""

    hand: Hand
    q0: np.ndarray


@dataclass(frozen=True)
class SegmentSpec:
    """The hand file's ``segment`` section: joint ``drive`` driven at ``speed`` (rad/s or m/s)
    in ``mode`` (family such as ``"4S"`` or a label) for at most ``max_time`` (s); the plan has
    ``waypoints`` waypoints; ``steps`` integration steps.  ``drives``/``speeds``: every driven
    joint and its rate (``drive``/``speed`` are the first)."""

    drive: int
    speed: float
    mode: str
    max_time: float
    waypoints: int
    steps: int
    drives: tuple[int, ...] = ()
    speeds: tuple[float, ...] = ()


@dataclass(frozen=True)
class HandFile:
    """A loaded hand file: ``hand``, ``q0``, the optional ``segment`` section, the ``mu``
    section's ``mu_interval`` (``(lo, hi)`` pairs, one or one per contact; None when absent)
    and ``validate_mu`` (friction values for the simulators), ``data`` (the parsed JSON,
    embedded verbatim in plans) and the optional ``goal`` (:class:`planner.files.hand_goal.Goal`,
    what a whole task should reach) and ``mu_bodies`` (``mu.bodies``: body name -> the friction
    interval of every contact on it; the others take ``mu_interval``)."""

    hand: Hand
    q0: np.ndarray
    segment: SegmentSpec | None
    mu_interval: tuple[tuple[float, float], ...] | None
    validate_mu: tuple[Any, ...]
    data: Mapping[str, Any]
    goal: Goal | None = None
    mu_bodies: Mapping[str, tuple[float, float]] = field(default_factory=dict)


def load_hand_file(path: str | os.PathLike[str]) -> HandFile:
    """Read a hand file (see the module docstring); errors name the file and the field."""
    data = read_json(path, "hand file")
    return hand_file_from_dict(data, source=f"hand file {str(path)!r}")


def load_hand(path: str | os.PathLike[str]) -> tuple[Hand, np.ndarray, dict[str, Any]]:
    """Read a hand file: ``(hand, q0, data)`` where ``data`` is the parsed JSON (kept for the
    ``segment`` and ``mu`` sections, already checked, and for embedding in plans)."""
    hf = load_hand_file(path)
    return hf.hand, hf.q0, dict(hf.data)


def hand_from_dict(data: Any, source: str = "<dict>") -> HandSetup:
    """:class:`HandSetup` ``(hand, q0)`` from a hand file's parsed content (every section is
    checked, ``segment`` and ``mu`` included).  Errors are :class:`FileFormatError` naming
    ``source``."""
    hf = hand_file_from_dict(data, source)
    return HandSetup(hf.hand, hf.q0)


def hand_from_plan(plan_hand: Mapping[str, Any]) -> HandSetup:
    """The typed hand of a plan: ``plan_hand`` is a plan's ``hand`` object (the hand file it was
    made for, :attr:`planner.plan.plan_file.Plan.hand`).  Returns :class:`HandSetup`
    ``(hand, q0)``; errors name ``plan.hand``.  (``Plan.hand_model`` caches this per plan.)"""
    return hand_from_dict(plan_hand, source="plan.hand")


def hand_file_from_dict(data: Any, source: str = "<dict>") -> HandFile:
    """:class:`HandFile` from parsed content; errors are :class:`FileFormatError` naming
    ``source`` and the field."""
    try:
        with np.errstate(all="ignore"):  # extreme inputs: non-finite results are caught below
            return _hand_file(data)
    except InputError as exc:  # FileFormatError included
        raise FileFormatError(f"{source}: {exc}") from None


def contact_spec(obj: Any, i: int, hand: Hand, section: str) -> ContactSpec:
    """A hand-file contact object (``section[i]`` in messages) parsed against ``hand``'s
    workpiece vertices, fingers and environment (how a plan's ``released`` contacts are read);
    raises :class:`FileFormatError` naming the field."""
    return _contact(obj, i, len(hand.vertices), list(hand.fingers), hand.environment, section)


# ---- the sections ----------------------------------------------------------------------------
def _points(value: Any, where: str, n: int | None = None) -> np.ndarray:
    """``(n, 2)`` finite numbers (``n`` None: any count >= 1)."""
    if not isinstance(value, list) or (n is not None and len(value) != n) or not value:
        want = f"{n} points [x, y]" if n is not None else "a list of points [x, y]"
        raise FileFormatError(f"{where}: expected {want}, got {short(value)}")
    for i, p in enumerate(value):
        if not isinstance(p, list) or len(p) != 2:
            raise FileFormatError(f"{where}[{i}]: expected a point [x, y], got {short(p)}")
    return np.array([[number(x, f"{where}[{i}]") for x in p] for i, p in enumerate(value)])


def _point(value: Any, where: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 2:
        raise FileFormatError(f"{where}: expected a point [x, y], got {short(value)}")
    return np.array([number(x, where) for x in value])


def _link(d: Any, where: str) -> tuple[Link, float]:
    d = as_object(d, where)
    check_keys(d, where, required=("type", "length", "width", "position"),
               optional=("offset", "mass", "name"), free=FREE_KEYS)
    kind = d["type"]
    if kind not in JOINT_KINDS:
        raise FileFormatError(f"{where}.type: expected one of {JOINT_KINDS}, got {short(kind)}")
    link = Link(
        kind=kind,
        length=number(d["length"], f"{where}.length", positive=True),
        width=number(d["width"], f"{where}.width", positive=True),
        offset=number(d.get("offset", 0.0), f"{where}.offset"),
        mass=number(d.get("mass", FINGER_MASS), f"{where}.mass", positive=True),
        name=string(d.get("name", ""), f"{where}.name"),
    )
    return link, number(d["position"], f"{where}.position")


def _finger(f: Any, k: int) -> tuple[Finger, list[float]]:
    """A finger and its initial joint coordinates (rad for revolute, m for prismatic)."""
    where = f"fingers[{k}]"
    f = as_object(f, where)
    name = string(f.get("name", f"finger{k + 1}"), f"{where}.name")
    if "links" in f:
        check_keys(f, where, required=("pivot", "links"), optional=("name", "tip_offset"),
                   free=FREE_KEYS)
        raw = f["links"]
        if not isinstance(raw, list) or not raw:
            raise FileFormatError(f"{where}.links: expected a non-empty list, got {short(raw)}")
        parsed = [_link(d, f"{where}.links[{j}]") for j, d in enumerate(raw)]
        links = tuple(lk for lk, _ in parsed)
        pivot = _point(f["pivot"], f"{where}.pivot")
        first = links[0]
        return Finger(name=name, pivot=(float(pivot[0]), float(pivot[1])), length=first.length,
                      width=first.width, mass=first.mass, links=links,
                      tip_offset=_tip_offset(f, where)), [x for _, x in parsed]
    if "type" in f and f["type"] != REVOLUTE:
        raise FileFormatError(
            f"{where}.type: expected \"revolute\" for a single-link finger (a prismatic joint "
            f"goes in \"links\": [...]), got {short(f['type'])}"
        )
    check_keys(f, where, required=("pivot", "length", "width", "angle"),
               optional=("name", "mass", "type", "tip_offset"), free=FREE_KEYS)
    pivot = _point(f["pivot"], f"{where}.pivot")
    finger = Finger(
        name=name,
        pivot=(float(pivot[0]), float(pivot[1])),
        length=number(f["length"], f"{where}.length", positive=True),
        width=number(f["width"], f"{where}.width", positive=True),
        mass=number(f.get("mass", FINGER_MASS), f"{where}.mass", positive=True),
        tip_offset=_tip_offset(f, where),
    )
    return finger, [number(f["angle"], f"{where}.angle")]


def _tip_offset(f: Any, where: str) -> tuple[float, float]:
    """A finger's optional ``tip_offset`` ``[along, across]`` [m] (:class:`Finger`)."""
    t = _point(f.get("tip_offset", [0.0, 0.0]), f"{where}.tip_offset")
    return float(t[0]), float(t[1])


def _environment(raw: Any) -> tuple[tuple[str, np.ndarray], ...]:
    if not isinstance(raw, list):
        raise FileFormatError(f"environment: expected a list of surfaces, got {short(raw)}")
    out = []
    for e, d in enumerate(raw):
        where = f"environment[{e}]"
        d = as_object(d, where)
        check_keys(d, where, required=("edge",), free=FREE_KEYS)
        ends = _points(d["edge"], f"{where}.edge", 2)
        if np.linalg.norm(ends[1] - ends[0]) <= 0:
            raise FileFormatError(f"{where}.edge: expected two distinct points, got equal points")
        out.append((string(d.get("name", f"surface{e + 1}"), f"{where}.name"), ends))
    return tuple(out)


def _contact(d: Any, i: int, n_v: int, fingers: list[Finger],
             env: tuple[tuple[str, np.ndarray], ...], section: str = "contacts") -> ContactSpec:
    where = f"{section}[{i}]"
    n_f = len(fingers)
    d = as_object(d, where)
    check_keys(d, where, required=("kind",),
               optional=("vertex", "edge", "finger", "side", "link", "surface"), free=FREE_KEYS)
    kind = d["kind"]
    if kind not in CONTACT_KINDS:
        raise FileFormatError(f"{where}.kind: expected one of {CONTACT_KINDS}, got {short(kind)}")
    keys = {"palm": ("vertex",), "surface": ("vertex", "surface"), "side": ("vertex", "finger"),
            "tip": ("edge", "finger")}[kind]
    opt = ("side", "link") if kind == "side" else ()
    check_keys(d, f"{where} ({kind})", required=("kind", *keys), optional=opt, free=FREE_KEYS)

    def index(key: str, n: int) -> int:
        return integer(d[key], f"{where}.{key}", 0, n - 1)

    if kind == "palm":
        return ContactSpec("palm", vertex=index("vertex", n_v))
    if kind == "surface":
        if not env:
            raise FileFormatError(f"{where}.surface: expected an 'environment' list to refer to, "
                                  "got none")
        names = [name for name, _ in env]
        surf = d["surface"]
        k = names.index(surf) if isinstance(surf, str) and surf in names else (
            index("surface", len(env)) if not isinstance(surf, str) else -1)
        if k < 0:
            raise FileFormatError(f"{where}.surface: expected an index or one of {names}, "
                                  f"got {short(surf)}")
        return ContactSpec("surface", vertex=index("vertex", n_v), surface=k)
    if kind == "side":
        side = d.get("side", 1)
        if isinstance(side, bool) or side not in (1, -1):
            raise FileFormatError(f"{where}.side: expected +1 or -1, got {short(side)}")
        finger = index("finger", n_f)
        link = integer(d.get("link", 0), f"{where}.link", 0, fingers[finger].n_joints - 1)
        return ContactSpec("side", vertex=index("vertex", n_v), finger=finger, side=int(side),
                           link=link)
    return ContactSpec("tip", edge=index("edge", n_v), finger=index("finger", n_f))


def _segment(seg: Any, n_joints: int, n_contacts: int) -> SegmentSpec:
    seg = as_object(seg, "segment")
    check_keys(seg, "segment", required=("drive", "speed", "mode"),
               optional=tuple(SEGMENT_DEFAULTS), free=FREE_KEYS)
    try:
        mode = check_mode_claim(string(seg["mode"], "segment.mode"), n_contacts)
    except FileFormatError:
        raise
    except InputError as exc:
        raise FileFormatError(f"segment.mode: {exc}") from None
    if isinstance(seg["drive"], list) or isinstance(seg["speed"], list):
        raw_d, raw_s = seg["drive"], seg["speed"]
        if not (isinstance(raw_d, list) and isinstance(raw_s, list) and raw_d
                and len(raw_d) == len(raw_s)):
            raise FileFormatError(
                "segment.drive/speed: expected a joint index and a rate, or two lists of the same "
                f"length, got {short(raw_d)} and {short(raw_s)}")
        drives = tuple(integer(x, f"segment.drive[{i}]", 0, n_joints - 1)
                       for i, x in enumerate(raw_d))
        if len(set(drives)) != len(drives):
            raise FileFormatError(f"segment.drive: expected distinct joints, got {list(drives)}")
        speeds = tuple(number(x, f"segment.speed[{i}]") for i, x in enumerate(raw_s))
    else:
        drives = (integer(seg["drive"], "segment.drive", 0, n_joints - 1),)
        speeds = (number(seg["speed"], "segment.speed"),)
    if not any(speeds):
        raise FileFormatError("segment.speed: expected a non-zero rate [rad/s], got 0")
    counts = {}
    for key, least in (("waypoints", 2), ("steps", 1)):
        n = integer(seg.get(key, SEGMENT_DEFAULTS[key]), f"segment.{key}", least)
        if n > MAX_WAYPOINTS:
            raise FileFormatError(
                f"segment.{key}: expected at most {MAX_WAYPOINTS} (each {key[:-1]} is a waypoint "
                f"the planner evaluates, docs/file-formats.md), got {n}")
        counts[key] = n
    return SegmentSpec(
        drive=drives[0],
        speed=speeds[0],
        mode=mode,
        max_time=number(seg.get("max_time", SEGMENT_DEFAULTS["max_time"]), "segment.max_time",
                        positive=True),
        waypoints=counts["waypoints"],
        steps=counts["steps"],
        drives=drives,
        speeds=speeds,
    )


def _hand_file(data: Any) -> HandFile:
    data = as_object(data, "hand")
    check_keys(data, "hand", required=("palm", "fingers", "workpiece", "contacts"),
               optional=("format", "version", "load", "segment", "mu", "environment", "goal",
                         "limits", "uncertainty"),
               free=FREE_KEYS)
    fmt, ver = data.get("format", HAND_FORMAT), data.get("version", HAND_VERSION)
    if fmt != HAND_FORMAT or ver != HAND_VERSION or isinstance(ver, bool):
        raise FileFormatError(
            f"expected format {HAND_FORMAT!r} version {HAND_VERSION}, got {short(fmt)} "
            f"version {short(ver)}"
        )
    palm_obj = as_object(data["palm"], "palm")
    check_keys(palm_obj, "palm", required=("edge",), free=FREE_KEYS)
    palm = _points(palm_obj["edge"], "palm.edge", 2)
    if np.linalg.norm(palm[1] - palm[0]) <= 0:
        raise FileFormatError("palm.edge: expected two distinct points, got equal points")
    fingers_raw = data["fingers"]
    if not isinstance(fingers_raw, list) or not fingers_raw:
        raise FileFormatError(f"fingers: expected a non-empty list, got {short(fingers_raw)}")
    parsed = [_finger(f, k) for k, f in enumerate(fingers_raw)]
    fingers = [f for f, _ in parsed]
    angles = [a for _, q in parsed for a in q]
    env = _environment(data["environment"]) if "environment" in data else ()
    wp = as_object(data["workpiece"], "workpiece")
    check_keys(wp, "workpiece", required=("vertices", "pose"), optional=("com", "mass"),
               free=FREE_KEYS)
    V = check_convex_ccw(_points(wp["vertices"], "workpiece.vertices"), "workpiece.vertices")
    com = _point(wp.get("com", [0.0, 0.0]), "workpiece.com")
    pose_raw = wp["pose"]
    if not isinstance(pose_raw, list) or len(pose_raw) != 3:
        raise FileFormatError(f"workpiece.pose: expected [x, y, phi], got {short(pose_raw)}")
    pose = np.array([number(x, f"workpiece.pose[{i}]") for i, x in enumerate(pose_raw)])
    contacts_raw = data["contacts"]
    if not isinstance(contacts_raw, list) or not contacts_raw:
        raise FileFormatError(f"contacts: expected a non-empty list, got {short(contacts_raw)}")
    contacts = tuple(_contact(c, i, len(V), fingers, env) for i, c in enumerate(contacts_raw))
    force = np.zeros(2)
    if "load" in data:
        load = as_object(data["load"], "load")
        check_keys(load, "load", required=("force",), free=FREE_KEYS)
        force = _point(load["force"], "load.force")
    mass = number(wp.get("mass", WORKPIECE_MASS), "workpiece.mass", positive=True)
    hand = Hand(
        palm=palm,
        fingers=tuple(fingers),
        vertices=V,
        com=com,
        mass=mass,
        contacts=contacts,
        load_force=force,
        name=string(data.get("name", "hand"), "name"),
        meta={k: data[k] for k in ("description", "load") if k in data},
        environment=env,
        load_set=(uncertainty_section(data["uncertainty"], mass, com,
                                      ("palm", *(e[0] for e in env), *(f.name for f in fingers)))
                  if "uncertainty" in data else None),
    )
    centroid = V.mean(axis=0) @ rotation(pose[2]).T + pose[:2]
    if rot90(palm[1] - palm[0]) @ (centroid - palm[0]) <= 0:
        raise FileFormatError(
            "palm.edge: expected the workpiece on the inward side (left of first->second point), "
            "got it on the other side"
        )
    for e, (_, ends) in enumerate(env):
        if rot90(ends[1] - ends[0]) @ (centroid - ends[0]) <= 0:
            raise FileFormatError(
                f"environment[{e}].edge: expected the workpiece on the inward side (left of "
                "first->second point), got it on the other side (the edge given in reverse?)")
    segment = (_segment(data["segment"], hand.n_joints, len(contacts)) if "segment" in data
               else None)
    interval, validate = mu_section(data["mu"], len(contacts)) if "mu" in data else (None, ())
    bodies: dict[str, tuple[float, float]] = {}
    if "mu" in data and "bodies" in data["mu"]:
        names = ("palm", *(e[0] for e in env), *(f.name for f in fingers))
        bodies = mu_bodies(data["mu"]["bodies"], names)
        for i, v in enumerate(validate):
            if isinstance(v, dict) and set(v) - set(names):
                raise FileFormatError(f"mu.validate[{i}]: expected body names among "
                                      f"{list(names)}, got {sorted(set(v) - set(names))}")
        if interval is not None and len(interval) > 1:
            raise FileFormatError("mu: expected mu.bodies with one mu.interval (the default of "
                                  f"the bodies not listed), got {len(interval)} intervals")
    goal = None
    if "goal" in data:
        goal = parse_goal(data["goal"], hand.length_scale, lambda c, i: _contact(
            c, i, len(V), fingers, env, "goal.contacts"))
    # Joint limits (planner.files.hand_limits): checked here, read by the planner from data.
    hand_limits(data, hand.joint_names())
    q0 = np.concatenate([pose, angles])
    check_hand_contacts(hand, q0)  # touching, on both features, normals into the workpiece
    try:
        fixed = hand.default_fixed(q0)
        q0 = hand.close(q0, fixed=fixed)
    except (DegenerateError, InputError) as exc:
        raise FileFormatError(f"initial configuration: {exc}") from None
    return HandFile(hand, q0, segment, interval, validate, data, goal, bodies)
