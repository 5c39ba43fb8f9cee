"""DART shapes of the scene's 2-D shapes (:mod:`sim.backends.dart_engine`): every contact is a
sphere on a box or a sphere in the plane z = 0. Derivations and measurements: docs/engine-dart.md
("How the scene is built").
"""

from __future__ import annotations

import dartpy as dart
import numpy as np

from sim.scene import Body, Capsule, Circle, Shape
from sim.scenes.shapes import polygon_inertia

#: Extrusion depth along z of every box, in scene length scales (any depth beyond the largest
#: in-plane penetration gives the same in-plane contacts).
EXTRUSION_OF_SCALE = 1.0
#: Thickness of a polygon's edge slab, in scene length scales (at most half the polygon's
#: width); thinner towards a vertex of interior angle below 90 deg (:func:`_edge_slabs`).
SLAB_OF_SCALE = 1e-2
#: Radius of the sphere at every polygon vertex (a *tip*), in scene length scales. The sphere
#: passes through the vertex, its centre on the inward bisector, so it reaches the vertex in
#: every direction of the vertex's normal cone (a vertex resting on a face touches whatever the
#: angle between them) and bulges past each edge by ``rho (1 - sin(theta / 2))`` at most, for
#: an interior angle ``theta``. Above the scenes' pre-load (:data:`sim.scene.PRELOAD_OF_SCALE`),
#: so a tip's centre starts outside the face it touches. (A sphere tangent to both edges, inside
#: the vertex, stays ``rho (1 / sin(theta / 2) - 1)`` short of it: 2.9 rho at a 30 deg corner,
#: more than the pre-load -- a ladder's acute foot started without contact.)
ROUNDING_OF_SCALE = 1e-4

