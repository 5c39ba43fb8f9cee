"""Quasistatic trajectory of a hand segment: integrate the predicted velocities (Section 5.2).

A segment keeps one contact mode (e.g. ``4S``, all four contacts sliding) while one joint (or
several: ``drive`` a list, ``speed`` one rate each, zero = held) is driven at a constant rate.
At every step the kinematic stage (eqs. 13-16, 23-25; independent
of friction and of the effort inputs) gives the mode's workpiece twist ``qdot`` and the
velocities of the effort-controlled joints; the state ``q = (x, y, phi, theta_1..theta_F)``
advances by fourth-order Runge-Kutta and is then projected back onto the contact manifold
(:meth:`planner.model.hand.Hand.close` with the driven joints held), so the contacts never drift.
Contact points move along their features as the state moves (vertex-edge contacts).

The segment ends at the first event:

* ``new contact`` -- a feature pair not in the mode touches (e.g. the left finger meets a
  workpiece edge edge-to-edge: the edge's other vertex reaches the finger);
* ``lost contact`` -- a contact point runs off the end of its edge or finger;
* ``mode change`` -- the mode stops being kinematically admissible (a sliding direction would
  reverse, a breaking contact would close, or the rank conditions 30-31 fail);
* ``goal`` -- the caller's ``stop(q)`` holds (the task planner's goal pose, ``planner.plan.task``);
* ``time limit``.

A feature pair that touches at the start but is not a contact of the hand (a contact the segment
releases: its mode would be ``B``) is watched with a small penetration tolerance
(``1e-9`` of the workpiece size) instead of ``<= 0``, so the segment can start; if the pair
closes instead of opening, that is a ``new contact`` event within the first step.

Events are located by bisection on the driven joint's angle to ``1e-9`` of a step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.hand import Hand
from planner.model.modes import BREAK, ROLL, SLIDE, Mode, enumerate_modes
from planner.plan.model import Event
from planner.plan.task_contacts import touching, with_contacts
from planner.plan.wording import (
    clearance_words,
    contact_words,
    meets_words,
    mode_change_words,
    runs_off_words,
)
from planner.predict.indeterminate import indeterminate_kinematics
from planner.predict.relaxed_modes import indeterminate_kinematics_of
from planner.predict.stages import DEFAULT_TOL, kinematic_stage

#: ``(d/dt of the hand state, workpiece twist, joint rates)`` at one state of a segment.
Rate = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The quasistatic motion of a segment sampled at ``n`` states.

    ``t (n,)`` s; ``q (n, 3 + F)`` configurations; ``qdot (n, 3)`` workpiece twist about the
    world origin; ``thetadot (n, F)`` joint rates; ``mode`` the label kept (with its sliding
    directions); ``drive`` index of the (first) driven joint and its ``speed`` (rad/s or m/s);
    ``drives``/``speeds`` every driven joint and its rate; ``event``.
    """

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    thetadot: np.ndarray
    mode: str
    drive: int
    speed: float
    event: Event
    drives: tuple[int, ...] = ()
    speeds: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not self.drives:
            object.__setattr__(self, "drives", (self.drive,))
            object.__setattr__(self, "speeds", (self.speed,))

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def travel(self) -> float:
        """Path length of the workpiece origin (m)."""
        return float(np.sum(np.linalg.norm(np.diff(self.q[:, :2], axis=0), axis=1)))

    def resample(self, hand: Hand, n: int) -> Trajectory:
        """``n`` states evenly spaced in time, each re-closed on the contact manifold."""
        if n < 2:
            raise InputError(f"resample: expected n >= 2, got {n}")
        return self.at_times(hand, np.linspace(0.0, self.duration, n))

    def at_times(self, hand: Hand, ts: np.ndarray) -> Trajectory:
        """The states at times ``ts`` (s, increasing, within ``[0, duration]``): interpolated
        linearly between the integrated states, the driven joints set to their exact
        coordinates, re-closed on the contact manifold, with the mode's rates there."""
        ts = np.asarray(ts, dtype=float)
        qs: list[np.ndarray] = []
        qd: list[np.ndarray] = []
        td: list[np.ndarray] = []
        for t in ts:
            k = int(np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2))
            a = (t - self.t[k]) / (self.t[k + 1] - self.t[k])
            q = (1 - a) * self.q[k] + a * self.q[k + 1]
            for d, v in zip(self.drives, self.speeds):
                q[3 + d] = self.q[0, 3 + d] + v * t
            q = close_in_mode(hand, q, [3 + d for d in self.drives], self.mode)
            vel = mode_velocity(hand, q, self.drives, self.speeds, self.mode)
            if vel is None:  # the event state itself may sit on the boundary: keep last rates
                vel = (qd[-1], td[-1]) if qd else (self.qdot[k], self.thetadot[k])
            qs.append(q)
            qd.append(vel[0])
            td.append(vel[1])
        return Trajectory(ts, np.array(qs), np.array(qd), np.array(td), self.mode, self.drive,
                          self.speed, self.event, self.drives, self.speeds)


