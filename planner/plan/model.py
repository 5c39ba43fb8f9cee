"""The plan model: what ``qsplan plan`` writes and ``qsplan validate`` runs (Section 5.2).

A :class:`Plan` is a chain of :class:`Segment` s, each a list of :class:`Waypoint` s.  One
segment keeps one contact set closed and one contact mode (its ``claim``); per joint it is
velocity- or effort-controlled (``control``, the Section 3.2 partition); its commands are held
from one waypoint to the next.  A plan made from a hand file's ``segment`` section is a plan of
one segment; a whole task (a ``goal``) chains several.  Files: :mod:`planner.plan.plan_file`
(docs/plan-format.md); planners: :mod:`planner.plan.segment_planner` (one segment, any number
of effort-controlled joints) and :mod:`planner.plan.task` (chains to a goal).

Units: SI (m, s, rad, N, N m); a joint's command is a rate (rad/s revolute, m/s prismatic) when
velocity-controlled and an effort (N m revolute, N prismatic) when effort-controlled.  Poses
are the workpiece body frame ``(x, y, phi)`` in the world frame (docs/conventions.md).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from planner.errors import InputError
from planner.files.hand_file import HandSetup, hand_from_plan
from planner.model.modes import check_mode_claim
from planner.model.validation import FrictionValue

if TYPE_CHECKING:  # the in-memory certificate of a planned segment
    from planner.plan.polytope import TorqueRegion

#: Why a segment ends (docs/planning.md).
EVENT_KINDS = ("new contact", "lost contact", "mode change", "goal", "time limit")


@dataclass(frozen=True)
class Event:
    """Why a segment ends: ``kind`` (one of :data:`EVENT_KINDS`), a sentence ``detail`` naming
    the contacts by their features, and the time ``t`` (s from the segment's start)."""

    kind: str
    detail: str
    t: float

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "detail": self.detail, "t": self.t}


@dataclass(frozen=True)
class Waypoint:
    """One waypoint of a segment; its commands are held until the next waypoint.

    ``t`` s from the segment's start; ``pose`` predicted workpiece ``(x, y, phi)`` (m, m, rad);
    ``angles`` predicted joint coordinates (rad, or m of slide), one per joint;
    ``velocity_commands`` the rates of the velocity-controlled joints in joint order (rad/s or
    m/s; the rate that takes each joint from this waypoint's planned coordinate to the next
    one's over the hold interval); ``torque_commands`` the efforts of the effort-controlled
    joints in joint order (N m or N); ``bands`` per effort-controlled joint ``(lower,
    upper)``: the range of its effort, the others held at their commands, that keeps the
    guarantee at both ends of the hold interval (``+-inf`` allowed; with one effort joint the
    guaranteed band of Figure 13); ``margin`` the radius of the ball of effort commands around
    the command that keeps it (in the efforts' units; negative: the command is outside at an
    end of the hold interval; with no effort joint the smallest normalised Coulomb slack);
    ``predicted`` the mode labels predicted at the command (``[claim]`` inside the guaranteed
    region, otherwise the modes possible there); ``rivals`` the other modes possible at this
    waypoint for some effort command.
    """

    t: float
    pose: tuple[float, float, float]
    angles: tuple[float, ...]
    velocity_commands: tuple[float, ...]
    torque_commands: tuple[float, ...]
    bands: tuple[tuple[float, float], ...]
    margin: float
    predicted: tuple[str, ...]
    rivals: tuple[str, ...]

    @property
    def q(self) -> np.ndarray:
        """The configuration ``(x, y, phi, joints...)`` ``(3 + n_joints,)``."""
        return np.array([*self.pose, *self.angles], dtype=float)

    def to_dict(self) -> dict[str, Any]:
        return {
            "t": self.t,
            "pose": list(self.pose),
            "angles": list(self.angles),
            "velocity_commands": list(self.velocity_commands),
            "torque_commands": list(self.torque_commands),
            "bands": [[finite_or_none(lo), finite_or_none(hi)] for lo, hi in self.bands],
            "margin": finite_or_none(self.margin),
            "predicted": list(self.predicted),
            "rivals": list(self.rivals),
        }


