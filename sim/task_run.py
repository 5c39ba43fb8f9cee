"""Run a whole-task plan in one continuous simulation per engine, and judge each segment and
the whole (issue 16).

Reads only the plan (:class:`planner.plan.model.Plan`, any file version).
:func:`run_task` builds one scene holding every contact of every segment
(:mod:`sim.task_scene`): the contacts a later segment gains start apart
(``RunSettings.open_at_start``: not a fault), joints whose control differs between segments
switch at the segment boundary (``RunSettings.control_switches``), and the whole plan runs as
one recording (:func:`sim.run.run_scene`). The recording is then sliced per segment: segment
``k``'s steps in ``(T_k, T_k + D_k]``, only its own contacts' pairs, its time counted from its
start, judged by :func:`sim.hand_run.judge_recording` as a single-segment run is (the claimed
mode on >= 95 % of the judged steps -- those at least the settling time after the segment's
start --, the final position within 2 % of the segment's travel). A later segment's predicted
poses are shifted by the difference between where the workpiece really is at the segment's
start and the planned start (``start_offset_m``), so each segment is judged on its own motion;
the drift the segments add up is judged on the whole. The whole task is ``agreed`` when every
segment agreed and the final position is within 2 % of the task's travel of the plan's. A
simulator fault ends the recording: the segment it falls in is a ``fault`` (judged, as a
single run is, on its steps up to one window before), later segments are not judged.

:func:`run_task_segments` is the earlier runner, kept for comparison: every segment its own
run, from the simulated end of the one before closed onto the new segment's contacts
(:meth:`planner.model.hand.Hand.close`; the correction is ``handoff_m``, a disagreement when
larger than 2 % of the segment's travel).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.plan.model import Plan
from sim.backends import EngineSettings, check_engine
from sim.compare import POSE_TOLERANCE_OF_TRAVEL, Outcome, Verdict, fault_verdict
from sim.hand_run import Schedule, judge_recording, run_schedule
from sim.run import Recording


@dataclass(frozen=True, eq=False)
class TaskRun:
    """The runs of a task plan: per-segment ``verdicts`` (only the segments run or reached),
    the ``whole`` verdict, the ``summary`` (what summary.json holds) and, for a continuous
    run, its ``recording`` (pairs ``c<i>``: the union of the segments' contacts)."""

    verdicts: tuple[Verdict, ...]
    whole: Verdict
    summary: dict[str, Any]
    recording: Recording | None = None


def run_task(plan: Plan, engine: str, mu: float | Sequence[float], *,
             settings: EngineSettings | None = None) -> TaskRun:
    """Run ``plan`` in ``engine`` at friction ``mu`` (every contact, or one per contact of the
    hand) as one continuous simulation, and judge every segment and the whole (module
    docstring)."""
    import time

    from sim.backends import make_backend
    from sim.hand_run import contact_drive_speed, effort_force, hand_engine_settings
    from sim.run import RunSettings, run_scene
    from sim.scenes.hand import hand_scene
    from sim.task_scene import task_layout

    check_engine(engine)
    lay = task_layout(plan)
    hand = lay.hand
    # MuJoCo's masses follow the largest squeeze of any segment's effort joints (as in
    # run_schedule), with each segment's own commands
    squeeze = max(effort_force(h, q, s.controls, s.joint_commands())
                  for h, q, s in zip(lay.hands, lay.q_starts, lay.schedules))
    es = settings or hand_engine_settings(hand, engine, squeeze)
    controls = lay.schedules[0].controls
    scene = hand_scene(hand, lay.q0, mu, controls, lay.commands(es.ramp),
                       mass_scale=es.mass_scale, site_configs=lay.site_configs,
                       open_sites=[i for i in range(hand.n_contacts)
                                   if i not in lay.members[0]])
    speeds = [contact_drive_speed(h, q, s.controls, s.joint_commands())
              for h, q, s in zip(lay.hands, lay.q_starts, lay.schedules)]
    wall = time.perf_counter()
    rec = run_scene(scene, make_backend(engine, es), RunSettings(
        duration=lay.duration, dt=es.dt, slip_speed=0.05 * min(speeds),
        penetration_tol=0.02 * scene.length_scale, record_every=es.record_every,
        open_at_start=lay.open_at_start, control_switches=lay.control_switches()))
    wall = time.perf_counter() - wall
    iw = rec.body_names.index("workpiece")
    verdicts: list[Verdict] = []
    rows: list[dict[str, Any]] = []
    final_pose = None
    for k, (seg, sched) in enumerate(zip(plan.segments, lay.schedules)):
        t0, t1 = lay.starts[k], lay.starts[k] + float(sched.times[-1])
        if len(rec.times) == 0 or rec.times[-1] <= t0 + 1e-9:
            break  # the recording ended (a fault) before this segment
        sub = _slice(rec, t0, t1, lay.members[k])
        # judge the segment's motion from where the workpiece really is at its start
        start = (np.asarray(lay.q0[:3], dtype=float) if k == 0 else
                 rec.poses[int(np.searchsorted(rec.times, t0 - 1e-9)), iw])
        shift = start - np.asarray(lay.q_starts[k][:3], dtype=float)
        sched = replace(sched, poses=tuple(
            (p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]) for p in sched.poses))
        # contacts this segment gains are judged once they touch (or from its start)
        gained = [j for j, i in enumerate(lay.members[k])
                  if k > 0 and i not in lay.members[k - 1]]
        delay = _touch_delay(sub, gained)
        verdict = _judge_segment(sub, sched, lay.hands[k], speeds[k], es, delay or 0.0)
        if delay is None:
            verdict = Verdict(Outcome.DISAGREED, (
                *verdict.reasons, f"a contact the segment gains never touched: "
                f"{[f'c{lay.members[k][j] + 1}' for j in gained]}"), verdict.agreement,
                verdict.judged_steps, verdict.observed_counts, verdict.fault, verdict.plan,
                verdict.motion)
        verdicts.append(verdict)
        rows.append({"segment": k + 1, "claim": seg.claim,
                     "start_offset_m": float(np.linalg.norm(shift[:2])),
                     "gained_contact_delay_s": delay,
                     "start_s": t0, "duration_s": float(sched.times[-1]),
                     "contacts": [f"c{i + 1}" for i in lay.members[k]],
                     "control": list(sched.controls), **verdict.to_dict()})
        if verdict.outcome is Outcome.FAULT:
            break
        if rec.fault is None and k == len(plan.segments) - 1:
            final_pose = rec.poses[-1, iw]
    whole = _whole(plan, verdicts, final_pose)
    summary: dict[str, Any] = {
        "task": "whole-task plan validation (one continuous simulation)",
        "engine": engine, "mu": mu if isinstance(mu, (int, float)) else [float(x) for x in mu],
        **whole.to_dict(), "segments": rows,
        "settings": {"dt": es.dt, "mass_scale": es.mass_scale, "ramp": es.ramp,
                     "steps": len(rec.times), "wall_time_s": wall,
                     "pairs": {f"c{i + 1}": c for i, c in enumerate(_union_dicts(plan))},
                     "open_at_start": list(lay.open_at_start),
                     "control_switches": [list(s) for s in lay.control_switches()]}}
    return TaskRun(tuple(verdicts), whole, summary, rec)