def close_in_mode(hand: Hand, q: np.ndarray, fixed: Sequence[int], label: str) -> np.ndarray:
    """Close ``q`` on the constraints of mode ``label`` (eqs. 13-16,
    :func:`planner.model.closure.close_configuration`): the gaps of its ``R`` and ``S`` contacts
    zero, no slip at its ``R`` contacts, its ``B`` contacts released; ``fixed`` held."""
    codes = Mode.parse(label, hand.n_contacts).codes
    kept = [i for i, c in enumerate(codes) if c != BREAK]
    closer = hand if len(kept) == hand.n_contacts else with_contacts(
        hand, tuple(hand.contacts[i] for i in kept))
    sticking = [k for k, i in enumerate(kept) if codes[i] == ROLL]
    return closer.close(q, fixed=fixed, sticking=sticking)


Drive = int | Sequence[int]
Speed = float | Sequence[float]


def drive_rates(drive: Drive, speed: Speed) -> tuple[tuple[int, ...], tuple[float, ...]]:
    """``(joints, rates)``: one driven joint and its rate, or lists of both (same length)."""
    drives = (int(drive),) if isinstance(drive, (int, np.integer)) else tuple(int(d) for d in drive)
    speeds = ((float(speed),) if isinstance(speed, (int, float, np.floating))
              else tuple(float(v) for v in speed))
    if len(drives) != len(speeds) or not drives:
        raise InputError(f"drive/speed: expected one rate per driven joint, got {len(drives)} "
                         f"joints and {len(speeds)} rates")
    return drives, speeds


def _drive_joints(hand: Hand, drive: Drive, speed: Speed) -> list[dict[str, float]]:
    drives, speeds = drive_rates(drive, speed)
    rate = dict(zip(drives, speeds))
    return [{"velocity": rate[k]} if k in rate else {"effort": 0.0}
            for k in range(hand.n_joints)]


def mode_velocity(
    hand: Hand, q: np.ndarray, drive: Drive, speed: Speed, mode: str, *,
    tol: float = DEFAULT_TOL,
) -> tuple[np.ndarray, np.ndarray] | None:
    """``(qdot, thetadot)`` of ``mode`` (a label, or a family such as ``"4S"``) at ``q`` with
    joint(s) ``drive`` at ``speed`` and the others effort-controlled; None if not admissible."""
    system = hand.system(q, 0.0, _drive_joints(hand, drive, speed))
    relaxed = _relaxed_codes(mode, system.n_contacts, system.dof)
    if relaxed is not None:
        for kin in indeterminate_kinematics_of(system, relaxed[None], tol=tol):
            if kin.mode.label == mode:
                return kin.qdot.copy(), kin.thetadot.copy()
        return None
    cand = enumerate_modes(system.n_contacts, system.dof)
    ks = kinematic_stage(system, cand, tol=tol)
    for i in np.flatnonzero(ks.ok):
        m = Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in ks.xi[i]))
        if m.label == mode or (m.family == mode and " " not in mode):
            return ks.qdot[i].copy(), ks.joint_velocities[i].copy()
    return None


def _relaxed_codes(mode: str, n_contacts: int, dof: int) -> np.ndarray | None:
    """The codes ``(n_c,)`` of a full mode label with more kinematic rows than ``dof = 3 +
    |tau_I|`` (``2 n_R + n_S > dof``: force-indeterminate, relaxed utility of Sec. 3.2, whose
    velocities :func:`planner.predict.relaxed_modes.indeterminate_kinematics_of` tests);
    None for a family name or a label of at most ``dof`` rows (the determinate stage)."""
    if " " not in mode:  # a family, or one contact (at most 2 rows < 3)
        return None
    try:
        codes = np.array(Mode.parse(mode, n_contacts).codes, dtype=np.int8)
    except InputError:
        return None
    rows = 2 * int(np.sum(codes == ROLL)) + int(np.sum(codes == SLIDE))
    return codes if rows > dof else None


