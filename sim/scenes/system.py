"""A physical scene for ANY contact-velocity :class:`~planner.model.system.System` (issue 14).

What is built (all in the world frame of the system file, metres, no rescaling):

* **workpiece**: the convex polygon of ``System.workpiece`` (mass and centre of mass from the
  file) when given; otherwise the polygon bounded by the contact tangent lines
  (:func:`sim.scenes.paper.workpiece_polygon`) with its centre of mass at the world origin (the
  paper's origin is the centre of gravity, Sec. 4) and a default mass;
* **environment contacts** (``"environment": true``): a *fixed flat surface* along the contact's
  tangent ``t_i = rot90(n_i)`` (not a peg): a static slab with rounded ends (a capsule of radius
  ``ENV_THICKNESS / 2`` times the scene size) whose flat top is the contact's tangent line. It
  reaches ``ENV_REACH`` times the size past the contact on any side where the workpiece does
  not lie, and only ``ENV_INSET`` times the size under the workpiece, so a workpiece vertex at
  the contact (a box corner on a table) can lift off or pivot there. Rounded ends rather than a
  box: MuJoCo's box-box contact of a flat workpiece edge on a box slab stuck and slipped (the
  box on a table, pushed, moved in jumps of up to 20x the drive speed); on the capsule it slides
  at the drive speed, as in pymunk;
* **manipulator contacts**: small driven fingertip circles touching at ``r_i`` and moving with
  the commanded contact velocity ``J_i thetadot = v_in n_i + v_it t_i`` (eq. 5) times
  ``speed_scale`` (slow motion; positive scaling leaves the quasistatic mode set unchanged);
* **load**: ``g_obj`` (eq. 2, given about the world origin) applied as a force through the
  centre of mass ``c`` plus the moment ``m_z - (c_x f_y - c_y f_x)`` -- the same wrench;
* **pre-load**: every contact starts overlapped by ``PRELOAD * size`` [m] (a known, scene-scaled
  depth; SIM-NOTES: bodies that start exactly touching flip a coin on rounding).

``size`` (the scene's ``length_scale``) is the largest distance of a polygon vertex from the
centre of mass.
"""

from __future__ import annotations

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.model.workpiece import point_in_convex_polygon, polygon_area_centroid
from sim.scene import Body, BodyKind, Capsule, Circle, ContactPair, Load, Polygon, Scene
from sim.scenes.paper import constant_twist, workpiece_polygon

#: Initial overlap of every contact, as a fraction of the scene size [-].
PRELOAD = 5e-5
#: Fingertip radius as a fraction of the scene size [-].
FINGER_RADIUS = 0.04
#: How far an environment surface reaches beyond the workpiece / under it, fractions of size.
ENV_REACH = 0.5
ENV_INSET = 0.05
#: Thickness (capsule diameter) of an environment surface, fraction of size.
ENV_THICKNESS = 0.1
#: Mass [kg] of a derived workpiece (no ``workpiece`` key in the file).
DEFAULT_MASS = 0.1


