"""Run a plan in a simulator and compare what happens with what the plan says (issue 5).

Reads only the plan (:class:`planner.plan.plan_file.Plan`: the hand it embeds, the control partition, the
per-waypoint commands, predicted modes and poses); nothing from the planner's internals.

Execution (:func:`run_plan`): the hand scene of :mod:`sim.scenes.hand` at the given friction,
the velocity-controlled joint at the waypoint's ``velocity_command`` and the effort-controlled
joint at its ``torque_command``, each held from one waypoint to the next (the change at a
waypoint is ramped linearly over ``ramp`` seconds: SIM-NOTES, stepped loads make MuJoCo's
contacts bounce), for the plan's duration in slow motion (the plan's own rates: a few mm/s at
the contacts). Observed modes come from contact data only (:mod:`sim.classify`).

Comparison (:func:`compare`), acceptance of issue 5:

* ``claim_fraction``: fraction of the settled steps whose observed mode is the plan's claim;
  required ``>= 0.95``;
* ``predicted_fraction``: fraction of settled steps whose observed mode is in the plan's
  ``predicted`` set of the waypoint interval the step is in (reported; for a correct plan it
  equals ``claim_fraction``; for the negative control it shows the rival was predicted right);
* final workpiece position: Euclidean distance of the simulated and predicted ``(x, y)`` at the
  last waypoint divided by the predicted travel (path length over the waypoints); required
  ``<= 0.02``. The orientation error (rad) and the per-waypoint errors are reported alongside.

``PASSED`` when both hold, ``FAILED`` otherwise (with reasons), ``FAULT`` on any simulator fault
(:mod:`sim.run`): a fault says nothing about the plan and is never a pass.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError
from sim.render import COLOURS, ORDER, _plt
from sim.render import _tokens as _render_tokens

MODE_FRACTION_REQUIRED = 0.95
POSE_TOLERANCE_OF_TRAVEL = 0.02


class ExecStatus(str, Enum):
    PASSED = "passed"
    FAILED = "failed"
    FAULT = "fault"


@dataclass(frozen=True)
class Comparison:
    """Observed vs predicted modes and poses of one run.

    ``claim_fraction`` / ``predicted_fraction``: see the module docstring (0..1, over
    ``settled_steps`` steps); ``final_error`` [m]; ``travel`` [m] predicted path length;
    ``final_error_of_travel`` = final_error / travel; ``final_angle_error`` [rad];
    ``max_error_of_travel``: largest waypoint position error / travel; ``observed_counts``:
    label -> settled steps; ``waypoint_observed``: per hold interval the most frequent observed
    label; ``reasons``: why it failed or faulted (empty if passed).
    """

    status: ExecStatus
    claim: str
    claim_fraction: float
    predicted_fraction: float
    settled_steps: int
    final_error: float
    travel: float
    final_error_of_travel: float
    final_angle_error: float
    max_error_of_travel: float
    observed_counts: tuple[tuple[str, int], ...]
    waypoint_observed: tuple[str, ...]
    reasons: tuple[str, ...]

    @property
    def agree_fraction(self) -> float:
        return self.claim_fraction

    def to_dict(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "claim": self.claim,
            "claim_fraction": self.claim_fraction,
            "predicted_fraction": self.predicted_fraction,
            "settled_steps": self.settled_steps,
            "final_error_m": self.final_error,
            "travel_m": self.travel,
            "final_error_of_travel": self.final_error_of_travel,
            "final_angle_error_rad": self.final_angle_error,
            "max_error_of_travel": self.max_error_of_travel,
            "observed_counts": dict(self.observed_counts),
            "waypoint_observed": list(self.waypoint_observed),
            "reasons": list(self.reasons),
        }


def _poses(name: str, value: Any, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n, 3):
        raise InputError(f"{name}: expected shape ({n}, 3) (x, y, theta per waypoint), "
                         f"got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got NaN or inf")
    return arr


def _counts(labels: Sequence[str]) -> dict[str, int]:
    out: dict[str, int] = {}
    for lab in labels:
        out[lab] = out.get(lab, 0) + 1
    return out


def compare(
    claim: str,
    observed: Sequence[str],
    predicted: Sequence[Sequence[str]],
    predicted_poses: Any,
    simulated_poses: Any,
    *,
    interval: Sequence[int] | None = None,
    mode_fraction: float = MODE_FRACTION_REQUIRED,
    pose_tolerance: float = POSE_TOLERANCE_OF_TRAVEL,
) -> Comparison:
    """Compare observed modes and poses with a plan's claim, predictions and poses.

    ``observed`` (m,) labels of the settled steps; ``predicted`` (m,) the predicted label set
    of each step's waypoint interval; ``interval`` (m,) that interval's index (default: all
    0); ``predicted_poses``, ``simulated_poses`` (n, 3) ``(x, y, theta)`` at the n waypoints.
    """
    m = len(observed)
    if m == 0:
        raise InputError("observed: expected at least one settled step, got none")
    if len(predicted) != m:
        raise InputError(f"predicted: expected {m} label sets (one per step), got {len(predicted)}")
    n = len(np.asarray(predicted_poses, dtype=float))
    if n < 2:
        raise InputError(f"predicted_poses: expected at least 2 waypoints, got {n}")
    pred = _poses("predicted_poses", predicted_poses, n)
    simu = _poses("simulated_poses", simulated_poses, n)
    idx = np.zeros(m, dtype=int) if interval is None else np.asarray(interval, dtype=int)
    if idx.shape != (m,):
        raise InputError(f"interval: expected {m} indices, got shape {idx.shape}")
    claim_frac = float(np.mean([o == claim for o in observed]))
    pred_frac = float(np.mean([o in p for o, p in zip(observed, predicted)]))
    travel = float(np.sum(np.linalg.norm(np.diff(pred[:, :2], axis=0), axis=1)))
    if travel <= 0.0:
        raise InputError("predicted_poses: expected a segment with positive travel, got 0")
    errs = np.linalg.norm(simu[:, :2] - pred[:, :2], axis=1)
    err = float(errs[-1])
    ang = float(abs(simu[-1, 2] - pred[-1, 2]))
    counts = _counts(observed)
    per_wp = []
    for k in range(int(idx.max()) + 1 if m else 0):
        labs = [o for o, j in zip(observed, idx) if j == k]
        per_wp.append(max(_counts(labs).items(), key=lambda kv: kv[1])[0] if labs else "")
    reasons = []
    if claim_frac < mode_fraction:
        others = sorted(((c, lab) for lab, c in counts.items() if lab != claim), reverse=True)
        top = (f"; most observed instead: {others[0][1]!r} ({others[0][0] / m:.1%})"
               if others else "")
        reasons.append(f"claimed mode {claim!r} observed on {claim_frac:.1%} of the segment, "
                       f"required {mode_fraction:.0%}{top}")
    if err / travel > pose_tolerance:
        reasons.append(f"final position off by {err:.4g} m = {err / travel:.1%} of travel "
                       f"{travel:.4g} m, allowed {pose_tolerance:.0%}")
    return Comparison(
        status=ExecStatus.FAILED if reasons else ExecStatus.PASSED,
        claim=claim,
        claim_fraction=claim_frac,
        predicted_fraction=pred_frac,
        settled_steps=m,
        final_error=err,
        travel=travel,
        final_error_of_travel=err / travel,
        final_angle_error=ang,
        max_error_of_travel=float(errs.max() / travel),
        observed_counts=tuple(sorted(counts.items())),
        waypoint_observed=tuple(per_wp),
        reasons=tuple(reasons),
    )


# ---- schedule ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Schedule:
    """Per-waypoint commands and predictions read from a plan (``n`` waypoints).

    ``times`` (n,) [s] increasing from 0; ``velocity`` (n,) [rad/s] command of the velocity
    joint; ``torque`` (n,) [N m] command of the effort joint (both held until the next
    waypoint); ``poses`` (n, 3) predicted workpiece pose; ``predicted`` (n,) predicted label
    sets; ``claim``; ``controls`` (F,) per finger joint ``"velocity"`` / ``"effort"``.
    """

    times: tuple[float, ...]
    velocity: tuple[float, ...]
    torque: tuple[float, ...]
    poses: tuple[tuple[float, float, float], ...]
    claim: str
    controls: tuple[str, ...]
    predicted: tuple[tuple[str, ...], ...] = ()

    @classmethod
    def from_plan(cls, plan: Any) -> Schedule:
        return cls(
            times=tuple(float(w.t) for w in plan.waypoints),
            velocity=tuple(float(w.velocity_command) for w in plan.waypoints),
            torque=tuple(float(w.torque_command) for w in plan.waypoints),
            poses=tuple(tuple(float(x) for x in w.pose) for w in plan.waypoints),
            claim=str(plan.claim),
            controls=tuple(plan.control),
            predicted=tuple(tuple(w.predicted) for w in plan.waypoints),
        )

    def truncated(self, n: int) -> Schedule:
        """The first ``n`` waypoints (a shorter run of the same plan, for tests)."""
        if not 2 <= n <= len(self.times):
            raise InputError(f"truncated: expected 2 <= n <= {len(self.times)}, got {n}")
        return replace(self, times=self.times[:n], velocity=self.velocity[:n],
                       torque=self.torque[:n], poses=self.poses[:n],
                       predicted=self.predicted[:n] if self.predicted else ())


def held_command(times: np.ndarray, values: np.ndarray, ramp: float = 0.0):
    """``command(t, states)``: ``values[k]`` on ``[times[k], times[k+1])``, ramped linearly from
    ``values[k-1]`` over the first ``ramp`` seconds of each interval."""
    def command(t: float, states: Any) -> float:
        k = int(np.searchsorted(times, t, side="right")) - 1
        k = min(max(k, 0), len(values) - 1)
        v = float(values[k])
        if ramp > 0 and k > 0 and t - times[k] < ramp:
            a = (t - times[k]) / ramp
            v = (1.0 - a) * float(values[k - 1]) + a * v
        return v
    return command


# ---- engine settings --------------------------------------------------------------------------
@dataclass(frozen=True)
class EngineSettings:
    """Per-engine simulation settings (justified in docs/simulation.md, "Two-finger hand").

    ``dt`` [s]; ``mass_scale``: factor on the workpiece and finger masses (dynamics only: the
    hand's load is the file's constant force, so the quasistatic prediction does not depend on
    mass); ``solref`` (MuJoCo contact time constant [s], damping ratio); ``creep`` [m/s]
    creep floor of a sticking contact; ``settle`` [s] start transient excluded from the
    comparison; ``ramp`` [s] command ramp at waypoints; ``record_every`` steps;
    ``z_stiffness`` [N/m] MuJoCo spring holding the workpiece in the plane (its out-of-plane
    slide exists only for noslip; without friction a vertex sphere on a capsule drifts off it).
    """

    dt: float
    mass_scale: float = 1.0
    solref: tuple[float, float] = (0.004, 1.0)
    creep: float = 1e-9
    settle: float = 0.2
    ramp: float = 0.05
    record_every: int = 1
    z_stiffness: float = 0.0


ENGINE_SETTINGS: dict[str, EngineSettings] = {
    "pymunk": EngineSettings(dt=1e-3),
    "mujoco": EngineSettings(dt=1e-3, mass_scale=0.1, solref=(0.01, 1.0), creep=1e-8,
                             settle=0.3, z_stiffness=1000.0),
}


def hand_backend(engine: str, es: EngineSettings | None = None) -> Any:
    """Backend with the hand settings of ``engine`` (:data:`ENGINE_SETTINGS`)."""
    es = es or ENGINE_SETTINGS.get(engine, EngineSettings(dt=1e-3))
    if engine == "pymunk":
        from sim.backends.pymunk_engine import PymunkBackend

        return PymunkBackend()
    if engine == "mujoco":
        from sim.backends.mujoco_engine import MujocoBackend

        return MujocoBackend(solref=es.solref, out_of_plane_stiffness=es.z_stiffness)
    raise InputError(f"engine: expected 'pymunk' or 'mujoco', got {engine!r}")


def scaled_hand(hand: Any, scale: float) -> dict[str, Any]:
    import copy

    data = copy.deepcopy(dict(hand))
    if scale != 1.0:
        wp = data.get("workpiece", {})
        if isinstance(wp, dict):
            wp["mass"] = float(wp.get("mass", 0.1)) * scale
        for f in data.get("fingers", []):
            if isinstance(f, dict):
                f["mass"] = float(f.get("mass", 0.05)) * scale
    return data


# ---- running ----------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PlanRun:
    """One execution of a plan: ``comparison``, the ``recording`` (:class:`sim.run.Recording`),
    per recorded step ``observed`` labels, ``summary`` (what summary.json holds) and the
    written ``files`` (name -> path)."""

    comparison: Comparison
    recording: Any
    observed: tuple[str, ...]
    summary: dict[str, Any]
    files: dict[str, str] = field(default_factory=dict)


def _check_mu(mu: Any, n_c: int) -> np.ndarray:
    arr = np.asarray(mu, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n_c, float(arr))
    if arr.shape != (n_c,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(f"mu: expected a coefficient >= 0 or {n_c} of them, "
                         f"got {np.asarray(mu).tolist()}")
    return arr


def run_schedule(
    hand: Any,
    mu: Any,
    schedule: Schedule,
    engine: str,
    *,
    settings: EngineSettings | None = None,
) -> tuple[Comparison, Any, list[str], dict[str, Any]]:
    """Run ``schedule`` on the hand (file content ``hand``) in ``engine`` at friction ``mu``.

    Returns ``(comparison, recording, observed labels per recorded step, details)``.
    """
    from planner.files.hand_file import hand_from_dict
    from sim.classify import Thresholds, observed_modes
    from sim.run import RunSettings, run_scene
    from sim.scenes.hand import finger_angles, hand_scene

    es = settings or ENGINE_SETTINGS.get(engine)
    if es is None:
        raise InputError(f"engine: expected one of {sorted(ENGINE_SETTINGS)}, got {engine!r}")
    t = np.asarray(schedule.times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise InputError(f"schedule.times: expected >= 2 increasing times from 0, got "
                         f"{t.tolist()[:5]}...")
    model, q0 = hand_from_dict(hand, source="plan.hand")
    mu_arr = _check_mu(mu, model.n_contacts)
    if len(schedule.controls) != model.n_fingers:
        raise InputError(f"controls: expected {model.n_fingers} (one per finger), got "
                         f"{len(schedule.controls)}")
    vel = held_command(t, np.asarray(schedule.velocity, dtype=float), es.ramp)
    tau = held_command(t, np.asarray(schedule.torque, dtype=float), es.ramp)
    commands = [vel if c == "velocity" else tau for c in schedule.controls]
    scene = hand_scene(scaled_hand(hand, es.mass_scale), mu_arr, schedule.controls, commands)
    # drive speed: the velocity joint's contact-point speed (classifier thresholds, SIM-NOTES)
    v_joint = list(schedule.controls).index("velocity")
    pts, _, _ = model.contact_geometry(q0)
    radius = max([float(np.linalg.norm(pts[i] - np.asarray(model.fingers[c.finger].pivot)))
                  for i, c in enumerate(model.contacts)
                  if c.kind != "palm" and c.finger == v_joint]
                 or [model.fingers[v_joint].length])
    drive_speed = float(np.max(np.abs(schedule.velocity))) * radius
    load = float(np.linalg.norm(model.load_force)) or 1e-3
    wall = time.perf_counter()
    rec = run_scene(scene, hand_backend(engine, es), RunSettings(
        duration=float(t[-1]), dt=es.dt, slip_speed=0.05 * drive_speed,
        penetration_tol=0.02 * scene.length_scale, record_every=es.record_every))
    wall = time.perf_counter() - wall
    th = Thresholds(slip_speed=max(0.05 * drive_speed, 10.0 * es.creep),
                    force_floor=1e-3 * load, settle=es.settle)
    labels = observed_modes(rec, th)
    iw = rec.body_names.index("workpiece")
    details: dict[str, Any] = {
        "engine": engine, "mu": mu_arr.tolist(), "dt": es.dt, "mass_scale": es.mass_scale,
        "solref": list(es.solref) if engine == "mujoco" else None, "ramp": es.ramp,
        "drive_speed_m_per_s": drive_speed, "slip_threshold_m_per_s": th.slip_speed,
        "force_floor_N": th.force_floor, "settle_s": th.settle, "steps": len(rec.times),
        "wall_time_s": wall,
    }
    if rec.fault is not None or len(rec.times) == 0:
        reason = rec.fault.reason if rec.fault is not None else "no steps recorded"
        comp = Comparison(ExecStatus.FAULT, schedule.claim, 0.0, 0.0, 0, np.nan, np.nan,
                          np.nan, np.nan, np.nan, (), (), (reason,))
        return comp, rec, labels, details
    k = np.clip(np.searchsorted(rec.times, t - 1e-9), 0, len(rec.times) - 1)
    settled = np.flatnonzero(rec.times >= th.settle)
    interval = np.clip(np.searchsorted(t, rec.times[settled], side="right") - 1, 0, len(t) - 2)
    predicted = schedule.predicted or tuple((schedule.claim,) for _ in t)
    comp = compare(schedule.claim, [labels[j] for j in settled],
                   [predicted[j] for j in interval], schedule.poses, rec.poses[k, iw],
                   interval=interval)
    details["simulated_poses"] = rec.poses[k, iw].tolist()
    details["simulated_angles"] = finger_angles(rec, model)[k].tolist()
    return comp, rec, labels, details


def run_plan(
    plan: Any,
    engine: str,
    mu: Any,
    out_dir: str | Path | None = None,
    *,
    settings: EngineSettings | None = None,
    waypoints: int | None = None,
    render: bool = True,
    name: str | None = None,
    expect: str = "agree",
) -> PlanRun:
    """Execute ``plan`` (:class:`planner.plan.plan_file.Plan`) in ``engine`` at friction ``mu`` (scalar or
    per contact) and compare (module docstring). ``waypoints``: run only the first so many
    (shortened runs for tests). With ``out_dir``: write ``summary.json``, ``timeline.png``
    (observed vs predicted tokens per contact) and ``animation.gif``.

    ``expect``: ``"agree"`` (the plan should pass) or ``"disagree"`` (a negative control that
    should fail); the summary's ``passed`` says whether that expectation held (a fault never
    passes), ``status`` is the validation outcome itself."""
    if expect not in ("agree", "disagree"):
        raise InputError(f"expect: expected 'agree' or 'disagree', got {expect!r}")
    from planner.files.atomic import atomic_write_json

    sched = Schedule.from_plan(plan)
    if waypoints is not None:
        sched = sched.truncated(waypoints)
    comp, rec, labels, details = run_schedule(plan.hand, mu, sched, engine, settings=settings)
    held = (comp.status is not ExecStatus.FAULT
            and (comp.status is ExecStatus.PASSED) == (expect == "agree"))
    summary: dict[str, Any] = {
        "task": "two-finger hand plan validation (issue 5, Sec. 5.2)",
        "scenario": name or f"plan {getattr(plan, 'policy', '')} mu={mu}",
        "engine": engine,
        "expect": expect,
        "status": comp.status.value,
        "agreement": comp.claim_fraction,
        "passed": held,
        "validation_passed": comp.status is ExecStatus.PASSED,
        "reason": "; ".join(comp.reasons) if comp.reasons else
        f"{comp.claim_fraction:.1%} of the segment in the claimed mode, final position "
        f"{comp.final_error_of_travel:.2%} of travel from the prediction",
        "policy": getattr(plan, "policy", None),
        "claim": sched.claim,
        "control": list(sched.controls),
        "waypoints": len(sched.times),
        "duration_s": sched.times[-1],
        "fault": rec.fault.reason if rec.fault is not None else None,
        "observed_segments": observed_segments(labels, rec.times),
        "thresholds": {"mode_fraction": MODE_FRACTION_REQUIRED,
                       "pose_of_travel": POSE_TOLERANCE_OF_TRAVEL},
        **comp.to_dict(),
        "settings": details,
    }
    files: dict[str, str] = {}
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        if render and len(rec.times):
            files["timeline"] = str(hand_timeline(rec, labels, sched, out / "timeline.png"))
            files["animation"] = str(hand_animation(rec, labels, plan.hand, sched,
                                                    out / "animation.gif"))
        summary["files"] = {k: Path(v).name for k, v in files.items()}
        files["summary"] = str(atomic_write_json(out / "summary.json", summary))
    return PlanRun(comp, rec, tuple(labels), summary, files)


def observed_segments(labels: Sequence[str], times: Any) -> list[dict[str, Any]]:
    """Runs of equal observed labels: ``[{"mode", "start_s", "end_s"}, ...]`` (the compressed
    timeline written to summary.json)."""
    out: list[dict[str, Any]] = []
    for lab, t in zip(labels, np.asarray(times, dtype=float)):
        if out and out[-1]["mode"] == lab:
            out[-1]["end_s"] = float(t)
        else:
            out.append({"mode": lab, "start_s": float(t), "end_s": float(t)})
    return out


# ---- drawing (matplotlib imported lazily, Agg) ----------------------------------------------
def _tokens(label: str, n: int) -> list[str]:
    """Per-contact tokens of a label (:func:`sim.render._tokens`), all ``B`` when the label does
    not have ``n`` contacts."""
    toks = _render_tokens(label, n)
    return toks if len(toks) == n else ["B"] * n


def hand_timeline(rec: Any, observed: Sequence[str], schedule: Schedule, path: Path) -> Path:
    """Per contact: the plan's predicted tokens per waypoint interval (bands; hatched where the
    prediction differs from the claim) and the observed tokens (dots), over time [s]."""
    from planner.files.atomic import save_figure

    plt = _plt()
    P = len(rec.pair_names)
    fig, axes = plt.subplots(P, 1, figsize=(8, 1.3 * P + 0.9), sharex=True, squeeze=False)
    t = np.asarray(schedule.times)
    pred = schedule.predicted or tuple((schedule.claim,) for _ in t)
    claim_tok = _tokens(schedule.claim, P)
    step = max(1, len(rec.times) // 2000)
    obs = np.array([_tokens(o, P) for o in observed[::step]]) if len(observed) else None
    for j, ax in enumerate(axes[:, 0]):
        for k in range(len(t) - 1):
            for label in pred[k]:
                tok = _tokens(label, P)[j]
                y = ORDER.index(tok)
                ax.fill_between([t[k], t[k + 1]], y - 0.4, y + 0.4, color=COLOURS[tok],
                                alpha=0.25, lw=0, hatch="//" if tok != claim_tok[j] else None)
        if obs is not None:
            y = [ORDER.index(tok) for tok in obs[:, j]]
            ax.scatter(rec.times[::step][: len(y)], y, s=3,
                       c=[COLOURS[tok] for tok in obs[:, j]])
        ax.set_yticks(range(len(ORDER)), ORDER)
        ax.set_ylim(-0.6, len(ORDER) - 0.4)
        ax.set_ylabel(f"contact {j + 1}")
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(f"{rec.engine}: predicted per waypoint (bands) vs observed (dots); "
                         f"claim {schedule.claim}", fontsize=9)
    fig.tight_layout()
    out = save_figure(fig, path, dpi=80)
    plt.close(fig)
    return out


def hand_animation(rec: Any, observed: Sequence[str], hand_data: Any, schedule: Schedule,
                   path: Path, frames: int = 30) -> Path:
    """GIF of the run: palm, finger capsules and workpiece from the recorded poses, the
    predicted workpiece outline (dashed), contact points coloured by observed token."""
    import io

    from PIL import Image

    from planner.files.atomic import atomic_write_bytes
    from planner.files.hand_file import hand_from_dict
    from sim.scenes.hand import finger_angles

    plt = _plt()
    hand, _ = hand_from_dict(hand_data, source="plan.hand")
    P = len(rec.pair_names)
    iw = rec.body_names.index("workpiece")
    ang = finger_angles(rec, hand)
    t = np.asarray(schedule.times)
    poses = np.asarray(schedule.poses)
    V = np.asarray(hand.vertices)
    lo = np.min(np.vstack([hand.palm, V + poses[0, :2], V + poses[-1, :2]]), axis=0)
    hi = np.max(np.vstack([hand.palm, V + poses[0, :2], V + poses[-1, :2]]), axis=0)
    pad = 0.1 * float(np.max(hi - lo))
    idx = np.linspace(0, len(rec.times) - 1, min(frames, len(rec.times))).astype(int)
    fig, ax = plt.subplots(figsize=(4, 3.4))
    ax.plot(*np.asarray(hand.palm).T, color="k", lw=3)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    (body,) = ax.fill(V[:, 0], V[:, 1], color="0.85", edgecolor="k")
    (outline,) = ax.plot([], [], "--", color="tab:blue", lw=1)
    width_pt = 72 * 3.4 * 0.9 / (float(np.max(hi - lo)) + 2 * pad)
    links = [ax.plot([], [], color="0.4", lw=f.width * width_pt, solid_capstyle="round")[0]
             for f in hand.fingers]
    dots = [ax.plot([], [], "o", ms=6)[0] for _ in range(P)]
    title = ax.set_title("", fontsize=7)
    images = []
    for k in idx:
        pw = hand.world_vertices(np.concatenate([rec.poses[k, iw], ang[k]]))
        body.set_xy(pw)
        pp = np.array([np.interp(rec.times[k], t, poses[:, c]) for c in range(3)])
        qp = hand.world_vertices(np.concatenate([pp, ang[k]]))
        outline.set_data(*np.vstack([qp, qp[:1]]).T)
        for f_i, f in enumerate(hand.fingers):
            a = np.asarray(f.pivot)
            b = a + f.length * np.array([np.cos(ang[k, f_i]), np.sin(ang[k, f_i])])
            links[f_i].set_data([a[0], b[0]], [a[1], b[1]])
        toks = _tokens(observed[k], P) if len(observed) else ["B"] * P
        for j in range(P):
            if rec.present[k, j]:
                dots[j].set_data([rec.points[k, j, 0]], [rec.points[k, j, 1]])
                dots[j].set_color(COLOURS[toks[j]])
            else:
                dots[j].set_data([], [])
        title.set_text(f"{rec.engine} t={rec.times[k]:.2f} s  "
                       f"{observed[k] if len(observed) else ''}")
        fig.canvas.draw()
        images.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3]))
    plt.close(fig)
    buf = io.BytesIO()
    images[0].save(buf, format="GIF", save_all=True, append_images=images[1:], duration=120,
                   loop=0)
    return atomic_write_bytes(path, buf.getvalue())
