"""A physical scene of several workpieces (issue 17) from a contact-velocity System.

What is built (world frame of the system file, metres, no rescaling), one contact site per
contact so each engine pair holds one contact:

* **workpieces** ``work0 .. work{n_b-1}``: the convex polygons of ``System.workpieces`` (or
  ``System.workpiece`` for one body) with their mass and centre of mass; body frame = world
  frame at the start, so a recorded twist is the planner's ``qdot`` block of that body
  (docs/conventions.md);
* **environment contacts**: the fixed slab of :func:`sim.scenes.system.environment_surface`;
* **manipulator contacts**: driven fingertip circles moving with ``J_i thetadot`` (eq. 5)
  times ``speed_scale``, as in :mod:`sim.scenes.system`;
* **contacts between two workpieces** ``(a_i, b_i)`` (normal into ``a_i``): a small circle
  ("foot", radius ``FINGER_RADIUS * size``) fixed to body ``b_i`` whose rim touches body
  ``a_i``'s polygon at ``r_i`` (pre-loaded by ``PRELOAD * size``). Only declared pairs collide
  (``only_pairs``), so the two polygons themselves never touch: the foot is the contact. The
  engine reading of the pair (``body_a`` = ``b_i``, ``body_b`` = ``a_i``) then has the planner's
  signs: normal into ``a_i``, force on ``a_i``, slip of ``a_i`` minus ``b_i`` (eq. 5);
* **loads**: each body's ``g_obj`` block (about the world origin, eq. 2) as a force through its
  centre of mass plus the moment ``m_z - c x f``.
"""

from __future__ import annotations

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.model.workpiece import WorkpieceGeometry, point_in_convex_polygon
from sim.scene import Body, BodyKind, Circle, ContactPair, Load, Polygon, Scene, Shape
from sim.scenes.paper import constant_twist
from sim.scenes.system import FINGER_RADIUS, PRELOAD, environment_surface


def polygon_inertia(poly: np.ndarray, com: np.ndarray, mass: float) -> float:
    """Polar moment of inertia [kg m^2] about ``com`` (2,) of a uniform polygon (V, 2) of
    ``mass`` [kg] (integrated about ``com`` directly)."""
    p = poly - com
    x, y = p[:, 0], p[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    j = float(np.sum(cr * (x * x + x * x1 + x1 * x1 + y * y + y * y1 + y1 * y1))) / 12.0
    return mass * j / (0.5 * float(np.sum(cr)))


def body_name(a: int) -> str:
    """Scene name of workpiece ``a``."""
    return f"work{a}"


def _geometries(system: System) -> tuple[WorkpieceGeometry, ...]:
    if system.workpieces:
        return system.workpieces
    if system.n_bodies == 1 and system.workpiece is not None:
        return (system.workpiece,)
    raise InputError("simulate: expected scene geometry (polygon and mass) for every "
                     "workpiece, got none")


def multibody_scene(system: System, *, speed_scale: float = 1.0) -> Scene:
    """Scene of a contact-velocity ``system`` with ``n_b >= 1`` workpieces at its ``mu``.

    ``speed_scale`` [-] multiplies every commanded contact velocity (slow motion). Raises
    :class:`InputError` for a joint-space manipulator, missing geometry or a contact that is
    not on the boundary of the body its normal points into."""
    if not system.virtual_joints:
        raise InputError("simulate: expected a system given by contact velocities, got a "
                         "joint-space manipulator")
    if not (np.isfinite(speed_scale) and speed_scale > 0):
        raise InputError(f"speed scale: expected a finite number > 0, got {speed_scale}")
    geoms = _geometries(system)
    polys = [np.asarray(g.polygon, dtype=float) for g in geoms]
    coms = [np.asarray(g.com, dtype=float) for g in geoms]
    size = max(float(np.max(np.linalg.norm(p - c, axis=1))) for p, c in zip(polys, coms))
    pts, nrm = np.asarray(system.points, float), np.asarray(system.normals, float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    for i, (a, _) in enumerate(system.contact_bodies):
        gap = float(np.min((polys[a] - pts[i]) @ nrm[i]))
        if abs(gap) > 1e-6 * size or not point_in_convex_polygon(pts[i], polys[a]):
            raise InputError(f"contact {i + 1}: expected a point on the boundary of workpiece "
                             f"{a} with the polygon on the side of its normal, got "
                             f"{pts[i].tolist()}")
    radius = FINGER_RADIUS * size
    shapes: list[list[Shape]] = [[Polygon(tuple(map(tuple, p.tolist())))] for p in polys]
    bodies_extra: list[Body] = []
    pairs = []
    vel = np.asarray(system.joint_inputs, float).reshape(-1, 2) * speed_scale
    for i, (a, b) in enumerate(system.contact_bodies):
        centre = pts[i] - (radius - PRELOAD * size) * nrm[i]
        if b >= 0:  # a foot on body b touching body a
            shapes[b].append(Circle((float(centre[0]), float(centre[1])), radius))
            pairs.append(ContactPair(f"c{i + 1}", body_name(b), body_name(a),
                                     mu_static=float(system.mu[i]),
                                     shape_a=len(shapes[b]) - 1, shape_b=0))
            continue
        if system.environment[i]:
            name = f"env{i + 1}"
            bodies_extra.append(Body(name, (environment_surface(pts[i], nrm[i], polys[a],
                                                                size),),
                                     kind=BodyKind.STATIC))
        else:
            name = f"finger{i + 1}"
            v = vel[i, 0] * nrm[i] + vel[i, 1] * tng[i]
            bodies_extra.append(Body(name, (Circle((0.0, 0.0), radius),),
                                     pose=(float(centre[0]), float(centre[1]), 0.0),
                                     kind=BodyKind.DRIVEN,
                                     twist=constant_twist((float(v[0]), float(v[1]), 0.0))))
        pairs.append(ContactPair(f"c{i + 1}", name, body_name(a),
                                 mu_static=float(system.mu[i])))
    works = [Body(body_name(a), tuple(shapes[a]), mass=float(g.mass),
                  com=(float(coms[a][0]), float(coms[a][1])),
                  inertia=polygon_inertia(polys[a], coms[a], float(g.mass)))
             for a, g in enumerate(geoms)]
    loads = []
    for a, c in enumerate(coms):
        f = system.g_obj[3 * a:3 * a + 3]
        loads.append(Load(body_name(a), (float(f[0]), float(f[1])),
                          float(f[2] - (c[0] * f[1] - c[1] * f[0]))))
    allp = np.vstack(polys)
    lo, hi = allp.min(axis=0) - 3 * size, allp.max(axis=0) + 3 * size
    fastest = float(np.max(np.linalg.norm(vel, axis=1))) if len(vel) else 0.0
    return Scene(bodies=tuple(works + bodies_extra), pairs=tuple(pairs), loads=tuple(loads),
                 bounds=(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])),
                 length_scale=size, only_pairs=True,
                 meta={"n_bodies": system.n_bodies, "finger_radius": radius,
                       "preload_m": PRELOAD * size, "drive_speed": fastest,
                       "masses": [float(g.mass) for g in geoms]})