def rotation(theta: float) -> np.ndarray:
    """Rotation (3, 3) by ``theta`` [rad] about z."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


Primitive = tuple[dart.dynamics.Shape, np.ndarray, tuple[float, float]]


def _box(a: np.ndarray, b: np.ndarray, width: float, inward: float, depth: float) -> Primitive:
    """Box from ``a`` to ``b`` (2,) of ``width`` [m], centred ``inward`` [m] to the left."""
    d = b - a
    u = d / np.linalg.norm(d)
    c = 0.5 * (a + b) + inward * np.array([-u[1], u[0]])
    return (dart.dynamics.BoxShape([float(np.linalg.norm(d)), width, depth]),
            rotation(float(np.arctan2(u[1], u[0]))), (float(c[0]), float(c[1])))


def _sphere(c: np.ndarray, radius: float) -> Primitive:
    return (dart.dynamics.SphereShape(float(radius)), np.eye(3), (float(c[0]), float(c[1])))


def _is_rectangle(v: np.ndarray) -> bool:
    e = np.roll(v, -1, axis=0) - v
    corners = np.abs(np.einsum("ij,ij->i", e, np.roll(e, -1, axis=0)))
    return len(v) == 4 and bool(np.all(corners <= 1e-9 * np.max(np.sum(e * e, axis=1))))


#: Kinds of primitives: flat faces (boxes), round geometry (circles, capsule ends), polygon tips.
FACES, ROUNDS, TIPS = "faces", "rounds", "tips"
#: Kinds of the two sides of a pair that collide (either order): a sphere on a box or sphere.
#: Tips collide with rounds too: a fingertip at an acute vertex touches the tip sphere, the
#: slabs there being cut back (:func:`primitives`).
COLLIDING = {(FACES, ROUNDS), (FACES, TIPS), (ROUNDS, ROUNDS), (ROUNDS, TIPS)}


def primitives(shape: Shape, length: float) -> dict[str, list[Primitive]]:
    """DART shapes of a 2-D ``shape`` by kind (:data:`FACES`, :data:`ROUNDS`, :data:`TIPS`):
    ``(shape, rotation (3, 3), centre (2,))`` in the body frame; ``length`` [m] the scene's
    length scale. A circle is a sphere; a capsule a box (its straight part) and two end
    spheres; a rectangle one box, another convex polygon slabs along each edge (outer face on
    the edge, :data:`SLAB_OF_SCALE` thick, at most half the polygon's width, thinner towards
    a vertex of interior angle below 90 deg: :func:`_edge_slabs`), and every polygon
    vertex a sphere of radius :data:`ROUNDING_OF_SCALE` through the vertex, its centre on the
    inward bisector."""
    depth = EXTRUSION_OF_SCALE * length
    if isinstance(shape, Circle):
        return {ROUNDS: [_sphere(np.asarray(shape.center, dtype=float), shape.radius)]}
    if isinstance(shape, Capsule):
        a, b = np.asarray(shape.a, dtype=float), np.asarray(shape.b, dtype=float)
        if np.linalg.norm(b - a) <= 1e-9 * length:
            return {ROUNDS: [_sphere(a, shape.radius)]}
        return {FACES: [_box(a, b, 2.0 * shape.radius, 0.0, depth)],
                ROUNDS: [_sphere(a, shape.radius), _sphere(b, shape.radius)]}
    v = np.asarray(shape.vertices, dtype=float)
    nxt = np.roll(v, -1, axis=0)
    u = (nxt - v) / np.linalg.norm(nxt - v, axis=1)[:, None]
    inward = np.stack([-u[:, 1], u[:, 0]], axis=1)
    prev = np.roll(inward, 1, axis=0)  # inward normal of the edge ending at each vertex
    rho = ROUNDING_OF_SCALE * length
    bisector = prev + inward
    tips = [_sphere(c, rho) for c in
            v + rho * bisector / np.linalg.norm(bisector, axis=1)[:, None]]
    if _is_rectangle(v):  # one box: its first edge, as wide as the second edge is long
        w = float(np.linalg.norm(v[2] - v[1]))
        return {FACES: [_box(v[0], v[1], w, 0.5 * w, depth)], TIPS: tips}
    width = float(min(np.max((v - v[k]) @ inward[k]) for k in range(len(v))))
    h = min(SLAB_OF_SCALE * length, 0.5 * width)
    before = -np.roll(u, 1, axis=0)  # from each vertex along the edge ending there
    cot = (np.einsum("ij,ij->i", u, before)
           / np.abs(u[:, 0] * before[:, 1] - u[:, 1] * before[:, 0]))  # of the interior angle
    faces = [box for k in range(len(v)) for box in
             _edge_slabs(v[k], nxt[k], float(cot[k]), float(cot[(k + 1) % len(v)]), h, rho,
                         depth)]
    return {FACES: faces, TIPS: tips}


def _edge_slabs(a: np.ndarray, b: np.ndarray, cot_a: float, cot_b: float, h: float,
                rho: float, depth: float) -> list[Primitive]:
    """The slabs of the polygon edge from vertex ``a`` to ``b`` (2,) [m], outer faces on the
    edge, none reaching outside the polygon. ``cot_a``, ``cot_b``: cotangents of the interior
    angles at ``a`` and ``b``. At a vertex of interior angle ``theta`` below 90 deg a slab of
    thickness ``t`` must end ``t cot(theta)`` short of it (else its inner corner sticks
    ``t cos(theta)`` out past the neighbouring edge, where a finger at the vertex meets it): the
    ``h``-thick slab is cut back there and the rest of the edge is covered by slabs of half,
    a quarter, ... the thickness, each as close to the vertex as its thickness allows, down to
    the tip sphere (radius ``rho``, which covers the edge's first ``2 rho cos(theta / 2)``)."""
    length = float(np.linalg.norm(b - a))
    u = (b - a) / length
    ca, cb = max(cot_a, 0.0), max(cot_b, 0.0)
    t = h
    while t * (ca + cb) >= length - rho:  # a short edge between acute vertices: thinner
        t *= 0.5
    lo, hi = t * ca, length - t * cb
    out = [_box(a + lo * u, a + hi * u, t, 0.5 * t, depth)]
    while lo > rho or length - hi > rho:
        t *= 0.5
        if lo > rho:
            out.append(_box(a + t * ca * u, a + lo * u, t, 0.5 * t, depth))
            lo = t * ca
        if length - hi > rho:
            out.append(_box(a + hi * u, a + (length - t * cb) * u, t, 0.5 * t, depth))
            hi = length - t * cb
    return out


def moment_of_inertia(body: Body) -> float:
    """Moment of inertia [kg m^2] about the centre of mass: ``body.inertia``, else that of its
    first shape at uniform density (the formulas pymunk uses, so both engines agree)."""
    if body.inertia is not None:
        return float(body.inertia)
    m, com, shape = body.mass, np.asarray(body.com, dtype=float), body.shapes[0]
    if isinstance(shape, Circle):
        return float(m * (0.5 * shape.radius ** 2 + np.sum((np.asarray(shape.center) - com) ** 2)))
    if isinstance(shape, Capsule):
        a, b = np.asarray(shape.a, dtype=float), np.asarray(shape.b, dtype=float)
        length = float(np.linalg.norm(b - a)) + 2.0 * shape.radius
        return float(m * ((length ** 2 + 4.0 * shape.radius ** 2) / 12.0
                          + np.sum((0.5 * (a + b) - com) ** 2)))
    return polygon_inertia(np.asarray(shape.vertices, dtype=float), m, com)
