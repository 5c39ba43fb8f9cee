"""The one simulation pipeline: a job describes a run completely; :func:`execute` runs any job in
any engine and judges it.

::

    system / plan / ruler  --job_for_*-->  SimJob(scene, settings, run settings, expectation,
                                                  thresholds, scale)
    SimJob  --execute-->  scaled scene -> engine limits (sim.limits.check_scene) -> backend
                          -> run loop -> recording (user units)
                          -> judge -> Judgement -> RunResult(summary, recording, judgement)

Everything that decides a run is in the job, built by one of three builders from the settings
table (:mod:`sim.settings`): :func:`job_for_system` (any system file: fingertips, chains,
environment surfaces, several workpieces; driven or static), :func:`job_for_plan` (a plan of any
hand: one segment or a whole task) and :func:`job_for_ruler`. The caller predicts (the planner's
:class:`~planner.predict.feasibility.Prediction`, a plan, or switch positions) and hands the
prediction in; the pipeline never enumerates modes.

Units: the job's scene, run settings, thresholds and expectation are in the user's units;
:func:`execute` simulates the similar scene of size inside :data:`sim.settings.SIZE_RANGE`
(:mod:`sim.similarity`) and maps the recording back before judging it, so every entry point --
``qsplan simulate``, ``validate``, ``scenarios run``, ``demo``, the validation campaign --
gets the verdict of the same scene at the same scale and speed.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.model.wedge import wedge_pairs
from sim.backends import make_backend
from sim.classify import Thresholds
from sim.consensus import engine_measures
from sim.expectation import Expectation, Judgement, ModeSet, Switches
from sim.judge import judge
from sim.limits import check_scene
from sim.run import Recording, RunSettings, run_scene
from sim.scene import Scene
from sim.schedule import contact_drive_speed, effort_force, plan_layout
from sim.settings import (
    EngineSettings,
    SceneKind,
    check_engine,
    scene_scale,
    settings_for,
    with_mass_for_load,
    with_stick_limits,
)
from sim.similarity import scaled_masses, scaled_scene, unscaled_recording
from sim.summary import RunSummary
from sim.verdict import Expect, mode_label

#: A total normal force above this multiple of the run's force scale is a jam (the scale: the
#: larger of the load and the largest total normal force certified by a mode predicted at the
#: simulated friction -- near a two-finger wedge the quasistatic forces are many times the load:
#: Example 4.1 at mu = .98 .82 .54, 34 N at a 1 N load, observed by pymunk to 0.5 %).
JAM_FORCE_OF_LOAD = 20.0
#: The classifier's slip threshold as a fraction of the drive speed (docs/simulation.md,
#: "Observed-mode classifier").
SLIP_OF_DRIVE = 0.05
#: Penetration deeper than this fraction of the scene size is a fault (a sound contact sinks
#: in by the pre-load and the engine's compliance, orders of magnitude less).
PENETRATION_OF_SIZE = 0.02
#: The ruler's run loop switches a contact to kinetic friction when its ``|v_t|`` exceeds this
#: fraction of the finger speed: a quasistatic switch is instantaneous; the rod needs
#: ``sqrt(2 m v_th / Fdot)`` to reach the threshold once the static capacity is exceeded and
#: the slider runs on by twice that times the speed (7.6 um at the first hand-over of 0.5 / 0.3
#: at 0.1 v, sqrt(5) less at 0.02 v); 0.02 v is still > 150 x the creep of a sticking finger in
#: either engine (docs/simulation.md, "The ruler against its closed form").
SWITCH_OF_SPEED = 0.02
#: A sticking contact may creep at this fraction of the classifier's slip threshold: where its
#: hysteresis leaves ``S`` (docs/simulation.md, "MuJoCo: friction creep").
CREEP_OF_SLIP = 0.5


@dataclass(frozen=True, eq=False)
class SimJob:
    """Everything that decides one run (module docstring): the ``scene`` and its
    ``expectation``, the engine and its ``settings``, the loop's ``run`` settings and the
    classifier's ``thresholds`` (all in user units), the similarity ``scale`` the scene is
    simulated at, and what the summary records (``name``, ``source``, ``expect``,
    ``parameters``, ``predicted``)."""

    kind: SceneKind
    engine: str
    scene: Scene
    settings: EngineSettings
    run: RunSettings
    thresholds: Thresholds
    expectation: Expectation
    scale: float = 1.0
    name: str = ""
    source: str | None = None
    expect: Expect = Expect.AGREE
    parameters: dict[str, Any] = field(default_factory=dict)
    predicted: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class RunResult:
    """One executed job: its ``summary``, the ``recording`` (user units), the
    ``judgement`` (verdict, observed mode per step, segments) and the ``job``."""

    job: SimJob
    summary: RunSummary
    recording: Recording
    judgement: Judgement

    @property
    def verdict(self) -> Any:
        return self.judgement.verdict


def execute(job: SimJob) -> RunResult:
    """Run ``job`` in its engine and judge it (module docstring)."""
    s = job.scale
    scene = scaled_masses(scaled_scene(job.scene, s), job.settings.mass_scale)
    check_scene(scene)  # the scene as built: InputError naming body, value, limit
    run = replace(job.run, slip_speed=job.run.slip_speed * s,
                  penetration_tol=job.run.penetration_tol * s)
    wall = time.perf_counter()
    backend = make_backend(job.engine, job.settings)
    rec = run_scene(scene, backend, run)
    wall = time.perf_counter() - wall
    rec = unscaled_recording(rec, s)
    judgement = judge(rec, job.expectation, job.thresholds)
    measures = engine_measures(rec, job.expectation, job.thresholds,
                               length_scale=job.scene.length_scale,
                               capped_solves=getattr(backend, "unconverged", None),
                               solves=getattr(backend, "solves", None))
    verdict = judgement.verdict
    observed = judgement.observed
    bodies = [b for b in ("workpiece", "work0") if b in rec.body_names]
    final_pose = rec.poses[-1, rec.body_names.index(bodies[0])].tolist() if (
        bodies and len(rec.times)) else None
    obs: dict[str, Any] = {
        "counts": dict(verdict.observed_counts), "judged_steps": verdict.judged_steps,
        "final": mode_label(observed[-1]) if observed else None,
        "workpiece_final_pose": final_pose, "jammed_at_s": rec.jammed_at,
        "fault": rec.fault.reason if rec.fault else None,
        "segments": observed_segments(observed, rec.times), "engine_measures": measures}
    if judgement.details:
        obs.update(judgement.details)
    summary = RunSummary(
        name=job.name, kind=job.kind.value, engine=job.engine, source=job.source,
        expect=job.expect, verdict=verdict,
        parameters={**job.parameters, **_run_parameters(job, rec), **(
            {"impratio": backend.impratio_used} if hasattr(backend, "impratio_used") else {})},
        predicted=job.predicted, observed=obs,
        segments=tuple(sv.to_dict() for sv in judgement.segments), wall_time_s=wall)
    return RunResult(job, summary, rec, judgement)


def _run_parameters(job: SimJob, rec: Recording) -> dict[str, Any]:
    es, th, run = job.settings, job.thresholds, job.run
    return {"scene_scale": job.scale, "dt_s": run.dt, "duration_s": run.duration,
            "steps": len(rec.times), "settle_s": th.settle,
            "slip_speed_m_per_s": th.slip_speed, "force_floor_N": th.force_floor,
            "window_s": th.window, "jam_force_N": run.jam_force if np.isfinite(run.jam_force)
            else None, "start_ramp_s": run.start_ramp, "command_ramp_s": es.ramp,
            "mass_scale": es.mass_scale, "creep_floor_m_per_s": es.creep}


def observed_segments(observed: Sequence[Any], times: np.ndarray) -> list[dict[str, Any]]:
    """Runs of equal observed modes: ``[{"mode", "start_s", "end_s"}, ...]``."""
    out: list[dict[str, Any]] = []
    for o, t in zip(observed, np.asarray(times, dtype=float)):
        lab = mode_label(o)
        if out and out[-1]["mode"] == lab:
            out[-1]["end_s"] = float(t)
        else:
            out.append({"mode": lab, "start_s": float(t), "end_s": float(t)})
    return out


def stick_limited(settings: EngineSettings, force: float, thresholds: Thresholds,
                  scale: float) -> EngineSettings:
    """``settings`` with the stick limits of a run (:func:`sim.settings.with_stick_limits`; the
    one rule for any job whose contacts creep by MuJoCo's soft friction): ``force`` [N, user
    units] the largest normal force a contact of the run carries, and a creep speed of
    :data:`CREEP_OF_SLIP` times the slip threshold of ``thresholds`` [m/s, user units] at the
    simulated size (``scale`` [-], the job's similarity factor; forces are scale-free). MuJoCo
    raises its ``impratio`` so that a contact sticking under ``mu force`` creeps no faster.
    Plan runs carry them (a jointed finger's contact creeps: noslip does not act on it);
    system runs do not (their workpieces are free bodies, whose contacts noslip holds, and a
    higher impratio cost agreeing runs: docs/simulation.md, "MuJoCo: friction creep")."""
    return with_stick_limits(settings, force, CREEP_OF_SLIP * thresholds.slip_speed * scale)


# ---- systems ------------------------------------------------------------------------------
def force_scale(modes: Sequence[Any], load: float) -> float:
    """The run's force scale [N]: the larger of ``load`` and the largest total normal force of
    a mode's certificate among ``modes`` (those predicted at the simulated friction)."""
    totals = [float(np.sum(np.asarray(m.contact_forces, dtype=float)[:, 0])) for m in modes]
    return max([load, *totals])


def system_load(system: System, size: float) -> float:
    """The load [N] that keeps a system's contacts closed: the largest in-plane force of its
    bodies' external wrenches, or moment over ``size`` [m]."""
    g = np.asarray(system.g_obj, dtype=float).reshape(-1, 3)
    return float(max(np.max(np.linalg.norm(g[:, :2], axis=1)), np.max(np.abs(g[:, 2])) / size))


def job_for_system(system: System, engine: str, prediction: Any, *,
                   judge_system: System | None = None, reference: Any = None,
                   mu_kinetic: np.ndarray | None = None, duration: float | None = None,
                   speed: float | None = None, name: str = "", source: str | None = None,
                   expect: Expect = Expect.AGREE,
                   parameters: dict[str, Any] | None = None) -> SimJob:
    """The job of simulating ``system`` (at its own friction) in ``engine`` and judging it
    against ``prediction`` (a :class:`planner.predict.feasibility.Prediction` of
    ``judge_system``, default ``system``; a negative control judges against another
    friction's or system's prediction). ``reference``: the prediction at the simulated
    friction (the force scale; default ``prediction``); ``mu_kinetic`` (n_c,) kinetic
    coefficients; ``duration`` [s] (default the settings'); ``speed`` [m/s] of the fastest
    contact (default the settings' drive speed). A system with no commanded motion is a static
    question: does it stay (its predicted equilibria) or move (none predicted)?"""
    from sim.scenes.system import (
        commanded_contact_speed,
        system_scene,
        system_size,
        workpiece_names,
    )

    kind = SceneKind.SYSTEM
    es = settings_for(kind, engine)
    size = system_size(system)
    s = scene_scale(size)
    fastest = commanded_contact_speed(system)
    static = not fastest > 0
    drive = es.drive_speed(size * s) / s if speed is None else float(speed)
    if not (np.isfinite(drive) and drive > 0):
        raise InputError(f"--speed: expected a finite speed > 0 [m/s], got {speed}")
    factor = 1.0 if static else drive / fastest
    duration = es.duration if duration is None else float(duration)
    if not (np.isfinite(duration) and es.settle < duration <= 600.0):
        raise InputError(f"--duration: expected seconds in ({es.settle}, 600] (longer than "
                         f"the {es.settle} s settling time on {engine}), got {duration}")
    load = system_load(system, size)
    if not load > 0:
        raise InputError("simulate: expected a non-zero external wrench (the load that keeps "
                         "the contacts closed), got zero")
    scene = system_scene(system, speed_scale=factor, mu_kinetic=mu_kinetic)
    es = with_mass_for_load(es, load, min(scene.meta["masses"]), size * s)
    ref = prediction if reference is None else reference
    scale_f = force_scale(ref.all_modes, load)
    jam_force = JAM_FORCE_OF_LOAD * scale_f
    # the force floor of a "breaking" contact is a fraction of the load; force errors and the
    # jam rules use the force scale (a near-wedge mode's forces are many times the load)
    th = replace(Thresholds.for_drive(drive, load, creep_floor=es.creep / s, settle=es.settle,
                                      jam_force=jam_force, length_scale=size),
                 load=scale_f, jam_depth_force=scale_f)
    # no stick limits: a system scene's workpieces are free bodies (MuJoCo's out-of-plane
    # slide), whose contacts' friction noslip re-solves without the soft creep the limits bound
    # (docs/simulation.md, "MuJoCo: friction creep")
    wedges = wedge_pairs(system)
    ramp = es.start_ramp if not static and (es.ramp_always or wedges) else 0.0
    run = RunSettings(duration=duration, dt=es.dt, slip_speed=SLIP_OF_DRIVE * drive,
                      penetration_tol=PENETRATION_OF_SIZE * size, jam_force=jam_force,
                      jam_after=es.settle + 0.2, start_ramp=ramp,
                      record_every=es.record_every)
    expectation = ModeSet(tuple(prediction.all_modes), judge_system or system, factor,
                          workpiece_names(system.n_bodies), drive, size, scale_f,
                          static=static, load=load)
    params = {"mu": np.asarray(system.mu).tolist(),
              "mu_kinetic": None if mu_kinetic is None else np.asarray(mu_kinetic).tolist(),
              "judge_mu": np.asarray((judge_system or system).mu).tolist(),
              "n_bodies": system.n_bodies, "size_m": size, "static": static,
              "drive_speed_m_per_s": drive, "speed_scale": factor, "load_N": load,
              "force_scale_N": scale_f, "wedge_pairs": [list(p) for p in wedges],
              "derived_workpiece": scene.meta["derived_workpiece"],
              "masses_kg": scene.meta["masses"], "environment": scene.meta["environment"],
              "preload_m": scene.meta["preload_m"], "finger_radius_m": scene.meta["finger_radius"],
              **(parameters or {})}
    predicted = {"labels": expectation.labels, "status": prediction.status.value,
                 "certificate": prediction.to_dict()}
    return SimJob(kind, check_engine(engine), scene, es, run, th, expectation, s, name, source,
                  expect, params, predicted)


# ---- plans --------------------------------------------------------------------------------
def job_for_plan(plan: Any, engine: str, mu: Any, *, torques: np.ndarray | None = None,
                 waypoints: int | None = None,
                 name: str = "", source: str | None = None, expect: Expect = Expect.AGREE,
                 parameters: dict[str, Any] | None = None) -> SimJob:
    """The job of running ``plan`` (a :class:`planner.plan.model.Plan` or one of its
    segments) in ``engine`` at friction ``mu`` (one coefficient, or one per contact of the
    plan's contact union) and judging every segment and the whole. ``torques`` replaces a
    one-segment plan's efforts (a negative control); ``waypoints`` runs only the first so
    many waypoints of it. Slow motion: a plan whose fastest contact would move
    faster than the settings' drive speed runs that many times slower (every rate divided,
    every time multiplied: the quasistatic modes do not change)."""
    from planner.model.validation import as_friction
    from sim.scenes.hand import hand_scene

    kind = SceneKind.HAND
    es = settings_for(kind, engine)
    lay = plan_layout(plan, torques=torques, waypoints=waypoints)
    h = lay.hand
    size = h.length_scale
    s = scene_scale(size)
    drives = [contact_drive_speed(hk, q, sk.controls, sk.commands)
              for hk, q, sk in zip(lay.hands, lay.q_starts, lay.schedules)]
    limit = es.drive_speed(size * s) / s
    slow = max(1.0, max(drives) / limit)
    lay = lay.slowed(slow)
    drives = [d / slow for d in drives]
    squeeze = max(effort_force(hk, q, sk.controls, sk.commands)
                  for hk, q, sk in zip(lay.hands, lay.q_starts, lay.schedules))
    load = float(np.linalg.norm(h.load_force)) or 1e-3
    es = with_mass_for_load(es, max(load, squeeze), h.mass, size * s)
    mu_arr = as_friction(mu, h.n_contacts)
    first = lay.schedules[0]
    scene = hand_scene(h, lay.q0, mu_arr, first.controls, lay.commands(es.ramp),
                       site_configs=lay.site_configs,
                       open_sites=[i for i in range(h.n_contacts) if i not in lay.members[0]])
    creep = es.creep / s
    exp = lay.expectation()
    exp = replace(exp, segments=tuple(
        replace(seg, drive=d, slip_speed=max(SLIP_OF_DRIVE * d, 10.0 * creep))
        for seg, d in zip(exp.segments, drives)))
    th = replace(Thresholds.for_drive(min(drives), load, creep_floor=creep, settle=es.settle,
                                      length_scale=size), jam_depth_rate=np.inf)
    # a sticking contact holds its friction on the load plus the squeeze
    # (docs/simulation.md, "MuJoCo: friction creep")
    es = stick_limited(es, load + squeeze, th, s)
    run = RunSettings(duration=lay.duration, dt=es.dt, slip_speed=SLIP_OF_DRIVE * min(drives),
                      penetration_tol=PENETRATION_OF_SIZE * size, record_every=es.record_every,
                      open_at_start=lay.open_at_start, control_switches=lay.control_switches())
    params = {"mu": mu_arr.tolist(), "size_m": size, "slow_motion": slow,
              "drive_speed_m_per_s": max(drives), "segments": len(lay.schedules),
              "control": [list(sk.controls) for sk in lay.schedules],
              "waypoints": [len(sk.times) for sk in lay.schedules],
              "load_N": load, "squeeze_N": squeeze, **(parameters or {})}
    predicted = {"claims": [sk.claim.label for sk in lay.schedules],
                 "labels": sorted({mode_label(m) for sk in lay.schedules for p in sk.predicted
                                   for m in p})}
    return SimJob(kind, check_engine(engine), scene, es, run, th, exp, s, name, source, expect,
                  params, predicted)


# ---- the ruler ----------------------------------------------------------------------------
def job_for_ruler(engine: str, *, mu_s: float, mu_k: float, positions: Sequence[float],
                  sliders: Sequence[int], left: float = -0.4, right: float = 0.25,
                  length: float = 0.1, speed: float | None = None, required: int = 5,
                  tolerance: float = 0.02, weight: float = 1.0, mass: float = 0.1,
                  name: str = "", expect: Expect = Expect.AGREE,
                  parameters: dict[str, Any] | None = None) -> SimJob:
    """The job of the ruler (Sec. 5.1): a rod of ``length`` [m], ``weight`` [N] on two fingers
    at ``left * length`` and ``right * length`` from its centre of mass approaching each other
    at ``speed`` [m/s] (default the settings'), static / kinetic friction ``mu_s`` / ``mu_k``,
    judged against the predicted switch ``positions`` [m] and ``sliders`` (from the planner or
    the closed form, :mod:`planner.predict.ruler`)."""
    from sim.scenes.ruler import ruler_scene

    kind = SceneKind.RULER
    es = settings_for(kind, engine)
    s = scene_scale(0.5 * length)
    v = es.drive_speed(0.5 * length * s) / s if speed is None else float(speed)
    x_left, x_right = left * length, right * length
    min_d = 0.015 * length
    scene = ruler_scene(length=length, weight=weight, mass=mass, x_left=x_left,
                        x_right=x_right, speed=v, mu_s=mu_s,
                        mu_k=None if mu_k == mu_s else mu_k, finger_radius=0.03 * length)
    duration = (x_right - x_left - 2 * min_d) / (2 * v)
    th = Thresholds.for_drive(v, weight, creep_floor=es.creep / s, settle=es.settle,
                              length_scale=length)
    run = RunSettings(duration=duration, dt=es.dt, slip_speed=SWITCH_OF_SPEED * v,
                      penetration_tol=0.01 * length, record_every=es.record_every)
    need = min(required, len(positions))
    exp = Switches(tuple(float(p) for p in positions), tuple(int(i) for i in sliders), need,
                   tolerance)
    params = {"mu_static": mu_s, "mu_kinetic": mu_k, "length_m": length, "left": left,
              "right": right, "finger_x_m": [x_left, x_right], "speed_m_per_s": v,
              "weight_N": weight, "mass_kg": mass, "tolerance": tolerance,
              **(parameters or {})}
    predicted = {"labels": ["S+1 R2" if i == 0 else "R1 S-2" for i in sliders],
                 "switch_positions_m": list(exp.positions), "sliding_finger": list(exp.sliders)}
    return SimJob(kind, check_engine(engine), scene, es, run, th, exp, s, name, None, expect,
                  params, predicted)
