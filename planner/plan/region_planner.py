"""Segment planner for any hand: control partition for any number of joints and torque regions.

Section 3.2 and 5.2 generalised.  A desired determinate mode with ``n_R`` rolling and ``n_S``
sliding contacts has ``k = 2 n_R + n_S`` contact unknowns; condition (29) asks
``3 <= k <= 3 + n_theta`` and condition (32) a square, non-singular ``Q_AI``, so exactly
``p = k - 3`` joints are effort-controlled (``tau_I``) and the other ``n_theta - p`` are
velocity-controlled (``zdot_II``, eq. 24).  :func:`control_partitions` lists every such choice;
for each, along the integrated segment (:func:`planner.plan.trajectory.integrate_segment`), the
velocity-controlled joints take the segment's joint rates and, per waypoint,
:func:`planner.plan.polytope.torque_region` gives the polytope of torques that guarantees the mode
and excludes every rival over the friction box (eq. 28; conditions 30-31 are checked by the
kinematic stage).  A partition is usable when every waypoint has a non-empty region; among
usable partitions the one with the largest worst relative margin is taken.

The command of waypoint ``j`` is held until waypoint ``j + 1``: it is the Chebyshev centre of the
intersection of both regions (of the region alone when they do not meet), and its margin the
radius of that ball.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.hand import Hand
from planner.model.validation import friction_interval
from planner.plan.polytope import TorqueRegion, chebyshev_centre, torque_region
from planner.plan.trajectory import Drive, Segment, Speed, integrate_segment


def mode_unknowns(label: str) -> int:
    """``k = 2 n_R + n_S`` of a mode label such as ``"S+1 R2 B3"`` (conditions 29, 32)."""
    parts = label.split()
    return sum(2 if t.startswith("R") else 1 if t.startswith("S") else 0 for t in parts)


def control_partitions(n_joints: int, label: str) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """Every ``(velocity joints, effort joints)`` split with ``|tau_I| = k - 3`` (eqs. 29, 32).

    Raises :class:`InputError` when condition (29) fails (``k < 3`` or ``k > 3 + n_theta``).
    """
    k = mode_unknowns(label)
    if not 3 <= k <= 3 + n_joints:
        raise InputError(f"mode {label}: condition (29) expected 3 <= 2 n_R + n_S <= 3 + "
                         f"n_theta = {3 + n_joints}, got {k}")
    p = k - 3
    out = []
    for E in itertools.combinations(range(n_joints), p):
        V = tuple(j for j in range(n_joints) if j not in E)
        out.append((V, tuple(E)))
    return out


@dataclass(frozen=True, eq=False)
class RegionWaypoint:
    """One waypoint: ``t`` s, ``q`` configuration, ``velocity_commands`` (rates of the
    velocity-controlled joints, rad/s or m/s), ``torque_command`` ``(p,)`` (efforts of the
    effort-controlled joints, N m or N), ``margin`` (radius of the ball of commands that keep
    the guarantee over the hold interval) and the waypoint's :class:`TorqueRegion`."""

    t: float
    q: np.ndarray
    velocity_commands: np.ndarray
    torque_command: np.ndarray
    margin: float
    region: TorqueRegion


@dataclass(frozen=True, eq=False)
class PartitionResult:
    """A control partition along a segment: ``velocity_joints``, ``effort_joints``, ``usable``,
    ``reason`` (when not: the waypoint and the region's diagnosis), ``worst_relative_margin``
    and the per-waypoint regions computed so far."""

    velocity_joints: tuple[int, ...]
    effort_joints: tuple[int, ...]
    usable: bool
    reason: str
    worst_relative_margin: float
    regions: tuple[TorqueRegion, ...]


@dataclass(frozen=True)
class Shortfall:
    """Where a partial plan stops: waypoint ``index`` at ``t`` (s), with ``velocity_joints``
    velocity-controlled; ``reason`` (the region's diagnosis: the covering ``rival`` and the
    friction points ``mu`` where it is feasible, when known) and ``widest_mu``: the widest
    friction interval ``(lo, hi')`` with the same lower ends (``hi'`` by bisection on a common
    scale of the upper ends) for which a region exists there, None when even ``lo`` fails."""

    index: int
    t: float
    velocity_joints: tuple[int, ...]
    reason: str
    rival: str | None
    mu: tuple[tuple[float, ...], ...]
    widest_mu: tuple[tuple[float, ...], tuple[float, ...]] | None


