"""Whole tasks: best-first search over chains of guaranteed segments to a goal (issue 16).

Section 5.2 says the paper's planner [39] took the workpiece of Figure 9 from its initial to its
goal grasp in three ``4S`` segments, each executed by velocity-controlling one joint while
torque-controlling the other.  This module searches for such chains for any hand.

A *node* is a contact set (:mod:`planner.plan.task_contacts`) and a configuration where all of
it touches.  Its *children* are the segments that can start there, one per choice of

1. the contacts to release (mode ``B``: they must open; the kept set has
   ``3 + n_theta - 1`` contacts, :func:`planner.plan.task_contacts.releases`),
2. the driven joint and the sign of its rate (``speed`` of the task options),
3. a determinate mode of the kept contacts that is kinematically admissible with that drive
   (eqs. 13-16, 23-25; every label, not only the ``4S`` family),

each integrated (:func:`planner.plan.trajectory.integrate_segment`) to its first event (new
contact, lost contact, mode change) or to the goal pose.  The search is greedy best-first on the
distance to the goal at a child's end (workpiece position over the workpiece size, angle over
pi/2, plus one per goal contact missing), ties to fewer segments; a child's torque regions
(:func:`planner.plan.region_planner.plan_regions`: every control partition, the polytope over
the friction box, its Chebyshev centre) are computed lazily, when the child is taken from the
queue, and a child without a guaranteed region everywhere is not expanded: its diagnosis (the
covering rival, the friction values, the widest interval that would work) is kept.  The search
stops at the first node that meets the goal (pose within tolerance, goal contacts present), or
when the queue empties or ``max_expansions`` is spent: then the plan is *partial*, the chain to
the node nearest the goal, with the diagnosis of the best child that failed there.

What it can find: chains of single-drive segments at one speed magnitude, each ending at a
contact event, the last one possibly cut at the goal pose.  What it cannot: segments that
drive several joints at once, stop between events other than at the goal, change speed, or
keep fewer/more contacts closed than the closure needs; motions through a configuration the
kinematic stage finds non-admissible for every mode; and it is not complete or optimal (greedy,
depth ``max_segments``, duplicates pruned on the rounded end state).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.files.hand_goal import Goal
from planner.model.hand import ContactSpec, Hand
from planner.model.modes import Mode, enumerate_modes
from planner.plan.region_planner import (
    NoRegionError,
    RegionPlan,
    Shortfall,
    joint_inputs,
    plan_regions,
)
from planner.plan.task_contacts import after_event, describe, releases, with_contacts
from planner.plan.trajectory import Segment, integrate_segment
from planner.predict.stages import kinematic_stage


@dataclass(frozen=True)
class TaskOptions:
    """Search settings: ``speed`` of the driven joint (rad/s or m/s, both signs are tried),
    ``mu`` the friction interval, ``model`` (``common``/``independent``), ``max_time`` (s) and
    ``steps`` per segment, ``waypoints`` per planned segment, ``max_expansions``."""

    speed: float
    mu: Any
    model: str = "common"
    max_time: float = 60.0
    steps: int = 120
    waypoints: int = 21
    max_expansions: int = 40


@dataclass(frozen=True, eq=False)
class TaskStep:
    """One planned segment of a task: the ``hand`` with the contact set it keeps closed,
    ``released`` (contacts of the previous set it opens), ``drive``/``speed``, the planned
    :class:`RegionPlan` ``plan`` and the contact set after its event, ``contacts_after``."""

    hand: Hand
    released: tuple[ContactSpec, ...]
    drive: int
    speed: float
    plan: RegionPlan
    contacts_after: tuple[ContactSpec, ...]

    @property
    def event(self) -> dict[str, Any]:
        ev = self.plan.segment.event
        return {"kind": ev.kind, "detail": ev.detail, "t": ev.t}


@dataclass(frozen=True)
class Rejection:
    """A child segment that was tried and failed: after ``depth`` segments, ``what`` (release,
    drive, mode) and ``why`` (the region's diagnosis), with its :class:`Shortfall` if any."""

    depth: int
    what: str
    why: str
    shortfall: Shortfall | None = None


@dataclass(frozen=True, eq=False)
class TaskPlan:
    """A task plan: ``steps`` in order, ``reached`` (the goal holds at the end), the
    ``goal``, ``distance`` to it at the end, ``rejections`` (every child that failed, in search
    order), ``partial`` (for a plan that stops short: the failing child that got furthest --
    its steps are *not* in ``steps``), ``expansions`` and ``segments_integrated``."""

    steps: tuple[TaskStep, ...]
    reached: bool
    goal: Goal
    distance: float
    rejections: tuple[Rejection, ...] = ()
    partial: Rejection | None = None
    expansions: int = 0
    segments_integrated: int = 0
    notes: tuple[str, ...] = field(default_factory=tuple)


@dataclass(frozen=True, eq=False)
class _Child:
    hand: Hand
    released: tuple[ContactSpec, ...]
    drive: int
    speed: float
    segment: Segment


def goal_distance(goal: Goal, hand: Hand, q: np.ndarray, contacts: tuple[ContactSpec, ...]
                  ) -> float:
    """Search heuristic: workpiece position error over the workpiece size plus angle error over
    pi/2 (0 within the goal's tolerance), plus one per goal contact missing."""
    d = float(len(goal.missing_contacts(contacts)))
    if goal.pose is not None and not goal.pose_reached(q):
        d += float(np.linalg.norm(q[:2] - goal.pose[:2])) / hand.length_scale
        d += abs(math.remainder(float(q[2] - goal.pose[2]), 2 * math.pi)) / (0.5 * math.pi)
    return d


def admissible_labels(hand: Hand, q: np.ndarray, drive: int, speed: float
                      ) -> list[tuple[str, np.ndarray]]:
    """``(label, state rate (3 + n_theta,))`` of every mode (no ``B``: every contact of
    ``hand`` stays closed) kinematically admissible at ``q`` with joint ``drive`` at ``speed``
    and the others effort-controlled; the state rate is ``d/dt (x, y, phi, theta)``."""
    system = hand.system(q, 0.0, joint_inputs(hand, (drive,), (speed,)))
    cand = enumerate_modes(system.n_contacts, system.dof)
    ks = kinematic_stage(system, cand)
    out = []
    for i in np.flatnonzero(ks.ok):
        m = Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in ks.xi[i]))
        if "B" not in m.tokens:
            rate = np.concatenate([hand.pose_rates_from_twist(q, ks.qdot[i]),
                                   ks.joint_velocities[i]])
            out.append((m.label, rate))
    return out


