"""Compare a simulated run of a plan with the plan's predictions (issue 5, EXECUTION).

This module holds the engine- and schema-independent comparison: given, per waypoint, the
predicted mode label (docs/conventions.md notation, e.g. ``"S-1 S-2 S+3 S+4"``), the observed
label from :mod:`sim.classify`, and predicted / simulated workpiece poses ``(x, y, theta)``
(metres, radians), decide PASSED / FAILED with reasons.

Acceptance of issue 5: the claimed mode observed on >= 95 % of the segment and the final pose
within 2 % of the travel of the prediction. The position error is the Euclidean distance of the
final (x, y) in metres, divided by the predicted travel (path length of the predicted (x, y));
the orientation error is reported alongside in radians.

The driver that runs a plan file in an engine (hand scene, slow motion) is not written yet.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from planner.errors import InputError

MODE_FRACTION_REQUIRED = 0.95
POSE_TOLERANCE_OF_TRAVEL = 0.02


class ExecStatus(str, Enum):
    PASSED = "passed"
    FAILED = "failed"
    FAULT = "fault"


@dataclass(frozen=True)
class Comparison:
    """Result of comparing observed with predicted modes and poses.

    ``agree_fraction``: fraction of waypoints whose observed label equals the claimed label.
    ``final_error``: final (x, y) distance in metres; ``travel``: predicted path length in
    metres; ``final_error_of_travel`` = final_error / travel; ``final_angle_error`` in radians.
    ``observed_counts``: label -> number of waypoints. ``reasons``: why it failed (empty if passed).
    """

    status: ExecStatus
    claim: str
    agree_fraction: float
    final_error: float
    travel: float
    final_error_of_travel: float
    final_angle_error: float
    observed_counts: tuple[tuple[str, int], ...]
    reasons: tuple[str, ...]

    def to_dict(self) -> dict:
        return {
            "status": self.status.value,
            "claim": self.claim,
            "agree_fraction": self.agree_fraction,
            "final_error": self.final_error,
            "travel": self.travel,
            "final_error_of_travel": self.final_error_of_travel,
            "final_angle_error": self.final_angle_error,
            "observed_counts": dict(self.observed_counts),
            "reasons": list(self.reasons),
        }


def _poses(name: str, value, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n, 3):
        raise InputError(f"{name}: expected shape ({n}, 3) (x, y, theta per waypoint), "
                         f"got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got NaN or inf")
    return arr


def compare(
    claim: str,
    observed: list[str] | tuple[str, ...],
    predicted_poses,
    simulated_poses,
    *,
    mode_fraction: float = MODE_FRACTION_REQUIRED,
    pose_tolerance: float = POSE_TOLERANCE_OF_TRAVEL,
) -> Comparison:
    """Compare per-waypoint observed labels and poses with the plan's claim and poses.

    ``observed``: (n,) labels; ``predicted_poses``, ``simulated_poses``: (n, 3).
    """
    n = len(observed)
    if n < 2:
        raise InputError(f"observed: expected at least 2 waypoints, got {n}")
    pred = _poses("predicted_poses", predicted_poses, n)
    simu = _poses("simulated_poses", simulated_poses, n)
    agree = sum(1 for lab in observed if lab == claim) / n
    travel = float(np.sum(np.linalg.norm(np.diff(pred[:, :2], axis=0), axis=1)))
    if travel <= 0.0:
        raise InputError("predicted_poses: expected a segment with positive travel, got 0")
    err = float(np.linalg.norm(simu[-1, :2] - pred[-1, :2]))
    ang = float(abs(simu[-1, 2] - pred[-1, 2]))
    counts: dict[str, int] = {}
    for lab in observed:
        counts[lab] = counts.get(lab, 0) + 1
    reasons = []
    if agree < mode_fraction:
        others = sorted(((c, lab) for lab, c in counts.items() if lab != claim), reverse=True)
        top = f"; most observed instead: {others[0][1]!r} ({others[0][0]}/{n})" if others else ""
        reasons.append(f"claimed mode {claim!r} observed on {agree:.1%} of waypoints, "
                       f"required {mode_fraction:.0%}{top}")
    if err / travel > pose_tolerance:
        reasons.append(f"final position off by {err:.4g} m = {err / travel:.1%} of travel "
                       f"{travel:.4g} m, allowed {pose_tolerance:.0%}")
    return Comparison(
        status=ExecStatus.FAILED if reasons else ExecStatus.PASSED,
        claim=claim,
        agree_fraction=agree,
        final_error=err,
        travel=travel,
        final_error_of_travel=err / travel,
        final_angle_error=ang,
        observed_counts=tuple(sorted(counts.items())),
        reasons=tuple(reasons),
    )


@dataclass(frozen=True)
class Schedule:
    """Per-waypoint commands and predictions, read from a plan (``n`` waypoints).

    ``times`` (n,) [s] increasing; ``velocity`` (n,) [rad/s] command of the velocity joint;
    ``torque`` (n,) [N m] command of the effort joint (both held until the next waypoint);
    ``poses`` (n, 3) predicted workpiece pose; ``claim`` the mode the plan says occurs.
    ``controls`` (2,) per finger joint, ``"velocity"`` or ``"effort"``.
    """

    times: tuple[float, ...]
    velocity: tuple[float, ...]
    torque: tuple[float, ...]
    poses: tuple[tuple[float, float, float], ...]
    claim: str
    controls: tuple[str, str]


def _hold(times: np.ndarray, values: np.ndarray):
    def command(t, states):
        k = int(np.searchsorted(times, t, side="right")) - 1
        return float(values[min(max(k, 0), len(values) - 1)])
    return command


def run_schedule(geometry, mu, schedule: Schedule, engine: str, *, dt: float = 1e-3,
                 drive_speed: float = 1e-3, load: float = 0.01):
    """Run ``schedule`` in ``engine`` on the hand of ``geometry``; return
    ``(Comparison, Recording, observed labels at the waypoints)``.

    ``drive_speed`` [m/s] and ``load`` [N] set the classifier thresholds
    (:meth:`sim.classify.Thresholds.for_drive`). A simulator fault gives status FAULT.
    """
    from sim.classify import Thresholds, observed_modes
    from sim.hand_scene import hand_scene
    from sim.run import RunSettings, run_scene
    from sim.scene import Control, make_backend

    t = np.asarray(schedule.times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"schedule.times: expected >= 2 increasing times, got {t.tolist()}")
    controls = [Control(c) for c in schedule.controls]
    vel = _hold(t, np.asarray(schedule.velocity, dtype=float))
    tau = _hold(t, np.asarray(schedule.torque, dtype=float))
    commands = [vel if c == Control.VELOCITY else tau for c in controls]
    scene = hand_scene(geometry, mu, controls, commands)
    rec = run_scene(scene, make_backend(engine), RunSettings(
        duration=float(t[-1]), dt=dt, slip_speed=0.05 * drive_speed,
        penetration_tol=0.1 * scene.length_scale))
    labels = observed_modes(rec, Thresholds.for_drive(drive_speed, load))
    i = rec.body_names.index("workpiece")
    k = np.clip(np.searchsorted(rec.times, t), 0, len(rec.times) - 1)
    obs = [labels[j] for j in k]
    if rec.fault is not None:
        comp = Comparison(ExecStatus.FAULT, schedule.claim, 0.0, np.nan, np.nan, np.nan, np.nan,
                          (), (rec.fault.reason,))
        return comp, rec, obs
    return compare(schedule.claim, obs, schedule.poses, rec.poses[k, i]), rec, obs
