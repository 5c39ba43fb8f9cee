"""What each uncertainty costs: the guaranteed efforts of a plan's binding waypoint as one axis of
its uncertainty grows, the others as planned (eqs. 2, 26, 28; docs/planning.md, "What each
uncertainty costs").

Axes: the workpiece's **mass** (``m0 +- d`` [kg]), its **centre of mass** (``c0 +- d`` [m] in
both body-frame coordinates; :meth:`planner.model.load_set.LoadSet.widened`) and **friction**
(each contact's interval scaled about its centre to ``w`` times the plan's width -- a point:
``w`` times :data:`DEFAULT_FRICTION_WIDTH` -- cut at 0; its size is the widest contact's width
after the cut).
Sizes: ``multiples`` of a reference -- the plan's own half-width of the axis (mass, centre of
mass: the larger distance from the nominal to an end of the set) or its friction box, or, for an
axis the plan keeps at a point, :data:`DEFAULT_MASS_FRACTION` of the nominal mass and
:data:`DEFAULT_COM_FRACTION` of the workpiece's size.

At each size the planner's exact functions give the result, nothing is sampled: with one effort
joint the claim's guaranteed band and the guaranteed pieces (the band minus every rival's
possible set; :func:`planner.plan.guarantee.guarantee` over the vertex loads,
:func:`planner.plan.load_bounds.load_bands`); with several the guaranteed region's radius (the
Chebyshev radius of :func:`planner.plan.polytope.torque_region`), the plan's contact-offset box
kept as planned (:func:`planner.plan.offset_bounds.offset_box`; guaranteed with one effort
joint only, as the planner does; growing it is not one of the axes).  The waypoint is the one with
the smallest margin relative to its command's size (the likeliest to bind).  A size at which a
stage of the planner fails (:class:`DegenerateError`) shows nothing guaranteed, marked inexact.

Units: efforts in N m (revolute) or N (prismatic); sizes in kg, m, and friction (no unit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.load_set import LoadSet, point_set
from planner.plan.guarantee import guarantee
from planner.plan.intervals import EMPTY, Interval
from planner.plan.model import Plan
from planner.plan.offset_bounds import offset_box
from planner.plan.partition import joint_inputs
from planner.plan.polytope import torque_region

#: Reference half-width of a mass the plan keeps at a point, as a fraction of the nominal mass.
DEFAULT_MASS_FRACTION = 0.1
#: Reference half-width of a centre of mass the plan keeps at a point, as a fraction of the
#: workpiece's size (``Hand.length_scale``).
DEFAULT_COM_FRACTION = 0.05
#: Reference width of a friction coefficient the plan keeps at a point.
DEFAULT_FRICTION_WIDTH = 0.1
#: The sizes drawn, as multiples of each axis's reference.
MULTIPLES = (0.0, 0.5, 1.0, 1.5, 2.0)
AXES = ("mass", "com", "friction")


@dataclass(frozen=True)
class CostPoint:
    """One size of one axis: ``size`` (kg, m or friction width), ``band`` the claim's guaranteed
    band (one effort joint; EMPTY otherwise), ``pieces`` the guaranteed efforts (band minus the
    rivals), ``radius`` the guaranteed region's Chebyshev radius (any number of effort joints;
    ``-inf``: empty) and ``exact`` as the planner says."""

    size: float
    band: Interval
    pieces: tuple[Interval, ...]
    radius: float
    exact: bool

    def to_dict(self) -> dict[str, Any]:
        def end(x: float) -> float | None:
            return x if math.isfinite(x) else None
        return {"size": self.size,
                "band": None if self.band.empty else [end(self.band.lower), end(self.band.upper)],
                "pieces": [[end(p.lower), end(p.upper)] for p in self.pieces],
                "radius": end(self.radius), "exact": self.exact}


@dataclass(frozen=True)
class SetCost:
    """The binding waypoint (``segment``, ``waypoint`` indices, ``t`` [s], its ``command``
    ``(p,)``) and per axis of :data:`AXES` its ``unit`` and :class:`CostPoint` per size."""

    segment: int
    waypoint: int
    t: float
    claim: str
    effort_joints: tuple[int, ...]
    command: tuple[float, ...]
    units: dict[str, str]
    curves: dict[str, tuple[CostPoint, ...]]

    def to_dict(self) -> dict[str, Any]:
        return {"segment": self.segment, "waypoint": self.waypoint, "t": self.t,
                "claim": self.claim, "effort_joints": list(self.effort_joints),
                "command": list(self.command), "units": dict(self.units),
                "curves": {k: [c.to_dict() for c in v] for k, v in self.curves.items()}}


def binding_waypoint(plan: Plan) -> tuple[int, int]:
    """``(segment, waypoint)`` of the smallest margin relative to its command's size."""
    best, at = math.inf, (0, 0)
    for i, seg in enumerate(plan.segments):
        for k, w in enumerate(seg.waypoints):
            size = float(np.linalg.norm(w.torque_commands)) if len(w.torque_commands) else 1.0
            rel = w.margin / max(size, 1e-300)
            if rel < best:
                best, at = rel, (i, k)
    return at


