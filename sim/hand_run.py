"""Run a plan in a simulator and judge what happens against what the plan says (Sec. 5.2).

Reads only the plan segment (:class:`planner.plan.model.Segment`: the hand it embeds, the control
partition, the per-waypoint commands, predicted modes and poses); nothing from the planner's
internals. The plan's hand is parsed once (:func:`plan_hand_model`); its mode labels are parsed
once into :class:`planner.model.modes.Mode` objects (:meth:`Schedule.from_plan`).

Execution (:func:`run_plan`): the hand scene of :mod:`sim.scenes.hand` at the given friction,
the velocity-controlled joint at the waypoint's ``velocity_command`` and the effort-controlled
joint at its ``torque_command``, each held from one waypoint to the next (the change at a
waypoint is ramped linearly over ``ramp`` seconds: SIM-NOTES, stepped loads make MuJoCo's
contacts bounce), for the plan's duration in slow motion (the plan's own rates: a few mm/s at
the contacts). Observed modes come from contact data only (:mod:`sim.classify`).

Judgement (:func:`sim.compare.compare_plan`): the claimed mode on ``>= 95 %`` of the judged
steps and the final workpiece position within 2 % of the predicted travel -> ``agreed``;
otherwise ``disagreed`` with the reasons; a simulator fault -> ``fault`` (never a pass).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
from planner.model.modes import Mode
from planner.model.validation import as_friction
from planner.plan.model import Segment
from sim.backends import EngineSettings, check_engine, make_backend
from sim.classify import Thresholds, judged_mask
from sim.compare import (
    MODE_FRACTION_REQUIRED,
    POSE_TOLERANCE_OF_TRAVEL,
    Expect,
    ObservedMode,
    Outcome,
    Verdict,
    compare_plan,
    fault_verdict,
    mode_label,
)
from sim.hand_settings import (
    ENGINE_SETTINGS,
    contact_drive_speed,
    effort_force,
    hand_engine_settings,
)
from sim.run import Recording
from sim.scene import BodyState

__all__ = ["ENGINE_SETTINGS", "PlanRun", "Schedule", "contact_drive_speed",
           "hand_engine_settings", "held_command", "judge_recording", "observed_segments",
           "plan_hand_model", "run_plan", "run_schedule"]


def plan_hand_model(plan: Segment) -> tuple[Hand, np.ndarray]:
    """The hand a plan segment embeds, parsed once: ``(hand, q0)`` (the closed initial
    configuration); :attr:`planner.plan.model.Segment.hand_model` parses and caches it."""
    hand, q0 = plan.hand_model
    return hand, q0


# ---- schedule ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Schedule:
    """Per-waypoint commands and predictions read from a plan (``n`` waypoints).

    ``times`` (n,) [s] increasing from 0; ``velocity`` (n,) [rad/s] command of the (first)
    velocity joint; ``torque`` (n,) [N m] command of the (first) effort joint (both held until
    the next waypoint); ``poses`` (n, 3) predicted workpiece pose; ``predicted`` (n,)
    predicted label sets; ``claim``; ``controls`` (n_theta,) per joint ``"velocity"`` /
    ``"effort"`` (one per finger for single-link fingers). ``commands`` (n, n_theta): every
    joint's command [rad/s, m/s, N m or N] per waypoint (:meth:`from_plan`: the segment's
    ``joint_commands()``); empty: each joint takes ``velocity`` or ``torque`` by its control.
    """

    times: tuple[float, ...]
    velocity: tuple[float, ...]
    torque: tuple[float, ...]
    poses: tuple[tuple[float, float, float], ...]
    claim: Mode
    controls: tuple[str, ...]
    predicted: tuple[frozenset[ObservedMode], ...]
    commands: tuple[tuple[float, ...], ...] = ()

    @classmethod
    def from_plan(cls, plan: Segment, n_contacts: int, torques: np.ndarray | None = None
                  ) -> Schedule:
        """A plan segment's commands and predictions; mode labels parsed once (``n_contacts``
        each).  ``torques`` (n, p) replaces the planned efforts (a negative control)."""
        def parse(label: str) -> Mode:
            return Mode.parse(label, n_contacts)

        claim = parse(plan.claim)
        controls = tuple(plan.control)
        cmd = plan.joint_commands()
        E = list(plan.effort_joints)
        if torques is not None:
            tau = np.asarray(torques, dtype=float)
            if tau.shape != (len(plan.waypoints), len(E)):
                raise InputError(f"torques: expected ({len(plan.waypoints)}, {len(E)}), got "
                                 f"{np.shape(torques)}")
            cmd[:, E] = tau
        commands = tuple(tuple(float(v) for v in row) for row in cmd)

        def first(c: str) -> tuple[float, ...]:
            j = controls.index(c) if c in controls else None
            return tuple(float(v) for v in (cmd[:, j] if j is not None
                                            else np.zeros(len(cmd))))

        return cls(
            times=tuple(float(w.t) for w in plan.waypoints),
            velocity=first("velocity"),
            torque=first("effort"),
            poses=tuple((float(w.pose[0]), float(w.pose[1]), float(w.pose[2]))
                        for w in plan.waypoints),
            claim=claim,
            controls=controls,
            predicted=tuple(frozenset(parse(lab) for lab in w.predicted) or frozenset({claim})
                            for w in plan.waypoints),
            commands=commands,
        )

    def joint_commands(self) -> np.ndarray:
        """(n, n_theta) every joint's command per waypoint (see the class docstring)."""
        if self.commands:
            return np.asarray(self.commands, dtype=float)
        by = {"velocity": np.asarray(self.velocity, dtype=float),
              "effort": np.asarray(self.torque, dtype=float)}
        return np.stack([by[c] for c in self.controls], axis=1)

    def slowed(self, factor: float) -> Schedule:
        """The same schedule ``factor`` times slower: times stretched, velocity commands
        divided, efforts and poses unchanged (a positive scaling of the joint rates leaves
        the quasistatic mode set unchanged)."""
        if not (np.isfinite(factor) and factor >= 1.0):
            raise InputError(f"slowed: expected a finite factor >= 1, got {factor}")
        cmd = self.joint_commands()
        cmd[:, [c == "velocity" for c in self.controls]] /= factor
        return replace(self, times=tuple(t * factor for t in self.times),
                       velocity=tuple(v / factor for v in self.velocity),
                       commands=tuple(tuple(float(v) for v in row) for row in cmd))

    def truncated(self, n: int) -> Schedule:
        """The first ``n`` waypoints (a shorter run of the same plan, for tests)."""
        if not 2 <= n <= len(self.times):
            raise InputError(f"truncated: expected 2 <= n <= {len(self.times)}, got {n}")
        return replace(self, times=self.times[:n], velocity=self.velocity[:n],
                       torque=self.torque[:n], poses=self.poses[:n],
                       predicted=self.predicted[:n], commands=self.commands[:n])


