"""A plan as a run: one scene holding every contact of every segment, each joint's command over
the whole plan, the times its control mode switches, and what each segment predicts.

Reads only the plan (:class:`planner.plan.model.Plan` or one of its segments): nothing of the
planner's internals. A single-segment plan is a task of one segment.

Contacts: the union of all segments' contacts, in order of first appearance (a contact is the
same when its hand-file object is); pair ``c<i>`` of the scene is the ``i``-th contact of that
union. A contact of the first segment is placed pre-loaded at the plan's start; a contact a
later segment gains is apart at the start (``RunSettings.open_at_start``) and its sites are
placed at the planned start of that segment (:func:`sim.scenes.hand.hand_scene`,
``site_configs``). A contact a segment releases stays in the scene (the bodies still collide
there) but is not judged in the segments that do not hold it.

Time: segment ``k`` runs on ``[T_k, T_k + D_k)``, ``T_0 = 0``, ``D_k`` its last waypoint's
time. Each joint's command is the segment's waypoint command held to the next waypoint and
ramped linearly over ``ramp`` seconds at each change (stepped loads make soft contacts
bounce: docs/simulation.md), also across a segment boundary when the joint keeps its control;
when its control switches (velocity <-> effort) the new command starts at once, from the first
step of the new segment (``RunSettings.control_switches``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.closure import tangent_jacobian
from planner.model.hand import Hand
from planner.model.modes import Mode
from sim.expectation import PlanSchedule, SegmentExpectation, point_travel
from sim.scene import BodyState, Command
from sim.verdict import ObservedMode


@dataclass(frozen=True, eq=False)
class SegmentSchedule:
    """One segment's commands and predictions (``n`` waypoints).

    ``times`` (n,) [s] increasing from 0; ``commands`` (n, n_theta) every joint's command per
    waypoint (rad/s, m/s, N m or N by its control), held until the next waypoint;
    ``controls`` (n_theta,) ``"velocity"`` / ``"effort"``; ``claim``; ``predicted`` (n,) the
    predicted mode set of each interval; ``poses`` (n, 3) predicted workpiece poses; ``angles``
    (n, n_theta) predicted joint coordinates [rad or m].
    """

    times: np.ndarray
    commands: np.ndarray
    controls: tuple[str, ...]
    claim: Mode
    predicted: tuple[frozenset[ObservedMode], ...]
    poses: np.ndarray
    angles: np.ndarray

    @classmethod
    def from_segment(cls, seg: Any, n_contacts: int,
                     torques: np.ndarray | None = None) -> SegmentSchedule:
        """A plan segment's commands and predictions (:class:`planner.plan.model.Segment`;
        mode labels parsed once): per waypoint ``t``, ``pose``, ``predicted`` and every joint's
        command (``Segment.joint_commands``). ``torques`` (n, p) replaces the planned efforts
        of the ``p`` effort-controlled joints (a negative control)."""
        claim = Mode.parse(seg.claim, n_contacts)
        controls = tuple(seg.control)
        cmd = np.asarray(seg.joint_commands(), dtype=float).reshape(len(seg.waypoints),
                                                                    len(controls))
        if torques is not None:
            E = [j for j, c in enumerate(controls) if c == "effort"]
            tau = np.asarray(torques, dtype=float)
            if tau.shape != (len(seg.waypoints), len(E)):
                raise InputError(f"torques: expected ({len(seg.waypoints)}, {len(E)}), got "
                                 f"{tau.shape}")
            cmd = cmd.copy()
            cmd[:, E] = tau
        return cls(
            times=np.array([float(w.t) for w in seg.waypoints]), commands=cmd,
            controls=controls, claim=claim,
            predicted=tuple(frozenset(Mode.parse(lab, n_contacts) for lab in w.predicted)
                            or frozenset({claim}) for w in seg.waypoints),
            poses=np.array([[float(x) for x in w.pose[:3]] for w in seg.waypoints]),
            angles=np.array([[float(a) for a in w.angles] for w in seg.waypoints],
                            dtype=float).reshape(len(seg.waypoints), len(controls)),
        )

    def slowed(self, factor: float) -> SegmentSchedule:
        """The same segment ``factor`` times slower: times stretched, velocity commands
        divided, efforts and poses unchanged (a positive scaling of the joint rates leaves the
        quasistatic mode set unchanged)."""
        if not (np.isfinite(factor) and factor >= 1.0):
            raise InputError(f"slowed: expected a finite factor >= 1, got {factor}")
        cmd = self.commands.copy()
        cmd[:, [c == "velocity" for c in self.controls]] /= factor
        return replace(self, times=self.times * factor, commands=cmd)

    def truncated(self, n: int) -> SegmentSchedule:
        """The first ``n`` waypoints (a shorter run of the same segment)."""
        if not 2 <= n <= len(self.times):
            raise InputError(f"waypoints: expected 2 <= n <= {len(self.times)}, got {n}")
        return replace(self, times=self.times[:n], commands=self.commands[:n],
                       poses=self.poses[:n], angles=self.angles[:n],
                       predicted=self.predicted[:n])


def predicted_slips(hand: Hand, times: np.ndarray, poses: np.ndarray,
                    angles: np.ndarray) -> np.ndarray:
    """(n, n_c) [m/s]: the tangential relative velocity ``v_it`` of each contact of ``hand``
    at each of ``n`` waypoints of the predicted motion -- workpiece ``poses`` (n, 3) and joint
    ``angles`` (n, n_theta) at ``times`` (n,) [s] -- by eq. 5's tangential rows
    (:func:`planner.model.closure.tangent_jacobian`) times the state rates, the central
    differences of the waypoints (second-order one-sided at the ends). The slip speed the
    classifier would read if the run followed the plan (docs/simulation.md, "Plan
    segments")."""
    t = np.asarray(times, dtype=float)
    q = np.hstack([np.asarray(poses, dtype=float), np.asarray(angles, dtype=float)])
    if len(t) < 2:
        return np.zeros((len(t), hand.n_contacts))
    q[:, 2] = np.unwrap(q[:, 2])
    rates = np.gradient(q, t, axis=0, edge_order=2 if len(t) > 2 else 1)
    return np.stack([tangent_jacobian(hand, qk) @ rk for qk, rk in zip(q, rates)])


def held_command(times: np.ndarray, values: np.ndarray, ramp: float = 0.0,
                 fresh: np.ndarray | None = None) -> Command:
    """``command(t, states)``: ``values[k]`` on ``[times[k], times[k+1])``, ramped linearly from
    ``values[k-1]`` over the first ``ramp`` seconds of each interval unless ``fresh[k]`` (the
    joint's control switched there: no ramp across)."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    new = np.zeros(len(values), dtype=bool) if fresh is None else np.asarray(fresh, dtype=bool)

    def command(t: float, states: Mapping[str, BodyState]) -> float:
        k = int(np.searchsorted(times, t + 1e-12, side="right")) - 1
        k = min(max(k, 0), len(values) - 1)
        v = float(values[k])
        if ramp > 0 and k > 0 and not new[k] and t - times[k] < ramp:
            a = (t - times[k]) / ramp
            v = (1.0 - a) * float(values[k - 1]) + a * v
        return v
    return command


def _key(contact: Any) -> str:
    return json.dumps(contact, sort_keys=True) if isinstance(contact, Mapping) else repr(contact)


@dataclass(frozen=True, eq=False)
class PlanLayout:
    """A plan as one run (module docstring). ``hand``: the plan's hand with the union of all
    segments' contacts (``n_u``); ``q0`` (3 + n_theta,) the plan's start; ``site_configs``
    (n_u,) where each contact's sites are placed; ``members`` per segment the union indices of
    its contacts (in the segment's order); ``starts`` (n_seg,) [s] segment start times,
    ``duration`` [s]; ``schedules`` per segment (its own time from 0); ``hands`` per segment
    its hand and ``q_starts`` its planned start."""

    hand: Hand
    q0: np.ndarray
    site_configs: tuple[np.ndarray, ...]
    members: tuple[tuple[int, ...], ...]
    starts: tuple[float, ...]
    duration: float
    schedules: tuple[SegmentSchedule, ...]
    hands: tuple[Hand, ...]
    q_starts: tuple[np.ndarray, ...]

    @property
    def open_at_start(self) -> tuple[str, ...]:
        """Scene pair names of the contacts the first segment does not hold."""
        first = set(self.members[0])
        return tuple(f"c{i + 1}" for i in range(self.hand.n_contacts) if i not in first)

    def control_switches(self) -> tuple[tuple[float, str, str], ...]:
        """``(time, scene joint name, control)`` for every joint whose control differs from
        the previous segment's (``RunSettings.control_switches``)."""
        names = self.hand.joint_names()
        out = []
        for k in range(1, len(self.schedules)):
            for j, (a, b) in enumerate(zip(self.schedules[k - 1].controls,
                                           self.schedules[k].controls)):
                if a != b:
                    out.append((self.starts[k], f"joint:{names[j]}", b))
        return tuple(out)

    def commands(self, ramp: float) -> list[Command]:
        """(n_theta,) ``command(t, states)`` over the whole plan (module docstring)."""
        times: list[float] = []
        values: list[np.ndarray] = []
        fresh: list[list[bool]] = []
        for k, (s, t0) in enumerate(zip(self.schedules, self.starts)):
            n = len(s.times) - (1 if k < len(self.schedules) - 1 else 0)  # next one takes over
            times.extend(t0 + s.times[:n])
            values.extend(s.commands[:n])
            switched = [k > 0 and s.controls[j] != self.schedules[k - 1].controls[j]
                        for j in range(s.commands.shape[1])]
            fresh.extend([switched] + [[False] * s.commands.shape[1]] * (n - 1))
        t_arr, v_arr, f_arr = np.asarray(times), np.asarray(values), np.asarray(fresh)
        return [held_command(t_arr, v_arr[:, j], ramp, f_arr[:, j])
                for j in range(v_arr.shape[1])]

    def slowed(self, factor: float) -> PlanLayout:
        """Every segment ``factor`` times slower (:meth:`SegmentSchedule.slowed`)."""
        if factor == 1.0:
            return self
        schedules = tuple(s.slowed(factor) for s in self.schedules)
        return replace(self, schedules=schedules, starts=tuple(t * factor for t in self.starts),
                       duration=self.duration * factor)

    def expectation(self) -> PlanSchedule:
        """What the run is judged against (:class:`sim.expectation.PlanSchedule`)."""
        segments = []
        points = np.asarray(self.hand.com, dtype=float).reshape(1, 2)  # judged at its com
        for k, (s, t0, members) in enumerate(zip(self.schedules, self.starts, self.members)):
            gained = tuple(j for j, i in enumerate(members)
                           if k > 0 and i not in self.members[k - 1])
            travel = point_travel(s.poses, points)
            segments.append(SegmentExpectation(
                claim=s.claim, start=t0, times=s.times, predicted=s.predicted, poses=s.poses,
                planned_start=np.asarray(self.q_starts[k][:3], dtype=float), pairs=members,
                gained=gained, travel=travel,
                slips=predicted_slips(self.hands[k], s.times, s.poses, s.angles),
                points=points))
        return PlanSchedule(tuple(segments), float(sum(s.travel for s in segments)),
                            np.asarray(self.schedules[-1].poses[-1], dtype=float),
                            self.hand.length_scale, points)


def plan_layout(plan: Any, *, torques: np.ndarray | None = None,
                waypoints: int | None = None) -> PlanLayout:
    """The :class:`PlanLayout` of ``plan``: a :class:`planner.plan.model.Plan` (any file
    version) or one of its :class:`~planner.plan.model.Segment` (a plan of one segment).
    ``torques`` (n, p) replaces the planned efforts of a one-segment plan (a negative control);
    ``waypoints``: run only its first so many waypoints (a shorter run of it)."""
    segs = list(plan.segments) if hasattr(plan, "segments") else [plan]
    if (torques is not None or waypoints is not None) and len(segs) != 1:
        raise InputError(f"torques, waypoints: expected a one-segment plan, got {len(segs)} "
                         "segments")
    parts = []
    for seg in segs:
        h, q = seg.hand_model
        objects = tuple(seg.contacts)
        if len(objects) != h.n_contacts:
            raise InputError(f"plan: expected {h.n_contacts} contact objects for a "
                             f"segment, got {len(objects)}")
        parts.append((h, np.asarray(q, dtype=float),
                      SegmentSchedule.from_segment(seg, h.n_contacts, torques), objects))
    if waypoints is not None:
        if len(parts) != 1:
            raise InputError(f"waypoints: expected a one-segment plan, got {len(parts)} "
                             "segments")
        parts[0] = (*parts[0][:2], parts[0][2].truncated(waypoints), parts[0][3])
    keys: list[str] = []
    specs: list[Any] = []
    refs: list[np.ndarray] = []
    members: list[tuple[int, ...]] = []
    starts: list[float] = []
    t0 = 0.0
    for h, q, sched, cs in parts:
        idx: list[int] = []
        for i, c in enumerate(cs):
            if _key(c) not in keys:
                keys.append(_key(c))
                specs.append(h.contacts[i])
                refs.append(q)
            idx.append(keys.index(_key(c)))
        members.append(tuple(idx))
        starts.append(t0)
        t0 += float(sched.times[-1])
    first = parts[0][0]
    for h, *_ in parts[1:]:
        if h.n_joints != first.n_joints or h.joint_names() != first.joint_names():
            raise InputError("plan: expected the same fingers in every segment, got joints "
                             f"{first.joint_names()} and {h.joint_names()}")
    union = replace(first, contacts=tuple(specs))
    return PlanLayout(hand=union, q0=parts[0][1], site_configs=tuple(refs),
                      members=tuple(members), starts=tuple(starts), duration=t0,
                      schedules=tuple(p[2] for p in parts), hands=tuple(p[0] for p in parts),
                      q_starts=tuple(p[1] for p in parts))


def contact_drive_speed(hand: Hand, q0: np.ndarray, controls: Sequence[str],
                        commands: np.ndarray) -> float:
    """Drive speed [m/s] of a segment: the fastest manipulator contact-point velocity the
    velocity-controlled joints give at ``q0``, ``max_k max_i |J_i(q0)[:, V] thetadot_V,k|``
    over the waypoints' commands ``(n, n_theta)`` (eqs. 3, 5). A driving joint that touches
    nothing: its links' length times its rate."""
    V = [j for j, c in enumerate(controls) if c == "velocity"]
    if not V:
        raise InputError("controls: expected at least one velocity-controlled joint, got none")
    J = hand.jacobian(q0)[:, :, V]  # (n_c, 2, |V|)
    rates = np.asarray(commands, dtype=float)[:, V]  # (n, |V|)
    speed = float(np.max(np.linalg.norm(np.einsum("cij,kj->kci", J, rates), axis=2)))
    if speed > 0:
        return speed
    reach = [sum(lk.length for lk in f.chain_links) for f in hand.fingers
             for _ in range(f.n_joints)]
    return float(max(np.max(np.abs(rates[:, i])) * reach[j] for i, j in enumerate(V)))


def effort_force(hand: Hand, q0: np.ndarray, controls: Sequence[str],
                 commands: np.ndarray) -> float:
    """Contact normal force [N] the effort-controlled joints exert, estimated from eq. 3
    without friction: joint ``j``'s effort ``tau_j = sum_i J_i,nj c_in`` carried by its
    contact with the longest normal lever ``max_i |J_i,nj(q0)|`` (m for a revolute joint, 1 for
    a prismatic one), so ``c_n = |tau_j| / max_i |J_i,nj|``; the largest over the effort
    joints and the waypoints' ``commands`` ``(n, n_theta)``. 0 without effort joints or when an
    effort joint's contacts all have zero normal lever (it presses on nothing)."""
    E = [j for j, c in enumerate(controls) if c == "effort"]
    if not E:
        return 0.0
    lever = np.max(np.abs(hand.jacobian(q0)[:, 0, E]), axis=0)  # (|E|,)
    tau = np.max(np.abs(np.asarray(commands, dtype=float)[:, E]), axis=0)  # (|E|,)
    ok = lever > 0
    return float(np.max(tau[ok] / lever[ok])) if np.any(ok) else 0.0
