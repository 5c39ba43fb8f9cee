"""A convex polygon as MuJoCo geoms whose union is the polygon's boundary band, nothing outside.

MuJoCo collides a sphere or capsule with a box analytically and cleanly, while a convex mesh
goes through its general convex collider; a polygon is therefore one thin box per edge, its
outer face on the edge and ``h`` thick inward. At a vertex of interior angle ``theta < 90 deg``
such a box's inner corner lies ``h cos theta`` outside the neighbouring edge's line (it is ``h``
along the first edge's inward normal ``m_1``, and ``-h m_1 . m_2 = h cos theta``): the polygon
grows a spur below and beside every acute vertex, and a body resting or pushed there stands on
the spur (a 30 deg foot on a floor turned 66 mrad and rested 2 % of its size away from the
vertex; docs/simulation.md, "MuJoCo: polygons without corner spurs").

:func:`polygon_pieces` cuts every edge box back at an acute vertex by ``s = h cot theta`` --
from there on its inner corner is inside the neighbouring edge's line (``s sin theta >=
h cos theta``) -- and fills the tip with a triangular prism ``(v - s u_1, v, v + s u_2)``
(``u_1``, ``u_2`` the edge directions), a convex mesh: every point of every piece is inside the
polygon, and the pieces cover its boundary. Polygons without acute vertices keep exactly the
boxes they had. Where a tip's cut would pass the far end of an edge (an edge shorter than the
cut), the cut stops at the edge's end; a box is made thinner wherever its inner corners would
leave the polygon (a cut so shortened, a polygon thinner than ``h``).

Measured against edge slabs cut by the vertex bisectors (every edge a convex mesh) and one
convex mesh for the whole polygon: all three remove the spur; the boxes keep the analytic
collider on every edge (docs/simulation.md, the same section).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import mujoco
import numpy as np

#: Thickness of an edge box as a fraction of the scene's length scale [-] (far more than any
#: penetration: the pre-load is 5e-5 and MuJoCo's soft contacts sink ~1e-4 x size).
EDGE_BOX_OF_SIZE = 0.02


class EdgeBox(NamedTuple):
    """A box on a polygon edge: outer face from ``a`` to ``b`` (2,) [m, body frame],
    ``thickness`` [m] inward (to the left of ``a -> b``)."""

    a: np.ndarray
    b: np.ndarray
    thickness: float


def interior_angles(vertices: np.ndarray) -> np.ndarray:
    """(V,) interior angle [rad] at every vertex of a convex counter-clockwise polygon."""
    v = np.asarray(vertices, dtype=float)
    u, w = np.roll(v, 1, axis=0) - v, np.roll(v, -1, axis=0) - v
    cos = np.einsum("ij,ij->i", u, w) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
    return np.arccos(np.clip(cos, -1.0, 1.0))


def _depth_inside(p: np.ndarray, m: np.ndarray, v: np.ndarray, inward: np.ndarray) -> float:
    """Largest ``t >= 0`` [m] with ``p + t m`` inside the polygon of vertices ``v`` (V, 2) and
    inward unit normals ``inward`` (V, 2) (``inf`` when no edge bounds the ray)."""
    towards = inward @ m
    reach = np.einsum("ij,ij->i", inward, p - v)
    hit = towards < -1e-15
    return float(np.min(reach[hit] / -towards[hit])) if np.any(hit) else np.inf


def polygon_pieces(vertices: np.ndarray, h: float
                   ) -> tuple[list[EdgeBox], list[np.ndarray]]:
    """The pieces of a convex counter-clockwise polygon ``vertices`` (V, 2) [m]: edge boxes of
    thickness ``h`` [m] -- less where the polygon is thinner, or where a tip's cut was
    shortened to its edge, so that no box corner leaves the polygon -- and, per acute vertex, a
    tip triangle (3, 2) [m]; all in the polygon's frame (module docstring)."""
    v = np.asarray(vertices, dtype=float)
    nv = len(v)
    edges = np.roll(v, -1, axis=0) - v
    length = np.linalg.norm(edges, axis=1)
    u = edges / length[:, None]
    inward = np.stack([-u[:, 1], u[:, 0]], axis=1)
    theta = interior_angles(v)
    acute = theta < 0.5 * np.pi - 1e-9
    cut = np.zeros(nv)
    for k in np.flatnonzero(acute):
        cut[k] = min(h / np.tan(theta[k]), length[k - 1], length[k])
    boxes = []
    for e in range(nv):
        lo, hi = cut[e], length[e] - cut[(e + 1) % nv]
        if hi - lo <= 1e-9 * length[e]:
            continue
        a, b = v[e] + lo * u[e], v[e] + hi * u[e]
        thick = min(h, _depth_inside(a, inward[e], v, inward),
                    _depth_inside(b, inward[e], v, inward))
        if thick > 1e-9 * h:
            boxes.append(EdgeBox(a, b, float(thick)))
    tips = [np.array([v[k] - cut[k] * u[k - 1], v[k], v[k] + cut[k] * u[k]])
            for k in np.flatnonzero(acute)]
    return boxes, tips


def _no_collisions(geom: Any) -> Any:
    """Only the scene's explicit pairs collide; shapes carry no mass (explicit inertials)."""
    geom.contype = 0
    geom.conaffinity = 0
    geom.mass = 0.0
    return geom


def polygon_geoms(spec: Any, body: Any, name: str, vertices: np.ndarray, depth: float,
                  length: float) -> list[Any]:
    """Add the pieces of polygon ``vertices`` (V, 2) [m, body frame] to MjSpec ``body``:
    boxes ``f"{name}:e<k>"`` and tip prisms ``f"{name}:v<k>"`` (meshes in ``spec``), all
    ``2 depth`` [m] thick out of the plane; ``length`` [m] the scene's length scale. Returns
    the geoms."""
    boxes, tips = polygon_pieces(vertices, EDGE_BOX_OF_SIZE * length)
    geoms = []
    for k, bx in enumerate(boxes):
        d = bx.b - bx.a
        ln = float(np.linalg.norm(d))
        ang = float(np.arctan2(d[1], d[0]))
        inward = np.array([-d[1], d[0]]) / ln
        c = 0.5 * (bx.a + bx.b) + 0.5 * bx.thickness * inward
        geoms.append(_no_collisions(body.add_geom(
            name=f"{name}:e{k}", type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.5 * ln, 0.5 * bx.thickness, depth], pos=[c[0], c[1], 0.0],
            quat=[np.cos(ang / 2), 0.0, 0.0, np.sin(ang / 2)])))
    for k, tri in enumerate(tips):
        mesh = f"{name}:v{k}:mesh"
        # the pieces carry no mass (explicit inertials): a shell's inertia needs no volume,
        # which a tip cut at a vertex of nearly 90 deg (``s = h cot theta``) hardly has
        spec.add_mesh(name=mesh, uservert=[float(c) for z in (-depth, depth)
                                           for p in tri for c in (p[0], p[1], z)],
                      inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL)
        geoms.append(_no_collisions(body.add_geom(
            name=f"{name}:v{k}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh)))
    return geoms
