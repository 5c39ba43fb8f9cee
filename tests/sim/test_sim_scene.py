"""Scene description, backends (joints, loads, contact conventions), example geometry, ruler."""

from __future__ import annotations

import numpy as np
import pytest
from sim_helpers import scaled_system

from planner.errors import InputError
from planner.files.system_file import load_system
from planner.model.geometry import cross2, rot90
from planner.predict.feasibility import feasible_modes
from planner.predict.ruler import predicted_switches
from scenarios.registry import DATA_DIR as DATA
from sim.backends import make_backend
from sim.run import RunSettings, run_scene
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
    Polygon,
    Scene,
)
from sim.scenes.shapes import workpiece_polygon

ENGINES = ("pymunk", "mujoco")


def test_input_errors():
    with pytest.raises(InputError, match="counter-clockwise"):
        Polygon(((0, 0), (0, 1), (1, 0)))
    with pytest.raises(InputError, match="expected mass > 0"):
        Body("b", (Circle((0, 0), 0.1),), mass=0.0)
    with pytest.raises(InputError, match="driven body needs a twist"):
        Body("b", (Circle((0, 0), 0.1),), kind=BodyKind.DRIVEN)
    with pytest.raises(InputError, match="friction >= 0"):
        ContactPair("c", "a", "b", mu_static=-0.1)
    body = Body("b", (Circle((0, 0), 0.1),))
    with pytest.raises(InputError, match="unknown body 'x'"):
        Scene(bodies=(body,), pairs=(ContactPair("c", "b", "x", 0.5),))
    with pytest.raises(InputError, match="expected one of pymunk, mujoco, dart, got 'ode'"):
        make_backend("ode")


@pytest.mark.parametrize(("data", "scale"), [("example_4_1", 0.01), ("example_4_3", 0.1)])
def test_example_workpiece_passes_through_contacts_tangent(data, scale):
    system = scaled_system(load_system(DATA / f"{data}.json"), scale)
    pts, nrm = np.asarray(system.points), np.asarray(system.normals)
    poly = workpiece_polygon(pts, nrm, 1.25 * np.max(np.abs(pts)))
    edges = np.roll(poly, -1, axis=0) - poly
    for r, n in zip(pts, nrm):
        t = rot90(n) / np.linalg.norm(n)  # eq. 37 is printed to 3 digits: |n| ~ 1 +- 2e-4
        # r lies on an edge whose direction is +-t
        on = [k for k in range(len(poly))
              if abs(cross2(edges[k], r - poly[k])) < 1e-9 * np.linalg.norm(edges[k])
              and -1e-9 <= (r - poly[k]) @ edges[k] <= edges[k] @ edges[k] + 1e-9]
        assert on, "contact point not on the boundary"
        e = edges[on[0]] / np.linalg.norm(edges[on[0]])
        assert abs(abs(e @ t) - 1.0) < 1e-9


@pytest.mark.parametrize("mu", [(0.2, 0.3, 0.1), (0.75, 0.45, 0.55), (0.75, 0.95, 0.25)])
def test_scaling_keeps_the_feasible_mode_set(mu):
    """The premise of simulating a similar scene (sim.similarity): a uniform scaling of
    lengths, and a positive one of the contact velocities, changes no feasible mode."""
    base = load_system(DATA / "example_4_1.json")
    scaled = scaled_system(base, 0.01, speed=0.002)
    assert feasible_modes(scaled, mu).labels == feasible_modes(base, mu).labels
    with pytest.raises(InputError, match="scale: expected a finite number > 0"):
        scaled_system(base, -1.0)


def test_ruler_predicted_switches_follow_the_kinetic_static_ratio():
    pos, sliders = predicted_switches(0.4, 0.25, 1.0, 0.05, 0.5, 0.3, n_max=6)
    # closed form of Sec. 5.1: l_s = (mu_k / mu_s) l_r, alternating fingers
    expected = [0.15, 0.09, 0.054, 0.0324, 0.01944, 0.011664]
    assert np.allclose(pos, expected, rtol=1e-6)
    assert sliders == [0, 1, 0, 1, 0, 1]
    single, _ = predicted_switches(0.4, 0.25, 1.0, 0.05, 0.5, 0.5)
    assert single == pytest.approx([0.25], rel=1e-6)


