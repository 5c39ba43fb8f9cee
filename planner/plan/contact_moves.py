"""A plan's contact-position offsets made physical: the moved geometry a run at one point of the
set simulates, and the set's contact axes (eqs. 3, 5; docs/planning.md, "Validating at points of
the set").

The planner's offset ``s_i`` (:meth:`planner.model.hand.Hand.system` with ``offsets``;
:mod:`planner.plan.offset_bounds`) moves contact ``i``'s point by ``s_i t_i`` (``t_i =
rot90(n_i)``, world frame) at a configuration ``q`` and keeps its normal; ``W`` and ``J`` are
taken at the moved point.  Each contact kind has one body whose feature carries the point
(a vertex or a tip) and one whose straight feature carries the normal (a surface, a link side, a
workpiece edge).  Moving the point's carrier realizes the offset exactly at ``q``:

* ``palm``, ``surface``, ``side`` (a workpiece vertex on a straight feature): the workpiece
  vertex moves by ``R(phi)^T s_i t_i`` in the body frame.  The feature is untouched, the gap
  stays 0, the normal is the feature's; ``W``'s column is taken at the moved vertex and ``J``
  (a link side) at the link's material point there -- what ``offsets`` models.
* ``tip`` (a finger's rounded tip on a workpiece edge): the tip circle moves by ``s_i t_i``
  expressed in its last link's frame (the finger's ``tip_offset``); the edge is untouched, so
  the gap and the normal are kept, and the finger point at the contact is the link's material
  point at ``p + s_i t_i``, whose velocity is the chain's point Jacobian there (eq. 5).

Each contact's move is taken at its **reference configuration**: the planned start of the first
segment holding it (where a run places its sites).  There the moved hand's system without
offsets *is* the nominal hand's system with ``offsets = s`` (``W``, ``J``, load, hence every
mode and force; :func:`moved_hand_data`, tested).  At another configuration the moved feature
turns with its body: the point sits at ``s_i cos(d)`` along the feature and ``s_i sin(d)`` across
it (``d`` the angle the two bodies turned relative to each other since the reference), a gap the
run closes -- never further along the feature than ``|s_i|``.

A geometry move that would disturb another contact cannot realize the point, and is refused
(:class:`InputError` naming both contacts): two contacts on one workpiece vertex (moving it along
one feature moves it across the other), a vertex next to an edge that carries a tip (the edge
would turn), one finger's tip on two edges.

Units: m (offsets, body and link frames), rad.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.geometry import rot90
from planner.model.hand import Hand
from planner.model.hand_parts import rotation
from planner.plan.model import Event, Plan, Segment

#: Relative size (of the workpiece's extent) below which a moved point or normal counts as
#: where the offset puts it (floating-point rounding of the moves; the moves are exact).
MOVE_TOL = 1e-9


@dataclass(frozen=True)
class UnionContact:
    """One contact of the plan's contact union: ``index`` (0-based, the run's pair ``c<index+1>``
    numbering), ``contact`` its hand-file object, ``segment`` the first segment holding it and
    ``local`` its index there, ``half`` [m] its offset half-width (0: it does not move) and
    ``words`` (``vertex 1 on table``)."""

    index: int
    contact: Mapping[str, Any]
    segment: int
    local: int
    half: float
    words: str


def contact_words(hand: Hand, i: int) -> str:
    """``vertex 1 on table``, ``finger tip on edge 2``, ``vertex 0 on finger side``."""
    c = hand.contacts[i]
    if c.kind in ("palm", "surface"):
        return f"vertex {c.vertex} on {hand.body_name(c)}"
    if c.kind == "side":
        return f"vertex {c.vertex} on {hand.body_name(c)} side"
    return f"{hand.body_name(c)} tip on edge {c.edge}"


def contact_union(plan: Plan) -> tuple[UnionContact, ...]:
    """The plan's contacts, each once in order of first appearance (the union a run simulates,
    keyed by its hand-file object as :func:`sim.schedule.plan_layout` does), with its offset
    half-width from the first segment holding it (:meth:`Hand.contact_offsets`)."""
    keys: list[str] = []
    out: list[UnionContact] = []
    for k, seg in enumerate(plan.segments):
        hand = seg.hand_model[0]
        half = hand.contact_offsets()
        for i, c in enumerate(seg.contacts):
            key = json.dumps(c, sort_keys=True) if isinstance(c, Mapping) else repr(c)
            if key in keys:
                continue
            keys.append(key)
            out.append(UnionContact(len(out), c, k, i, 0.0 if half is None else float(half[i]),
                                    contact_words(hand, i)))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class PlacedContact:
    """One contact to move: ``hand`` and ``q`` its reference configuration (module docstring),
    ``local`` its index in ``hand``, ``number`` (1-based) and ``words`` as the run names it,
    ``s`` [m] its offset along ``t = rot90(n)``."""

    hand: Hand
    q: np.ndarray
    local: int
    number: int
    words: str
    s: float


def geometry_moves(placed: Sequence[PlacedContact]
                   ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """The geometry moves realizing every contact's offset (module docstring): ``(vertex ->
    (2,) body-frame displacement [m], finger -> (2,) tip displacement (along, across) in its
    last link's frame [m])``.  Refuses a move that disturbs another contact (two contacts on one
    vertex or one finger's tip, an edge carrying a tip turned, a polygon no longer convex) with
    an :class:`InputError` naming the contacts."""
    vert: dict[int, np.ndarray] = {}
    tips: dict[int, np.ndarray] = {}
    owner: dict[tuple[str, int], PlacedContact] = {}
    for u in placed:
        hand, q, s = u.hand, u.q, u.s
        c = hand.contacts[u.local]
        _p, n, _gap, _frac = hand.contact_frame(q, u.local)
        world = s * rot90(n)
        table = tips if c.kind == "tip" else vert
        if c.kind == "tip":
            _start, d = hand.links_at(q, c.finger)[-1]
            move, slot = np.array([world @ d, world @ rot90(d)]), ("finger", c.finger)
        else:
            move, slot = rotation(-float(q[2])) @ world, ("vertex", c.vertex)
        if slot in owner:
            other = owner[slot]
            if s != 0.0 or np.any(table[slot[1]] != 0.0):
                what = (f"workpiece vertex {c.vertex}" if slot[0] == "vertex"
                        else f"{hand.body_name(c)}'s tip")
                raise InputError(
                    f"contact positions: contacts {other.number} ({other.words}) and "
                    f"{u.number} ({u.words}) share {what}: moving it along one's feature "
                    "moves it off the other's, so this point of the set has no physical "
                    "geometry")
        owner[slot] = u
        table[slot[1]] = move
    if not placed:
        return vert, tips
    hand0 = placed[0].hand
    nv = len(hand0.vertices)
    V = hand0.vertices + np.array([vert.get(v, np.zeros(2)) for v in range(nv)])
    e = np.roll(V, -1, axis=0) - V
    e1 = np.roll(e, -1, axis=0)
    turn = e[:, 0] * e1[:, 1] - e[:, 1] * e1[:, 0]
    if np.any(turn <= 0):
        names = ", ".join(f"{u.number} ({u.words})" for u in placed
                          if u.s != 0.0 and u.hand.contacts[u.local].kind != "tip")
        raise InputError(f"contact positions: moving contacts {names} leaves the workpiece "
                         f"polygon not convex (a flat or clockwise turn at vertex "
                         f"{(int(np.argmax(turn <= 0)) + 1) % nv}), so this point of the set "
                         "has no physical geometry")
    for u in placed:                                    # an edge carrying a tip must not turn
        c = u.hand.contacts[u.local]
        if c.kind != "tip":
            continue
        a, b = c.edge, (c.edge + 1) % nv
        edge = hand0.vertices[b] - hand0.vertices[a]
        da, db = vert.get(a, np.zeros(2)), vert.get(b, np.zeros(2))
        turned = db - da
        if abs(float(edge[0] * turned[1] - edge[1] * turned[0])) > MOVE_TOL * float(edge @ edge):
            mover = owner[("vertex", a if np.any(da != 0.0) else b)]
            raise InputError(
                f"contact positions: moving contact {mover.number} ({mover.words}) turns "
                f"workpiece edge {c.edge}, on which contact {u.number} ({u.words}) lies, so "
                "this point of the set has no physical geometry")
    return vert, tips


def moves(plan: Plan, offsets: Mapping[int, float]
          ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """:func:`geometry_moves` for ``plan``'s contact union (:func:`contact_union`), each at the
    planned start of the first segment holding it; ``offsets`` union index -> ``s`` [m]."""
    placed = []
    for u in contact_union(plan):
        hand, q = plan.segments[u.segment].hand_model
        placed.append(PlacedContact(hand, np.asarray(q, dtype=float), u.local, u.index + 1,
                                    u.words, float(offsets.get(u.index, 0.0))))
    return geometry_moves(placed)


def moved_hand_data(hand: Mapping[str, Any], vert: Mapping[int, np.ndarray],
                    tips: Mapping[int, np.ndarray]) -> dict[str, Any]:
    """The hand-file content ``hand`` with the workpiece vertices and finger tips moved
    (:func:`moves`): ``workpiece.vertices[v] += vert[v]`` (body frame) and
    ``fingers[k].tip_offset += tips[k]`` (its last link's frame)."""
    d = copy.deepcopy(dict(hand))
    V = d["workpiece"]["vertices"]
    for v, dv in vert.items():
        V[v] = [float(V[v][0]) + float(dv[0]), float(V[v][1]) + float(dv[1])]
    for k, dt in tips.items():
        t0 = d["fingers"][k].get("tip_offset", [0.0, 0.0])
        d["fingers"][k]["tip_offset"] = [float(t0[0]) + float(dt[0]), float(t0[1]) + float(dt[1])]
    return d


def offset_values(keys: Sequence[str], values: Sequence[float]) -> dict[int, float]:
    """Union index -> offset [m] from a point's values on the axes ``keys`` (``s<index+1>``;
    the other keys ignored)."""
    return {int(k[1:]) - 1: float(v) for k, v in zip(keys, values)
            if k.startswith("s") and k[1:].isdigit()}


@dataclass(frozen=True, eq=False)
class MovedPath:
    """The moved body's path along a segment (:func:`moved_path`): ``t`` (n,) [s] the
    waypoints' times up to the motion's end, ``q`` (n, 3 + n_theta) the configurations there,
    and ``event`` the event that ends the motion before the segment's last waypoint (``None``
    when it runs to the end; then ``t`` is every waypoint's time)."""

    t: np.ndarray
    q: np.ndarray
    event: Event | None


def moved_path(hand: Hand, q0: np.ndarray, seg: Segment) -> MovedPath:
    """The configurations of ``seg``'s waypoints for the moved ``hand`` from its closed start
    ``q0``: the claim's quasistatic motion (eqs. 13-16, 23-25;
    :func:`planner.plan.trajectory.integrate_segment`) with the segment's velocity joints at
    their first waypoint's rates, read at the waypoints' times -- where the run's workpiece is
    expected, so the judge compares it with the moved body's path and not the nominal one's.

    An event that ends the motion before the last waypoint (a new contact, a contact running
    off its feature, the claim no longer kinematically admissible) ends the path there: the
    waypoints before it, then the event's time and state. At the point the segment ends at
    that event, as the planned segment ends at its own -- the claim says nothing of the
    motion after it (a box that meets the table earlier because its corner sits 2 mm
    further along it). Rates that change between waypoints are refused
    (:class:`InputError`)."""
    from planner.plan.trajectory import integrate_segment

    V = tuple(seg.velocity_joints)
    rates = np.array([w.velocity_commands for w in seg.waypoints], dtype=float)
    if rates.size and np.any(np.abs(rates - rates[0]) > 1e-12 * np.max(np.abs(rates[0]))):
        raise InputError("contact positions: expected a segment whose velocity joints keep "
                         "their rates (the moved body's path is integrated at them), got rates "
                         "that change between waypoints")
    t = np.array([w.t for w in seg.waypoints], dtype=float)
    if not V or len(t) < 2 or not t[-1] > 0:
        return MovedPath(t, np.array([w.q for w in seg.waypoints], dtype=float), None)
    traj = integrate_segment(hand, q0, drive=list(V), speed=[float(r) for r in rates[0]],
                             mode=seg.claim, max_time=float(t[-1]),
                             steps=max(8 * (len(t) - 1), 64))
    end = float(traj.t[-1])
    event = None
    if end < t[-1] * (1.0 - 1e-9):
        event = traj.event
        t = np.append(t[t < end * (1.0 - 1e-9)], end)
    q = np.array([[np.interp(tk, traj.t, traj.q[:, c]) for c in range(traj.q.shape[1])]
                  for tk in t], dtype=float)
    return MovedPath(t, q, event)
