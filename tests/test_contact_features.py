"""A contact's workpiece feature in system scenes (:func:`sim.scenes.system.contact_feature`).

MuJoCo builds a polygon as one thin box per edge, its outer face on the edge and thickness
``h`` inward. At a vertex of interior angle ``theta`` the inner corner of one edge's box lies
``h cos theta`` past the neighbouring edge's line (the corner is ``h`` along the first edge's
inward normal ``m_1``; its distance outside edge 2 is ``-h m_1 . m_2 = h cos theta``, since the
inward normals meet at ``pi - theta``), so at an acute vertex resting on a table the workpiece
stands on that corner, below and inside its vertex. Environment contacts therefore pair with
their own feature: a small circle touching the vertex, or a capsule on the edge.

The triangle below (vertices ``(0, 0)``, ``(0.1, 0)``, ``(0.03, 0.06)``: 63, 41 and 76 deg)
stands on the table at its two bottom vertices (friction 0.3) and a frictionless finger pushes
the middle of its left edge. By hand: with the finger's normal ``n_3 = (2, -1)/sqrt 5``
pushing with force ``P``, horizontal balance ``P 2/sqrt 5 = 0.3 N`` and vertical ``N = m g + P /
sqrt 5`` give ``P = 0.3 m g / (2/sqrt 5 - 0.3/sqrt 5) = 0.387`` N, and the triangle slides
without turning, ``S-1 S-2 S+3``; mirrored, ``S+1 S+2 S-3``. With the whole polygon paired,
MuJoCo turned the triangle (twist 23 % off the prediction, ``inconclusive``) on its 41 deg
vertex's box corner 1.5 mm below the table line.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.system_file import system_from_dict
from planner.predict.feasibility import feasible_modes
from scenarios.runs import simulate_system
from sim.scene import Capsule, Circle
from sim.scenes.shapes import FEATURE_RADIUS, contact_feature, near_acute_vertex
from sim.scenes.system import system_scene
from sim.verdict import Outcome

WEIGHT = 0.981
POLY = [[0.0, 0.0], [0.1, 0.0], [0.03, 0.06]]


def triangle(mirrored: bool = False) -> dict:
    cx = sum(p[0] for p in POLY) / 3
    n3 = [2 / math.sqrt(5), -1 / math.sqrt(5)]
    d = {
        "name": "triangle pushed on its sloped side",
        "contacts": [
            {"point": [0.0, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
            {"point": [0.1, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
            {"point": [0.015, 0.03], "normal": n3, "mu": 0.0},
        ],
        "external_wrench": [0.0, -WEIGHT, -cx * WEIGHT],
        "manipulator": {"contact_velocities": [[0.0, 0.0], [0.0, 0.0], [0.001, 0.0]]},
        "workpiece": {"polygon": POLY, "mass": 0.1},
    }
    if mirrored:  # x -> -x; the polygon reversed to stay counter-clockwise
        for c in d["contacts"]:
            c["point"][0] *= -1
            c["normal"][0] *= -1
        d["external_wrench"][2] *= -1
        d["workpiece"]["polygon"] = [[-x, y] for x, y in reversed(POLY)]
    return d


def test_features_touch_where_the_contact_is() -> None:
    poly = np.array(POLY)
    size = 0.07
    rho = FEATURE_RADIUS * size
    v = contact_feature(np.array([0.1, 0.0]), np.array([0.0, 2.0]), poly, size)
    assert isinstance(v, Circle)
    assert v.radius == pytest.approx(rho)
    assert np.allclose(v.center, [0.1, rho])  # lowest point on the vertex
    e = contact_feature(np.array([0.05, 0.0]), np.array([0.0, 1.0]), poly, size)
    assert isinstance(e, Capsule)
    assert np.allclose([e.a, e.b], [[0.0, rho], [0.1, rho]])  # surface on the edge line
    with pytest.raises(InputError, match="expected a polygon vertex or a point on an edge"):
        contact_feature(np.array([0.05, 0.0]), np.array([1.0, 0.0]), poly, size)


def test_only_contacts_at_acute_vertices_need_a_feature() -> None:
    box = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tri = np.array(POLY)
    assert not near_acute_vertex(np.array([0.0, 0.0]), box, 1.0)  # 90 deg: no stick-out
    assert not near_acute_vertex(np.array([0.5, 0.0]), box, 1.0)
    assert near_acute_vertex(np.array([0.1, 0.0]), tri, 0.07)  # the 41 deg vertex
    assert near_acute_vertex(np.array([0.05, 0.0]), tri, 0.07)  # an edge ending at one


def test_environment_contacts_pair_with_their_feature_fingers_with_the_polygon() -> None:
    scene = system_scene(system_from_dict(triangle()))
    work = next(b for b in scene.bodies if b.name == "workpiece")
    pairs = {p.name: p for p in scene.pairs}
    assert isinstance(work.shapes[pairs["c1"].shape_b], Circle)
    assert isinstance(work.shapes[pairs["c2"].shape_b], Circle)
    assert pairs["c3"].shape_b == 0  # the polygon


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
@pytest.mark.parametrize("mirrored", [False, True])
def test_triangle_on_a_table_slides_in_both_engines(engine: str, mirrored: bool) -> None:
    system = system_from_dict(triangle(mirrored))
    pred = feasible_modes(system)
    expected = "S+1 S+2 S-3" if mirrored else "S-1 S-2 S+3"
    assert pred.labels == [expected]
    assert pred.modes[0].contact_forces[2, 0] == pytest.approx(0.3 * WEIGHT / (1.7 / math.sqrt(5)), rel=1e-6)
    res = simulate_system(system, engine)
    assert res.verdict.outcome is Outcome.AGREED, res.verdict.reason