def widened_friction(intervals: Any, multiple: float,
                     point_width: float = 0.1) -> list[tuple[float, float]]:
    """Each ``(lo, hi)`` scaled about its centre to ``multiple`` times its width (a point:
    ``multiple * point_width`` wide), cut at 0."""
    out = []
    for lo, hi in intervals:
        width = hi - lo if hi > lo else point_width
        c, h = 0.5 * (lo + hi), 0.5 * width * multiple
        out.append((max(c - h, 0.0), c + h))
    return out


def plan_sizes(plan: Plan) -> dict[str, float]:
    """Per axis the plan's own size: the larger distance from the nominal mass or centre of
    mass to an end of its set, the widest friction interval of its first segment (0: a
    point)."""
    hand = plan.segments[0].hand_model[0]
    ls = hand.load_set or point_set(hand.mass, hand.com)
    m0, c0 = ls.nominal_mass, ls.nominal_com
    return {"mass": max(m0 - ls.mass[0], ls.mass[1] - m0),
            "com": max(max(c0[k] - ls.com[k][0], ls.com[k][1] - c0[k]) for k in range(2)),
            "friction": max((hi - lo for lo, hi in plan.segments[0].mu_intervals),
                            default=0.0)}


def reference_sizes(plan: Plan) -> dict[str, float]:
    """Per axis the size the multiples scale (module docstring): the plan's own
    (:func:`plan_sizes`), or a default for an axis it keeps at a point."""
    hand = plan.segments[0].hand_model[0]
    own = plan_sizes(plan)
    default = {"mass": DEFAULT_MASS_FRACTION * hand.mass,
               "com": DEFAULT_COM_FRACTION * hand.length_scale,
               "friction": DEFAULT_FRICTION_WIDTH}
    return {k: own[k] if own[k] > 0 else default[k] for k in own}


def cost_point(plan: Plan, seg_i: int, wp_i: int, load_set: LoadSet, mu: Any,
               size: float) -> CostPoint:
    """The guaranteed efforts at one waypoint for ``load_set`` and friction ``mu``."""
    seg = plan.segments[seg_i]
    w = seg.waypoints[wp_i]
    hand = replace(seg.hand_model[0], load_set=load_set)
    joints = joint_inputs(hand, seg.velocity_joints, w.velocity_commands)
    system = hand.system(w.q, 0.0, joints)
    loads = hand.load_vertices(w.q)
    try:
        box = offset_box(hand, w.q, joints)  # the contact positions' box (None: none)
        return _cost_point(plan, seg, system, loads, mu, size, box)
    except DegenerateError:  # a stage fails at this size: nothing guaranteed that it can show
        return CostPoint(size, EMPTY, (), -math.inf, False)


def _cost_point(plan: Plan, seg: Any, system: Any, loads: Any, mu: Any,
                size: float, box: Any) -> CostPoint:
    if len(seg.effort_joints) == 1:
        g = guarantee(system, seg.claim, mu, model=plan.mu_model, loads=loads, box=box)
        band = g.claim_band.guaranteed if g.claim_band is not None else EMPTY
        widest = g.best()
        radius = (-math.inf if widest.empty else 0.5 * (widest.upper - widest.lower))
        return CostPoint(size, band, g.pieces, radius, g.exact)
    if box is not None:
        raise DegenerateError("contact offsets: guaranteed with one effort-controlled joint")
    reg = torque_region(system, seg.claim, mu, model=plan.mu_model, loads=loads)
    return CostPoint(size, EMPTY, (), reg.margin, reg.exact)


def set_cost(plan: Plan, multiples: tuple[float, ...] = MULTIPLES) -> SetCost:
    """The guaranteed efforts at the binding waypoint as each axis grows (module docstring)."""
    if not plan.segments:
        raise InputError("plan: expected at least one segment, got a plan without one")
    if not multiples or any(not (math.isfinite(x) and x >= 0) for x in multiples):
        raise InputError(f"multiples: expected finite sizes >= 0, got {multiples!r}")
    if not plan.segments[0].effort_joints and all(not s.effort_joints for s in plan.segments):
        raise InputError("plan: expected a segment with an effort-controlled joint (a torque "
                         "band or region to show), got none")
    seg_i, wp_i = binding_waypoint(plan)
    if not plan.segments[seg_i].effort_joints:
        seg_i = next(i for i, s in enumerate(plan.segments) if s.effort_joints)
        wp_i = 0
    seg = plan.segments[seg_i]
    hand = seg.hand_model[0]
    base = hand.load_set or point_set(hand.mass, hand.com)
    ref = reference_sizes(plan)
    mus = list(seg.mu_intervals)
    curves: dict[str, tuple[CostPoint, ...]] = {}
    for axis in AXES:
        pts = []
        for x in multiples:
            size = x * ref[axis]
            if axis == "friction":
                box = widened_friction(mus, x, DEFAULT_FRICTION_WIDTH)
                size = max(hi - lo for lo, hi in box)  # its width once cut at 0
                pts.append(cost_point(plan, seg_i, wp_i, base, box, size))
            else:
                pts.append(cost_point(plan, seg_i, wp_i, base.widened(axis, size), mus, size))
        curves[axis] = tuple(pts)
    w = seg.waypoints[wp_i]
    return SetCost(seg_i, wp_i, float(w.t), seg.claim, tuple(seg.effort_joints),
                   tuple(float(x) for x in w.torque_commands),
                   {"mass": "kg", "com": "m", "friction": ""}, curves)
