"""sim.hand_scene: the two-finger hand builds and runs in both engines (issue 5, smoke level)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from sim.hand_scene import hand_scene
from sim.run import RunSettings, run_scene
from sim.scene import Control, make_backend

R = 0.002  # finger half-width [m]
GAP = 0.9 * R * 2**0.5  # pivot offset: links start 0.2 mm into the workpiece corners
GEOM = {
    "palm": {"left": [[-0.1, -0.001], [-0.005, -0.001]],
             "right": [[0.005, -0.001], [0.1, -0.001]], "radius": 0.001},
    "fingers": [
        {"name": "left", "pivot": [-0.07 - GAP, 0.0], "length": 0.07, "width": 2 * R,
         "angle": np.pi / 4},
        {"name": "right", "pivot": [0.07 + GAP, 0.0], "length": 0.07, "width": 2 * R,
         "angle": 3 * np.pi / 4},
    ],
    "workpiece": {"vertices": [[-0.03, 0.0], [0.03, 0.0], [0.03, 0.04], [-0.03, 0.04]],
                  "mass": 0.1, "pose": [0.0, 0.0, 0.0]},
    "g_obj": [0.0, 0.0, 0.0],
}


def _scene(torque, speed):
    return hand_scene(GEOM, [0.1] * 4, [Control.EFFORT, Control.VELOCITY],
                      [lambda t, s: torque, lambda t, s: speed])


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_velocity_finger_pushes_workpiece_left(engine):
    rec = run_scene(_scene(-0.01, 0.05), make_backend(engine), RunSettings(
        duration=0.5, dt=1e-3, slip_speed=1e-4, penetration_tol=0.003))
    assert rec.fault is None
    i = rec.body_names.index("workpiece")
    assert rec.poses[-1, i, 0] < -1e-3  # moved left by more than 1 mm
    # reversing the finger lets the torque finger push it right instead
    rec2 = run_scene(_scene(-0.01, -0.05), make_backend(engine), RunSettings(
        duration=0.5, dt=1e-3, slip_speed=1e-4, penetration_tol=0.003))
    assert rec2.fault is None and rec2.poses[-1, i, 0] > 1e-3


def test_bad_inputs_rejected():
    with pytest.raises(InputError, match=r"expected 4 coefficients.*got shape \(3,\)"):
        hand_scene(GEOM, [0.1] * 3, [Control.EFFORT, Control.VELOCITY], [None, None])
    with pytest.raises(InputError, match="expected key 'palm'"):
        hand_scene({}, [0.1] * 4, [Control.EFFORT, Control.VELOCITY], [None, None])


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_schedule_with_wrong_claim_fails(engine):
    from sim.plan_exec import ExecStatus, Schedule, run_schedule

    times = tuple(np.linspace(0.0, 0.5, 11))
    # predicted poses: pushed left 1 mm at constant rate; claim "R1 R2 R3 R4" cannot be
    # observed while the workpiece slides on the palm, so the validator must disagree
    poses = tuple((-0.002 * s, 0.0, 0.0) for s in times)
    sched = Schedule(times=times, velocity=(0.05,) * 11, torque=(-0.01,) * 11, poses=poses,
                     claim="R1 R2 R3 R4", controls=("effort", "velocity"))
    comp, rec, obs = run_schedule(GEOM, [0.1] * 4, sched, engine, drive_speed=3e-3)
    assert comp.status is ExecStatus.FAILED
    assert "R1 R2 R3 R4" in comp.reasons[0] and comp.agree_fraction < 0.5
    assert len(obs) == 11
