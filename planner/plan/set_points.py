"""Points of a plan's uncertainty set, and the plan as it is at one of them (eqs. 2, 13-32).

A plan guaranteed over a mass / centre-of-mass / contact-position set
(:class:`planner.model.load_set.LoadSet`; docs/planning.md, "Uncertainty beyond friction",
"Contact positions") is validated by running it at points of that set (docs/planning.md,
"Validating at points of the set"):

* the set is described by its **axes** (:func:`plan_axes`): one interval per scalar the set lets
  vary, with its nominal value -- the workpiece's mass ``m`` [kg], the two body-frame
  coordinates of its centre of mass [m] (:func:`set_axes`), and the offset ``s<k>`` [m] of each
  contact that may move along its feature (:func:`contact_axes`).  Every other function here
  iterates over the axes;
* the **corners** are every combination of the axes' ends (an axis of zero width gives one
  value; :func:`corner_count`), the **centre** is every axis at its midpoint, and an
  **outside** point pushes one axis's end out by ``step`` times its half-width, the other axes
  at their midpoints (:func:`set_points`);
* :func:`plan_at` is the plan run at a point: every segment's hand with that mass, centre of
  mass and the load scaled with the mass (the load is proportional to the mass, as the set
  assumes), its workpiece vertices and fingertips moved to the contact offsets
  (:mod:`planner.plan.contact_moves`: the hand *is* the moved geometry) and then its waypoints
  on the moved body's path (:func:`planner.plan.contact_moves.moved_path`), and every
  waypoint's ``predicted`` modes *recomputed by the planner there* (eqs. 13-32 at the point's
  geometry and load, the run's friction and the waypoint's commands;
  :func:`planner.plan.partition.predicted_modes`) -- never copied from the plan.

Units: kg, m (body frame), N.
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.load_set import LoadSet
from planner.plan.contact_moves import (
    contact_union,
    moved_hand_data,
    moved_path,
    moves,
    offset_values,
)
from planner.plan.load_margins import plan_load_set
from planner.plan.model import Plan, Segment
from planner.plan.partition import predicted_modes

#: The kinds of point :func:`set_points` draws (``--set`` of ``qsplan validate``).
POINT_KINDS = ("corners", "centre", "outside")
#: How far past the set an outside point lies, in half-widths of its axis (``--outside``).
OUTSIDE_STEP = 0.25


@dataclass(frozen=True)
class SetAxis:
    """One scalar the set lets vary: ``key`` (short, as in point names: ``m``, ``cx``,
    ``cy``), ``name`` in words, its ``unit``, the interval ``lo <= nominal <= hi``."""

    key: str
    name: str
    unit: str
    lo: float
    hi: float
    nominal: float

    @property
    def mid(self) -> float:
        return 0.5 * (self.lo + self.hi)

    @property
    def half(self) -> float:
        return 0.5 * (self.hi - self.lo)


def set_axes(load_set: LoadSet) -> tuple[SetAxis, ...]:
    """The axes of ``load_set``: the mass interval [kg], then the centre-of-mass box's x and y
    intervals [m, body frame]."""
    (ax, bx), (ay, by) = load_set.com
    cx, cy = load_set.nominal_com
    return (SetAxis("m", "mass", "kg", *load_set.mass, load_set.nominal_mass),
            SetAxis("cx", "centre of mass x", "m", ax, bx, cx),
            SetAxis("cy", "centre of mass y", "m", ay, by, cy))


def contact_axes(plan: Plan) -> tuple[SetAxis, ...]:
    """One axis per contact of the plan's union that may move along its feature
    (:func:`planner.plan.contact_moves.contact_union`): key ``s<k>`` (``k`` the contact's
    number in the run, ``c<k>``), the interval ``[-half, half]`` [m] around 0."""
    return tuple(SetAxis(f"s{u.index + 1}", f"contact {u.index + 1} position ({u.words})", "m",
                         -u.half, u.half, 0.0)
                 for u in contact_union(plan) if u.half > 0)


def plan_axes(plan: Plan) -> tuple[SetAxis, ...]:
    """Every axis of ``plan``'s set: :func:`set_axes` of its hand's load set, then
    :func:`contact_axes`; none when its hand has no ``uncertainty`` section."""
    ls = plan_load_set(plan)
    return () if ls is None else set_axes(ls) + contact_axes(plan)


def corner_count(axes: Sequence[SetAxis]) -> int:
    """How many corners :func:`set_points` draws: the product of the axes' end counts (2 for
    an axis of non-zero width, 1 otherwise)."""
    return int(np.prod([2 if a.hi > a.lo else 1 for a in axes]))


@dataclass(frozen=True)
class SetPoint:
    """One point of (or just outside) the set: ``name`` (``centre``, ``m+cx-cy+`` for a corner:
    each varying axis at its upper ``+`` or lower ``-`` end, ``out-m+`` for the mass pushed
    above its interval), ``kind`` (``corner``, ``centre``, ``outside``), ``values`` one per axis
    of :func:`set_axes` (their units), ``inside`` whether it belongs to the set."""

    name: str
    kind: str
    values: tuple[float, ...]
    inside: bool

    def to_dict(self, axes: Sequence[SetAxis]) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "inside": self.inside,
                "values": {a.key: v for a, v in zip(axes, self.values)}}

    def words(self, axes: Sequence[SetAxis]) -> str:
        """``m=0.11 kg cx=22 mm cy=16.5 mm`` (lengths in mm)."""
        return " ".join(f"{a.key}={1000 * v:.4g} mm" if a.unit == "m" else
                        f"{a.key}={v:.4g} {a.unit}" for a, v in zip(axes, self.values))


def parse_kinds(text: str) -> tuple[str, ...]:
    """``"corners,centre"``, ``"all"`` (every kind) or ``"none"`` -> the kinds, in
    :data:`POINT_KINDS` order; :class:`InputError` naming what came otherwise."""
    words = [w.strip() for w in str(text).split(",")]
    if words == ["none"]:
        return ()
    if words == ["all"]:
        return POINT_KINDS
    bad = [w for w in words if w not in POINT_KINDS]
    if bad or not words:
        raise InputError(f"--set: expected 'none', 'all' or comma-separated kinds of "
                         f"{', '.join(POINT_KINDS)}, got {text!r}")
    return tuple(k for k in POINT_KINDS if k in words)


def set_points(axes: Sequence[SetAxis], kinds: Sequence[str],
               step: float = OUTSIDE_STEP) -> tuple[SetPoint, ...]:
    """The points of ``kinds`` (module docstring); ``step`` > 0 half-widths past an end for an
    outside point (an axis of zero width has none; a mass pushed to ``<= 0`` is left out)."""
    if not (np.isfinite(step) and step > 0):
        raise InputError(f"--outside: expected a finite step > 0 (in half-widths of each "
                         f"axis), got {step!r}")
    out: list[SetPoint] = []
    wide = [a for a in axes if a.hi > a.lo]
    if "corners" in kinds:
        ends = [(a.lo, a.hi) if a.hi > a.lo else (a.lo,) for a in axes]
        for vals in itertools.product(*ends):
            name = "".join(f"{a.key}{'+' if v == a.hi else '-'}" for a, v in zip(axes, vals)
                           if a.hi > a.lo) or "nominal"
            out.append(SetPoint(name, "corner", tuple(float(v) for v in vals), True))
    if "centre" in kinds:
        out.append(SetPoint("centre", "centre", tuple(a.mid for a in axes), True))
    if "outside" in kinds:
        for a in wide:
            for sign, end in (("+", a.hi + step * a.half), ("-", a.lo - step * a.half)):
                if abs(end) <= 1e-12 * (abs(a.lo) + abs(a.hi)):
                    end = 0.0  # rounding of an end that lands on zero
                if a.key == "m" and not end > 0:
                    continue
                vals = tuple(end if b is a else b.mid for b in axes)
                out.append(SetPoint(f"out-{a.key}{sign}", "outside", vals, False))
    return tuple(out)


def hand_data_at(hand: Mapping[str, Any], axes: Sequence[SetAxis],
                 values: Sequence[float]) -> dict[str, Any]:
    """The hand-file content ``hand`` at the point ``values`` (one per axis of
    :func:`set_axes`): ``workpiece.mass``, ``workpiece.com`` and ``load.force`` times
    ``m / m0`` (the load is proportional to the mass); its ``uncertainty`` section is dropped
    (the point is a nominal workpiece)."""
    at = {a.key: float(v) for a, v in zip(axes, values)}
    d = copy.deepcopy(dict(hand))
    d.pop("uncertainty", None)
    wp = d["workpiece"]
    m0 = next(a.nominal for a in axes if a.key == "m")
    wp["mass"] = at["m"]
    wp["com"] = [at["cx"], at["cy"]]
    if "load" in d and "force" in d["load"]:
        d["load"]["force"] = [float(f) * at["m"] / m0 for f in d["load"]["force"]]
    return d


def segment_at(seg: Segment, axes: Sequence[SetAxis], values: Sequence[float],
               mu: Any, geometry: tuple[Mapping[int, Any], Mapping[int, Any]] = ({}, {})
               ) -> Segment:
    """``seg`` at the point ``values`` (:func:`hand_data_at`), its workpiece vertices and
    finger tips moved by ``geometry`` (:func:`planner.plan.contact_moves.moves`), its waypoints
    on the moved body's path -- ending, with the segment's ``event``, at an event that ends the
    motion there before the planned end (:func:`planner.plan.contact_moves.moved_path`) -- and
    every waypoint's ``predicted`` recomputed there at friction ``mu``
    (:func:`planner.plan.partition.predicted_modes`)."""
    data = moved_hand_data(hand_data_at(seg.hand, axes, values), *geometry)
    moved = replace(seg, hand=data, regions=(), shortfall=None)
    hand, q0 = moved.hand_model
    V = seg.velocity_joints
    wps = seg.waypoints
    if any(np.any(np.asarray(m) != 0.0) for part in geometry for m in part.values()):
        path = moved_path(hand, np.asarray(q0, dtype=float), seg)
        wps = tuple(replace(w, t=float(t), pose=(float(q[0]), float(q[1]), float(q[2])),
                            angles=tuple(float(x) for x in q[3:]))
                    for w, t, q in zip(wps, path.t, path.q))
        if path.event is not None:  # the motion ends early here: so does the segment
            moved = replace(moved, event=path.event)
    wps = tuple(replace(w, predicted=predicted_modes(hand, w.q, V, w.velocity_commands,
                                                     w.torque_commands, (mu,)))
                for w in wps)
    return replace(moved, waypoints=wps)


def plan_at(plan: Plan, axes: Sequence[SetAxis], point: SetPoint,
            mus: Sequence[Any]) -> Plan:
    """``plan`` at ``point`` (module docstring); ``mus`` per segment its friction (one
    coefficient or one per contact of the segment)."""
    if len(mus) != len(plan.segments):
        raise InputError(f"mus: expected {len(plan.segments)} (one per segment), got "
                         f"{len(mus)}")
    if len(point.values) != len(axes):
        raise InputError(f"point: expected {len(axes)} values (one per axis), got "
                         f"{len(point.values)}")
    geometry = moves(plan, offset_values([a.key for a in axes], point.values))
    segs = tuple(segment_at(s, axes, point.values, mu, geometry)
                 for s, mu in zip(plan.segments, mus))
    return replace(plan, segments=segs,
                   hand=moved_hand_data(hand_data_at(plan.hand, axes, point.values), *geometry))


def claim_shares(plan: Plan) -> tuple[tuple[float, float], ...]:
    """Per segment ``(only, absent)``: the fractions of its duration whose hold intervals have
    the claim as the only predicted mode, and have it not predicted at all (each waypoint's
    ``predicted`` held to the next waypoint; the last waypoint holds nothing)."""
    out = []
    for seg in plan.segments:
        t = np.array([w.t for w in seg.waypoints], dtype=float)
        dt = np.diff(t)
        total = float(dt.sum())
        if not total > 0:
            out.append((0.0, 0.0))
            continue
        only = sum(d for d, w in zip(dt, seg.waypoints) if tuple(w.predicted) == (seg.claim,))
        absent = sum(d for d, w in zip(dt, seg.waypoints) if seg.claim not in w.predicted)
        out.append((float(only / total), float(absent / total)))
    return tuple(out)