def finite_or_none(x: float) -> float | None:
    """``x`` as a JSON number, ``None`` for an infinite value (an unbounded band end)."""
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True)
class Shortfall:
    """Where a partial segment stops (a planner diagnosis, in memory only): waypoint ``index``
    at ``t`` (s), with ``velocity_joints`` velocity-controlled; ``reason`` (the guarantee's
    diagnosis: the covering ``rival`` and the friction points ``mu`` where it is feasible, when
    known) and ``widest_mu``: the widest friction interval ``(lo, hi')`` with the same lower ends
    (``hi'`` by bisection on a common scale of the upper ends) for which a guaranteed set exists
    there, None when even ``lo`` fails."""

    index: int
    t: float
    velocity_joints: tuple[int, ...]
    reason: str
    rival: str | None
    mu: tuple[tuple[float, ...], ...]
    widest_mu: tuple[tuple[float, ...], tuple[float, ...]] | None


@dataclass(frozen=True, eq=False)
class Segment:
    """One quasistatic segment of a plan.

    ``claim`` the mode it guarantees (e.g. ``"S+1 S+2 S-3 S-4"``, contacts numbered as in
    its own contact set); ``control`` per joint ``"velocity"`` or ``"effort"``;
    ``waypoints``; ``hand`` the hand file content with this segment's contacts and start
    configuration (no goal; :func:`segment_hand`), parsed once into :attr:`hand_model`;
    ``mu_intervals`` one ``(lo, hi)`` per contact of its set; ``released`` the contacts of the
    previous segment's set it opens (hand-file contact objects); ``event`` why it ends;
    ``policy`` how its efforts were chosen (:data:`planner.plan.policies.POLICIES`,
    ``least-effort:M``, ``rival:MODE``, or a negative control's name); ``exact`` whether its
    regions come from the exact friction dependence; ``notes`` (the control partitions tried,
    the waypoint spacing) and ``extra`` (free content: ``commands``, the largest change of the
    effort commands against the smooth policy's bound; the band curves of Figures 10-13 for one
    effort joint).

    In memory only (not written to a file): ``regions`` the guaranteed effort region at each
    waypoint (:class:`planner.plan.polytope.TorqueRegion`, the planner's certificate) and,
    for a partial segment, ``shortfall`` (where and why it stops).
    """

    claim: str
    control: tuple[str, ...]
    waypoints: tuple[Waypoint, ...]
    hand: Mapping[str, Any]
    mu_intervals: tuple[tuple[float, float], ...]
    event: Event
    released: tuple[Mapping[str, Any], ...] = ()
    policy: str = "midband"
    exact: bool = True
    notes: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)
    regions: tuple[TorqueRegion, ...] = field(default=(), repr=False)
    shortfall: Shortfall | None = field(default=None, repr=False)

    @cached_property
    def hand_model(self) -> HandSetup:
        """The typed hand of this segment and its closed start configuration, ``(hand, q0)``,
        parsed once from :attr:`hand` (:func:`planner.files.hand_file.hand_from_plan`)."""
        return hand_from_plan(self.hand)

    @property
    def contacts(self) -> tuple[Mapping[str, Any], ...]:
        """The contact set it keeps closed (hand-file contact objects, in contact order)."""
        return tuple(self.hand["contacts"])

    @property
    def velocity_joints(self) -> tuple[int, ...]:
        return tuple(j for j, c in enumerate(self.control) if c == "velocity")

    @property
    def effort_joints(self) -> tuple[int, ...]:
        return tuple(j for j, c in enumerate(self.control) if c == "effort")

    def duration(self) -> float:
        """Length of the segment (s)."""
        return float(self.waypoints[-1].t)

    def times(self) -> np.ndarray:
        """(n,) waypoint times (s)."""
        return np.array([w.t for w in self.waypoints], dtype=float)

    def poses(self) -> np.ndarray:
        """(n, 3) predicted workpiece poses."""
        return np.array([w.pose for w in self.waypoints], dtype=float)

    def torques(self) -> np.ndarray:
        """(n, p) efforts of the effort-controlled joints."""
        return np.array([w.torque_commands for w in self.waypoints], dtype=float).reshape(
            len(self.waypoints), -1)

    def margins(self) -> np.ndarray:
        """(n,) margins of the commands."""
        return np.array([w.margin for w in self.waypoints], dtype=float)

    def travel(self) -> float:
        """Path length of the workpiece origin (m) through the waypoints."""
        p = self.poses()
        return float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)))

    def joint_commands(self) -> np.ndarray:
        """(n_waypoints, n_joints) every joint's command by its control: rates of the
        velocity-controlled joints, efforts of the effort-controlled ones."""
        out = np.zeros((len(self.waypoints), len(self.control)))
        V, E = list(self.velocity_joints), list(self.effort_joints)
        for k, w in enumerate(self.waypoints):
            out[k, V] = w.velocity_commands
            out[k, E] = w.torque_commands
        return out


