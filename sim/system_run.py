"""Simulate any system file and judge the run against the planner's prediction (issue 14).

:func:`simulate_system` is the whole check behind ``qsplan simulate``:

1. **predict** -- :func:`planner.predict.feasibility.feasible_modes` at the judging friction
   (``judge_mu``, default the simulated ``mu``), as ``qsplan modes`` does; a positive
   scaling of every contact velocity (slow motion) leaves the feasible mode set unchanged, and
   the prediction is made on the system with its contact velocities scaled to the scene's
   (the certificate's ``qdot`` is then the twist the run should show);
2. **build** the scene (:func:`sim.scenes.system.system_scene`) at the simulated ``mu``;
3. **run** it in slow motion (:func:`sim.run.run_scene`): the fastest contact moves at
   ``min(RATE[engine] * size, MAX_SPEED[engine])`` [m/s] (``size``: the scene's length scale)
   unless ``speed`` is given;
4. **classify** the simulator's own contact data (:mod:`sim.classify`) -- never the
   prediction -- and **compare** (:mod:`sim.compare`, one :class:`~sim.compare.Verdict`).

``judge_mu`` different from ``mu`` is a negative control: the run is judged against the
prediction at friction it was not run at.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from sim.backends import (
    SUPPORT_IMPRATIO,
    SUPPORT_SOLREF,
    SYSTEM_HEAVY_RATIO,
    EngineSettings,
    soft_squeeze,
)
from sim.compare import JAM, ObservedMode, Verdict

#: Slow-motion drive rate per engine [1/s]: the fastest contact moves this many scene sizes per
#: second, at most ``MAX_SPEED`` [m/s] (pymunk 2 mm/s and MuJoCo 0.5 mm/s, the paper examples'
#: settings in ``scenarios/paper_sims.py``; SIM-NOTES: MuJoCo's sliding contacts chatter above
#: 3-5 mm/s whatever the scene size).
RATE = {"pymunk": 0.02, "mujoco": 0.005}
MAX_SPEED = {"pymunk": 2e-3, "mujoco": 5e-4}
#: Time step [s], creep floor of a sticking contact [m/s], default duration and settling time
#: [s] per engine (the creep floors are SIM-NOTES measurements; MuJoCo's soft contacts need a
#: longer start transient).
ENGINE = {
    "pymunk": {"dt": 1e-3, "creep": 1e-9, "duration": 1.5, "settle": 0.3},
    "mujoco": {"dt": 1e-3, "creep": 1e-8, "duration": 2.5, "settle": 1.0},
}
#: Backend settings of system scenes per engine: MuJoCo with the soft, damped squeeze pairs
#: (:func:`sim.backends.soft_squeeze`, docs/simulation.md "MuJoCo: the sliding lift-off"),
#: driven bodies :data:`sim.backends.SYSTEM_HEAVY_RATIO` times the workpiece's mass and the
#: sliding supports' solref and impratio (:data:`sim.backends.SUPPORT_SOLREF`,
#: :data:`sim.backends.SUPPORT_IMPRATIO`; "MuJoCo: sliding supports").
SYSTEM_SETTINGS = {
    "pymunk": EngineSettings(),
    "mujoco": soft_squeeze(EngineSettings(heavy_ratio=SYSTEM_HEAVY_RATIO,
                                          support_solref=SUPPORT_SOLREF,
                                          support_impratio=SUPPORT_IMPRATIO)),
}
#: A total normal force above this multiple of the run's force scale is a jam: the scale is the
#: larger of the load and the largest total normal force certified by a mode predicted at the
#: *simulated* friction (:func:`force_scale`). Near a two-finger wedge the quasistatic forces
#: are many times the load (Example 4.1 at mu = .98 .82 .54: 34 N at a 1 N load, observed by
#: pymunk to 0.5 %), so a bare multiple of the load stopped sound runs.
JAM_FORCE_OF_LOAD = 20.0
#: The drive rises from rest over this fraction of the settling time (smoothstep,
#: :func:`sim.run.ramped`): a velocity step wedged Example 4.3 at mu = .86 .42 .95 in pymunk
#: (33 N in the first step at a 1 N load; ramped: 1.2 N and the predicted mode).
RAMP_OF_SETTLE = 0.5
#: :func:`stick_slip_verdict`: relative twist error [-] within which the workpiece "moves as
#: predicted", and the fraction of judged contact-steps missing above which the engine is
#: said not to resolve the modes (pymunk runs of the box and the disc miss none).
TWIST_TOLERANCE = 0.1
LOST_FRACTION = 0.01


@dataclass(frozen=True, eq=False)
class SystemRun:
    """The result of :func:`simulate_system`: the verdict, the JSON-ready summary, the
    recording, the observed mode per recorded step and the scene (for drawing)."""

    verdict: Verdict
    summary: dict[str, Any]
    recording: Any
    observed: list[ObservedMode]
    predicted: list[ObservedMode]
    scene: Any


def force_scale(prediction: Any, load: float) -> float:
    """The run's force scale [N]: the larger of ``load`` and the largest total normal force of
    a mode of ``prediction`` (its certificate; the simulated friction's prediction, never the
    judged one, so a negative control is judged on the same run)."""
    totals = [float(np.sum(np.asarray(m.contact_forces, dtype=float)[:, 0]))
              for m in prediction.all_modes]
    return max([load, *totals])


def judge_recording(rec: Any, prediction: Any, engine: str, drive: float, load: float,
                    size: float, jam_force: float | None = None
                    ) -> tuple[Verdict, list[ObservedMode], Any]:
    """Classify ``rec`` (simulator contact data only) and judge it against ``prediction`` (a
    :class:`planner.predict.feasibility.Prediction`): ``(verdict, observed modes,
    thresholds)``. ``drive`` [m/s] fastest contact speed, ``load`` [N], ``size`` [m];
    ``jam_force`` [N] total normal force of a jam (default ``JAM_FORCE_OF_LOAD * load``; pass
    the run's ``parameters.jam_force_N``).

    Works with both classifier interfaces of :func:`sim.classify.judge_run` (predicted modes
    plus ``jam_force``, or the feasible modes with the jam force in the thresholds) so this
    module does not depend on the order the two are merged in."""
    import inspect

    from sim.classify import Thresholds, judge_run

    es = ENGINE[engine]
    jam_force = JAM_FORCE_OF_LOAD * load if jam_force is None else float(jam_force)
    if "jam_force" in inspect.signature(judge_run).parameters:
        th = Thresholds.for_drive(drive, load, creep_floor=es["creep"], settle=es["settle"])
        modes: list[ObservedMode] = [m.mode for m in prediction.all_modes] or [JAM]
        verdict, observed = judge_run(rec, th, modes, jam_force=jam_force)  # type: ignore[call-arg,arg-type,unused-ignore]
    else:
        th = Thresholds.for_drive(drive, load, creep_floor=es["creep"],  # type: ignore[call-arg,unused-ignore]
                                  settle=es["settle"], jam_force=jam_force, length_scale=size)
        # force errors relative to the run's force scale (the load amplified by a near-wedge
        # mode amplifies every geometric error by the same factor), never below the load
        scale = max(load, jam_force / JAM_FORCE_OF_LOAD)
        th = replace(th, load=scale, jam_depth_force=scale)
        verdict, observed = judge_run(rec, th, list(prediction.all_modes))
    return stick_slip_verdict(verdict, rec, prediction, es["settle"], size), observed, th


def stick_slip_verdict(verdict: Verdict, rec: Any, prediction: Any, settle: float,
                       size: float) -> Verdict:
    """A ``disagreed`` label comparison becomes ``inconclusive`` when the engine measurably
    cannot resolve the contact modes although the workpiece moves as predicted: the mean
    workpiece twist over the judged steps (least-squares slope of the recorded pose) is within
    ``TWIST_TOLERANCE`` of a predicted mode's ``qdot`` (relative, rotation weighted by the
    scene size) while contacts go missing on more than ``LOST_FRACTION`` of the judged steps
    (stick-slip or chatter; a resting contact is never missing in a sound run). Contacts that
    the nearest predicted mode (by twist) breaks are not counted (their absence is predicted)."""

    from sim.compare import Outcome

    if verdict.outcome is not Outcome.DISAGREED or not prediction.all_modes:
        return verdict
    k = rec.times >= settle
    if k.sum() < 3:
        return verdict
    iw = rec.body_names.index("workpiece")
    pose = rec.poses[k, iw].copy()
    pose[:, 2] = np.unwrap(pose[:, 2])
    twist = np.polyfit(rec.times[k], pose, 1)[0]
    wvec = np.array([1.0, 1.0, size])
    errors = [float(np.linalg.norm((twist - np.asarray(m.qdot)) * wvec)
                    / max(float(np.linalg.norm(np.asarray(m.qdot) * wvec)), 1e-300))
              for m in prediction.all_modes]
    from planner.model.modes import BREAK

    # contacts the nearest predicted mode (by twist) keeps closed (a broken one may be absent)
    nearest = prediction.all_modes[int(np.argmin(errors))]
    kept = np.array([c != BREAK for c in nearest.mode.codes], dtype=bool)
    if not kept.any():
        return verdict
    lost = float(np.mean(~rec.present[k][:, kept]))
    if min(errors) > TWIST_TOLERANCE or lost <= LOST_FRACTION:
        return verdict
    return replace(verdict, outcome=Outcome.INCONCLUSIVE, reasons=verdict.reasons + (
        f"the workpiece's mean twist is within {min(errors):.1%} of a predicted qdot but "
        f"contacts are missing on {lost:.1%} of the judged steps (stick-slip or chatter): "
        "this engine cannot resolve the contact modes here",))


def simulate_system(system: System, engine: str, *, mu: Any = None, mu_kinetic: Any = None,
                    judge_mu: Any = None, duration: float | None = None,
                    speed: float | None = None,
                    engine_settings: Any = None) -> SystemRun:
    """Run ``system`` on ``engine`` at ``mu`` (default the file's) and judge it at
    ``judge_mu`` (default ``mu``). ``duration`` [s]; ``speed`` [m/s] of the fastest contact;
    ``engine_settings``: the backend's :class:`sim.backends.EngineSettings` (default:
    :data:`SYSTEM_SETTINGS`)."""
    from planner.predict.feasibility import feasible_modes
    from sim.backends import ENGINES, make_backend
    from sim.run import RunSettings, run_scene
    from sim.scenes.system import commanded_contact_speed, scale_velocities, system_scene

    if engine not in ENGINES:
        raise InputError(f"--engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    es = ENGINE[engine]
    sim_sys = system if mu is None else system.with_mu(mu)
    judge_sys = sim_sys if judge_mu is None else system.with_mu(judge_mu)
    muk = None
    if mu_kinetic is not None:
        muk = np.asarray(system.with_mu(mu_kinetic).mu, dtype=float)
    duration = es["duration"] if duration is None else float(duration)
    if not (np.isfinite(duration) and es["settle"] < duration <= 600.0):
        raise InputError(f"--duration: expected seconds in ({es['settle']}, 600] (longer than "
                         f"the {es['settle']} s settling time on {engine}), got {duration}")
    fastest = commanded_contact_speed(system)  # chains: |J_i thetadot| (sim.scenes.system)
    probe = system_scene(sim_sys)  # checks the geometry; gives the scene size
    size = probe.length_scale
    if not fastest > 0:
        raise InputError("simulate: expected at least one non-zero commanded contact velocity, "
                         "got none (nothing would move)")
    drive = min(RATE[engine] * size, MAX_SPEED[engine]) if speed is None else float(speed)
    if not (np.isfinite(drive) and drive > 0):
        raise InputError(f"--speed: expected a finite speed > 0 [m/s], got {speed}")
    scale = drive / fastest
    scene = system_scene(sim_sys, speed_scale=scale, mu_kinetic=muk)
    # predicted at the scene's speeds, so the certificate's qdot is the twist to observe
    pred = feasible_modes(scale_velocities(judge_sys, scale))
    predicted: list[ObservedMode] = [m.mode for m in pred.all_modes] or [JAM]
    g = np.asarray(system.g_obj, dtype=float)
    load = max(float(np.linalg.norm(g[:2])), abs(float(g[2])) / size)
    if not load > 0:
        raise InputError("simulate: expected a non-zero external wrench (the load that keeps "
                         "the contacts closed), got zero")
    sim_pred = pred if judge_mu is None else feasible_modes(
        sim_sys.with_joint_inputs(np.asarray(sim_sys.joint_inputs) * scale))
    jam_force = JAM_FORCE_OF_LOAD * force_scale(sim_pred, load)
    ramp = RAMP_OF_SETTLE * es["settle"]
    settings = RunSettings(duration=duration, dt=es["dt"], slip_speed=0.05 * drive,
                           penetration_tol=0.02 * size, jam_force=jam_force,
                           jam_after=es["settle"] + 0.2, start_ramp=ramp)
    rec = run_scene(scene, make_backend(engine, engine_settings or SYSTEM_SETTINGS[engine]),
                    settings)
    verdict, observed, th = judge_recording(rec, pred, engine, drive, load, size, jam_force)
    iw = rec.body_names.index("workpiece")
    summary: dict[str, Any] = {
        "engine": engine,
        **verdict.to_dict(),
        "parameters": {
            "mu": np.asarray(sim_sys.mu).tolist(),
            "mu_kinetic": None if muk is None else muk.tolist(),
            "judge_mu": np.asarray(judge_sys.mu).tolist(),
            "negative_control": judge_mu is not None
            and not np.array_equal(np.asarray(judge_sys.mu), np.asarray(sim_sys.mu)),
            "length": size, "drive_speed_m_per_s": drive, "speed_scale": scale,
            "duration_s": duration, "dt_s": es["dt"], "mass_kg": scene.meta["mass"],
            "derived_workpiece": scene.meta["derived_workpiece"],
            "environment": scene.meta["environment"], "preload_m": scene.meta["preload_m"],
            "finger_radius_m": scene.meta["finger_radius"],
            "slip_speed_m_per_s": th.slip_speed, "force_floor_N": th.force_floor,
            "settle_s": th.settle, "jam_force_N": jam_force, "start_ramp_s": ramp,
        },
        "predicted": {"labels": [str(m) if isinstance(m, str) else m.label for m in predicted],
                      "status": pred.status.value, "certificate": pred.to_dict()},
        "observed": {"counts": dict(verdict.observed_counts),
                     "judged_steps": verdict.judged_steps,
                     "final": (str(observed[-1]) if isinstance(observed[-1], str)
                               else observed[-1].label) if observed else None,
                     "workpiece_final_pose": rec.poses[-1, iw].tolist() if len(rec.times)
                     else None,
                     "jammed_at_s": rec.jammed_at,
                     "fault": rec.fault.reason if rec.fault else None},
    }
    return SystemRun(verdict, summary, rec, observed, predicted, scene)
