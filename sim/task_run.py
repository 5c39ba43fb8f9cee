"""Run a whole-task plan segment after segment, each from where the last one ended, and judge
each segment and the whole.

Reads only the plan (:class:`planner.plan.task_file.TaskPlanFile`, version 2 or 1).  Segment
``k`` runs with :func:`sim.hand_run.run_schedule` (the single-segment runner and its judgement:
the claimed mode on >= 95 % of the judged steps, the final position within 2 % of the
segment's travel) on the segment's own hand (its contact set, one contact pair each), starting
from the configuration the engine reached at the end of segment ``k - 1`` -- closed onto the
segment's contacts (:meth:`planner.model.hand.Hand.close`; the size of that correction is
recorded as ``handoff_m`` and a correction larger than 2 % of the segment's travel is a
disagreement).  A later segment's predicted poses are shifted by the difference between that
start and the planned one, so each segment is judged on its own motion; the drift the
segments add up is judged on the whole.  The first segment starts at the plan's start.  The
whole task is ``agreed`` when every segment agreed and the final position is within 2 % of the
task's travel of the plan's; a fault in a segment is a ``fault`` and the segments after it
are not run.

Why not one scene for the whole task: the run loop (:mod:`sim.run`) faults when a declared
contact pair is apart at the first step (``contact_lost_at_start``), and the contacts a later
segment gains (edge-to-edge) are apart at the start; and a hand scene has one control
partition.  A continuous run needs two hooks outside this module: pairs allowed to start open
(a ``RunSettings`` field) and joints whose control mode switches at given times.  The scenes
build single-link revolute fingers only (as for one segment).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.plan.task_file import TaskPlanFile
from sim.backends import EngineSettings, check_engine
from sim.compare import POSE_TOLERANCE_OF_TRAVEL, Outcome, Verdict
from sim.hand_run import Schedule, run_schedule


@dataclass(frozen=True, eq=False)
class TaskRun:
    """Segment-by-segment runs of a task plan: per-segment ``verdicts`` (only the segments
    run), the ``whole`` verdict and the ``summary`` (what summary.json holds)."""

    verdicts: tuple[Verdict, ...]
    whole: Verdict
    summary: dict[str, Any]


def run_task(plan: TaskPlanFile, engine: str, mu: float, *,
             settings: EngineSettings | None = None) -> TaskRun:
    """Run ``plan`` in ``engine`` at friction ``mu`` (every contact), segment after segment
    from the simulated state, and judge every segment and the whole (module docstring)."""
    check_engine(engine)
    verdicts: list[Verdict] = []
    rows: list[dict[str, Any]] = []
    q_sim: np.ndarray | None = None
    final_pose = None
    for k, seg in enumerate(plan.segments):
        hand, q_plan = seg.hand_model
        handoff = 0.0
        q0 = q_plan
        if q_sim is not None:
            try:
                q0 = hand.close(q_sim, fixed=hand.default_fixed(q_sim))
            except (DegenerateError, InputError) as exc:
                verdicts.append(Verdict(Outcome.DISAGREED, (
                    f"the simulated end of segment {k} cannot be closed onto segment "
                    f"{k + 1}'s contacts: {exc}",)))
                rows.append({"segment": k + 1, "claim": seg.claim, **verdicts[-1].to_dict()})
                break
            handoff = float(np.linalg.norm(q0[:2] - q_sim[:2]))
        sched = Schedule.from_plan(seg, hand.n_contacts)
        if q_sim is not None:  # judge the segment's motion from where it really starts
            shift = np.asarray(q0[:3]) - np.asarray(q_plan[:3])
            sched = replace(sched, poses=tuple(
                (p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]) for p in sched.poses))
        verdict, _, _, details = run_schedule(hand, q0, mu, sched, engine, settings=settings)
        travel = seg.travel()
        if handoff > POSE_TOLERANCE_OF_TRAVEL * max(travel, 1e-12):
            verdict = Verdict(Outcome.DISAGREED, (*verdict.reasons, (
                f"hand-off from segment {k}: the simulated state is {handoff:.3g} m from "
                f"segment {k + 1}'s contact set, more than {POSE_TOLERANCE_OF_TRAVEL:.0%} of "
                f"its travel")), verdict.agreement, verdict.judged_steps,
                verdict.observed_counts, verdict.fault, verdict.plan, verdict.motion)
        verdicts.append(verdict)
        rows.append({"segment": k + 1, "claim": seg.claim, "handoff_m": handoff,
                     "duration_s": seg.waypoints[-1].t, **verdict.to_dict(),
                     "wall_time_s": details.get("wall_time_s")})
        if verdict.outcome is Outcome.FAULT or "simulated_poses" not in details:
            break
        final_pose = np.asarray(details["simulated_poses"][-1], dtype=float)
        q_sim = np.concatenate([final_pose, details["simulated_angles"][-1]])
    whole = _whole(plan, verdicts, final_pose)
    summary: dict[str, Any] = {
        "task": "whole-task plan validation (segment after segment from the simulated state)",
        "engine": engine, "mu": mu, **whole.to_dict(), "segments": rows}
    return TaskRun(tuple(verdicts), whole, summary)


def _whole(plan: TaskPlanFile, verdicts: list[Verdict], final: np.ndarray | None) -> Verdict:
    outcomes = [v.outcome for v in verdicts]
    reasons = [f"segment {k + 1}: {v.outcome.value}" + (f" ({v.reason})" if v.reasons else "")
               for k, v in enumerate(verdicts) if v.outcome is not Outcome.AGREED]
    if len(verdicts) < len(plan.segments):
        reasons.append(f"only {len(verdicts)} of {len(plan.segments)} segments ran")
    travel = float(sum(s.travel() for s in plan.segments))
    goal = np.asarray(plan.segments[-1].waypoints[-1].pose[:2])
    if final is None:
        reasons.append("no final position: the run stopped before the end of the task")
    elif (off := float(np.linalg.norm(final[:2] - goal))) > POSE_TOLERANCE_OF_TRAVEL * travel:
        reasons.append(f"final position {off:.3g} m from the plan's, more than "
                       f"{POSE_TOLERANCE_OF_TRAVEL:.0%} of the task's travel {travel:.3g} m")
    agreement = float(np.mean([v.agreement for v in verdicts])) if verdicts else 0.0
    judged = sum(v.judged_steps for v in verdicts)
    if Outcome.FAULT in outcomes:
        return Verdict(Outcome.FAULT, tuple(reasons), agreement, judged)
    if not reasons:
        return Verdict(Outcome.AGREED, (), agreement, judged)
    bad = (Outcome.INCONCLUSIVE if Outcome.INCONCLUSIVE in outcomes
           and Outcome.DISAGREED not in outcomes else Outcome.DISAGREED)
    return Verdict(bad, tuple(reasons), agreement, judged)
