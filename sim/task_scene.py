"""One scene for a whole task: every contact of every segment, the joints' commands over the
whole plan and the times their control mode switches (issue 16, a continuous validation).

Reads only the plan (:class:`planner.plan.model.Plan`). The contacts of all
segments are united in order of first appearance (a contact is the same in two segments when
its hand-file contact object is); pair ``c<i>`` of the scene is the ``i``-th contact of that
union. A contact of the first segment is placed pre-loaded at the plan's start; a contact a
later segment gains is apart at the start (``RunSettings.open_at_start``) and its sites are
placed at the planned start of that segment (:func:`sim.scenes.hand.hand_scene`,
``site_configs``). A contact a segment releases stays in the scene (the bodies still collide
there) but is not judged in the segments that do not hold it.

Time: segment ``k`` runs on ``[T_k, T_k + D_k)``, ``T_0 = 0``, ``D_k`` its last waypoint's
time. Each joint's command is the segment's waypoint command held to the next waypoint and
ramped over ``ramp`` seconds at each change (:func:`sim.hand_run.held_command`), also across a
segment boundary when the joint keeps its control; when its control switches (velocity <->
effort) the new command starts at once, from the first step of the new segment
(``RunSettings.control_switches``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
from planner.plan.model import Plan
from sim.hand_run import Schedule
from sim.scene import BodyState, Command


def _key(contact: Mapping[str, Any]) -> str:
    return json.dumps(contact, sort_keys=True)


@dataclass(frozen=True, eq=False)
class TaskLayout:
    """The whole task as one run. ``hand``: the plan's hand with the union of all segments'
    contacts (``n_u``); ``q0`` (3 + n_theta,) the plan's start; ``site_configs`` (n_u,) where
    each contact's sites are placed; ``members`` per segment the union indices of its
    contacts (in the segment's order); ``starts`` (n_seg,) [s] segment start times,
    ``duration`` [s]; ``schedules`` per segment (its own time from 0); ``hands`` per segment
    its hand (``n_c`` contacts) and ``q_starts`` its planned start."""

    hand: Hand
    q0: np.ndarray
    site_configs: tuple[np.ndarray, ...]
    members: tuple[tuple[int, ...], ...]
    starts: tuple[float, ...]
    duration: float
    schedules: tuple[Schedule, ...]
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
        """(n_theta,) ``command(t, states)`` over the whole task (module docstring)."""
        times: list[float] = []
        values: list[np.ndarray] = []
        fresh: list[list[bool]] = []
        for k, (s, t0) in enumerate(zip(self.schedules, self.starts)):
            cmd = s.joint_commands()
            n = len(s.times) - (1 if k < len(self.schedules) - 1 else 0)  # next one takes over
            times.extend(t0 + np.asarray(s.times[:n]))
            values.extend(cmd[:n])
            switched = [k > 0 and s.controls[j] != self.schedules[k - 1].controls[j]
                        for j in range(cmd.shape[1])]
            fresh.extend([switched] + [[False] * cmd.shape[1]] * (n - 1))
        t_arr, v_arr, f_arr = np.asarray(times), np.asarray(values), np.asarray(fresh)
        return [_task_command(t_arr, v_arr[:, j], f_arr[:, j], ramp)
                for j in range(v_arr.shape[1])]


def _task_command(times: np.ndarray, values: np.ndarray, fresh: np.ndarray,
                  ramp: float) -> Command:
    """``values[k]`` on ``[times[k], times[k+1])``, ramped from ``values[k-1]`` over ``ramp``
    seconds unless ``fresh[k]`` (the joint's control switched there: no ramp across)."""
    def command(t: float, states: Mapping[str, BodyState]) -> float:
        k = int(np.searchsorted(times, t + 1e-12, side="right")) - 1
        k = min(max(k, 0), len(values) - 1)
        v = float(values[k])
        if ramp > 0 and k > 0 and not fresh[k] and t - times[k] < ramp:
            a = (t - times[k]) / ramp
            v = (1.0 - a) * float(values[k - 1]) + a * v
        return v
    return command


def task_layout(plan: Plan) -> TaskLayout:
    """The :class:`TaskLayout` of ``plan`` (module docstring)."""
    keys: list[str] = []
    specs: list[Any] = []
    refs: list[np.ndarray] = []
    members, starts, schedules, hands, q_starts = [], [], [], [], []
    t0 = 0.0
    for seg, contacts in zip(plan.segments, plan.contacts):
        hand, q = seg.hand_model
        if len(contacts) != hand.n_contacts:
            raise InputError(f"task plan: expected {hand.n_contacts} contact objects for a "
                             f"segment, got {len(contacts)}")
        idx = []
        for i, c in enumerate(contacts):
            if _key(c) not in keys:
                keys.append(_key(c))
                specs.append(hand.contacts[i])
                refs.append(np.asarray(q, dtype=float))
            idx.append(keys.index(_key(c)))
        members.append(tuple(idx))
        sched = Schedule.from_plan(seg, hand.n_contacts)
        schedules.append(sched)
        hands.append(hand)
        q_starts.append(np.asarray(q, dtype=float))
        starts.append(t0)
        t0 += float(sched.times[-1])
    first = hands[0]
    for h in hands[1:]:
        if h.n_joints != first.n_joints or h.joint_names() != first.joint_names():
            raise InputError("task plan: expected the same fingers in every segment, got "
                             f"joints {first.joint_names()} and {h.joint_names()}")
    union = replace(first, contacts=tuple(specs))
    return TaskLayout(hand=union, q0=q_starts[0], site_configs=tuple(refs),
                      members=tuple(members), starts=tuple(starts), duration=t0,
                      schedules=tuple(schedules), hands=tuple(hands), q_starts=tuple(q_starts))
