"""What a run is judged against (:func:`sim.judge.judge`): one of three expectations, all built
by the caller from the planner's results -- the simulator never predicts.

:class:`ModeSet`
    a system's feasible modes with their certificates (``qsplan simulate``: any system file,
    the paper's examples, several workpieces); an empty set is a predicted jam;
:class:`PlanSchedule`
    a plan's segments: per segment the claimed mode, the predicted mode set of every waypoint
    interval and the predicted workpiece poses (``qsplan validate``; one segment or a whole
    task);
:class:`Switches`
    the ruler's predicted switch positions and sliding fingers (Sec. 5.1).

Units: every length in an expectation is in the *user's* metres and every time in the *run's*
seconds (slow motion included): the pipeline judges the recording after mapping it back from
the simulated scene's scale (:mod:`sim.similarity`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planner.model.modes import Mode
from planner.model.system import System
from planner.predict.stages import FeasibleMode
from sim.verdict import ObservedMode, Verdict


@dataclass(frozen=True, eq=False)
class ModeSet:
    """The planner's feasible modes of a system at the judged friction.

    ``modes``: the feasible modes with their certificates (empty: a predicted jam);
    ``system``: the judged system (its friction), used to re-check an observation against a
    mode's whole certificate family (:mod:`planner.predict.family`); ``velocity_factor`` [-]:
    a certificate's ``qdot`` times this is the twist the run should show (the slow-motion
    factor of the drive); ``bodies``: the scene names of the workpieces, in the system's order
    (``qdot`` blocks); ``drive`` [m/s] the fastest commanded contact speed of the run;
    ``length`` [m] the scene size (weights rotation in twist errors); ``force_scale`` [N] the
    run's force scale for its jam rules (the larger of the load and the largest certified
    total normal force at the simulated friction); ``load`` [N] the load (force errors are
    judged relative to the larger of it and the compared certificate's total normal force).
    ``static``: nothing is driven (a static question): the modes are the predicted static
    equilibria, and an empty set predicts that the workpiece moves (no equilibrium holds), not
    a jam."""

    modes: tuple[FeasibleMode, ...]
    system: System | None
    velocity_factor: float
    bodies: tuple[str, ...]
    drive: float
    length: float
    force_scale: float
    static: bool = False
    load: float = 0.0

    @property
    def labels(self) -> list[str]:
        """The predicted labels (``["JAM"]`` for a predicted jam, ``["MOVES"]`` for a static
        system without equilibrium)."""
        return [m.label for m in self.modes] or (["MOVES"] if self.static else ["JAM"])

    def twists(self) -> list[np.ndarray]:
        """The twist ``(3 n_b,)`` each predicted mode should show in the run."""
        return [np.asarray(m.qdot, dtype=float) * self.velocity_factor for m in self.modes]


@dataclass(frozen=True, eq=False)
class SegmentExpectation:
    """One segment of a plan run.

    ``claim``: the mode the plan guarantees; ``start`` [s] the segment's start on the run's
    clock; ``times`` (n,) [s] its waypoints from 0; ``predicted`` (n,) the predicted mode set
    of each waypoint interval; ``poses`` (n, 3) the predicted workpiece pose at each waypoint;
    ``planned_start`` (3,) the pose the plan starts the segment from; ``pairs``: the recording's
    pair columns of the segment's contacts (its mode labels index them 1..); ``gained``: the
    positions in ``pairs`` of contacts the segment gains at its start (judged once they touch);
    ``travel`` [m] the predicted path length; ``drive`` [m/s] its fastest commanded contact
    speed and ``slip_speed`` [m/s] the classifier's slip threshold for it; ``slips`` (n, n_c)
    [m/s] each contact's predicted tangential relative velocity at each waypoint (eq. 5,
    :func:`sim.schedule.predicted_slips`; empty: not known); ``points`` (k, 2) [m] the
    body-frame points of the workpiece whose positions are judged (a plan run: its centre of
    mass; default its frame origin), :func:`point_travel`, :func:`point_errors`."""

    claim: Mode
    start: float
    times: np.ndarray
    predicted: tuple[frozenset[ObservedMode], ...]
    poses: np.ndarray
    planned_start: np.ndarray
    pairs: tuple[int, ...]
    gained: tuple[int, ...]
    travel: float
    drive: float = 0.0
    slip_speed: float = 0.0
    slips: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    points: np.ndarray = field(default_factory=lambda: np.zeros((1, 2)))


@dataclass(frozen=True, eq=False)
class PlanSchedule:
    """A plan's segments in run order (one for a single-segment plan); ``travel`` [m] of the
    whole task (:func:`point_travel` of its ``points``); ``goal`` (3,) the final predicted
    pose; ``length`` [m] the hand's size; ``points`` (k, 2) as in
    :class:`SegmentExpectation`."""

    segments: tuple[SegmentExpectation, ...]
    travel: float
    goal: np.ndarray
    length: float
    points: np.ndarray = field(default_factory=lambda: np.zeros((1, 2)))


def point_positions(poses: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, k, 2) [m] world positions of the body-frame ``points`` (k, 2) at the workpiece
    ``poses`` (n, 3) ``(x, y, phi)``: ``(x, y) + R(phi) p`` (docs/conventions.md)."""
    q = np.atleast_2d(np.asarray(poses, dtype=float))
    p = np.atleast_2d(np.asarray(points, dtype=float))
    c, s = np.cos(q[:, 2])[:, None], np.sin(q[:, 2])[:, None]
    return np.stack([q[:, 0:1] + c * p[None, :, 0] - s * p[None, :, 1],
                     q[:, 1:2] + s * p[None, :, 0] + c * p[None, :, 1]], axis=-1)


