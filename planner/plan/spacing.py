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
from planner.plan.partition import Guaranteed, choose_pieces
from planner.plan.policies import MARGIN_KEPT
from planner.plan.polytope import TorqueRegion, band_region, chebyshev_centre
from planner.plan.trajectory import Trajectory, mode_velocity

#: The validation's limits (docs/simulation.md, "Judging a plan"): the claimed mode on this share
#: of the judged steps ...
MODE_FRACTION = 0.95
#: ... and the final workpiece position within this share of the segment's travel.
POSE_TOLERANCE_OF_TRAVEL = 0.02
#: Jumps of the guaranteed set are resolved to this share of the segment's duration ...
SHORTEST = 0.2 * (1.0 - MODE_FRACTION) / 10
#: ... so that this many of them use at most a fifth of the judged steps' allowance.
SHORTEST_COUNT = 10


@dataclass(frozen=True)
class Spacing:
    """How a segment's waypoints were spaced: ``rule`` (``"adaptive"`` or ``"uniform"``, the
    count given), the ``initial`` interval (s), the number of ``splits`` made and the
    ``unresolved`` intervals ``(t_k, t_k+1)`` (s) where the set guaranteed at both ends keeps
    less than :data:`MARGIN_KEPT` of its size (adaptive: only jumps shorter than
    :data:`SHORTEST` of the duration)."""

    rule: str
    initial: float
    splits: int
    unresolved: tuple[tuple[float, float], ...]

    def to_dict(self) -> dict[str, object]:
        """As stored in a segment's ``extra["spacing"]`` (docs/plan-format.md)."""
        return {"rule": self.rule, "initial_s": self.initial, "splits": self.splits,
                "unresolved_s": [list(iv) for iv in self.unresolved]}

    def words(self, duration: float) -> str:
        """One sentence for a plan's notes."""
        head = (f"waypoints spaced adaptively from {self.initial:.3g} s ({self.splits} "
                "splits)" if self.rule == "adaptive" else "waypoints evenly spaced as asked")
        if not self.unresolved:
            return head + "; every hold interval keeps the guarantee"
        share = sum(b - a for a, b in self.unresolved) / max(duration, 1e-300)
        return (f"{head}; {len(self.unresolved)} hold interval(s) "
                f"({share:.1%} of the segment) where the guaranteed set moves by more than "
                f"{1 - MARGIN_KEPT:.0%} of its size or jumps: "
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


def failing_intervals(hand: Hand, states: Trajectory, V: tuple[int, ...],
                      gs: list[Guaranteed]) -> list[int]:
    """Indices ``k`` of the hold intervals ``[t_k, t_k+1]`` that fail the module's tests."""
    regions = interval_regions(hand, states, V, gs)
    held = velocity_commands(states, V)
    out = []
    for k in range(len(gs) - 1):
        ok = hold_ratio(regions[k], regions[k + 1]) >= MARGIN_KEPT
        if ok and not np.allclose(held[k], states.thetadot[k, list(V)], rtol=1e-9, atol=0.0):
            ok = mode_velocity(hand, states.q[k], V, held[k], states.mode) is not None
        if not ok:
            out.append(k)
    return out


def adaptive(hand: Hand, states_at: Callable[[np.ndarray], Trajectory], V: tuple[int, ...],
             evaluate: Callable[[int, Trajectory], Guaranteed], duration: float, step: float
             ) -> tuple[np.ndarray, list[Guaranteed], Spacing, int | None]:
    """Space the waypoints (module docstring).  ``states_at(ts)``: the trajectory at times
    ``ts``; ``evaluate(k, states)``: the guaranteed set at waypoint ``k`` of ``states``.
    Returns ``(times, sets, spacing, failed)``: ``failed`` the index of the first waypoint
    without a guaranteed set (the times and sets then stop there), else None."""
    ts = initial_times(duration, step)
    cache: dict[float, Guaranteed] = {}
    shortest = SHORTEST * duration
    splits = 0
    while True:
        states = states_at(ts)
        gs: list[Guaranteed] = []
        for k, t in enumerate(ts):
            if t not in cache:
                cache[t] = evaluate(k, states)
            gs.append(cache[t])
            if gs[-1].empty:
                return ts[:k + 1], gs, Spacing("adaptive", float(step), splits, ()), k
        bad = failing_intervals(hand, states, V, gs)
        split = [k for k in bad if ts[k + 1] - ts[k] > shortest]
        if not split:
            unresolved = tuple((float(ts[k]), float(ts[k + 1])) for k in bad)
            return ts, gs, Spacing("adaptive", float(step), splits, unresolved), None
        splits += len(split)
        ts = np.sort(np.concatenate([ts, [0.5 * (ts[k] + ts[k + 1]) for k in split]]))


def uniform(hand: Hand, states: Trajectory, V: tuple[int, ...],
            evaluate: Callable[[int, Trajectory], Guaranteed]
            ) -> tuple[np.ndarray, list[Guaranteed], Spacing, int | None]:
    """The waypoints as given (``states``), with the same report as :func:`adaptive`."""
    gs: list[Guaranteed] = []
    for k in range(len(states.t)):
        gs.append(evaluate(k, states))
        if gs[-1].empty:
            return states.t[:k + 1], gs, Spacing("uniform", 0.0, 0, ()), k
    bad = failing_intervals(hand, states, V, gs)
    return states.t, gs, Spacing("uniform", 0.0, 0, tuple(
        (float(states.t[k]), float(states.t[k + 1])) for k in bad)), None