def _children(hand: Hand, q: np.ndarray, opts: TaskOptions,
              stop: Callable[[Hand], Callable[[np.ndarray], bool] | None]
              ) -> tuple[list[_Child], int]:
    """Every segment that can start at ``(hand, q)``; returns ``(children, integrated)``."""
    out: list[_Child] = []
    n = 0
    scale = hand.length_scale
    G = hand.gap_jacobian(q)
    for rel in releases(hand.n_contacts, 2 + hand.n_joints):
        kept = tuple(c for i, c in enumerate(hand.contacts) if i not in rel)
        hk = with_contacts(hand, kept)
        released = tuple(hand.contacts[i] for i in rel)
        for drive, sign in itertools.product(range(hand.n_joints), (1.0, -1.0)):
            speed = sign * opts.speed
            try:
                labels = admissible_labels(hk, q, drive, speed)
            except DegenerateError:
                continue
            for label, rate in labels:
                if rel and not np.all(G[list(rel)] @ rate > 1e-9 * abs(speed) * scale):
                    continue  # a released contact would not open (B inadmissible)
                n += 1
                try:
                    seg = integrate_segment(hk, q, drive=drive, speed=speed, mode=label,
                                            max_time=opts.max_time, steps=opts.steps,
                                            stop=stop(hk))
                except (DegenerateError, InputError):
                    continue
                if seg.travel() + scale * float(np.ptp(seg.q[:, 2])) <= 1e-6 * scale:
                    continue  # ends where it starts (a released contact closes at once)
                out.append(_Child(hk, released, drive, speed, seg))
    return out, n


