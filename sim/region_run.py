"""Run a region plan of any hand in a simulator and judge it (issue 16, Sec. 5.2 generalised).

A planned :class:`planner.plan.model.Segment` (from
:func:`~planner.plan.segment_planner.plan_segment`: any number of fingers, chains of revolute
and prismatic links, several effort-controlled joints, fixed environment surfaces) is executed
like a plan file (:func:`sim.hand_run.run_schedule`): the velocity-controlled joints at their
planned rates and the effort-controlled joints at the waypoint's torque vector (the Chebyshev
centre of the guaranteed region), each held to the next waypoint and ramped; the hand scene of
:mod:`sim.scenes.hand` builds every link as a body. Slow motion: when the fastest
manipulator contact point would move faster than the engine's ``MAX_SPEED``
(:data:`sim.system_run.MAX_SPEED`: pymunk 2 mm/s, MuJoCo 0.5 mm/s -- SIM-NOTES, MuJoCo's
sliding contacts chatter above a few mm/s), every rate is divided and every time multiplied
by the same factor (:meth:`sim.hand_run.Schedule.slowed`; the quasistatic modes do not
change). The verdict is the plan runs' (claimed mode
on ``>= 95 %`` of the judged steps, final pose within 2 % of the travel).

Negative control (:func:`outside_torques`): the same run with torque vectors outside every
waypoint's region, where the planner itself predicts a mode other than the claim at the
simulated friction; the verdict must then be ``disagreed``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
from sim.backends import EngineSettings, check_engine
from sim.compare import MODE_FRACTION_REQUIRED, POSE_TOLERANCE_OF_TRAVEL, Expect
from sim.hand_run import (
    PlanRun,
    Schedule,
    contact_drive_speed,
    observed_segments,
    run_schedule,
)
from sim.system_run import MAX_SPEED


def run_region_plan(plan: Any, hand: Hand, q0: np.ndarray, engine: str,
                    mu: float | Sequence[float] | np.ndarray, *,
                    settings: EngineSettings | None = None,
                    torques: np.ndarray | None = None,
                    expect: Expect | str = Expect.AGREE, name: str | None = None,
                    waypoints: int | None = None) -> PlanRun:
    """Execute region plan ``plan`` of ``hand`` (closed initial configuration ``q0``) in
    ``engine`` at friction ``mu`` (scalar or per contact) and judge it (module docstring).

    ``torques`` (n_waypoints, p) replaces the planned torque vectors (negative controls);
    ``waypoints``: run only the first so many (a shorter run of the same plan);
    ``expect`` ``agree`` or ``disagree``: the summary's ``passed`` says whether it held."""
    exp = Expect.parse(expect)
    if exp is Expect.INFO:
        raise InputError("expect: expected 'agree' or 'disagree' for a plan run, got 'info'")
    check_engine(engine)
    sched = Schedule.from_plan(plan, hand.n_contacts, torques)
    if waypoints is not None:
        sched = sched.truncated(waypoints)
    drive = contact_drive_speed(hand, q0, sched.controls, sched.joint_commands())
    slow = max(1.0, drive / MAX_SPEED[engine])
    if slow > 1.0:
        sched = sched.slowed(slow)
    verdict, rec, observed, details = run_schedule(hand, q0, mu, sched, engine,
                                                   settings=settings)
    summary: dict[str, Any] = {
        "task": "hand region plan validation (Sec. 5.2, any hand)",
        "scenario": name or f"{hand.name} region plan mu={mu}",
        "engine": engine,
        "expect": exp.value,
        **verdict.to_dict(),
        "passed": verdict.held(exp),
        "claim": sched.claim.label,
        "control": list(sched.controls),
        "velocity_joints": list(plan.velocity_joints),
        "effort_joints": list(plan.effort_joints),
        "torques": [list(row) for row in np.asarray(sched.joint_commands())[
            :, list(plan.effort_joints)].tolist()],
        "waypoints": len(sched.times),
        "duration_s": sched.times[-1],
        "slow_motion": slow,
        "observed_segments": observed_segments(observed, rec.times),
        "thresholds": {"mode_fraction": MODE_FRACTION_REQUIRED,
                       "pose_of_travel": POSE_TOLERANCE_OF_TRAVEL},
        "settings": details,
    }
    return PlanRun(verdict, rec, tuple(observed), summary)


def outside_torques(plan: Any, hand: Hand, mu: float | Sequence[float] | np.ndarray,
                    *, reach: float = 3.0) -> np.ndarray:
    """(n_waypoints, p) torque vectors outside every waypoint's region for a negative control.

    From each waypoint's planned torque ``c`` (the region's Chebyshev centre, radius ``r``)
    along the outward normal ``a`` of a facet of ``A tau <= b`` (nearest facet first):
    ``c + (slack + k max(r, |c|)) a`` for ``k = reach, 3 reach``, the first point where the
    planner's own prediction (:func:`planner.predict.feasibility.feasible_modes`) at ``mu``
    does not contain the claim (a rival instead). Raises :class:`InputError` for a plan without
    effort joints or a waypoint where no such point is found."""
    from planner.plan.partition import joint_inputs
    from planner.predict.feasibility import feasible_modes

    E = list(plan.effort_joints)
    if not E:
        raise InputError("outside_torques: expected a plan with effort-controlled joints, got "
                         "none (a velocity-only plan has no torque to move outside)")
    out = []
    for w, reg in zip(plan.waypoints, plan.regions):
        c = np.asarray(w.torque_commands, dtype=float)
        A, b = np.asarray(reg.A, dtype=float), np.asarray(reg.b, dtype=float)
        norms = np.linalg.norm(A, axis=1)
        slack = (b - A @ c) / np.where(norms > 0, norms, np.inf)
        system = hand.system(w.q, mu, joint_inputs(hand, plan.velocity_joints,
                                                   w.velocity_commands))
        inputs = np.array(system.joint_inputs)
        size = max(float(w.margin), float(np.linalg.norm(c)))
        found = None
        for i in np.argsort(slack):  # nearest facet first, then further ones
            if not np.isfinite(slack[i]):
                continue
            for k in (reach, 3.0 * reach):
                tau = c + (slack[i] + k * size) * A[i] / norms[i]
                inputs[E] = tau
                if plan.claim not in feasible_modes(system.with_joint_inputs(inputs)).labels:
                    found = tau
                    break
            if found is not None:
                break
        if found is None:
            raise InputError(f"outside_torques: no torque past a facet of the region at t = "
                             f"{w.t:.3g} s rules out {plan.claim} at mu = {mu}")
        out.append(found)
    return np.array(out)