def _union_dicts(plan: Plan) -> list[Any]:
    out: list[Any] = []
    for cs in plan.contacts:
        out.extend(c for c in cs if c not in out)
    return out


def _slice(rec: Recording, t0: float, t1: float, pairs: tuple[int, ...]) -> Recording:
    """Steps of ``rec`` in ``(t0, t1]`` with only the columns of ``pairs`` (renamed ``c1 ..``
    in that order), times counted from ``t0``; the fault kept when it falls in the slice."""
    k0 = int(np.searchsorted(rec.times, t0 + 1e-9, side="left"))
    k1 = int(np.searchsorted(rec.times, t1 + 1e-9, side="right"))
    cols = list(pairs)
    per_pair = {f: getattr(rec, f)[k0:k1][:, cols] for f in (
        "present", "points", "normals", "normal_force", "tangent_force", "slip_velocity",
        "depth", "mu_used")}
    fault = rec.fault if rec.fault is not None and t0 < rec.fault.time <= t1 + 1e-9 else None
    if fault is not None:
        fault = replace(fault, time=fault.time - t0)
    return replace(rec, pair_names=tuple(f"c{i + 1}" for i in range(len(cols))),
                   times=rec.times[k0:k1] - t0, poses=rec.poses[k0:k1], fault=fault,
                   jammed_at=None, **per_pair)


def _touch_delay(sub: Recording, cols: list[int]) -> float | None:
    """Seconds from a segment's start until all its gained pairs ``cols`` of slice ``sub``
    touch (0 when they already do at its first step); ``None`` when they never do."""
    if not cols or len(sub.times) == 0:
        return 0.0
    all_on = np.all(sub.present[:, cols], axis=1)
    if not np.any(all_on):
        return None
    k = int(np.argmax(all_on))
    return 0.0 if k == 0 else float(sub.times[k])


def _judge_segment(sub: Recording, sched: Schedule, hand: Any, drive_speed: float,
                   es: EngineSettings, delay: float) -> Verdict:
    """A segment's slice judged as a single-segment run (:func:`sim.hand_run.run_schedule`);
    its steps are judged from ``delay`` [s] (its gained contacts touching) plus the settling
    time."""
    from sim.classify import Thresholds, observed_modes

    load = float(np.linalg.norm(hand.load_force)) or 1e-3
    th = replace(Thresholds.for_drive(drive_speed, load, creep_floor=es.creep,
                                      settle=es.settle, length_scale=hand.length_scale),
                 jam_depth_rate=np.inf)
    th = replace(th, settle=th.settle + delay)
    if sub.fault is not None:
        before = sub.until(sub.fault.time - th.window)
        return fault_verdict(sub.fault, judge_recording(before, observed_modes(before, th), th,
                                                        sched, hand))
    return judge_recording(sub, observed_modes(sub, th), th, sched, hand) or Verdict(
        Outcome.INCONCLUSIVE, ("no step could be judged",))


def run_task_segments(plan: Plan, engine: str, mu: float, *,
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


def _whole(plan: Plan, verdicts: list[Verdict], final: np.ndarray | None) -> Verdict:
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