def _mode_label(hand: Hand, q: np.ndarray, drive: Drive, speed: Speed, family: str) -> str:
    system = hand.system(q, 0.0, _drive_joints(hand, drive, speed))
    relaxed = _relaxed_codes(family, system.n_contacts, system.dof)
    if relaxed is not None:
        hits = [kin.mode.label for kin in indeterminate_kinematics_of(system, relaxed[None])]
        if hits != [family]:
            raise DegenerateError(
                f"mode {family!r}: expected it kinematically admissible at the start of the "
                f"segment (force-indeterminate: its constraint rows of full column rank and "
                f"consistent, Sec. 3.2), got {hits or 'none'}")
        return family
    cand = enumerate_modes(system.n_contacts, system.dof)
    ks = kinematic_stage(system, cand)
    hits = []
    for i in np.flatnonzero(ks.ok):
        m = Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in ks.xi[i]))
        if m.label == family or m.family == family:
            hits.append(m.label)
    if not hits and " " not in family:  # a family of force-indeterminate modes (Sec. 3.2)
        hits = [k.mode.label for k in indeterminate_kinematics(system) if k.mode.family == family]
    if len(hits) != 1:
        raise DegenerateError(
            f"mode {family!r}: expected exactly one kinematically admissible mode at the start "
            f"of the segment, got {hits or 'none'}"
        )
    return hits[0]


def integrate_segment(
    hand: Hand,
    q0: Any,
    *,
    drive: Drive,
    speed: Speed,
    mode: str = "4S",
    max_time: float,
    steps: int = 400,
    stop: Callable[[np.ndarray], bool] | None = None,
) -> Trajectory:
    """Integrate the quasistatic motion of ``mode`` from ``q0`` with joint ``drive`` at
    ``speed`` (rad/s or m/s; or lists: several driven joints, a zero rate holds a joint) until
    an event or ``max_time`` (s); ``steps`` RK4 steps over ``max_time``.  ``stop(q)``: an
    optional goal test; the segment ends (event ``goal``) at the first state where it holds.
    """
    drives, speeds = drive_rates(drive, speed)
    for d in drives:
        if not 0 <= d < hand.n_joints:
            raise InputError(f"drive: expected a joint index in [0, {hand.n_joints - 1}], "
                             f"got {d}")
    if not all(np.isfinite(speeds)) or not any(speeds):
        raise InputError(f"speed: expected a non-zero finite joint rate, got {speed!r}")
    if not (np.isfinite(max_time) and max_time > 0):
        raise InputError(f"max_time: expected a positive duration, got {max_time!r}")
    fixed = [3 + d for d in drives]
    q = hand.close(hand.check_q(q0), fixed=fixed) if " " not in mode else close_in_mode(
        hand, hand.check_q(q0), fixed, mode)
    label = _mode_label(hand, q, drives, speeds, mode)
    breaking = [i for i, c in enumerate(Mode.parse(label, hand.n_contacts).codes)
                if c == BREAK]
    h = max_time / steps
    slack = 1e-9 * hand.length_scale
    released = {name for name, d in hand.clearances(q).items() if d <= slack}
    # A contact that starts at its feature's end (a vertex just past a link's end, a tip at an
    # edge's vertex) may sit a rounding error outside [0, 1]: it gets the same small slack.
    s0 = hand.contact_geometry(q)[2]
    s_lo = np.where(s0 < 0.0, -1e-9, 0.0)
    s_hi = np.where(s0 > 1.0, 1.0 + 1e-9, 1.0)
    s_lo[breaking], s_hi[breaking] = -np.inf, np.inf  # a breaking contact leaves its feature

    def rate(qq: np.ndarray) -> Rate | None:
        vel = mode_velocity(hand, qq, drives, speeds, label)
        if vel is None:
            return None
        qd, td = vel
        return np.concatenate([hand.pose_rates_from_twist(qq, qd), td]), qd, td

    def step(qq: np.ndarray, dt: float) -> tuple[np.ndarray | None, str]:
        """``(state after dt, "")`` or ``(None, why)``: ``"mode"`` when the mode is not
        admissible at an intermediate state, ``"closure: ..."`` (the closure's own message)
        when the contacts cannot all stay closed."""
        k1 = rate(qq)
        k2 = rate(qq + 0.5 * dt * k1[0]) if k1 is not None else None
        k3 = rate(qq + 0.5 * dt * k2[0]) if k2 is not None else None
        k4 = rate(qq + dt * k3[0]) if k3 is not None else None
        if k1 is None or k2 is None or k3 is None or k4 is None:
            return None, "mode"
        nxt = qq + dt / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        for d, v in zip(drives, speeds):
            nxt[3 + d] = qq[3 + d] + v * dt
        try:
            return close_in_mode(hand, nxt, fixed, label), ""
        except DegenerateError as exc:
            return None, f"closure: {exc}"

    def event_at(qq: np.ndarray | None, why: str) -> tuple[Event | None, Rate | None]:
        """``(event or None, rate at qq)``; the rate is reused when the state is accepted.
        ``qq`` None: the step there failed for reason ``why`` (see :func:`step`)."""
        if qq is None:
            return Event("mode change", why, 0.0), None
        _, _, s = hand.contact_geometry(qq)
        off = np.flatnonzero((s < s_lo) | (s > s_hi))
        if off.size:
            i = int(off[0])
            return Event("lost contact", runs_off_words(hand, i, float(s[i])), 0.0), None
        cl = hand.clearances(qq)
        hit = [name for name, d in cl.items() if d <= (-slack if name in released else 0.0)]
        if hit:
            return Event("new contact", hit[0], 0.0), None
        if stop is not None and stop(qq):
            return Event("goal", "the goal is reached", 0.0), None
        r = rate(qq)
        if r is None:
            return Event("mode change", "mode", 0.0), None
        return None, r

    first, r0 = event_at(q, "")
    if first is not None or r0 is None:
        first = first or Event("mode change", "mode", 0.0)
        raise DegenerateError("segment cannot start: "
                              + _event_words(hand, q, q, first, drives, speeds, label))
    ts, qs, qds, tds = [0.0], [q], [r0[1]], [r0[2]]

    def record(t_new: float, q_new: np.ndarray, r: Rate) -> None:
        ts.append(t_new)
        qs.append(q_new)
        qds.append(r[1])
        tds.append(r[2])

    t = 0.0
    event = Event("time limit", f"the time limit, max_time {max_time:g} s, is reached", max_time)
    while t < max_time - 1e-12 * max_time:
        dt = min(h, max_time - t)
        nxt, why = step(q, dt)
        ev, r = event_at(nxt, why)
        if ev is None and nxt is not None and r is not None:
            t += dt
            q = nxt
            record(t, q, r)
            continue
        if ev is None:  # unreachable: event_at returns a rate whenever it finds no event
            raise DegenerateError("internal: step accepted without a rate")
        # Bisect on the step length for the first event.
        a, b = 0.0, dt
        q_ok, r_ok = q, None
        q_bad = nxt
        while b - a > 1e-9 * h:
            mid = 0.5 * (a + b)
            qm, why_m = step(q, mid)
            ev_m, r_m = event_at(qm, why_m)
            if ev_m is None and qm is not None:
                a, q_ok, r_ok = mid, qm, r_m
            else:
                b, ev, q_bad = mid, ev_m or ev, qm
        if a > 0 and r_ok is not None:
            t += a
            q = q_ok
            record(t, q, r_ok)
        event = Event(ev.kind, _event_words(hand, q, q_bad, ev, drives, speeds, label), t)
        break
    if len(ts) < 2:
        raise DegenerateError(f"segment ended at its start: {event.detail}")
    return Trajectory(np.array(ts), np.array(qs), np.array(qds), np.array(tds), label,
                      drives[0], speeds[0], event, drives, speeds)