def _polygon_inertia(poly: np.ndarray, com: np.ndarray, mass: float) -> float:
    """Polar moment of inertia [kg m^2] about ``com`` of a uniform polygon of ``mass``."""
    p = poly - com
    x, y = p[:, 0], p[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    area = 0.5 * float(np.sum(cr))
    j = float(np.sum(cr * (x * x + x * x1 + x1 * x1 + y * y + y * y1 + y1 * y1))) / 12.0
    # the area centroid may differ from com: parallel axis handled by integrating about com
    return mass * j / area


def environment_surface(r: np.ndarray, n: np.ndarray, poly: np.ndarray, size: float
                        ) -> Capsule:
    """The fixed surface of an environment contact at ``r`` (2,) [m] with inward normal ``n``:
    a capsule whose flat top lies on the tangent line through ``r`` shifted ``PRELOAD * size``
    into the workpiece, spanning the tangent interval described in the module docstring, of
    radius ``ENV_THICKNESS * size / 2`` on the side away from the workpiece (world frame)."""
    t = np.array([-n[1], n[0]])
    along = (poly - r) @ t
    tol = 1e-9 * size
    lo = -ENV_REACH * size if along.min() >= -tol else -ENV_INSET * size
    hi = ENV_REACH * size if along.max() <= tol else ENV_INSET * size
    radius = 0.5 * ENV_THICKNESS * size
    axis = r + PRELOAD * size * n - radius * n
    a, b = axis + lo * t, axis + hi * t
    return Capsule((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), radius)


def system_scene(system: System, *, speed_scale: float = 1.0,
                 mu_kinetic: np.ndarray | None = None) -> Scene:
    """Scene of ``system`` (a contact-velocity system, eq. 5) at the system's ``mu``.

    ``speed_scale`` [-] multiplies every commanded contact velocity; ``mu_kinetic`` (n_c,)
    optional kinetic coefficients (static = ``system.mu``). Raises :class:`InputError` for a
    joint-space manipulator (chains are not built yet) or a contact off the workpiece boundary.
    """
    if not system.virtual_joints:
        raise InputError("simulate: expected a system given by contact velocities "
                         "(manipulator.contact_velocities), got a joint-space manipulator; "
                         "chain manipulators are not built as scenes yet")
    if not (np.isfinite(speed_scale) and speed_scale > 0):
        raise InputError(f"speed scale: expected a finite number > 0, got {speed_scale}")
    pts = np.asarray(system.points, dtype=float)
    nrm = np.asarray(system.normals, dtype=float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    n_c = len(pts)
    env = system.environment or (False,) * n_c
    geom = system.workpiece
    if geom is not None:
        poly = np.asarray(geom.polygon, dtype=float)
        com = np.asarray(geom.com, dtype=float)
        mass = float(geom.mass)
        derived = False
    else:
        reach = float(np.max(np.linalg.norm(pts, axis=1)))
        if not reach > 0:
            raise InputError("simulate: expected contact points away from the origin to "
                             "derive a workpiece, got all at the origin")
        poly = workpiece_polygon(pts, nrm, 1.25 * reach)
        com = np.zeros(2)
        mass = DEFAULT_MASS
        derived = True
    size = float(np.max(np.linalg.norm(poly - com, axis=1)))
    for i, r in enumerate(pts):
        gap = float(np.min((poly - r) @ nrm[i]))  # 0 when the tangent line supports the polygon
        if abs(gap) > 1e-6 * size or not point_in_convex_polygon(r, poly):
            raise InputError(f"contact {i + 1}: expected a point on the workpiece boundary "
                             f"with the polygon on the side of its normal, got point "
                             f"{r.tolist()} (polygon reaches {gap:.3g} m along the normal)")
    _, centroid = polygon_area_centroid(poly)
    inertia = _polygon_inertia(poly, com, mass)
    # body frame = world frame at the start: the recorded pose is then the workpiece point at
    # the world origin, whose velocity is the planner's qdot (docs/conventions.md)
    work = Body("workpiece", (Polygon(tuple(map(tuple, poly.tolist()))),), mass=mass,
                com=(float(com[0]), float(com[1])), inertia=inertia, pose=(0.0, 0.0, 0.0))
    vel = np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2) * speed_scale
    radius = FINGER_RADIUS * size
    bodies = [work]
    pairs = []
    for i in range(n_c):
        name = f"env{i + 1}" if env[i] else f"finger{i + 1}"
        if env[i]:
            bodies.append(Body(name, (environment_surface(pts[i], nrm[i], poly, size),),
                               kind=BodyKind.STATIC))
        else:
            v_world = vel[i, 0] * nrm[i] + vel[i, 1] * tng[i]
            centre = pts[i] - (radius - PRELOAD * size) * nrm[i]
            bodies.append(Body(name, (Circle((0.0, 0.0), radius),),
                               pose=(float(centre[0]), float(centre[1]), 0.0),
                               kind=BodyKind.DRIVEN,
                               twist=constant_twist((float(v_world[0]), float(v_world[1]), 0.0))))
        muk = None if mu_kinetic is None else float(mu_kinetic[i])
        pairs.append(ContactPair(f"c{i + 1}", name, "workpiece",
                                 mu_static=float(system.mu[i]), mu_kinetic=muk))
    g = np.asarray(system.g_obj, dtype=float)
    moment = float(g[2] - (com[0] * g[1] - com[1] * g[0]))
    span = 4.0 * size
    cx, cy = float(com[0]), float(com[1])
    fastest = float(np.max(np.linalg.norm(vel, axis=1))) if n_c else 0.0
    return Scene(
        bodies=tuple(bodies),
        pairs=tuple(pairs),
        loads=(Load("workpiece", (float(g[0]), float(g[1])), moment),),
        bounds=(cx - span, cy - span, cx + span, cy + span),
        length_scale=size,
        only_pairs=True,
        meta={"polygon": poly.tolist(), "com": com.tolist(), "mass": mass,
              "derived_workpiece": derived, "area_centroid": centroid.tolist(),
              "finger_radius": radius, "preload_m": PRELOAD * size,
              "environment": list(env), "drive_speed": fastest},
    )
