"""sim.scenes.hand: the two-finger hand file as a scene in both engines (issue 5)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.hand_file import hand_from_dict, load_hand
from sim.backends import make_backend
from sim.hand_run import ENGINE_SETTINGS
from sim.run import RunSettings, run_scene
from sim.scenes.hand import hand_scene, pair_names, polygon_inertia


@pytest.fixture(scope="module")
def hand_file(data_dir):
    return load_hand(data_dir / "two_finger_hand.json")


def _scene(hand, q0, tau=-0.003, speed=0.02, mu=0.1, mass_scale=1.0):
    return hand_scene(hand, q0, mu, ["effort", "velocity"],
                      [lambda t, s: tau, lambda t, s: speed], mass_scale=mass_scale)


def test_scene_layout(hand_file):
    hand, q0, _ = hand_file
    scene = _scene(hand, q0)
    assert [p.name for p in scene.pairs] == list(pair_names(4)) == ["c1", "c2", "c3", "c4"]
    assert scene.only_pairs and scene.loads[0].force == tuple(hand.load_force)
    wp = scene.body("workpiece")
    assert wp.pose == pytest.approx(tuple(q0[:3])) and wp.mass == hand.mass
    # each palm contact has its own palm shape and its own vertex circle
    palm_pairs = [p for p in scene.pairs if p.body_a == "palm"]
    assert len({p.shape_a for p in palm_pairs}) == len({p.shape_b for p in palm_pairs}) == 2
    # a vertex circle touches its feature where the sharp vertex does
    pts, nrm, _ = hand.contact_geometry(q0)
    for i, p in enumerate(scene.pairs[:3]):
        c = wp.shapes[p.shape_b]
        centre = np.asarray(c.center) + q0[:2]
        assert np.allclose(centre - c.radius * nrm[i], pts[i], atol=1e-5)


def test_polygon_inertia_of_a_square():
    sq = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    assert polygon_inertia(sq, 3.0, np.zeros(2)) == pytest.approx(3.0 * 4 / 6)


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_contacts_and_normals_match_the_model(hand_file, engine):
    """With the hand settings (sim.hand_run.ENGINE_SETTINGS): all four contacts touch, along the model's inward normals, and the
    driven finger pushes the workpiece to the left (the 4S direction)."""
    hand, q0, _ = hand_file
    es = ENGINE_SETTINGS[engine]
    scene = _scene(hand, q0, mass_scale=es.mass_scale)
    rec = run_scene(scene, make_backend(engine, es), RunSettings(
        duration=0.3, dt=1e-3, slip_speed=1e-4, penetration_tol=2e-3))
    assert rec.fault is None
    assert rec.present[-50:].all()
    _, nrm, _ = hand.contact_geometry(q0)
    assert np.allclose(rec.normals[-1], nrm, atol=0.02)
    assert np.all(rec.normal_force[-1] > 0)
    i = rec.body_names.index("workpiece")
    assert rec.poses[-1, i, 0] < -1e-4


def test_bad_inputs_rejected(hand_file):
    hand, q0, data = hand_file
    with pytest.raises(InputError, match=r"expected 4 friction coefficients.*got shape \(3,\)"):
        hand_scene(hand, q0, [0.1] * 3, ["effort", "velocity"], [None, None])
    with pytest.raises(InputError, match=r"mu: expected friction coefficients >= 0, got \[-0.1"):
        hand_scene(hand, q0, -0.1, ["effort", "velocity"], [None, None])
    with pytest.raises(InputError, match="expected 2 each .one per finger., got 1/2"):
        hand_scene(hand, q0, 0.1, ["effort"], [None, None])
    with pytest.raises(InputError, match="expected 'velocity' or 'effort' per joint"):
        hand_scene(hand, q0, 0.1, ["effort", "torque"], [None, None])
    with pytest.raises(InputError, match="mass_scale: expected a finite number > 0, got 0"):
        hand_scene(hand, q0, 0.1, ["effort", "velocity"], [None, None], mass_scale=0.0)
    broken = json.loads(json.dumps(data))
    del broken["palm"]
    with pytest.raises(InputError, match="expected key 'palm'"):
        hand_from_dict(broken)
