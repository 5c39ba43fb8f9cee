"""Round shapes moved off the line of a polygon edge, for pymunk (Chipmunk2D).

Chipmunk's closest points between a circle (or a capsule's end) and a polygon
(``ClosestPointsNew`` in ``cpCollision.c``) take the normal of the Minkowski-difference edge
GJK ends on and, when the distance along that normal is ``<= 0``, report an overlap along it.
A round shape whose centre lies exactly on the line of a polygon edge, beyond the edge's end,
ends on that edge with distance exactly 0: the contact comes out along the edge's normal, at a
depth of the whole radius, instead of along the line from the vertex to the centre. That is
where a scene puts a fingertip or a foot that touches a rectangle's corner along one side's
normal (a block's corner resting on a support, a finger pushing a corner squarely): the centre
``r - (R - preload) n`` lies on the line of the other side. Measured: a circle of radius
16 mm under a box corner reports depth 16 mm along ``(1, 0)`` at offset 0 and the correct
20 um along ``(0, 1)`` at offsets of +-1e-15 m; a capsule ending there, 16 mm along ``(1, 0)``
or no contact at all (docs/simulation.md, "Contacts at polygon vertices").

:func:`edge_line_offsets` moves such a shape :data:`EDGE_LINE_OFFSET` times the scene's length
scale off the line, to the polygon's outside: it then touches the vertex, and its contact normal
turns by that offset over the radius (2.5e-8 rad for a fingertip of 0.04 x the scene size).
"""

from __future__ import annotations

import numpy as np

from sim.scene import Body, Capsule, Circle, Polygon, Scene

#: Offset of a round shape from a polygon edge's line, as a fraction of the scene's length
#: scale [-]: far above rounding (1e-16 relative; Chipmunk resolves 1e-15 m at 0.4 m) and
#: far below every tolerance (the pre-load is 5e-5).
EDGE_LINE_OFFSET = 1e-9


def _world(body: Body, p: tuple[float, float]) -> np.ndarray:
    x, y, th = body.pose
    c, s = np.cos(th), np.sin(th)
    return np.array([x + c * p[0] - s * p[1], y + s * p[0] + c * p[1]])


def _centres(body: Body, shape: Circle | Capsule) -> list[np.ndarray]:
    """World centres of the round ends of ``shape`` (a circle's centre, a capsule's ends)."""
    if isinstance(shape, Circle):
        return [_world(body, shape.center)]
    return [_world(body, shape.a), _world(body, shape.b)]


def off_line_shift(centres: list[np.ndarray], vertices: np.ndarray, tol: float
                   ) -> np.ndarray:
    """World shift (2,) [m] that puts every point of ``centres`` at least ``tol`` [m] off the
    line of each edge of the counter-clockwise polygon ``vertices`` (V, 2) [m, world] it lies
    on beyond the edge's ends; zero when none does."""
    shift = np.zeros(2)
    nxt = np.roll(vertices, -1, axis=0)
    for p in centres:
        for a, b in zip(vertices, nxt):
            e = b - a
            length = float(np.linalg.norm(e))
            u = e / length
            inward = np.array([-u[1], u[0]])
            q = p + shift
            outside = -float(inward @ (q - a))  # signed distance outside the edge's line
            along = float(u @ (q - a))
            if abs(outside) <= tol and (along < 0.0 or along > length):
                shift = shift - (tol - outside) * inward
    return shift


def edge_line_offsets(scene: Scene) -> dict[tuple[str, int], tuple[float, float]]:
    """``{(body, shape index): (dx, dy)}`` in that body's frame [m]: the round shape of each
    declared pair with a polygon that lies on the line of one of its edges beyond the edge's
    end (module docstring), moved :data:`EDGE_LINE_OFFSET` x ``scene.length_scale`` outside.
    Poses are the scene's initial ones."""
    tol = EDGE_LINE_OFFSET * scene.length_scale
    out: dict[tuple[str, int], tuple[float, float]] = {}
    for p in scene.pairs:
        ends = ((p.body_a, p.shape_a), (p.body_b, p.shape_b))
        for (rb, rk), (pb, pk) in (ends, ends[::-1]):
            round_body, poly_body = scene.body(rb), scene.body(pb)
            shape, poly = round_body.shapes[rk], poly_body.shapes[pk]
            if not isinstance(shape, Circle | Capsule) or not isinstance(poly, Polygon):
                continue
            verts = np.array([_world(poly_body, v) for v in poly.vertices])
            shift = off_line_shift(_centres(round_body, shape), verts, tol)
            if np.any(shift):
                th = round_body.pose[2]
                c, s = np.cos(th), np.sin(th)
                prev = np.array(out.get((rb, rk), (0.0, 0.0)))
                local = prev + np.array([c * shift[0] + s * shift[1],
                                         -s * shift[0] + c * shift[1]])
                out[(rb, rk)] = (float(local[0]), float(local[1]))
    return out
