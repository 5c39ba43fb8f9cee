"""pymunk's sweeps over a gantry finger's joints (:mod:`sim.backends.pymunk_solver`;
docs/simulation.md, "pymunk": a slid link is kinematic, not held).

The flip's gantry (a 0.02 m and a 0.05 m link of 50 g, the first slid up by a velocity joint,
the second run out along 135 degrees by an effort joint) held to a carriage: a sweep leaves
more of the error the further the second slide runs out (0.954 at the start, above 0.99 past 60
degrees of the flip: the links came off their joints at 68 degrees with 60 iterations). With the
slid link kinematic the rate is the second link's groove and gear alone,
``(r^2 / I_2) / (1 / m_2 + r^2 / I_2)`` with ``r`` its centre of mass's distance from its
joint, whatever the extension. The backend builds the slid link kinematic and moves it exactly
at the joint's rate.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planner.plan.plan_file import load_plan
from sim.backends.pymunk_solver import gauss_seidel_rate, joint_rows, slid_bodies
from sim.scene import BodyKind, Control
from sim.scenes.hand import hand_scene
from sim.schedule import plan_layout

pymunk = pytest.importorskip("pymunk")

TEST_DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def flip():
    lay = plan_layout(load_plan(TEST_DATA / "plan_flip_against_wall.json"))
    return lay.hands[0], lay.schedules[0]


def _scene_at(flip, k, rate=0.0):
    hand, sched = flip
    q = np.concatenate([sched.poses[k], sched.angles[k]])
    return hand_scene(hand, q, 0.7, sched.controls,
                      [lambda t, s: rate, lambda t, s: 0.5][:len(sched.controls)])


def _inertia(scene):
    return {b.name: float(b.inertia) for b in scene.bodies
            if b.kind == BodyKind.DYNAMIC and b.inertia is not None}


def test_a_held_slid_link_slows_the_sweeps_as_the_next_slide_runs_out(flip) -> None:
    hand, sched = flip
    turn = np.degrees(sched.poses[:, 2])
    rates = []
    for deg in (5.0, 40.0, 68.0):
        k = int(np.argmin(np.abs(turn - deg)))
        sc = _scene_at(flip, k)
        rates.append(gauss_seidel_rate(sc, _inertia(sc), kinematic_slides=False))
    assert rates[0] > 0.95 and rates[0] < rates[1] < rates[2]
    assert rates[2] > 0.99  # 60 sweeps leave 3/4 of the error


def test_a_kinematic_slid_link_leaves_the_second_links_rate(flip) -> None:
    sc0 = _scene_at(flip, 0)
    link2 = next(b for b in sc0.bodies if b.name.endswith(".1"))
    r = link2.com[0]  # its centre of mass on its axis, from its joint
    closed = (r ** 2 / link2.inertia) / (1.0 / link2.mass + r ** 2 / link2.inertia)
    assert closed == pytest.approx(0.75, abs=0.01)
    _, sched = flip
    for k in (0, len(sched.times) // 2, len(sched.times) - 1):
        sc = _scene_at(flip, k)
        assert gauss_seidel_rate(sc, _inertia(sc)) == pytest.approx(closed, rel=1e-6)


def test_rows_of_a_slid_link(flip) -> None:
    sc = _scene_at(flip, 0)
    slid = slid_bodies(sc)
    assert len(slid) == 1 and next(iter(slid)).startswith("finger:")
    held = joint_rows(sc, kinematic_slides=False)
    kin = joint_rows(sc)
    assert len(held) - len(kin) == 2  # the pivot and the gear to the carriage
    assert all(slid.isdisjoint(row) or len(row) == 2 for c in kin for row in c)


def test_the_backend_moves_a_slid_link_exactly_at_its_rate(flip) -> None:
    from sim.backends.pymunk_engine import PymunkBackend

    rate = 0.004  # m/s along the slide
    sc = _scene_at(flip, 0, rate=rate)
    (name,) = slid_bodies(sc)
    joint = next(j for j in sc.joints if j.body == name)
    assert joint.control == Control.VELOCITY
    b = PymunkBackend()
    b.build(sc)
    assert b.bodies[name].body_type == pymunk.Body.KINEMATIC
    start = np.array(b.state()[name].pose)
    for _ in range(200):
        b.step(1e-3)
    moved = np.array(b.state()[name].pose) - start
    assert moved[:2] == pytest.approx(0.2 * rate * np.asarray(joint.axis), abs=1e-12)
    assert math.isclose(moved[2], 0.0, abs_tol=1e-15)