@dataclass(frozen=True, eq=False)
class RegionPlan:
    """A planned segment: ``segment`` (resampled), the chosen partition, ``waypoints``, every
    partition tried (``partitions``) and ``exact`` (every region exact, see
    :mod:`planner.plan.polytope`); ``mu_model`` the friction set the regions hold for:
    ``"common"`` (one coefficient for all contacts in the interval; one effort joint, today's
    band) or ``"box"`` (each contact's coefficient anywhere in its interval); ``shortfall``:
    for a partial plan, where and why it stops (:class:`Shortfall`)."""

    claim: str
    segment: Segment
    velocity_joints: tuple[int, ...]
    effort_joints: tuple[int, ...]
    waypoints: tuple[RegionWaypoint, ...]
    partitions: tuple[PartitionResult, ...]
    exact: bool
    mu_model: str = "box"
    shortfall: Shortfall | None = None

    @property
    def min_margin(self) -> float:
        return min(w.margin for w in self.waypoints)


class NoRegionError(DegenerateError):
    """A partial plan asked for, but not even the segment's first waypoint has a region:
    ``shortfall`` says why there (:class:`Shortfall`)."""

    def __init__(self, message: str, shortfall: Shortfall) -> None:
        super().__init__(message)
        self.shortfall = shortfall


def joint_inputs(hand: Hand, V: tuple[int, ...], rates: Any) -> list[dict[str, float]]:
    """Per joint ``{"velocity": rate}`` for ``V`` (rates in order) and ``{"effort": 0}`` else."""
    r = dict(zip(V, (float(x) for x in rates)))
    return [{"velocity": r[j]} if j in r else {"effort": 0.0} for j in range(hand.n_joints)]


def evaluate_partition_set(hand: Hand, seg: Segment, V: tuple[int, ...], E: tuple[int, ...],
                           mu: Any, model: str = "common") -> PartitionResult:
    """Torque regions along ``seg`` with the joints ``V`` velocity-controlled (Section 3.2)."""
    regions: list[TorqueRegion] = []
    worst = math.inf
    for k in range(len(seg.t)):
        rates = seg.thetadot[k, list(V)]
        if np.all(np.abs(rates) <= 1e-12 * max(1.0, *np.abs(seg.speeds))):
            return PartitionResult(V, E, False, f"no velocity-controlled joint moves at t = "
                                   f"{seg.t[k]:.3g} s", -math.inf, tuple(regions))
        system = hand.system(seg.q[k], 0.0, joint_inputs(hand, V, rates))
        try:
            reg = torque_region(system, seg.mode, mu, model=model)
        except DegenerateError as exc:
            return PartitionResult(V, E, False, str(exc), -math.inf, tuple(regions))
        regions.append(reg)
        if reg.empty:
            why = reg.diagnosis.get("reason", "empty region")
            return PartitionResult(V, E, False, f"no guaranteed torque at t = {seg.t[k]:.3g} s: "
                                   f"{why}", -math.inf, tuple(regions))
        size = float(np.linalg.norm(reg.centre)) if len(E) else 1.0
        worst = min(worst, reg.margin / max(size, 1e-300) if math.isfinite(reg.margin) else 1.0)
    return PartitionResult(V, E, True, "", worst, tuple(regions))