def held_command(times: np.ndarray, values: np.ndarray,
                 ramp: float = 0.0) -> Callable[[float, Mapping[str, BodyState]], float]:
    """``command(t, states)``: ``values[k]`` on ``[times[k], times[k+1])``, ramped linearly from
    ``values[k-1]`` over the first ``ramp`` seconds of each interval."""
    def command(t: float, states: Mapping[str, BodyState]) -> float:
        k = int(np.searchsorted(times, t, side="right")) - 1
        k = min(max(k, 0), len(values) - 1)
        v = float(values[k])
        if ramp > 0 and k > 0 and t - times[k] < ramp:
            a = (t - times[k]) / ramp
            v = (1.0 - a) * float(values[k - 1]) + a * v
        return v
    return command


# ---- running ----------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PlanRun:
    """One execution of a plan: its ``verdict``, the ``recording``, per recorded step the
    ``observed`` modes, ``summary`` (what summary.json holds) and the written ``files``
    (name -> path)."""

    verdict: Verdict
    recording: Recording
    observed: tuple[ObservedMode, ...]
    summary: dict[str, Any]
    files: dict[str, str] = field(default_factory=dict)


def run_schedule(
    hand: Hand,
    q0: np.ndarray,
    mu: float | Sequence[float] | np.ndarray,
    schedule: Schedule,
    engine: str,
    *,
    settings: EngineSettings | None = None,
) -> tuple[Verdict, Recording, list[ObservedMode], dict[str, Any]]:
    """Run ``schedule`` on ``hand`` (initial configuration ``q0``) in ``engine`` at friction
    ``mu`` (scalar or per contact). Returns ``(verdict, recording, observed mode per recorded
    step, details)``."""
    from sim.classify import observed_modes
    from sim.run import RunSettings, run_scene
    from sim.scenes.hand import finger_angles, hand_scene, joint_coordinates

    t = np.asarray(schedule.times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise InputError(f"schedule.times: expected >= 2 increasing times from 0, got "
                         f"{t.tolist()[:5]}...")
    mu_arr = as_friction(mu, hand.n_contacts)
    if len(schedule.controls) != hand.n_joints:
        per = "finger" if hand.n_joints == hand.n_fingers else "joint"
        raise InputError(f"controls: expected {hand.n_joints} (one per {per}), got "
                         f"{len(schedule.controls)}")
    cmd = schedule.joint_commands()
    if cmd.shape != (len(t), hand.n_joints):
        raise InputError(f"schedule.commands: expected ({len(t)}, {hand.n_joints}), got "
                         f"{cmd.shape}")
    es = settings or hand_engine_settings(
        hand, engine, effort_force(hand, q0, schedule.controls, cmd))
    commands = [held_command(t, cmd[:, j], es.ramp) for j in range(hand.n_joints)]
    scene = hand_scene(hand, q0, mu_arr, schedule.controls, commands,
                       mass_scale=es.mass_scale)
    drive_speed = contact_drive_speed(hand, q0, schedule.controls, cmd)
    load = float(np.linalg.norm(hand.load_force)) or 1e-3
    wall = time.perf_counter()
    rec = run_scene(scene, make_backend(engine, es), RunSettings(
        duration=float(t[-1]), dt=es.dt, slip_speed=0.05 * drive_speed,
        penetration_tol=0.02 * scene.length_scale, record_every=es.record_every))
    wall = time.perf_counter() - wall
    # no jam rule in plan runs: a plan predicts no jam; one would show as the claim not
    # observed and the pose off the plan
    th = replace(Thresholds.for_drive(drive_speed, load, creep_floor=es.creep,
                                      settle=es.settle, length_scale=hand.length_scale),
                 jam_depth_rate=np.inf)
    observed = observed_modes(rec, th)
    iw = rec.body_names.index("workpiece")
    details: dict[str, Any] = {
        "engine": engine, "mu": mu_arr.tolist(), "dt": es.dt, "mass_scale": es.mass_scale,
        "solref": list(es.solref) if engine == "mujoco" else None, "ramp": es.ramp,
        "drive_speed_m_per_s": drive_speed, "slip_threshold_m_per_s": th.slip_speed,
        "force_floor_N": th.force_floor, "settle_s": th.settle, "steps": len(rec.times),
        "wall_time_s": wall,
    }
    if rec.fault is not None:
        # what the run showed up to one window before the fault (its blow-up excluded)
        before = rec.until(rec.fault.time - th.window)
        verdict = judge_recording(before, observed_modes(before, th), th, schedule, hand)
        return fault_verdict(rec.fault, verdict), rec, observed, details
    verdict = judge_recording(rec, observed, th, schedule, hand) or Verdict(
        Outcome.INCONCLUSIVE, ("no step could be judged",))
    k = np.clip(np.searchsorted(rec.times, t - 1e-9), 0, len(rec.times) - 1)
    details["simulated_poses"] = rec.poses[k, iw].tolist()
    details["simulated_angles"] = finger_angles(rec, hand)[k].tolist()
    if hand.n_joints != hand.n_fingers:
        details["simulated_joints"] = joint_coordinates(rec.poses[k], rec.body_names,
                                                        hand).tolist()
    return verdict, rec, observed, details


def judge_recording(rec: Recording, observed: list[ObservedMode], th: Thresholds,
                    schedule: Schedule, hand: Hand) -> Verdict | None:
    """The verdict of a recording (one that ended normally, or the part of a faulted one
    before its fault) against the schedule; None when nothing can be judged."""
    t = np.asarray(schedule.times, dtype=float)
    iw = rec.body_names.index("workpiece")
    if len(rec.times) == 0:
        return None
    mask = judged_mask(rec, th)
    judged = [o for o, m in zip(observed, mask) if m]
    # waypoints passed by the run (all of them unless it stopped early), plus its last step
    t_end = float(rec.times[-1])
    n_wp = int(np.searchsorted(t, t_end + 1e-9))
    t_cmp = t[:n_wp] if n_wp == len(t) else np.append(t[:n_wp], t_end)
    pred_poses = np.asarray(schedule.poses, dtype=float)
    if n_wp < len(t):
        pred_poses = np.vstack([pred_poses[:n_wp], [np.interp(t_end, t, pred_poses[:, c])
                                                   for c in range(3)]])
    k = np.clip(np.searchsorted(rec.times, t_cmp - 1e-9), 0, len(rec.times) - 1)
    if not judged:
        # before the settling time only the pose can be judged (modes need settling)
        off = float(np.linalg.norm(rec.poses[-1, iw, :2] - pred_poses[-1, :2]))
        travel = float(np.linalg.norm(pred_poses[-1, :2] - pred_poses[0, :2]))
        if off > POSE_TOLERANCE_OF_TRAVEL * max(travel, 0.01 * hand.length_scale):
            return Verdict(Outcome.DISAGREED, (
                f"the workpiece left the planned path before the settling time: "
                f"{off:.3g} m from the predicted position at t = {t_end:.3f} s",))
        return Verdict(Outcome.INCONCLUSIVE, ("no step after the settling time was recorded",))
    settled = np.flatnonzero(mask)
    interval = np.clip(np.searchsorted(t, rec.times[settled], side="right") - 1, 0, len(t) - 2)
    try:
        return compare_plan(schedule.claim, judged,
                            [schedule.predicted[j] for j in interval], pred_poses,
                            rec.poses[k, iw], interval=interval)
    except InputError:
        return None  # no predicted travel yet


def run_plan(
    plan: Segment,
    engine: str,
    mu: float | Sequence[float] | np.ndarray,
    out_dir: str | Path | None = None,
    *,
    settings: EngineSettings | None = None,
    waypoints: int | None = None,
    render: bool = True,
    name: str | None = None,
    expect: Expect | str = Expect.AGREE,
) -> PlanRun:
    """Execute ``plan`` in ``engine`` at friction ``mu`` (scalar or per contact) and judge it
    (module docstring). ``waypoints``: run only the first so many (shortened runs for tests).
    With ``out_dir``: write ``summary.json``, ``timeline.png`` (observed vs predicted tokens per
    contact) and ``animation.gif``.

    ``expect``: :class:`sim.compare.Expect` ``agree`` (the plan should hold) or ``disagree`` (a
    negative control); the summary's ``passed`` says whether that expectation held (a fault
    never passes), ``status`` is the verdict's outcome."""
    exp = Expect.parse(expect)
    if exp is Expect.INFO:
        raise InputError("expect: expected 'agree' or 'disagree' for a plan run, got 'info'")
    check_engine(engine)
    from planner.files.atomic import atomic_write_json

    hand, q0 = plan_hand_model(plan)
    sched = Schedule.from_plan(plan, hand.n_contacts)
    if waypoints is not None:
        sched = sched.truncated(waypoints)
    verdict, rec, observed, details = run_schedule(hand, q0, mu, sched, engine,
                                                   settings=settings)
    summary: dict[str, Any] = {
        "task": "two-finger hand plan validation (Sec. 5.2)",
        "scenario": name or f"plan {plan.policy} mu={mu}",
        "engine": engine,
        "expect": exp.value,
        **verdict.to_dict(),
        "passed": verdict.held(exp),
        "policy": plan.policy,
        "claim": sched.claim.label,
        "control": list(sched.controls),
        "waypoints": len(sched.times),
        "duration_s": sched.times[-1],
        "observed_segments": observed_segments(observed, rec.times),
        "thresholds": {"mode_fraction": MODE_FRACTION_REQUIRED,
                       "pose_of_travel": POSE_TOLERANCE_OF_TRAVEL},
        "settings": details,
    }
    files: dict[str, str] = {}
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        if render and len(rec.times):
            from sim.render import hand_animation, hand_timeline
            from sim.scenes.hand import finger_angles

            times = np.asarray(sched.times)
            files["timeline"] = str(hand_timeline(rec, observed, times, sched.predicted,
                                                  sched.claim, out / "timeline.png"))
            files["animation"] = str(hand_animation(
                rec, observed, hand, finger_angles(rec, hand), times, np.asarray(sched.poses),
                out / "animation.gif"))
        summary["files"] = {k: Path(v).name for k, v in files.items()}
        files["summary"] = str(atomic_write_json(out / "summary.json", summary))
    return PlanRun(verdict, rec, tuple(observed), summary, files)


def observed_segments(observed: Sequence[ObservedMode],
                      times: np.ndarray) -> list[dict[str, Any]]:
    """Runs of equal observed modes: ``[{"mode", "start_s", "end_s"}, ...]`` (the compressed
    timeline written to summary.json)."""
    out: list[dict[str, Any]] = []
    for o, t in zip(observed, np.asarray(times, dtype=float)):
        lab = mode_label(o)
        if out and out[-1]["mode"] == lab:
            out[-1]["end_s"] = float(t)
        else:
            out.append({"mode": lab, "start_s": float(t), "end_s": float(t)})
    return out
