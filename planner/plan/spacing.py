"""Waypoint spacing of a planned segment (docs/planning.md, "Waypoint spacing").

A plan's commands are held from one waypoint to the next, and ``qsplan validate`` judges a
segment by the claimed mode on at least :data:`MODE_FRACTION` of its judged steps and the final
workpiece position within :data:`POSE_TOLERANCE_OF_TRAVEL` of its travel.  What the spacing
decides, and how it is chosen:

* **Position.** The closure that keeps the contacts touching determines the configuration from
  the velocity-controlled joints' coordinates (:meth:`planner.model.hand.Hand.close`; the
  mode's velocities are linear in their rates, eq. 24), and the held rate of a joint is its
  mean rate over the hold interval (:func:`planner.plan.commands.velocity_commands`), so a
  rigid quasistatic execution passes through every waypoint's planned configuration whatever
  the spacing; the planned configurations themselves are integrated states projected onto that
  closure (:mod:`planner.plan.trajectory`), exact to the closure's tolerance.  Holding the
  rate *at* ``t_k`` instead is off by ``1/2 dt_k^2 |d rate/dt|`` per interval, which adds up to
  ``1/2 dt sum |rate_{k+1} - rate_k|``: first order in the spacing.
* **Mode.** The held effort must stay guaranteed over the whole hold interval; the planner sees
  the guaranteed set only at waypoints.  An interval is accepted when the sets guaranteed at its
  two ends still hold a common ball of at least :data:`MARGIN_KEPT` of the larger end's own
  radius (:func:`hold_ratio`): from one end to the other the set moves, shrinks or grows by at
  most that share of its size, so a variation that is linear over the interval leaves the held
  command at least that share of its margin, and the interval's second-order bulge -- which a
  midpoint sample would show -- is small against it when the set changes this little.  The
  held rates must also keep the claimed mode kinematically admissible at the waypoint (their
  mean has the sign of the rate there).  An interval that fails is split at its middle, down to
  :data:`SHORTEST` of the segment's duration: where the guaranteed set jumps or collapses within
  one interval no spacing helps, and the held command is then outside it for at most that long
  -- :data:`SHORTEST_COUNT` such intervals use a fifth of the judged steps' allowance
  (``1 - MODE_FRACTION``).  They are reported (``Spacing.unresolved``).
* **Rates.** Inside a hold interval the planned rate of a joint runs from ``r_k`` to
  ``r_k+1`` (the kinematic stage's joint rates, eqs. 13-16, 23-25), while a velocity-controlled
  joint is held at its mean rate and the plan describes every joint by its coordinates at the
  two waypoints (the simulators read the predicted motion from them:
  :func:`sim.schedule.predicted_slips`, eq. 5).  Inside the interval the planned coordinate
  leaves that straight line by up to ``dt_k |r_k+1 - r_k| / 4`` (a rate monotone over the
  interval; the extreme is a step at its middle), and the closure puts the workpiece where the
  coordinates say.  An interval is accepted when this distance is at most
  :data:`POSE_TOLERANCE_OF_TRAVEL` of the joint's travel over the segment (at least
  :data:`STILL` of the workpiece size, :func:`joint_travel`), for every joint
  (:func:`rate_lags`): the tolerance the final position is judged against, taken in each joint.
  An interval that fails is split like the others; one that still fails at :data:`SHORTEST`
  -- the rates diverge, as where the contact constraints become singular (a fold of the
  closure, where a joint's rate grows as ``1/sqrt(t_end - t)``) -- ends the segment at the
  interval's first waypoint (``Spacing.ended``, :class:`RateEnd`): no spacing can hold its
  commands there.  With an explicit count the waypoints are kept as given; an interval that
  fails is split on the trajectory alone (:func:`diverging`) and ends the segment only when a
  piece of at most :data:`SHORTEST` still fails -- else it is reported like the others.

The initial grid is the trajectory's integration step (``max_time / steps``), the resolution at
which the motion itself was followed.  Units: s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from planner.model.hand import Hand
from planner.plan.commands import velocity_commands
from planner.plan.model import Event
from planner.plan.partition import Guaranteed, choose_pieces
from planner.plan.policies import MARGIN_KEPT
from planner.plan.polytope import TorqueRegion, band_region, chebyshev_centre
from planner.plan.trajectory import Trajectory, mode_velocity
from planner.plan.wording import effort_unit, joint_words

#: The validation's limits (docs/simulation.md, "Judging a plan"): the claimed mode on this share
#: of the judged steps ...
MODE_FRACTION = 0.95
#: ... and the final workpiece position within this share of the segment's travel.
POSE_TOLERANCE_OF_TRAVEL = 0.02
#: Jumps of the guaranteed set are resolved to this share of the segment's duration ...
SHORTEST = 0.2 * (1.0 - MODE_FRACTION) / 10
#: ... so that this many of them use at most a fifth of the judged steps' allowance.
SHORTEST_COUNT = 10
#: A joint whose planned coordinate leaves the line between its waypoints by less than this share
#: of the workpiece size (a point at that distance from a pivot) has not moved: the tolerance
#: the planner takes contacts as touching at (:func:`planner.plan.task_contacts.touching`).
STILL = 1e-6


@dataclass(frozen=True)
class RateEnd:
    """Where a segment ends because its rates change too fast to be held between waypoints
    (module docstring, "Rates"): the last kept waypoint's time ``t`` (s), the first failing
    hold interval's other end ``t_next`` (s), the ``joint`` (index) whose rate fails most,
    its rate ``rate`` at ``t`` and the rate ``needed`` at ``t_next`` (rad/s or m/s), and
    ``lag`` (its distance from the held line over that interval over the joint's travel)."""

    t: float
    t_next: float
    joint: int
    rate: float
    needed: float
    lag: float

    def words(self, hand: Hand, event: Event) -> str:
        """The segment's end in plain words (its ``Event.detail``); ``event`` the end of the
        integrated motion the segment stops short of."""
        unit = "rad/s" if effort_unit(hand, (self.joint,)) == "N m" else "m/s"
        where = ("near a singular configuration" if "singular" in event.detail
                 else "the commanded rates diverge")
        return (f"{where}: {joint_words(hand, self.joint)} would need {abs(self.needed):.5g} "
                f"{unit} at t = {self.t_next:.4g} s, against {abs(self.rate):.3g} {unit} at the "
                f"last waypoint kept (t = {self.t:.4g} s); between two waypoints that change "
                f"puts the joint {self.lag:.3g} times its travel off the commands held, over the "
                f"{POSE_TOLERANCE_OF_TRAVEL:.0%} the validation allows, and no waypoint "
                f"spacing holds it, so the segment ends here; the motion would reach t = "
                f"{event.t:.4g} s ({event.kind}: {event.detail})")

    def to_dict(self) -> dict[str, object]:
        return {"t_s": self.t, "t_next_s": self.t_next, "joint": self.joint,
                "rate": self.rate, "needed": self.needed, "lag_of_travel": self.lag}


@dataclass(frozen=True)
class Spacing:
    """How a segment's waypoints were spaced: ``rule`` (``"adaptive"`` or ``"uniform"``, the
    count given), the ``initial`` interval (s), the number of ``splits`` made and the
    ``unresolved`` intervals ``(t_k, t_k+1)`` (s) where the set guaranteed at both ends keeps
    less than :data:`MARGIN_KEPT` of its size (adaptive: only jumps shorter than
    :data:`SHORTEST` of the duration); ``ended`` where the segment was ended before its rates
    diverge (:class:`RateEnd`; None when it runs to its event)."""

    rule: str
    initial: float
    splits: int
    unresolved: tuple[tuple[float, float], ...]
    ended: RateEnd | None = None

    def to_dict(self) -> dict[str, object]:
        """As stored in a segment's ``extra["spacing"]`` (docs/plan-format.md)."""
        out: dict[str, object] = {"rule": self.rule, "initial_s": self.initial,
                                  "splits": self.splits,
                                  "unresolved_s": [list(iv) for iv in self.unresolved]}
        if self.ended is not None:
            out["ended"] = self.ended.to_dict()
        return out

    def words(self, duration: float) -> str:
        """One sentence for a plan's notes."""
        head = (f"waypoints spaced adaptively from {self.initial:.3g} s ({self.splits} "
                "splits)" if self.rule == "adaptive" else "waypoints evenly spaced as asked")
        if not self.unresolved:
            return head + "; every hold interval keeps the guarantee"
        share = sum(b - a for a, b in self.unresolved) / max(duration, 1e-300)
        return (f"{head}; {len(self.unresolved)} hold interval(s) "
                f"({share:.1%} of the segment) where the guaranteed set moves by more than "
                f"{1 - MARGIN_KEPT:.0%} of its size or jumps, or the rates change faster "
                "than the spacing holds: "
                + ", ".join(f"{a:.3g}-{b:.3g} s" for a, b in self.unresolved[:4])
                + (" ..." if len(self.unresolved) > 4 else ""))


def initial_times(duration: float, step: float) -> np.ndarray:
    """Evenly spaced times ``0 .. duration`` at most ``step`` apart (at least two)."""
    n = max(1, math.ceil(duration / step - 1e-9)) if step > 0 else 1
    return np.linspace(0.0, duration, n + 1)


def hold_ratio(a: TorqueRegion, b: TorqueRegion) -> float:
    """Radius of the largest ball in both regions over the larger of their own radii: at least
    :data:`MARGIN_KEPT` when the guaranteed set neither moves nor shrinks or grows by more than
    that share of its size from one end of a hold interval to the other (``<= 0`` when they
    do not meet; 1 without effort joints, where a region is a point that holds or not)."""
    if not min(a.margin, b.margin) > 0:
        return -math.inf
    if a.A.shape[1] == 0:
        return 1.0
    _, r = chebyshev_centre(np.vstack([a.A, b.A]), np.concatenate([a.b, b.b]))
    own = max(a.margin, b.margin)
    if not math.isfinite(own):
        return 1.0 if r > 0 else -math.inf
    return r / own


def interval_regions(hand: Hand, states: Trajectory, V: tuple[int, ...],
                     gs: list[Guaranteed]) -> list[TorqueRegion]:
    """The region each waypoint's command uses (one effort joint: the chosen band piece)."""
    if not gs or gs[0].guarantee is None:
        return [g.region for g in gs]
    from planner.plan.partition import joint_inputs

    pieces = choose_pieces(gs)
    vel = states.thetadot[:, list(V)]
    return [band_region(hand.system(states.q[k], 0.0, joint_inputs(hand, V, vel[k])),
                        gs[k].guarantee, pieces[k])  # type: ignore[arg-type]
            for k in range(len(gs))]


def rate_lags(states: Trajectory, travel: np.ndarray) -> np.ndarray:
    """``(n - 1, F)``: per hold interval of ``states`` and joint, the largest distance inside
    the interval between the planned coordinate and the straight line between the waypoints
    (the held mean rate of a velocity-controlled joint), ``dt_k |r_k+1 - r_k| / 4``, over the
    joint's ``travel`` ``(F,)`` (rad or m) on the segment (module docstring, "Rates"); 0 for a
    joint whose rate does not change."""
    r = np.asarray(states.thetadot, dtype=float)
    lag = 0.25 * np.diff(states.t)[:, None] * np.abs(np.diff(r, axis=0))
    scale = np.broadcast_to(np.asarray(travel, dtype=float), lag.shape)
    return np.divide(lag, scale, out=np.where(lag > 0, np.inf, 0.0), where=scale > 0)


def rate_fails(states: Trajectory, travel: np.ndarray) -> np.ndarray:
    """``(n - 1,)`` bool: the hold intervals of ``states`` in which some joint's
    :func:`rate_lags` exceeds :data:`POSE_TOLERANCE_OF_TRAVEL` (module docstring, "Rates")."""
    return np.any(rate_lags(states, travel) > POSE_TOLERANCE_OF_TRAVEL, axis=1)


def joint_travel(hand: Hand, states: Trajectory) -> np.ndarray:
    """``(F,)`` the path length of each joint over ``states`` (rad or m), at least what keeps a
    distance below :data:`STILL` of the workpiece size (in joint units: rad for a revolute
    joint, whose lever is taken as the size; m for a prismatic one) within the tolerance."""
    travel = np.sum(np.abs(np.diff(states.q[:, 3:], axis=0)), axis=0)
    still = np.array([STILL * (1.0 if effort_unit(hand, (j,)) == "N m" else hand.length_scale)
                      for j in range(hand.n_joints)])
    return np.maximum(travel, still / POSE_TOLERANCE_OF_TRAVEL)


def rate_end(states: Trajectory, travel: np.ndarray, k: int) -> RateEnd:
    """The :class:`RateEnd` of a segment whose hold interval ``k`` fails the rate test."""
    lags = rate_lags(states, travel)[k]
    j = int(np.argmax(lags))
    return RateEnd(float(states.t[k]), float(states.t[k + 1]), j,
                   float(states.thetadot[k, j]), float(states.thetadot[k + 1, j]),
                   float(lags[j]))


def failing_intervals(hand: Hand, states: Trajectory, V: tuple[int, ...],
                      gs: list[Guaranteed], travel: np.ndarray | None = None) -> list[int]:
    """Indices ``k`` of the hold intervals ``[t_k, t_k+1]`` that fail the module's tests;
    ``travel`` ``(F,)`` every joint's travel on the segment (default over ``states``)."""
    regions = interval_regions(hand, states, V, gs)
    held = velocity_commands(states, V)
    travel = joint_travel(hand, states) if travel is None else travel
    fast = rate_fails(states, travel)
    out = []
    for k in range(len(gs) - 1):
        ok = hold_ratio(regions[k], regions[k + 1]) >= MARGIN_KEPT and not fast[k]
        if ok and not np.allclose(held[k], states.thetadot[k, list(V)], rtol=1e-9, atol=0.0):
            ok = mode_velocity(hand, states.q[k], V, held[k], states.mode) is not None
        if not ok:
            out.append(k)
    return out


def _ended(ts: np.ndarray, gs: list[Guaranteed], states: Trajectory, travel: np.ndarray,
           spacing: Spacing, diverges: Callable[[float, float], bool] | None = None
           ) -> tuple[np.ndarray, list[Guaranteed], Spacing]:
    """The waypoints up to the first hold interval that fails the rate test (module
    docstring, "Rates") -- and, given ``diverges(t_k, t_k+1)``, still fails it at every
    spacing -- with ``spacing`` saying where and why they end; unchanged when none does."""
    fast = np.flatnonzero(rate_fails(states, travel))
    fast = np.array([k for k in fast if diverges is None or diverges(ts[k], ts[k + 1])],
                    dtype=int)
    if not fast.size:
        return ts, gs, spacing
    k = int(fast[0])
    kept = tuple(iv for iv in spacing.unresolved if iv[1] <= ts[k])
    return ts[:k + 1], gs[:k + 1], Spacing(spacing.rule, spacing.initial, spacing.splits, kept,
                                           rate_end(states, travel, k))


def diverging(states_at: Callable[[np.ndarray], Trajectory], travel: np.ndarray, a: float,
              b: float, shortest: float) -> bool:
    """Whether the rate test fails on ``[a, b]`` (s) at every spacing: splitting its failing
    halves (the trajectory alone, ``states_at``; no guaranteed sets) leaves a failing piece of
    at most ``shortest`` (s) -- the rates diverge there, as at a fold of the closure.  A rate
    that only changes fast is resolved by the splits: False."""
    if b - a <= shortest:
        return True
    m = 0.5 * (a + b)
    fail = rate_fails(states_at(np.array([a, m, b])), travel)
    return any(diverging(states_at, travel, lo, hi, shortest)
               for (lo, hi), bad in zip(((a, m), (m, b)), fail) if bad)


def adaptive(hand: Hand, states_at: Callable[[np.ndarray], Trajectory], V: tuple[int, ...],
             evaluate: Callable[[int, Trajectory], Guaranteed], duration: float, step: float,
             travel: np.ndarray | None = None
             ) -> tuple[np.ndarray, list[Guaranteed], Spacing, int | None]:
    """Space the waypoints (module docstring).  ``states_at(ts)``: the trajectory at times
    ``ts``; ``evaluate(k, states)``: the guaranteed set at waypoint ``k`` of ``states``;
    ``travel``: every joint's travel on the segment (``(F,)``, rad or m; default over the
    first grid).  Returns ``(times, sets, spacing, failed)``: ``failed`` the index of the
    first waypoint without a guaranteed set (the times and sets then stop there), else None;
    the times also stop where the rates cannot be held (``spacing.ended``)."""
    ts = initial_times(duration, step)
    cache: dict[float, Guaranteed] = {}
    shortest = SHORTEST * duration
    splits = 0
    if travel is None:
        travel = joint_travel(hand, states_at(ts))
    while True:
        states = states_at(ts)
        gs: list[Guaranteed] = []
        for k, t in enumerate(ts):
            if t not in cache:
                cache[t] = evaluate(k, states)
            gs.append(cache[t])
            if gs[-1].empty:
                return ts[:k + 1], gs, Spacing("adaptive", float(step), splits, ()), k
        bad = failing_intervals(hand, states, V, gs, travel)
        split = [k for k in bad if ts[k + 1] - ts[k] > shortest]
        if not split:
            unresolved = tuple((float(ts[k]), float(ts[k + 1])) for k in bad)
            ts, gs, spacing = _ended(ts, gs, states, travel,
                                     Spacing("adaptive", float(step), splits, unresolved))
            return ts, gs, spacing, None
        splits += len(split)
        ts = np.sort(np.concatenate([ts, [0.5 * (ts[k] + ts[k + 1]) for k in split]]))


def uniform(hand: Hand, states: Trajectory, V: tuple[int, ...],
            evaluate: Callable[[int, Trajectory], Guaranteed], travel: np.ndarray | None = None,
            states_at: Callable[[np.ndarray], Trajectory] | None = None
            ) -> tuple[np.ndarray, list[Guaranteed], Spacing, int | None]:
    """The waypoints as given (``states``), with the same report as :func:`adaptive`: they
    also stop where the rates cannot be held at any spacing (:func:`diverging` on
    ``states_at``, the trajectory at any times; without it, at the first interval that fails
    the rate test)."""
    gs: list[Guaranteed] = []
    for k in range(len(states.t)):
        gs.append(evaluate(k, states))
        if gs[-1].empty:
            return states.t[:k + 1], gs, Spacing("uniform", 0.0, 0, ()), k
    travel = joint_travel(hand, states) if travel is None else travel
    bad = failing_intervals(hand, states, V, gs, travel)
    shortest = SHORTEST * float(states.t[-1])
    ts, gs, spacing = _ended(states.t, gs, states, travel, Spacing(
        "uniform", 0.0, 0, tuple((float(states.t[k]), float(states.t[k + 1])) for k in bad)),
        None if states_at is None else (
            lambda a, b: diverging(states_at, travel, a, b, shortest)))
    return ts, gs, spacing, None
