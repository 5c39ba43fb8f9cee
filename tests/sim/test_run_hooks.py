"""The two hooks of a continuous whole-task run: pairs allowed to start open, and
joints whose control mode switches at given times -- in both engines."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from sim.backends import DEFAULT_ENGINES, make_backend
from sim.run import FaultKind, RunSettings, run_scene
from sim.scene import (
    Body,
    BodyKind,
    Capsule,
    Circle,
    ContactPair,
    Control,
    Joint,
    JointKind,
    Load,
    Scene,
)

MASS, LENGTH = 0.05, 0.1
INERTIA_PIVOT = MASS * LENGTH ** 2 / 12 + MASS * (LENGTH / 2) ** 2


def _link_scene(command, control=Control.VELOCITY, kind=JointKind.REVOLUTE):
    link = Body("link", (Capsule((0.0, 0.0), (LENGTH, 0.0), 0.005),), mass=MASS,
                com=(LENGTH / 2, 0.0), inertia=MASS * LENGTH ** 2 / 12)
    joint = Joint("q", body="link", kind=kind, anchor=(0.0, 0.0), control=control,
                  command=command, axis=(0.0, 1.0))
    return Scene(bodies=(link,), pairs=(), joints=(joint,), length_scale=LENGTH)


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_a_joint_switching_control_follows_velocity_then_effort(engine):
    omega, tau, t_s, t_end = 0.2, 1e-3, 0.25, 0.5
    scene = _link_scene(lambda t, s: omega if t < t_s - 1e-9 else tau)
    rec = run_scene(scene, make_backend(engine), RunSettings(
        duration=t_end, dt=1e-3, slip_speed=1e-5, penetration_tol=1e-3,
        control_switches=((t_s, "q", "effort"),)))
    assert rec.fault is None
    angle = rec.poses[:, 0, 2]
    k_s = int(np.searchsorted(rec.times, t_s - 1e-9))
    # velocity control: the angle grows at the commanded rate
    assert angle[k_s] == pytest.approx(omega * t_s, rel=0.02)
    # effort control from t_s on: the link keeps its rate and accelerates by tau / I
    dt_e = t_end - t_s
    expected = angle[k_s] + omega * dt_e + 0.5 * tau / INERTIA_PIVOT * dt_e ** 2
    assert angle[-1] == pytest.approx(expected, rel=0.03)
    # had it stayed velocity-controlled, the angle would be omega * t_end (far from this)
    assert abs(angle[-1] - omega * t_end) > 0.1


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_a_joint_switching_back_to_velocity_holds_the_new_rate(engine):
    t_s = 0.2
    scene = _link_scene(lambda t, s: 1e-3 if t < t_s - 1e-9 else -0.1, control=Control.EFFORT)
    rec = run_scene(scene, make_backend(engine), RunSettings(
        duration=0.4, dt=1e-3, slip_speed=1e-5, penetration_tol=1e-3,
        control_switches=((t_s, "q", "velocity"),)))
    angle = rec.poses[:, 0, 2]
    k_s = int(np.searchsorted(rec.times, t_s + 0.01))
    rate = np.diff(angle[k_s:]) / np.diff(rec.times[k_s:])
    assert np.allclose(rate, -0.1, atol=2e-3)


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_switching_is_checked(engine):
    for joint, control, kind, match in (("nope", "effort", JointKind.REVOLUTE, "joint"),
                                        ("q", "torque", JointKind.REVOLUTE, "velocity"),
                                        ("q", "effort", JointKind.PRISMATIC, "revolute")):
        scene = _link_scene(lambda t, s: 0.0, kind=kind)
        with pytest.raises(InputError, match=match):
            run_scene(scene, make_backend(engine), RunSettings(
                duration=0.01, dt=1e-3, slip_speed=1e-5, penetration_tol=1e-3,
                control_switches=((0.0, joint, control),)))


def _gap_scene(gap):
    """A ball ``gap`` above a static bar, pushed down onto it by a constant load."""
    bar = Body("bar", (Capsule((-0.05, 0.0), (0.05, 0.0), 0.005),), kind=BodyKind.STATIC)
    r = 0.005
    ball = Body("ball", (Circle((0.0, 0.0), r),), mass=0.01, com=(0.0, 0.0),
                inertia=0.5 * 0.01 * r ** 2, pose=(0.0, 0.005 + r + gap, 0.0))
    return Scene(bodies=(bar, ball), pairs=(ContactPair("c1", "bar", "ball", 0.3),),
                 loads=(Load("ball", (0.0, -0.01), 0.0),), length_scale=0.1, only_pairs=True,
                 bounds=(-1.0, -1.0, 1.0, 1.0))


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_a_pair_allowed_to_start_open_is_no_fault_and_closes(engine):
    base = dict(duration=0.3, dt=1e-3, slip_speed=1e-5, penetration_tol=1e-3)
    rec = run_scene(_gap_scene(1e-3), make_backend(engine), RunSettings(**base))
    assert rec.fault is not None and rec.fault.kind is FaultKind.CONTACT_LOST_AT_START
    rec = run_scene(_gap_scene(1e-3), make_backend(engine),
                    RunSettings(**base, open_at_start=("c1",)))
    assert rec.fault is None
    assert not rec.present[0, 0]          # apart at the start ...
    assert rec.present[-1, 0]             # ... and touching once the load closed the gap
    assert rec.normal_force[-1, 0] == pytest.approx(0.01, rel=0.1)
