"""Simulate a system of several workpieces and judge the run per contact and per body (issue 17).

:func:`simulate_multibody` follows :func:`sim.system_run.simulate_system`:

1. **predict** -- :func:`planner.predict.feasibility.feasible_modes` at the judging friction
   (``judge_mu``, default the simulated ``mu``) on the system with its contact velocities
   scaled to the scene's (slow motion leaves the mode set unchanged; the certificate's ``qdot``
   is then the twists the run should show);
2. **build** the scene (:func:`sim.scenes.multibody.multibody_scene`) and **run** it in slow
   motion (:func:`sim.run.run_scene`, the engine settings of :mod:`sim.system_run`);
3. **classify** each contact from the simulator's own data (:func:`sim.classify.observed_modes`)
   and **compare**: the judged steps' modes against the predicted set
   (:func:`sim.compare.compare_modes`), and every body's mean twist (least-squares slope of its
   recorded pose over the judged steps) against the ``qdot`` block of the predicted mode it
   shows, within :data:`sim.compare.TWIST_TOLERANCE` of the drive speed (rotation weighted by
   the scene size). The run jams when the loop stops on a sustained total normal force above
   ``JAM_FORCE_OF_LOAD`` times the load (or the drive pushes the bodies into each other, a
   penetration fault): its steps from then on are ``JAM``, which agrees with a predicted jam.

``judge_mu`` different from ``mu`` is a negative control.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from sim.compare import JAM, TWIST_TOLERANCE, ObservedMode, Outcome, Verdict, compare_modes
from sim.system_run import ENGINE, JAM_FORCE_OF_LOAD, MAX_SPEED, RATE


@dataclass(frozen=True, eq=False)
class MultibodyRun:
    """Result of :func:`simulate_multibody`: ``verdict``; ``predicted`` labels (``["JAM"]`` for
    a predicted jam); ``observed`` label per judged step; ``twists`` ``(n_b, 3)`` observed mean
    twist per body divided by the drive speed; ``recording``."""

    verdict: Verdict
    predicted: list[str]
    observed: list[str]
    twists: np.ndarray
    recording: Any


def body_twists(rec: Any, n_bodies: int, mask: np.ndarray) -> np.ndarray:
    """``(n_b, 3)`` mean twist of each workpiece (bodies ``work0 ..``) over the ``mask`` steps:
    the least-squares slope of its recorded pose (angle unwrapped)."""
    out = np.zeros((n_bodies, 3))
    if mask.sum() < 3:
        return np.full((n_bodies, 3), np.nan)
    for a in range(n_bodies):
        pose = rec.poses[mask, rec.body_names.index(f"work{a}")].copy()
        pose[:, 2] = np.unwrap(pose[:, 2])
        out[a] = np.polyfit(rec.times[mask], pose, 1)[0]
    return out


def simulate_multibody(system: System, engine: str, *, mu: Any = None, judge_mu: Any = None,
                       judge_system: System | None = None,
                       duration: float | None = None) -> MultibodyRun:
    """Run ``system`` (contact velocities, ``n_b >= 1`` workpieces with geometry) on ``engine``
    at ``mu`` (default the file's) and judge it at ``judge_mu`` (default ``mu``), against the
    prediction of ``judge_system`` when given (a negative control: another system with the
    same contacts and bodies, e.g. pushed elsewhere)."""
    from planner.predict.feasibility import feasible_modes
    from sim.backends import ENGINES, make_backend
    from sim.classify import Thresholds, judged_mask, observed_modes
    from sim.compare import fault_verdict
    from sim.run import RunSettings, run_scene
    from sim.scenes.multibody import multibody_scene

    if engine not in ENGINES:
        raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    es = ENGINE[engine]
    sim_sys = system if mu is None else system.with_mu(mu)
    judge_sys = sim_sys if judge_mu is None else system.with_mu(judge_mu)
    if judge_system is not None:
        if (judge_system.n_contacts, judge_system.n_bodies) != (system.n_contacts,
                                                                system.n_bodies):
            raise InputError("judge_system: expected the same number of contacts and bodies "
                             f"({system.n_contacts}, {system.n_bodies}), got "
                             f"({judge_system.n_contacts}, {judge_system.n_bodies})")
        judge_sys = judge_system if judge_mu is None else judge_system.with_mu(judge_mu)
    duration = es["duration"] if duration is None else float(duration)
    vel = np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2)
    fastest = float(np.max(np.linalg.norm(vel, axis=1))) if system.virtual_joints else 0.0
    if not fastest > 0:
        raise InputError("simulate: expected contact velocities with at least one non-zero "
                         "command, got none")
    size = multibody_scene(sim_sys).length_scale
    drive = min(RATE[engine] * size, MAX_SPEED[engine])
    scale = drive / fastest
    scene = multibody_scene(sim_sys, speed_scale=scale)
    pred = feasible_modes(judge_sys.with_joint_inputs(np.asarray(judge_sys.joint_inputs) * scale))
    predicted: list[ObservedMode] = [m.mode for m in pred.all_modes] or [JAM]
    g = np.asarray(system.g_obj, dtype=float).reshape(-1, 3)
    load = float(max(np.max(np.linalg.norm(g[:, :2], axis=1)), np.max(np.abs(g[:, 2])) / size))
    # no per-step force or depth rule: a jam is the run's own (the loop stops when the total
    # normal force stays above JAM_FORCE_OF_LOAD x the load); MuJoCo's soft contacts breathe
    # (depth 1e-6 -> 2e-5 m within 0.1 s on a resting ruler), which the depth rule took for one
    th = replace(Thresholds.for_drive(drive, load, creep_floor=es["creep"],
                                      settle=es["settle"]), jam_depth_rate=np.inf)
    settings = RunSettings(duration=duration, dt=es["dt"], slip_speed=0.05 * drive,
                           penetration_tol=0.02 * size, jam_force=JAM_FORCE_OF_LOAD * load,
                           jam_after=es["settle"] + 0.2)
    rec = run_scene(scene, make_backend(engine), settings)
    labels = [str(m) if isinstance(m, str) else m.label for m in predicted]
    mask = judged_mask(rec, th)
    twists = body_twists(rec, system.n_bodies, mask) / drive
    if rec.fault is not None:
        if predicted == [JAM] and rec.fault.kind.value == "penetration":
            verdict = Verdict(Outcome.AGREED, (
                f"predicted jam; the drive pushed the bodies into each other: {rec.fault.reason}",
            ), agreement=1.0)
        else:
            verdict = fault_verdict(rec.fault)
        return MultibodyRun(verdict, labels, [], twists, rec)
    steps: list[ObservedMode] = list(observed_modes(rec, th))
    if rec.jammed_at is not None:
        steps = [JAM if t >= rec.jammed_at - th.window else o for o, t in zip(steps, rec.times)]
    observed = [o for o, k in zip(steps, mask) if k]
    obs_labels = [str(o) if isinstance(o, str) else o.label for o in observed]
    if predicted == [JAM]:  # a predicted jam is judged on the run: did the drive stall?
        jammed = rec.jammed_at is not None
        what = f"jammed at {rec.jammed_at:.3f} s" if jammed else "did not jam"
        verdict = Verdict(Outcome.AGREED if jammed else Outcome.DISAGREED,
                          (f"predicted jam; the run {what}",),
                          agreement=1.0 if jammed else 0.0, judged_steps=len(observed))
        return MultibodyRun(verdict, labels, obs_labels, twists, rec)
    verdict = compare_modes(observed, predicted)
    if verdict.outcome is Outcome.AGREED:
        shown = max(set(obs_labels), key=obs_labels.count)
        mode = next(m for m in pred.all_modes if m.label == shown)
        q = np.asarray(mode.qdot).reshape(-1, 3) / drive
        w = np.array([1.0, 1.0, size])
        err = float(np.max(np.linalg.norm((twists - q) * w, axis=1)))
        reason = (f"largest body twist error {err:.3f} of the drive speed for {shown} "
                  f"(tolerance {TWIST_TOLERANCE})")
        outcome = Outcome.AGREED if err <= TWIST_TOLERANCE else Outcome.DISAGREED
        verdict = replace(verdict, outcome=outcome, reasons=verdict.reasons + (reason,))
    return MultibodyRun(verdict, labels, obs_labels, twists, rec)
