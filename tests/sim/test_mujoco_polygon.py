"""MuJoCo polygons without corner spurs (:mod:`sim.backends.mujoco_polygon`).

A polygon is thin boxes along its edges; at a vertex of interior angle ``theta < 90 deg`` a box
reaching the vertex puts its inner corner ``h cos theta`` outside the neighbouring edge. The
pieces cut the boxes back by ``h cot theta`` there and fill the tip with a triangular prism:
every point of every piece is inside the polygon, and the pieces cover its boundary.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.backends.mujoco_polygon import (
    EDGE_BOX_OF_SIZE,
    interior_angles,
    polygon_geoms,
    polygon_pieces,
)

#: A ladder's outline: rails at 30 deg, ends cut at 60 deg (two 30-deg and two 150-deg corners).
LADDER = np.array([[0.0, 0.0], [1.732051, 1.0], [1.782051, 1.086603], [0.05, 0.086603]])
#: A needle triangle (10, 10, 160 deg) and a triangle with a 5-deg tip on a short base.
NEEDLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0882]])
SLIVER = np.array([[0.0, 0.0], [0.02, 0.0], [0.01, 0.2286]])
#: A strip 5 mm thin whose 27-deg corner has a 11 mm edge: the tip's cut (2 h) passes the
#: edge's end, and the top edge's box would pass the bottom edge.
STRIP = np.array([[0.0, 0.0], [1.0, 0.0], [1.01, 0.005], [0.0, 0.005]])


def box_corners(a: np.ndarray, b: np.ndarray, thickness: float) -> np.ndarray:
    u = (b - a) / np.linalg.norm(b - a)
    m = np.array([-u[1], u[0]])
    return np.array([a, b, b + thickness * m, a + thickness * m])


def outside(points: np.ndarray, poly: np.ndarray) -> float:
    """Largest distance [m] of ``points`` outside the convex counter-clockwise ``poly``."""
    nxt = np.roll(poly, -1, axis=0)
    worst = 0.0
    for a, b in zip(poly, nxt):
        u = (b - a) / np.linalg.norm(b - a)
        m = np.array([-u[1], u[0]])
        worst = max(worst, float(np.max(-(points - a) @ m)))
    return worst


def random_polygon(rng: np.random.Generator) -> np.ndarray:
    """A convex polygon of 3-7 vertices: sorted angles on an ellipse (acute corners common)."""
    k = int(rng.integers(3, 8))
    ang = np.sort(rng.uniform(0.0, 2 * np.pi, size=k))
    ax = rng.uniform(0.2, 1.0, size=2)
    return np.stack([ax[0] * np.cos(ang), ax[1] * np.sin(ang)], axis=1)


def on_boundary_covered(poly: np.ndarray, boxes, tips, samples: int = 400) -> bool:
    """Every sampled boundary point lies on a box's outer face or on a tip triangle's side."""
    faces = [(bx.a, bx.b) for bx in boxes]
    faces += [(t[0], t[1]) for t in tips] + [(t[1], t[2]) for t in tips]
    fa = np.array([f[0] for f in faces])
    d = np.array([f[1] - f[0] for f in faces])
    s = np.linspace(0.0, 1.0, samples)
    pts = np.concatenate([a + s[:, None] * (b - a)
                          for a, b in zip(poly, np.roll(poly, -1, axis=0))])
    rel = pts[:, None, :] - fa[None]  # (P, F, 2)
    t = np.clip(np.einsum("pfi,fi->pf", rel, d) / np.einsum("fi,fi->f", d, d), 0.0, 1.0)
    gap = np.linalg.norm(rel - t[..., None] * d[None], axis=2)
    return bool(np.all(np.min(gap, axis=1) <= 1e-9))


@pytest.mark.parametrize("poly", [LADDER, NEEDLE, SLIVER, STRIP],
                         ids=["ladder", "needle", "sliver", "strip"])
def test_pieces_stay_inside_the_polygon_and_cover_its_boundary(poly: np.ndarray) -> None:
    h = 0.02 * float(np.max(np.linalg.norm(poly - poly.mean(axis=0), axis=1)))
    boxes, tips = polygon_pieces(poly, h)
    assert len(tips) == int(np.sum(interior_angles(poly) < np.pi / 2))
    for bx in boxes:
        assert outside(box_corners(bx.a, bx.b, bx.thickness), poly) <= 1e-12
        assert bx.thickness > 0
    for tri in tips:
        assert outside(tri, poly) <= 1e-12
    assert on_boundary_covered(poly, boxes, tips)


def test_a_box_reaching_an_acute_vertex_sticks_out_h_cos_theta() -> None:
    """The representation replaced: one box per edge, full length. At the ladder's 30-deg foot
    the neighbouring edge's box corner is ``h cos 30 deg`` outside the polygon."""
    h = 0.02
    a, b = LADDER[0], LADDER[1]  # the rail from the 30-deg foot
    corners = box_corners(a, b, h)
    assert outside(corners, LADDER) == pytest.approx(h * np.cos(np.radians(30.0)), rel=1e-5)


def test_polygons_without_acute_corners_keep_their_boxes() -> None:
    box = np.array([[0.0, 0.0], [0.08, 0.0], [0.08, 0.12], [0.0, 0.12]])
    boxes, tips = polygon_pieces(box, 0.002)
    assert tips == []
    assert len(boxes) == 4
    for k, bx in enumerate(boxes):
        assert np.allclose([bx.a, bx.b], [box[k], box[(k + 1) % 4]])
        assert bx.thickness == 0.002


def test_random_convex_polygons() -> None:
    rng = np.random.default_rng(7)
    for _ in range(60):
        poly = random_polygon(rng)
        h = 0.02 * float(np.max(np.linalg.norm(poly - poly.mean(axis=0), axis=1)))
        boxes, tips = polygon_pieces(poly, h)
        for bx in boxes:
            assert outside(box_corners(bx.a, bx.b, bx.thickness), poly) <= 1e-12
        for tri in tips:
            assert outside(tri, poly) <= 1e-12
        assert on_boundary_covered(poly, boxes, tips, samples=60)


def test_a_vertex_just_under_90_degrees_compiles_at_a_user_size():
    """A 3.4 cm block whose corners are 89.1 deg (a random hand of the campaign, seed 7): the
    tip cut there is ``h cot theta`` = 0.3 um long and its prism has almost no volume, which
    MuJoCo refuses for a mesh whose inertia it computes ("mesh volume is too small"). The
    pieces carry no mass, so the tip meshes take a shell's inertia and compile."""
    v = np.array([[-0.0007812700837830993, 0.0], [0.0330225323729085, 0.0],
                  [0.033524482864468436, 0.033124276846770356],
                  [3.615511333801062e-05, 0.03362348828606614]])
    _, tips = polygon_pieces(v, EDGE_BOX_OF_SIZE * 0.034)
    assert len(tips) == 2 and max(np.ptp(t, axis=0).max() for t in tips) < 2e-5
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="w", mass=0.08, inertia=[1e-5, 1e-5, 1e-5],
                                   explicitinertial=True)
    polygon_geoms(spec, body, "workpiece:g0", v, 0.0034, 0.034)
    assert spec.compile().nmesh == 2