def _event_words(hand: Hand, q: np.ndarray, q_past: np.ndarray | None, ev: Event,
                 drives: tuple[int, ...], speeds: tuple[float, ...], label: str) -> str:
    """The event's ``detail`` in plain words, contacts named by their features
    (:mod:`planner.plan.wording`).  ``q``: the last state of the segment; ``q_past``: a state
    just past the event (None when the step there failed)."""
    if ev.kind == "new contact":
        at = q_past if q_past is not None else q
        new = [c for c in touching(hand, at, 1e-4 * hand.length_scale)
               if c not in hand.contacts]
        return "; ".join(meets_words(hand, c) for c in new) or clearance_words(hand, ev.detail,
                                                                               at)
    if ev.kind != "mode change":
        return ev.detail
    if ev.detail.startswith("closure"):
        why = ev.detail.removeprefix("closure: close: ")
        return ("past this point the constraints of the contacts "
                + ", ".join(contact_words(hand, c) for c in hand.contacts)
                + f" become singular or ill-conditioned (the closure fails: {why})")
    return f"{label} stops being kinematically admissible: " + mode_change_words(
        hand, label, _admissible_near(hand, q, drives, speeds))


def _admissible_near(hand: Hand, q: np.ndarray, drives: tuple[int, ...],
                     speeds: tuple[float, ...]) -> list[str]:
    """Labels of the modes of ``hand``'s contacts (``B`` included) that are kinematically
    admissible at ``q`` or on the boundary of admissibility there with a loosened tolerance
    (at the end of a mode the next one starts on its boundary)."""
    system = hand.system(q, 0.0, _drive_joints(hand, drives, speeds))
    cand = enumerate_modes(system.n_contacts, system.dof)
    ks = kinematic_stage(system, cand, tol=1e3 * DEFAULT_TOL)
    return [Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in ks.xi[i])).label
            for i in np.flatnonzero(ks.ok | ks.boundary)]
