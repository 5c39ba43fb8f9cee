"""Shapes shared by the scene builders: polygon inertia, the polygon a system's contacts bound,
environment surfaces, the face of a workpiece under another's corner, and constant drives.

Sizes are fractions of the scene's ``size`` (its largest distance of a workpiece vertex from the
centre of mass), so a scene and its scaled copy (:mod:`sim.similarity`) are similar.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from planner.errors import InputError
from sim.scene import BodyState, Capsule, Command

#: Initial overlap of every contact, as a fraction of the scene size [-] (a known pre-load:
#: bodies built exactly touching get a gap of +-1e-17 m from rounding, and a positive one is no
#: contact at the first step; :func:`sim.scene.preload_depth` of the same scene).
PRELOAD = 5e-5
#: Fingertip radius as a fraction of the scene size [-].
FINGER_RADIUS = 0.04
#: How far an environment surface reaches beyond the workpiece / under it, fractions of size.
ENV_REACH = 0.5
ENV_INSET = 0.05
#: Thickness (capsule diameter) of an environment surface, fraction of size.
ENV_THICKNESS = 0.1


def polygon_inertia(vertices: np.ndarray, mass: float, com: np.ndarray) -> float:
    """Rotational inertia [kg m^2] about ``com`` (2,) [m] of a uniform polygon ``vertices``
    (V, 2) [m] (counter-clockwise) of total ``mass`` [kg], integrated about ``com`` directly
    (the area centroid may differ from ``com``)."""
    v = np.asarray(vertices, dtype=float) - np.asarray(com, dtype=float)
    a, b = v, np.roll(v, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    area = 0.5 * float(np.sum(cross))
    second = float(np.sum(cross * (np.sum(a * a, axis=1) + np.sum(a * b, axis=1)
                                   + np.sum(b * b, axis=1)))) / 12.0
    return mass * second / area


def _clip(poly: np.ndarray, n: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: keep the part of convex ``poly`` (k, 2) with ``n . (x - r) >= 0``."""
    out = []
    k = len(poly)
    for i in range(k):
        a, b = poly[i], poly[(i + 1) % k]
        da, db = float(n @ (a - r)), float(n @ (b - r))
        if da >= 0:
            out.append(a)
        if (da >= 0) != (db >= 0):
            out.append(a + (b - a) * (da / (da - db)))
    return np.asarray(out)


def workpiece_polygon(points: np.ndarray, normals: np.ndarray, box: float) -> np.ndarray:
    """Convex polygon (k, 2), counter-clockwise, bounded by the contact tangent lines.

    ``box`` [m] half-width of the square that closes it when the normals do not positively span
    the plane. Raises :class:`InputError` when a contact point is not on the boundary (another
    contact's half-plane cuts it off).
    """
    poly = box * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    for n, r in zip(normals, points):
        poly = _clip(poly, n, r)
        if len(poly) < 3:
            raise InputError("workpiece: the contact half-planes leave no body")
    for i, r in enumerate(points):
        slack = np.array([nj @ (r - rj) for nj, rj in zip(normals, points)])
        if np.any(slack < -1e-9 * box) or np.any(np.abs(r) > box):
            raise InputError(f"workpiece: contact {i + 1} is not on the polygon boundary")
    return poly


def constant_twist(twist: tuple[float, float, float]) -> Command:
    """A driven body's command that always returns ``twist`` ``(v_x, v_y, omega)``."""
    def command(t: float, states: Mapping[str, BodyState]) -> tuple[float, float, float]:
        return twist
    return command


def at_vertex(r: np.ndarray, poly: np.ndarray, size: float) -> bool:
    """True when the point ``r`` (2,) [m] is a vertex of ``poly`` (V, 2) [m] (within
    ``1e-6 * size``)."""
    return bool(np.min(np.linalg.norm(np.asarray(poly) - np.asarray(r), axis=1)) <= 1e-6 * size)


def _surface(r: np.ndarray, n: np.ndarray, lo: float, hi: float, size: float) -> Capsule:
    """A capsule of radius ``ENV_THICKNESS * size / 2`` on the side of ``-n``, its flat top on
    the tangent line through ``r`` shifted ``PRELOAD * size`` along ``n``, from ``lo`` to
    ``hi`` [m] along ``t = rot90(n)``."""
    t = np.array([-n[1], n[0]])
    radius = 0.5 * ENV_THICKNESS * size
    axis = r + PRELOAD * size * n - radius * n
    a, b = axis + lo * t, axis + hi * t
    return Capsule((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), radius)


def _reach(r: np.ndarray, n: np.ndarray, poly: np.ndarray, size: float) -> tuple[float, float]:
    """How far [m] a surface at ``r`` reaches along ``t = rot90(n)`` each way: ``ENV_REACH *
    size`` where ``poly`` does not lie, ``ENV_INSET * size`` under it."""
    t = np.array([-n[1], n[0]])
    along = (poly - r) @ t
    tol = 1e-9 * size
    lo = -ENV_REACH * size if along.min() >= -tol else -ENV_INSET * size
    hi = ENV_REACH * size if along.max() <= tol else ENV_INSET * size
    return lo, hi


def environment_surface(r: np.ndarray, n: np.ndarray, poly: np.ndarray, size: float
                        ) -> Capsule:
    """The fixed surface of an environment contact at ``r`` (2,) [m] with inward normal ``n``:
    a capsule whose flat top lies on the tangent line through ``r`` shifted ``PRELOAD * size``
    into the workpiece, spanning the tangent interval described in the module docstring, of
    radius ``ENV_THICKNESS * size / 2`` on the side away from the workpiece (world frame)."""
    lo, hi = _reach(r, n, poly, size)
    return _surface(r, n, lo, hi, size)


def support_surface(r: np.ndarray, n: np.ndarray, poly: np.ndarray, support: np.ndarray,
                    size: float) -> Capsule | None:
    """The face of another workpiece (polygon ``support`` (S, 2) [m]) that a vertex ``r`` (2,)
    [m] of ``poly`` rests on, inward normal ``n`` (into ``poly``; world frame): the capsule of
    :func:`environment_surface` with its flat top cut where ``support``'s boundary leaves the
    tangent line (the vertex slides along the face, and off it only where the face ends).
    ``None`` when ``support`` meets the tangent line at a point only (its own vertex: the
    contact is vertex on vertex, and a round foot stands for that corner)."""
    n = np.asarray(n, dtype=float) / float(np.linalg.norm(n))
    t = np.array([-n[1], n[0]])
    tol = 1e-6 * size
    on = np.abs((support - r) @ n) <= tol
    along = np.append((support[on] - r) @ t, 0.0)
    lo, hi = _reach(r, n, poly, size)
    lo, hi = max(lo, float(along.min())), min(hi, float(along.max()))
    if hi - lo <= tol:
        return None
    return _surface(r, n, lo, hi, size)