def plan_task(hand: Hand, q0: Any, goal: Goal, opts: TaskOptions) -> TaskPlan:
    """Search a chain of guaranteed segments from ``(hand, q0)`` to ``goal`` (module docstring).

    Returns a :class:`TaskPlan`; ``reached`` False means a partial plan (the chain to the node
    nearest the goal) with its diagnosis.  Raises :class:`InputError` for bad options."""
    if not (math.isfinite(opts.speed) and opts.speed > 0):
        raise InputError(f"speed: expected a positive joint rate, got {opts.speed!r}")
    if opts.max_expansions < 1:
        raise InputError(f"max_expansions: expected >= 1, got {opts.max_expansions}")
    q0 = hand.check_q(q0)

    def stop(hk: Hand) -> Callable[[np.ndarray], bool] | None:
        if goal.pose is None or goal.missing_contacts(hk.contacts):
            return None
        return lambda q: goal.pose_error(q) <= 1.0

    counter = itertools.count()
    heap: list[tuple[float, int, int, _Child, tuple[TaskStep, ...]]] = []
    seen: set[Any] = set()
    rejections: list[Rejection] = []
    best_steps: tuple[TaskStep, ...] = ()
    best_d = goal_distance(goal, hand, q0, hand.contacts)
    expansions = integrated = 0
    if goal.reached(q0, hand.contacts):
        return TaskPlan((), True, goal, 0.0, notes=("the goal holds at the start",))

    def expand(h: Hand, q: np.ndarray, steps: tuple[TaskStep, ...]) -> None:
        nonlocal expansions, integrated
        expansions += 1
        kids, n = _children(h, q, opts, stop)
        integrated += n
        for c in kids:
            end = c.segment.q[-1]
            after = c.hand.contacts if c.segment.event.kind == "goal" else after_event(
                c.hand, end, c.segment.event.kind)
            key = (after, tuple(np.round(end / (1e-4 * h.length_scale)).astype(int)))
            if key in seen:
                continue
            seen.add(key)
            d = goal_distance(goal, h, end, after)
            heapq.heappush(heap, (d, len(steps) + 1, next(counter), c, steps))

    expand(hand, q0, ())
    while heap and expansions <= opts.max_expansions:
        d, depth, _, c, steps = heapq.heappop(heap)
        what = _what(hand, c)
        try:
            rp = plan_regions(c.hand, c.segment.q[0], drive=c.drive, speed=c.speed,
                              mode=c.segment.mode, mu=opts.mu, model=opts.model,
                              waypoints=opts.waypoints, segment=c.segment, partial=True)
        except NoRegionError as exc:
            rejections.append(Rejection(depth - 1, what, str(exc), exc.shortfall))
            continue
        except DegenerateError as exc:
            rejections.append(Rejection(depth - 1, what, str(exc)))
            continue
        if rp.shortfall is not None:
            rejections.append(Rejection(depth - 1, what, rp.shortfall.reason, rp.shortfall))
            continue
        end = c.segment.q[-1]
        after = c.hand.contacts if c.segment.event.kind == "goal" else after_event(
            c.hand, end, c.segment.event.kind)
        chain = (*steps, TaskStep(c.hand, c.released, c.drive, c.speed, rp, after))
        if goal.reached(end, after):
            return TaskPlan(chain, True, goal, 0.0, tuple(rejections), None, expansions,
                            integrated)
        if d < best_d:
            best_d, best_steps = d, chain
        if depth < goal.max_segments:
            expand(with_contacts(c.hand, after), end, chain)
    why = ("search exhausted" if not heap else f"max_expansions {opts.max_expansions} spent")
    return TaskPlan(best_steps, False, goal, best_d, tuple(rejections),
                    _nearest_failure(rejections, len(best_steps)), expansions, integrated, (why,))


def _nearest_failure(rejections: list[Rejection], depth: int) -> Rejection | None:
    """The failure to report with a partial plan: among the children of its last node (else
    all), one with a diagnosis that got furthest along its segment."""
    pool = [r for r in rejections if r.depth == depth] or rejections
    if not pool:
        return None
    return max(pool, key=lambda r: (r.shortfall is not None,
                                    r.shortfall.index if r.shortfall is not None else -1))


def _what(root: Hand, c: _Child) -> str:
    rel = ", ".join(describe(root, r) for r in c.released)
    name = root.joint_names()[c.drive]
    return (f"{'release ' + rel + '; ' if rel else ''}drive {name} "
            f"{'+' if c.speed > 0 else '-'}{abs(c.speed):g}; {c.segment.mode} "
            f"({c.segment.event.kind}: {c.segment.event.detail})")
