"""sim.scenes.hand: the two-finger hand file as a scene in both engines."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.hand_file import hand_from_dict, load_hand
from sim.backends import make_backend
from sim.run import RunSettings, run_scene
from sim.scene import preload_depth
from sim.scenes.hand import hand_scene, pair_names
from sim.scenes.shapes import polygon_inertia
from sim.settings import SceneKind, settings_for
from sim.similarity import scaled_masses


@pytest.fixture(scope="module")
def hand_file(data_dir):
    return load_hand(data_dir / "two_finger_hand.json")


def _scene(hand, q0, tau=-0.003, speed=0.02, mu=0.1, mass_scale=1.0):
    return scaled_masses(hand_scene(hand, q0, mu, ["effort", "velocity"],
                                    [lambda t, s: tau, lambda t, s: speed]), mass_scale)


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
    # a vertex circle on the palm is centred on the vertex (the palm lies its radius behind
    # the palm line); on a finger's side it touches the side where the sharp vertex does
    pts, nrm, _ = hand.contact_geometry(q0)
    kinds = [c.kind for c in hand.contacts]
    for i, p in enumerate(scene.pairs[:3]):
        c = wp.shapes[p.shape_b]
        centre = np.asarray(c.center) + q0[:2]
        lift = 0.0 if kinds[i] in ("palm", "surface") else c.radius
        assert np.allclose(centre - lift * nrm[i], pts[i], atol=1e-5), kinds[i]


def test_polygon_inertia_of_a_square():
    sq = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    assert polygon_inertia(sq, 3.0, np.zeros(2)) == pytest.approx(3.0 * 4 / 6)


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_contacts_and_normals_match_the_model(hand_file, engine):
    """With the hand settings (sim.settings.SETTINGS): all four contacts touch, along the
    model's inward normals, and the driven finger pushes the workpiece to the left (the 4S
    direction)."""
    hand, q0, _ = hand_file
    es = settings_for(SceneKind.HAND, engine)
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
    with pytest.raises(InputError, match="mass scale: expected a finite number > 0, got 0"):
        _scene(hand, q0, mass_scale=0.0)
    broken = json.loads(json.dumps(data))
    del broken["palm"]
    with pytest.raises(InputError, match="expected key 'palm'"):
        hand_from_dict(broken)


@pytest.fixture(scope="module")
def acute_tip(figure9_plan):
    """Segment 3 of the Figure 9 task: the left tip starts at vertex 3, whose interior angle
    is 32 deg, on edge 3 (the link flush along that edge: edge-to-edge)."""
    seg = figure9_plan.segments[2]
    hand, q = seg.hand_model
    i = next(k for k, c in enumerate(hand.contacts) if c.kind == "tip" and c.finger == 0)
    return hand, q, i


@pytest.mark.long
def test_a_tip_pair_touches_its_declared_edge_only(acute_tip):
    hand, q, i = acute_tip
    V = np.asarray(hand.vertices)
    e = hand.contacts[i].edge
    a, b, prev = V[e], V[(e + 1) % len(V)], V[e - 1]
    u, w = (b - a) / np.linalg.norm(b - a), (prev - a) / np.linalg.norm(prev - a)
    assert np.degrees(np.arccos(u @ w)) < 90.0  # the acute vertex this guards
    scene = _scene(hand, q, mu=0.2, tau=0.0, speed=0.0)
    cap = scene.body("workpiece").shapes[scene.pairs[i].shape_b]
    # a capsule along the edge, its surface on the edge line (body frame)
    inward = np.array([-u[1], u[0]])
    for end, vert in ((cap.a, a), (cap.b, b)):
        assert np.allclose(np.asarray(end), vert + cap.radius * inward, atol=1e-12)


@pytest.mark.long
@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_a_tip_at_an_acute_vertex_reads_its_edge(acute_tip, engine):
    """The tip's first reading: the declared edge's normal and the pre-load depth (with the
    whole polygon MuJoCo read 1.3 mm on the neighbouring edge's box)."""
    hand, q, i = acute_tip
    pts, nrm, _ = hand.contact_geometry(q)
    scene = _scene(hand, q, mu=0.2, tau=0.0, speed=0.0)
    backend = make_backend(engine, settings_for(SceneKind.HAND, engine))
    backend.build(scene)
    backend.step(1e-4)
    r = backend.contacts()[scene.pairs[i].name]
    assert r.present
    assert abs(float(np.asarray(r.normal) @ nrm[i])) > 1 - 1e-6
    assert r.depth < 10 * preload_depth(hand.length_scale)  # the pre-load's order, not 1.3 mm


def _gap_circle_capsule(centre, cap):
    """Signed distance [m] between a circle (world centre (2,), radius) and a static capsule
    (world frame)."""
    (c, r), (a, b, rc) = centre, cap
    a, b, c = np.asarray(a), np.asarray(b), np.asarray(c)
    s = np.clip((c - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return float(np.linalg.norm(c - (a + s * (b - a))) - r - rc)


@pytest.mark.parametrize("turn_deg", [0.0, 20.0, 55.0, 75.0])
def test_a_vertex_on_a_fixed_surface_rides_on_it_at_any_turn(data_dir, turn_deg):
    """The flip's block turned about the corner mechanism (vertex 0 on the table at ``x = h
    sin(theta)``, vertex 3 on the wall at ``y = h cos(theta)``): the vertex circles touch the
    table's and the wall's capsules at the pre-load depth however far it turns -- the circle
    is centred on the vertex and the surface lies the circle's radius behind its line. A
    circle placed to touch where the vertex does at the start (centre = vertex + r n) would
    stand ``r (1 - cos(turn))`` off the surface: 0.37 mm at 75 degrees."""
    hand, q0, _ = load_hand(data_dir / "flip_against_wall.json")
    scene = hand_scene(hand, q0, [0.0, 0.0, 0.7], ["velocity", "effort"],
                       [lambda t, s: 0.0, lambda t, s: 0.0])
    theta = float(q0[2]) + np.radians(turn_deg)
    h = 0.02
    pose = np.array([h * np.sin(theta), 0.0, theta])
    rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    wp = scene.body("workpiece")
    depth = preload_depth(hand.length_scale)
    for pair in scene.pairs[:2]:  # c1 vertex 0 on the table, c2 vertex 3 on the palm (wall)
        circle = wp.shapes[pair.shape_b]
        cap = scene.body(pair.body_a).shapes[pair.shape_a]
        centre = pose[:2] + rot @ np.asarray(circle.center)
        gap = _gap_circle_capsule((centre, circle.radius), (cap.a, cap.b, cap.radius))
        assert gap == pytest.approx(-depth * np.cos(np.radians(turn_deg)), abs=1e-9), pair.name
