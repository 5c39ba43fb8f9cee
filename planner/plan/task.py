"""Whole tasks: best-first search over chains of guaranteed segments to a goal.

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
pi/2, plus one per goal contact missing), ties to fewer segments; a child is planned
(:func:`planner.plan.segment_planner.plan_segment`: every control partition, the guaranteed
efforts over the friction set, the waypoint spacing, the commands) lazily, when it is taken from
the queue, and a child without a guaranteed set everywhere is not expanded: its diagnosis (the
covering rival, the friction values, the widest interval that would work) is kept.  The search
stops at the first node that meets the goal (pose within tolerance, goal contacts present), or
when the queue empties or ``max_expansions`` is spent: then the plan is *partial*, the chain to
the node nearest the goal, with the diagnosis of the best child that failed there.  The result
is a :class:`planner.plan.model.Plan`.

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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.files.hand_goal import Goal
from planner.model.hand import ContactSpec, Hand
from planner.model.modes import BREAK, ROLL, Mode, enumerate_modes
from planner.model.validation import FrictionValue, friction_interval
from planner.plan.model import Plan, Segment, Shortfall
from planner.plan.partition import joint_inputs
from planner.plan.segment_planner import NoRegionError, plan_segment, remedies
from planner.plan.task_contacts import (
    after_event,
    contact_dict,
    releases,
    with_contacts,
)
from planner.plan.trajectory import Trajectory, integrate_segment
from planner.plan.wording import contact_words, drive_words, motion_words
from planner.predict.indeterminate import indeterminate_kinematics
from planner.predict.stages import kinematic_stage


@dataclass(frozen=True)
class TaskOptions:
    """Search settings: ``speed`` of the driven joint (rad/s or m/s, both signs are tried),
    ``mu`` the friction interval ``(lo, hi)`` of every contact whose body has none in
    ``friction`` (body name -- ``palm``, an environment surface's or a finger's name -- to its
    interval, :meth:`planner.model.hand.Hand.body_name`; with any, the model is
    ``independent``), ``model``
    (``common``/``independent``), ``max_time`` (s) and ``steps`` per segment (RK4 steps over
    ``max_time``), ``waypoints`` per planned segment (None: the spacing rule,
    :mod:`planner.plan.spacing`), ``max_expansions``."""

    speed: float
    mu: Any
    model: str = "common"
    max_time: float = 60.0
    steps: int = 120
    waypoints: int | None = None
    max_expansions: int = 40
    friction: Mapping[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class Rejection:
    """A child segment that was tried and failed: after ``depth`` segments, ``what`` (release,
    drive, motion, mode) and ``why`` (the guarantee's diagnosis), with its :class:`Shortfall`
    if any."""

    depth: int
    what: str
    why: str
    shortfall: Shortfall | None = None
    child: Any = None


@dataclass(frozen=True, eq=False)
class _Child:
    hand: Hand
    released: tuple[ContactSpec, ...]
    drive: int
    speed: float
    trajectory: Trajectory


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


def _candidates(hand: Hand, q: np.ndarray, speed: float, level: int
                ) -> list[tuple[tuple[int, ...], int, float, str]]:
    """``(released contact indices, driven joint, its rate, label of the kept contacts)`` of
    the segments that can start at ``(hand, q)``, one joint driven at ``+-speed`` and the
    others effort-controlled.

    Level 1 (the paper's search, Sec. 5.2): every way to keep ``3 + n_theta - 1`` contacts
    closed, the others released, in an admissible mode without ``B`` (all sliding, as the
    ``4S`` segments of Figure 9, or rolling where the kinematics allow).  Level 2: every
    kinematically admissible mode of the whole contact set (eqs. 13-16, 23-25) --
    rolling/sticking, sliding and breaking contacts in any mix with ``2 n_R + n_S = 3 + n_theta
    - 1`` (condition 29 with one velocity-controlled joint), and the force-indeterminate ones
    with more rows whose velocities the rows still fix (relaxed utility, end of Sec. 3.2:
    :func:`planner.predict.indeterminate.indeterminate_kinematics`; two sticking contacts of one
    finger face) -- that level 1 does not list; its ``B`` contacts are the ones released (eq. 25
    makes them open)."""
    out: list[tuple[tuple[int, ...], int, float, str]] = []
    drives = list(itertools.product(range(hand.n_joints), (speed, -speed)))
    n_keep = 2 + hand.n_joints
    if level == 1:
        G = hand.gap_jacobian(q)
        scale = hand.length_scale
        for rel in releases(hand.n_contacts, n_keep):
            kept = tuple(c for i, c in enumerate(hand.contacts) if i not in rel)
            for drive, rate in drives:
                try:
                    labels = admissible_labels(with_contacts(hand, kept), q, drive, rate)
                except DegenerateError:
                    continue
                for label, qrate in labels:
                    if rel and not np.all(G[list(rel)] @ qrate > 1e-9 * abs(rate) * scale):
                        continue  # a released contact would not open (B inadmissible)
                    out.append((rel, drive, rate, label))
        return out
    for drive, rate in drives:
        try:
            system = hand.system(q, 0.0, joint_inputs(hand, (drive,), (rate,)))
            cand = enumerate_modes(system.n_contacts, system.dof)
            ks = kinematic_stage(system, cand)
        except DegenerateError:
            continue
        modes = [(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in ks.xi[i]))
                 for i in np.flatnonzero(ks.ok)]
        try:  # force-indeterminate modes (relaxed utility, Sec. 3.2): more rows than dof
            modes += [(k.mode.codes, k.mode.xi) for k in indeterminate_kinematics(system)]
        except DegenerateError:
            pass
        for codes, xi in modes:
            if ROLL not in codes and sum(c != BREAK for c in codes) == n_keep:
                continue  # listed by level 1
            keep = [j for j, c in enumerate(codes) if c != BREAK]
            label = Mode(tuple(codes[j] for j in keep), tuple(xi[j] for j in keep)).label
            out.append((tuple(j for j, c in enumerate(codes) if c == BREAK), drive, rate,
                        label))
    return out


def _children(hand: Hand, q: np.ndarray, opts: TaskOptions,
              stop: Callable[[Hand], Callable[[np.ndarray], bool] | None], level: int = 1
              ) -> tuple[list[_Child], int]:
    """Every segment that can start at ``(hand, q)`` (:func:`_candidates` at ``level``),
    integrated to its first event; returns ``(children, integrated)``."""
    out: list[_Child] = []
    n = 0
    scale = hand.length_scale
    for rel, drive, speed, label in _candidates(hand, q, opts.speed, level):
        kept = tuple(c for i, c in enumerate(hand.contacts) if i not in rel)
        hk = with_contacts(hand, kept)
        n += 1
        try:
            tr = integrate_segment(hk, q, drive=drive, speed=speed, mode=label,
                                   max_time=opts.max_time, steps=opts.steps, stop=stop(hk))
        except (DegenerateError, InputError):
            continue
        if tr.travel() + scale * float(np.ptp(tr.q[:, 2])) <= 1e-6 * scale:
            continue  # ends where it starts (a released contact closes at once)
        out.append(_Child(hk, tuple(hand.contacts[i] for i in rel), drive, speed, tr))
    return out, n


def plan_task(hand: Hand, q0: Any, goal: Goal, opts: TaskOptions, *,
              data: Mapping[str, Any], validate_mu: tuple[FrictionValue, ...] = ()) -> Plan:
    """Search a chain of guaranteed segments from ``(hand, q0)`` to ``goal`` (module docstring).

    ``data``: the hand file content ``hand`` was read from (embedded in the plan);
    ``validate_mu``: friction values the plan is meant to be validated at.  Returns a
    :class:`planner.plan.model.Plan`; ``reached`` False means a partial plan (the chain to the
    node nearest the goal) with its ``diagnosis``.  Raises :class:`InputError` for bad
    options."""
    if not (math.isfinite(opts.speed) and opts.speed > 0):
        raise InputError(f"speed: expected a positive joint rate, got {opts.speed!r}")
    if opts.max_expansions < 1:
        raise InputError(f"max_expansions: expected >= 1, got {opts.max_expansions}")
    q0 = hand.check_q(q0)
    lo, hi = (float(x) for x in np.ravel(opts.mu)[:2])
    friction = dict(opts.friction)
    model = "independent" if friction else opts.model

    def contact_intervals(h: Hand) -> Any:
        """One ``(lo, hi)`` per contact of ``h``: its body's interval, else ``opts.mu``."""
        if not friction:
            return (lo, hi)
        return [friction.get(h.body_name(c), (lo, hi)) for c in h.contacts]

    def stop(hk: Hand) -> Callable[[np.ndarray], bool] | None:
        if goal.pose is None or goal.missing_contacts(hk.contacts):
            return None
        return lambda q: goal.pose_error(q) <= 1.0

    def result(chain: tuple[Segment, ...], reached: bool, distance: float,
               failure: Rejection | None, notes: tuple[str, ...]) -> Plan:
        diag = None if reached else _diagnosis(distance, notes, len(chain), failure)
        if diag is not None and diag["failed"] is not None and failure is not None:
            diag["failed"]["remedies"] = list(_remedies(failure, contact_intervals, model))
        return Plan(hand=dict(data), segments=chain, mu_model=model,
                    mu_intervals=((lo, hi),), validate_mu=tuple(validate_mu), reached=reached,
                    diagnosis=diag, notes="; ".join(notes),
                    extra={"expansions": expansions, "segments_integrated": integrated,
                           "rejections": [{"after_segments": r.depth, "what": r.what,
                                           "why": r.why} for r in rejections]})

    rejections: list[Rejection] = []
    expansions = integrated = 0
    if goal.reached(q0, hand.contacts):
        raise InputError("goal: expected a goal the hand does not meet at its start, got one "
                         "it meets already (nothing to plan)")
    start_d = goal_distance(goal, hand, q0, hand.contacts)

    def search(levels: tuple[int, ...]) -> tuple[tuple[Segment, ...], bool, float, str]:
        """One best-first search whose children are those of ``levels``
        (:func:`_candidates`): ``(chain, reached, distance, why it stopped)``."""
        nonlocal expansions, integrated
        counter = itertools.count()
        heap: list[tuple[float, int, int, _Child, tuple[Segment, ...]]] = []
        seen: set[Any] = set()
        best_steps: tuple[Segment, ...] = ()
        best_d = start_d
        budget = expansions + opts.max_expansions

        def expand(h: Hand, q: np.ndarray, steps: tuple[Segment, ...]) -> None:
            nonlocal expansions, integrated
            expansions += 1
            for level in levels:
                kids, n = _children(h, q, opts, stop, level)
                integrated += n
                for c in kids:
                    end = c.trajectory.q[-1]
                    after = c.hand.contacts if c.trajectory.event.kind == "goal" else (
                        after_event(c.hand, end, c.trajectory.event.kind))
                    key = (after, tuple(np.round(end / (1e-4 * h.length_scale)).astype(int)))
                    if key in seen:
                        continue
                    seen.add(key)
                    d = goal_distance(goal, h, end, after)
                    heapq.heappush(heap, (d, len(steps) + 1, next(counter), c, steps))

        expand(hand, q0, ())
        while heap and expansions <= budget:
            d, depth, _, c, steps = heapq.heappop(heap)
            what = _what(hand, c)
            try:
                seg = plan_segment(
                    c.hand, c.trajectory.q[0], data=data, drive=c.drive, speed=c.speed,
                    mode=c.trajectory.mode, mu=contact_intervals(c.hand), model=model,
                    waypoints=opts.waypoints, max_time=opts.max_time, steps=opts.steps,
                    trajectory=c.trajectory, partial=True,
                    released=tuple(contact_dict(hand, r) for r in c.released))
            except NoRegionError as exc:
                rejections.append(Rejection(depth - 1, what, str(exc), exc.shortfall, c))
                continue
            except DegenerateError as exc:
                rejections.append(Rejection(depth - 1, what, str(exc)))
                continue
            if seg.shortfall is not None or seg.extra["spacing"].get("ended"):
                why = (seg.shortfall.reason if seg.shortfall is not None else  # rates diverge
                       f"its commands cannot be held to its end: {seg.event.detail}")
                rejections.append(Rejection(depth - 1, what, why, seg.shortfall, c))
                continue
            end = c.trajectory.q[-1]
            after = c.hand.contacts if c.trajectory.event.kind == "goal" else after_event(
                c.hand, end, c.trajectory.event.kind)
            chain = (*steps, seg)
            if goal.reached(end, after):
                return chain, True, 0.0, ""
            if d < best_d:
                best_d, best_steps = d, chain
            if depth < goal.max_segments:
                expand(with_contacts(c.hand, after), end, chain)
        why = ("the search is exhausted: no further segment can start" if not heap else
               f"max_expansions {opts.max_expansions} spent")
        return best_steps, False, best_d, why

    # The paper's search first (Figure 9's chain is found there); modes with sticking contacts
    # and any release (level 2) only when it does not reach the goal.
    chain, reached, dist, why = search((1,))
    if reached:
        return result(chain, True, 0.0, None, ())
    chain2, reached, dist2, why2 = search((1, 2))
    if reached:
        return result(chain2, True, 0.0, None, ())
    if dist2 < dist or (dist2 == dist and len(chain2) > len(chain)):
        chain, dist, why = chain2, dist2, why2
    return result(chain, False, dist, _nearest_failure(rejections, len(chain)),
                  (f"sliding modes only: {why}; with sticking modes and any release: {why2}",))


def _diagnosis(distance: float, notes: tuple[str, ...], after: int,
               fail: Rejection | None) -> dict[str, Any]:
    """The diagnosis of a partial plan (docs/plan-format.md): how far from the goal it ends,
    why the search stopped, and the failure of the child that got furthest there."""
    sf = fail.shortfall if fail is not None else None
    failed = None if fail is None else {
        "what": fail.what, "why": fail.why,
        "t": None if sf is None else sf.t,
        "rival": None if sf is None else sf.rival,
        "mu": None if sf is None else [list(m) for m in sf.mu],
        "widest_mu": None if sf is None or sf.widest_mu is None
        else [list(sf.widest_mu[0]), list(sf.widest_mu[1])]}
    return {"distance_to_goal": distance, "notes": list(notes), "after_segments": after,
            "failed": failed}


def _remedies(fail: Rejection, intervals: Callable[[Hand], Any], model: str
              ) -> tuple[str, ...]:
    """What would make the reported failure work (:func:`planner.plan.segment_planner.remedies`
    at the waypoint where its guarantee fails); () when it is not a guarantee failure."""
    sf, c = fail.shortfall, fail.child
    if sf is None or c is None or sf.widest_mu is not None:
        return ()
    try:
        at = c.trajectory.at_times(c.hand, np.array([sf.t]))
        lo, hi = friction_interval(intervals(c.hand), c.hand.n_contacts)
        return remedies(c.hand, at.q[0], sf.velocity_joints,
                        at.thetadot[0, list(sf.velocity_joints)], c.trajectory.mode, lo, hi,
                        model)
    except (DegenerateError, InputError):
        return ()


def _nearest_failure(rejections: list[Rejection], depth: int) -> Rejection | None:
    """The failure to report with a partial plan: among the children of its last node (else
    all), one with a diagnosis that got furthest along its segment and, among those, the one
    closest to working (the widest friction interval that would work there)."""
    pool = [r for r in rejections if r.depth == depth] or rejections
    if not pool:
        return None

    def key(r: Rejection) -> tuple[bool, int, float]:
        sf = r.shortfall
        if sf is None:
            return (False, -1, -math.inf)
        widest = -math.inf if sf.widest_mu is None else float(np.sum(sf.widest_mu[1]))
        return (True, sf.index, widest)

    return max(pool, key=key)


def _what(root: Hand, c: _Child) -> str:
    """A tried child in plain words: what it releases and drives, which way the workpiece
    moves, in which mode and how it ends."""
    tr = c.trajectory
    rel = ", ".join(contact_words(root, r) for r in c.released)
    return (f"{'release ' + rel + ' and ' if rel else ''}drive "
            f"{drive_words(root, c.drive, c.speed)}: the workpiece "
            f"{motion_words(tr.q[0], tr.q[-1], root.length_scale)} in {tr.mode}; it ends at "
            f"t = {tr.event.t:.3g} s ({tr.event.kind}): {tr.event.detail}")
