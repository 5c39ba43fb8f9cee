"""The segment planner: one quasistatic segment of any hand, any number of effort joints
(Sections 3.2 and 5.2).

:func:`plan_segment` is the one planner entry point for a segment:

1. integrate the quasistatic motion of the desired mode with the driven joints at their rates
   (:func:`planner.plan.trajectory.integrate_segment`) -- or take a given trajectory;
2. for every control partition (:func:`planner.plan.partition.control_partitions`: ``p = k - 3``
   effort-controlled joints, conditions 29-32), space the waypoints
   (:mod:`planner.plan.spacing`; or evenly, when a count is given) and find at each the efforts
   that guarantee the mode and exclude every rival over the friction set (eq. 28;
   :func:`planner.plan.partition.guaranteed_at`).  A partition is usable when every waypoint
   has them; among usable partitions the one with the largest worst relative margin
   (:func:`planner.plan.partition.relative_margin`) is used, on a tie the one that
   velocity-controls the driven joints;
3. choose the commands (:mod:`planner.plan.commands`: the policies of
   :mod:`planner.plan.policies` -- ``smooth`` by default -- or the negative control
   ``rival:MODE``, inside the hand file's joint limits) and, with one effort joint, the band
   curves of Figures 10-13 (:mod:`planner.plan.curves`).

The result is a :class:`planner.plan.model.Segment`.  With ``partial=True`` a segment whose
guarantee fails part-way stops before the first waypoint without one and says where and why
(:class:`Shortfall`, ``Segment.shortfall``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.files.hand_limits import hand_limits
from planner.model.hand import Hand
from planner.model.validation import friction_interval
from planner.plan.commands import check_policy, effort_commands
from planner.plan.curves import band_curves, bands_at_ends
from planner.plan.model import Event, Segment, Shortfall, segment_hand
from planner.plan.partition import (
    Guaranteed,
    control_partitions,
    guaranteed_at,
    mode_rows,
    relative_margin,
)
from planner.plan.policies import DEFAULT_POLICY
from planner.plan.polytope import empty_region
from planner.plan.spacing import Spacing, adaptive, joint_travel, uniform
from planner.plan.task_contacts import contact_dict
from planner.plan.trajectory import Drive, Speed, Trajectory, integrate_segment
from planner.plan.wording import contact_label, joint_words


class NoRegionError(DegenerateError):
    """A partial segment asked for, but not even its first waypoint has a guaranteed set:
    ``shortfall`` says why there (:class:`Shortfall`)."""

    def __init__(self, message: str, shortfall: Shortfall) -> None:
        super().__init__(message)
        self.shortfall = shortfall


@dataclass(frozen=True, eq=False)
class _Partition:
    """One partition along the segment: its waypoint ``times``, guaranteed sets ``gs``, the
    ``spacing`` report, ``failed`` (index of the first waypoint without a guaranteed set) and
    ``reason``; ``worst`` the worst relative margin (usable partitions)."""

    V: tuple[int, ...]
    E: tuple[int, ...]
    times: np.ndarray
    gs: list[Guaranteed]
    spacing: Spacing
    failed: int | None
    reason: str
    worst: float

    @property
    def usable(self) -> bool:
        return self.failed is None and not self.reason


class _States:
    """The trajectory at any set of times, each state computed once."""

    def __init__(self, hand: Hand, traj: Trajectory) -> None:
        self.hand, self.traj = hand, traj
        self.rows: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def __call__(self, ts: np.ndarray) -> Trajectory:
        new = [t for t in ts if float(t) not in self.rows]
        if new:
            at = self.traj.at_times(self.hand, np.array(new))
            for i, t in enumerate(new):
                self.rows[float(t)] = (at.q[i], at.qdot[i], at.thetadot[i])
        rows = [self.rows[float(t)] for t in ts]
        tr = self.traj
        return Trajectory(np.asarray(ts, dtype=float), np.array([r[0] for r in rows]),
                          np.array([r[1] for r in rows]), np.array([r[2] for r in rows]),
                          tr.mode, tr.drive, tr.speed, tr.event, tr.drives, tr.speeds)


def plan_segment(hand: Hand, q0: Any, *, data: Mapping[str, Any], drive: Drive, speed: Speed,
                 mode: str, mu: Any, model: str = "common", policy: str = DEFAULT_POLICY,
                 control: Sequence[int] | None = None, waypoints: int | None = None,
                 max_time: float = 60.0, steps: int = 200, partial: bool = False,
                 trajectory: Trajectory | None = None, curves: bool = False,
                 released: tuple[Mapping[str, Any], ...] = ()) -> Segment:
    """Plan one segment of ``hand`` from ``q0`` (module docstring).

    ``data``: the hand file content ``hand`` was read from (embedded in the segment with its
    contacts and start configuration); ``drive``/``speed``: the joint(s) that move the segment
    and their rates (rad/s or m/s); ``mode``: a family (``"4S"``) or label; ``mu``: the friction
    interval (``(lo, hi)``, one pair per contact, or a number); ``model``: ``common`` or
    ``independent``; ``control``: the velocity-controlled joints (default: every partition is
    tried); ``waypoints``: that many evenly spaced (default: :mod:`planner.plan.spacing`);
    ``max_time`` (s) and ``steps`` (RK4 steps over ``max_time``, also the initial waypoint
    spacing); ``trajectory``: an integrated trajectory from ``q0`` to use instead (the task
    planner's); ``curves``: store the band curves of Figures 10-13 (one effort joint);
    ``released``: the contacts of the previous segment this one opens.

    Raises :class:`DegenerateError` naming every partition's reason when none is usable --
    unless ``partial`` (then :class:`NoRegionError` only when not even the first waypoint has a
    guaranteed set) -- and :class:`InputError` for bad options."""
    check_policy(policy)
    if waypoints is not None and waypoints < 2:
        raise InputError(f"waypoints: expected >= 2, got {waypoints}")
    if not (isinstance(steps, int) and steps >= 1):
        raise InputError(f"steps: expected a positive integer, got {steps!r}")
    lo, hi = friction_interval(mu, hand.n_contacts)
    if model not in ("common", "independent"):
        raise InputError(f"model: expected 'common' or 'independent', got {model!r}")
    if model == "common" and not (np.all(lo == lo[0]) and np.all(hi == hi[0])):
        raise InputError("model 'common': expected one friction interval for every contact, "
                         f"got {[(float(a), float(b)) for a, b in zip(lo, hi)]}; use "
                         "'independent'")
    traj = trajectory if trajectory is not None else integrate_segment(
        hand, q0, drive=drive, speed=speed, mode=mode, max_time=max_time, steps=steps)
    parts_all = control_partitions(hand.n_joints, traj.mode,
                                   mode_rows(hand, traj.q[0], traj.mode))
    parts = parts_all
    if control is not None:
        parts = [(V, E) for V, E in parts if V == tuple(int(j) for j in control)]
        if not parts:
            raise InputError(f"control: expected velocity-controlled joints forming a partition "
                             f"of {traj.mode} (|tau_I| = {len(parts_all[0][1])}), got "
                             f"{tuple(control)}")
    states_at = _States(hand, traj)
    step = max_time / steps
    results = [_evaluate(hand, states_at, V, E, mu, model, waypoints, step)
               for V, E in parts]
    usable = [r for r in results if r.usable]
    shortfall = None
    if usable:
        # ties (e.g. one-sided bands everywhere) go to the partition that velocity-controls
        # the driven joints: its rate commands are the segment's own constant rates
        # a partition whose rates can be held further along the segment first (its spacing
        # ends it before they diverge: planner.plan.spacing, "Rates")
        best = max(usable, key=lambda r: (float(r.times[-1]), r.worst,
                                          set(traj.drives) <= set(r.V)))
        times, gs = best.times, best.gs
    else:
        why = "; ".join(f"{_partition_words(hand, r.V)}: {r.reason}" for r in results)
        furthest = max(results, key=lambda r: (r.failed or 0))
        good = furthest.failed or 0
        msg = f"no control partition guarantees {traj.mode}: {why}"
        if not partial:
            raise DegenerateError(msg)
        sf = _shortfall(hand, states_at(furthest.times), furthest, good, lo, hi, model)
        if good == 0:
            raise NoRegionError(msg, sf)
        best, shortfall = furthest, sf
        times, gs = furthest.times[:good], furthest.gs[:good]
        if good < 2:  # one waypoint cannot hold a command: keep two, the second at the stop
            raise NoRegionError(msg, sf)
    states = states_at(times)
    at_lo = at_hi = None
    one = len(best.E) == 1
    if one and (curves or policy.startswith("rival:")):
        at_lo, at_hi = bands_at_ends(hand, states, best.V, lo, hi)
    wps, regions, changes = effort_commands(hand, states, best.V, gs, policy, (lo, hi), at_hi,
                                            hand_limits(data, hand.joint_names()))
    extra: dict[str, Any] = {"spacing": best.spacing.to_dict(), "commands": changes}
    if one and curves and at_lo is not None and at_hi is not None:
        extra["curves"] = band_curves(states, gs, at_lo, at_hi, lo, hi)
    notes = "; ".join([_choice_words(hand, best, results),
                       best.spacing.words(float(times[-1]))])
    return Segment(
        claim=traj.mode,
        control=tuple("velocity" if j in best.V else "effort" for j in range(hand.n_joints)),
        waypoints=tuple(wps),
        hand=segment_hand(data, [contact_dict(hand, c) for c in hand.contacts], states.q[0],
                          traj.mode),
        mu_intervals=tuple((float(a), float(b)) for a, b in zip(lo, hi)),
        event=traj.event if best.spacing.ended is None else Event(
            "mode change", best.spacing.ended.words(hand, traj.event),
            best.spacing.ended.t),
        released=tuple(released), policy=policy,
        exact=all(r.exact for r in regions), notes=notes, extra=extra,
        regions=regions, shortfall=shortfall)


def _evaluate(hand: Hand, states_at: _States, V: tuple[int, ...], E: tuple[int, ...], mu: Any,
              model: str, waypoints: int | None, step: float) -> _Partition:
    """One partition along the segment (module docstring, step 2)."""
    traj = states_at.traj
    reason = ""

    def evaluate(k: int, states: Trajectory) -> Guaranteed:
        nonlocal reason
        rates = states.thetadot[k, list(V)]
        t = float(states.t[k])
        if np.all(np.abs(rates) <= 1e-12 * max(1.0, *np.abs(traj.speeds))):
            reason = f"no velocity-controlled joint moves at t = {t:.3g} s"
        else:
            try:
                gd = guaranteed_at(hand, states.q[k], V, rates, traj.mode, mu, model)
            except DegenerateError as exc:
                reason = f"at t = {t:.3g} s: {exc}"
            else:
                if not gd.empty:
                    return gd
                reason = f"no guaranteed effort at t = {t:.3g} s: {gd.reason()}"
        return Guaranteed(empty_region(traj.mode, len(E), E, {"reason": reason}))

    travel = joint_travel(hand, traj)
    if waypoints is None:
        times, gs, spacing, failed = adaptive(hand, states_at, V, evaluate, traj.duration, step,
                                              travel)
    else:
        times, gs, spacing, failed = uniform(
            hand, states_at(np.linspace(0.0, traj.duration, waypoints)), V, evaluate, travel,
            states_at)
    if failed is None and spacing.ended is not None and len(times) < 2:
        failed, reason = 0, spacing.ended.words(hand, traj.event)
    worst = min((relative_margin(g) for g in gs), default=-math.inf) if failed is None else (
        -math.inf)
    return _Partition(V, E, times, gs, spacing, failed, reason if failed is not None else "",
                      worst)


def _partition_words(hand: Hand, V: tuple[int, ...]) -> str:
    names = ", ".join(joint_words(hand, j) for j in V) or "no joint"
    return f"with {names} velocity-controlled"


def _choice_words(hand: Hand, best: _Partition, results: list[_Partition]) -> str:
    """The partition used and why the others were not (a plan's notes)."""
    eff = ", ".join(joint_words(hand, j) for j in best.E) or "no joint"
    tried = "; ".join(f"{_partition_words(hand, r.V)}: "
                      + (f"usable, worst relative margin {r.worst:.3g}" if r.usable else r.reason)
                      for r in results)
    return (f"velocity-controlled: {', '.join(joint_words(hand, j) for j in best.V)}; "
            f"effort-controlled: {eff}; partitions tried: {tried}")


def remedies(hand: Hand, q: np.ndarray, V: tuple[int, ...], rates: np.ndarray, mode: str,
             lo: np.ndarray, hi: np.ndarray, model: str, steps: int = 10) -> tuple[str, ...]:
    """What would give a guaranteed set at ``q`` where the friction box ``[lo, hi]`` (one pair
    per contact) has none, in plain words: the friction interval with the same upper ends and
    the lowest lower ends that works (a sticking contact that needs more friction), and per
    contact (model ``independent``) the lowest lower end that works with the others unchanged,
    naming the contact
    (bisection, ``steps`` halvings; the guaranteed set only grows as the box shrinks).  Empty
    when even the upper ends alone give no set."""
    def works(a: np.ndarray, b: np.ndarray) -> bool:
        return not guaranteed_at(hand, q, V, rates, mode, np.stack([a, b], 1), model).empty

    if np.all(lo == hi) or not works(hi, hi):
        return ()
    out = []
    a, b = 0.0, 1.0  # fraction of the way from lo to hi of the raised lower ends
    for _ in range(steps):
        mid = 0.5 * (a + b)
        a, b = (a, mid) if works(lo + mid * (hi - lo), hi) else (mid, b)
    new_lo = lo + b * (hi - lo)
    out.append("friction at least " + ", ".join(
        f"{x:.3g}" for x in (new_lo[:1] if len(set(new_lo.tolist())) == 1 else new_lo))
        + " (raised lower ends of the friction interval) would give a guaranteed set")
    for i in np.flatnonzero(lo < hi) if model == "independent" else ():
        top = lo.copy()
        top[i] = hi[i]
        if not works(top, hi):
            continue
        a, b = 0.0, 1.0
        for _ in range(steps):
            mid = 0.5 * (a + b)
            trial = lo.copy()
            trial[i] = lo[i] + mid * (hi[i] - lo[i])
            a, b = (a, mid) if works(trial, hi) else (mid, b)
        need = lo[i] + b * (hi[i] - lo[i])
        out.append(f"{contact_label(hand, int(i))} needs friction of at least {need:.3g} "
                   f"(its interval starts at {lo[i]:.3g})")
    return tuple(out)


def _shortfall(hand: Hand, states: Trajectory, part: _Partition, k: int, lo: np.ndarray,
               hi: np.ndarray, model: str, steps: int = 12) -> Shortfall:
    """Diagnosis at waypoint ``k`` (the first without a guaranteed set) and the widest friction
    interval ``[lo, lo + s (hi - lo)]`` that still has one (bisection on ``s``; the set only
    grows as the box shrinks, so the search is monotone)."""
    V = part.V
    q, rates = states.q[k], states.thetadot[k, list(V)]
    reg = guaranteed_at(hand, q, V, rates, states.mode, np.stack([lo, hi], 1), model).region
    diag = reg.diagnosis

    def works(frac: float) -> bool:
        top = lo + frac * (hi - lo)
        return not guaranteed_at(hand, q, V, rates, states.mode, np.stack([lo, top], 1),
                                 model).empty

    widest = None
    if works(0.0):
        a, b = 0.0, 1.0
        for _ in range(steps):
            mid = 0.5 * (a + b)
            a, b = (mid, b) if works(mid) else (a, mid)
        widest = (tuple(float(x) for x in lo), tuple(float(x) for x in lo + a * (hi - lo)))
    return Shortfall(k, float(states.t[k]), V, str(diag.get("reason", part.reason)),
                     diag.get("rival"), tuple(tuple(m) for m in diag.get("mu", [])), widest)