def plan_regions(hand: Hand, q0: Any, *, drive: Drive, speed: Speed, mode: str, mu: Any,
                 max_time: float = 60.0, steps: int = 200, waypoints: int = 41,
                 model: str = "common", control: tuple[int, ...] | None = None,
                 partial: bool = False, segment: Segment | None = None) -> RegionPlan:
    """Plan one segment of any hand (module docstring).  ``drive``/``speed``: the joints that
    move the segment and their rates; ``control``: the velocity-controlled joints (default:
    every partition of :func:`control_partitions` is tried).  Raises
    :class:`DegenerateError` naming every partition's reason when none is usable -- unless
    ``partial``: then the plan stops before the first waypoint without a region of the
    partition that got furthest, and says where and why (:attr:`RegionPlan.shortfall`).
    ``segment``: an already integrated segment from ``q0`` (e.g. the task planner's, ended at
    its goal); it is resampled at ``waypoints`` instead of integrating again."""
    lo, hi = friction_interval(mu, hand.n_contacts)
    if model == "common" and not (np.all(lo == lo[0]) and np.all(hi == hi[0])):
        model = "independent"  # per-contact intervals: the box
    if segment is None:
        segment = integrate_segment(hand, q0, drive=drive, speed=speed, mode=mode,
                                    max_time=max_time, steps=steps)
    seg = segment.resample(hand, waypoints)
    parts = control_partitions(hand.n_joints, seg.mode)
    if control is not None:
        parts = [(V, E) for V, E in parts if V == tuple(control)]
        if not parts:
            raise InputError(f"control: expected velocity-controlled joints forming a partition "
                             f"of {seg.mode} (|tau_I| = {mode_unknowns(seg.mode) - 3}), got "
                             f"{tuple(control)}")
    results = [evaluate_partition_set(hand, seg, V, E, mu, model) for V, E in parts]
    usable = [r for r in results if r.usable]
    shortfall = None
    if not usable:
        why = "; ".join(f"velocity joints {list(r.velocity_joints)}: {r.reason}"
                        for r in results)
        furthest = max(results, key=lambda r: sum(not g.empty for g in r.regions))
        good = [g for g in furthest.regions if not g.empty]
        if not partial:
            raise DegenerateError(f"no control partition guarantees {seg.mode}: {why}")
        if not good:
            raise NoRegionError(f"no control partition guarantees {seg.mode}: {why}",
                                _shortfall(hand, seg, furthest, 0, lo, hi, model))
        best = furthest
        shortfall = _shortfall(hand, seg, furthest, len(good), lo, hi, model)
        regs = tuple(good)
    else:
        best = max(usable, key=lambda r: r.worst_relative_margin)
        regs = best.regions
    V, E = best.velocity_joints, best.effort_joints
    wps = []
    for k, reg in enumerate(regs):
        nxt = regs[min(k + 1, len(regs) - 1)]
        centre, radius = chebyshev_centre(np.vstack([reg.A, nxt.A]),
                                          np.concatenate([reg.b, nxt.b]))
        if not radius > 0:
            centre, radius = reg.centre, reg.margin
        wps.append(RegionWaypoint(float(seg.t[k]), seg.q[k].copy(), seg.thetadot[k, list(V)],
                                  np.asarray(centre, dtype=float), float(radius), reg))
    return RegionPlan(seg.mode, seg, V, E, tuple(wps), tuple(results),
                      all(r.exact for r in regs),
                      "common" if model == "common" and len(E) == 1 else "box", shortfall)


def _shortfall(hand: Hand, seg: Segment, part: PartitionResult, k: int, lo: np.ndarray,
               hi: np.ndarray, model: str, steps: int = 12) -> Shortfall:
    """Diagnosis at waypoint ``k`` (the first without a region) and the widest friction
    interval ``[lo, lo + s (hi - lo)]`` that still has one (bisection on ``s``; the region
    only grows as the box shrinks, so the search is monotone)."""
    V = part.velocity_joints
    system = hand.system(seg.q[k], 0.0, joint_inputs(hand, V, seg.thetadot[k, list(V)]))
    reg = torque_region(system, seg.mode, np.stack([lo, hi], 1), model=model)
    diag = reg.diagnosis

    def works(frac: float) -> bool:
        top = lo + frac * (hi - lo)
        return not torque_region(system, seg.mode, np.stack([lo, top], 1), model=model).empty

    widest = None
    if works(0.0):
        a, b = 0.0, 1.0
        for _ in range(steps):
            mid = 0.5 * (a + b)
            a, b = (mid, b) if works(mid) else (a, mid)
        widest = (tuple(float(x) for x in lo), tuple(float(x) for x in lo + a * (hi - lo)))
    return Shortfall(k, float(seg.t[k]), V, str(diag.get("reason", part.reason)),
                     diag.get("rival"), tuple(tuple(m) for m in diag.get("mu", [])), widest)