@dataclass(frozen=True, eq=False)
class Plan:
    """A plan: ``segments`` in order (each segment's time starts at 0), the ``hand`` file it was
    made for (with its ``goal`` when a task), whether the goal is ``reached`` (a plan of a
    ``segment`` section: True), the ``diagnosis`` of a partial plan (None when reached: where
    and why it stops, docs/plan-format.md), the friction set -- ``mu_model`` (``common``: one
    coefficient for every contact; ``independent``: one per contact), ``mu_intervals`` (one
    ``(lo, hi)`` for every contact of every segment, or one per contact when the contact set
    never changes) and ``validate_mu`` (values the simulators run it at: a coefficient for every
    contact, or one per contact) -- and free ``notes`` and ``extra``."""

    hand: Mapping[str, Any]
    segments: tuple[Segment, ...]
    mu_model: str
    mu_intervals: tuple[tuple[float, float], ...]
    validate_mu: tuple[FrictionValue, ...] = ()
    reached: bool = True
    diagnosis: Mapping[str, Any] | None = None
    notes: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def contacts(self) -> tuple[tuple[Mapping[str, Any], ...], ...]:
        """Per segment, the contact set it keeps closed (hand-file contact objects)."""
        return tuple(s.contacts for s in self.segments)

    @property
    def released(self) -> tuple[tuple[Mapping[str, Any], ...], ...]:
        """Per segment, the contacts of the previous set it opens."""
        return tuple(s.released for s in self.segments)

    @property
    def policy(self) -> str:
        """The segments' policy (one per plan; see :class:`Segment`)."""
        policies = {s.policy for s in self.segments}
        if len(policies) != 1:
            raise InputError(f"plan: expected one policy for every segment, got "
                             f"{sorted(policies)}")
        return policies.pop()

    @property
    def exact(self) -> bool:
        return all(s.exact for s in self.segments)

    def start_times(self) -> np.ndarray:
        """(n_segments,) start of each segment on the plan's clock (s)."""
        durations = [s.duration() for s in self.segments]
        return np.concatenate([[0.0], np.cumsum(durations)])[:len(durations)]

    def duration(self) -> float:
        """Length of the whole plan (s)."""
        return float(sum(s.duration() for s in self.segments))

    def travel(self) -> float:
        """Path length of the workpiece origin over every segment (m)."""
        return float(sum(s.travel() for s in self.segments))


def segment_hand(hand: Mapping[str, Any], contacts: Sequence[Any], q: Any,
                 mode: str | None = None) -> dict[str, Any]:
    """The hand file ``hand`` with contact list ``contacts`` and start configuration ``q``
    ``(x, y, phi, joint coordinates)`` (finger ``angle``, or each link's ``position``); its
    ``goal`` is dropped (a segment has none).  A ``segment.mode`` that does not fit the new
    contact list (a family or label of another contact count) becomes ``mode``, the segment's
    own claim, when given."""
    d = copy.deepcopy(dict(hand))
    d.pop("goal", None)
    d["contacts"] = copy.deepcopy(list(contacts))
    seg = d.get("segment")
    if mode is not None and isinstance(seg, dict) and "mode" in seg:
        try:
            check_mode_claim(str(seg["mode"]), len(contacts))
        except InputError:
            seg["mode"] = mode
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


def negative_control(plan: Plan) -> Plan:
    """A negative control: the same plan with every effort-controlled joint's command reversed
    (a finger that pressed pulls away), still claiming every segment's mode; a validation must
    reject it.  Its policy is ``negative:reversed-torque``."""
    name = "negative:reversed-torque"
    segs = []
    for s in plan.segments:
        wps = tuple(replace(w, torque_commands=tuple(-x for x in w.torque_commands),
                            bands=tuple((-hi, -lo) for lo, hi in w.bands))
                    for w in s.waypoints)
        extra = {k: v for k, v in s.extra.items() if k != "commands"}  # the policy's report
        segs.append(replace(s, waypoints=wps, policy=name, regions=(), shortfall=None,
                            extra=extra))
    return replace(plan, segments=tuple(segs),
                   notes=(plan.notes + "; " if plan.notes else "")
                   + "negative control: efforts reversed")