def point_travel(poses: np.ndarray, points: np.ndarray) -> float:
    """[m] the longest path any of the workpiece's ``points`` (k, 2) takes through ``poses``
    (n, 3): what the workpiece travels, wherever its frame origin is (a block tilted about
    its frame origin travels by its far corners)."""
    w = point_positions(poses, points)
    return float(np.max(np.sum(np.linalg.norm(np.diff(w, axis=0), axis=2), axis=0)))


def point_errors(simulated: np.ndarray, predicted: np.ndarray, points: np.ndarray
                 ) -> np.ndarray:
    """(n,) [m] at each of the n poses the largest distance between where a workpiece point
    (``points`` (k, 2)) is in ``simulated`` (n, 3) and where ``predicted`` (n, 3) puts it."""
    d = point_positions(simulated, points) - point_positions(predicted, points)
    return np.max(np.linalg.norm(d, axis=2), axis=1)


@dataclass(frozen=True, eq=False)
class Switches:
    """The ruler's predicted switch positions [m] (sliding finger's distance to the rod's
    centre of mass) and which finger (0 left, 1 right) slid before each; the first
    ``required`` must be observed within ``tolerance`` (relative)."""

    positions: tuple[float, ...]
    sliders: tuple[int, ...]
    required: int
    tolerance: float


Expectation = ModeSet | PlanSchedule | Switches


@dataclass(frozen=True, eq=False)
class SegmentVerdict:
    """The verdict of one segment of a plan run and what it measured: ``start`` [s],
    ``duration`` [s], ``start_offset`` [m] (how far the workpiece really was from the planned
    start), ``gained_delay`` [s] (until the contacts it gains touched; None: never)."""

    index: int
    claim: str
    start: float
    duration: float
    start_offset: float
    gained_delay: float | None
    contacts: tuple[str, ...]
    verdict: Verdict

    def to_dict(self) -> dict[str, object]:
        return {"segment": self.index + 1, "claim": self.claim, "start_s": self.start,
                "duration_s": self.duration, "start_offset_m": self.start_offset,
                "gained_contact_delay_s": self.gained_delay, "contacts": list(self.contacts),
                **self.verdict.to_dict()}


@dataclass(frozen=True, eq=False)
class Judgement:
    """What the judge returns: the ``verdict``, the ``observed`` mode of every recorded step
    (over the recording's pairs; for drawing) and, for a plan, one :class:`SegmentVerdict`
    per segment reached. ``details``: measured quantities for the summary."""

    verdict: Verdict
    observed: tuple[ObservedMode, ...]
    segments: tuple[SegmentVerdict, ...] = ()
    details: dict[str, object] | None = None