def _link_scene(control, command, kind=JointKind.REVOLUTE):
    link = Body("link", (Capsule((0.0, 0.0), (0.1, 0.0), 0.005),), mass=0.05, com=(0.05, 0.0),
                inertia=0.05 * 0.1 ** 2 / 12)
    joint = Joint("q", body="link", kind=kind, anchor=(0.0, 0.0), control=control,
                  command=lambda t, s: command, axis=(0.0, 1.0))
    return Scene(bodies=(link,), pairs=(), joints=(joint,), length_scale=0.1)


def _run(scene, engine, duration=0.5):
    return run_scene(scene, make_backend(engine), RunSettings(
        duration=duration, dt=1e-3, slip_speed=1e-5, penetration_tol=1e-3))


@pytest.mark.parametrize("engine", ENGINES)
def test_velocity_revolute_joint_follows_its_command(engine):
    rec = _run(_link_scene(Control.VELOCITY, 0.2), engine)
    assert rec.poses[-1, 0, 2] == pytest.approx(0.2 * 0.5, rel=0.02)
    assert np.allclose(rec.poses[-1, 0, :2], 0.0, atol=1e-6)  # pivot at the link origin


@pytest.mark.parametrize("engine", ENGINES)
def test_effort_revolute_joint_applies_its_torque(engine):
    tau = 1e-3
    rec = _run(_link_scene(Control.EFFORT, tau), engine, duration=0.2)
    inertia_pivot = 0.05 * 0.1 ** 2 / 12 + 0.05 * 0.05 ** 2
    expected = 0.5 * tau / inertia_pivot * 0.2 ** 2
    assert rec.poses[-1, 0, 2] == pytest.approx(expected, rel=0.05)


@pytest.mark.parametrize("engine", ENGINES)
def test_velocity_prismatic_joint_moves_along_its_axis(engine):
    rec = _run(_link_scene(Control.VELOCITY, 0.01, JointKind.PRISMATIC), engine)
    assert rec.poses[-1, 0, 1] == pytest.approx(0.005, rel=0.02)
    assert abs(rec.poses[-1, 0, 0]) < 1e-6 and abs(rec.poses[-1, 0, 2]) < 1e-6


@pytest.mark.parametrize("engine", ENGINES)
def test_contact_reading_conventions(engine):
    """A box resting on a driven fingertip under a 1 N load: n points into the box (+y), the
    normal force balances the load, a sideways push shows up as tangential force along t."""
    box = Body("workpiece", (Polygon(((-0.02, 0.0), (0.02, 0.0), (0.02, 0.02), (-0.02, 0.02))),),
               mass=0.01, com=(0.0, 0.0), inertia=0.01 * 0.0008 / 12)  # COM on the contact
    finger = Body("finger1", (Circle((0.0, 0.0), 0.003),), pose=(0.0, -0.003 + 1e-7, 0.0),
                  kind=BodyKind.DRIVEN, twist=lambda t, s: (0.0, 0.0, 0.0))
    scene = Scene(bodies=(box, finger), pairs=(ContactPair("c1", "finger1", "workpiece", 0.5),),
                  loads=(Load("workpiece", (0.1, -1.0), 0.0),), length_scale=0.04)
    rec = _run(scene, engine, duration=0.1)
    assert rec.fault is None
    k = -1
    assert rec.present[k, 0]
    assert np.allclose(rec.normals[k, 0], [0.0, 1.0], atol=1e-3)
    assert rec.normal_force[k, 0] == pytest.approx(1.0, rel=0.02)
    # t = rot90(n) = (-1, 0): the finger pushes the box against the +x load, c_t = +0.1
    assert rec.tangent_force[k, 0] == pytest.approx(0.1, rel=0.05)
