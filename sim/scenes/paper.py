"""Physical scenes for the paper's abstract examples (Sec. 4, eqs. 37 and 42) and the ruler (5.1).

From a planner :class:`~planner.model.system.System` given as a wrench matrix ``W`` (eq. 1) and
contact-point velocities ``J_i thetadot``:

* contact points ``r_i = m_it n_i - m_in t_i``
  (:func:`planner.model.system.contact_points_from_wrench`), scaled uniformly by ``scale``
  (the paper's points are 2-20 m from the origin);
* the workpiece is the convex polygon ``{x : n_i . (x - r_i) >= 0}`` (its boundary passes through
  every ``r_i`` tangent to ``t_i``), clipped by a box when the normals do not close it; its centre
  of mass is the world origin, where ``g_obj`` acts (the paper's origin is the centre of gravity);
* each fingertip is a small driven circle touching the workpiece at ``r_i`` and moving with the
  constant world velocity ``speed * (v_in n_i + v_it t_i)`` (``J_i thetadot`` at the initial
  configuration, Sec. 4).

Uniform scaling by ``s`` maps the moment row of ``W`` and ``g_obj`` by ``s``; the feasible mode set
is invariant, which :func:`scaled_system` lets callers re-check (the scaled prediction is the one
reported).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from sim.scene import (
    Body,
    BodyKind,
    BodyState,
    Circle,
    Command,
    ContactPair,
    Load,
    Polygon,
    Scene,
    preload_depth,
)


def scaled_system(system: System, scale: float, speed: float = 1.0) -> System:
    """``system`` with lengths times ``scale`` [-] and contact velocities times ``speed`` [m/s].

    Needs contact-velocity (virtual-joint) manipulators; ``g_obj``'s moment is scaled too.
    """
    if not system.virtual_joints:
        raise InputError("scaled_system: expected a system given by contact velocities, "
                         "got a joint-space manipulator")
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"scale: expected a finite number > 0, got {scale}")
    g = np.array(system.g_obj, dtype=float) * np.array([1.0, 1.0, scale])
    W = np.array(system.W, dtype=float)
    W[2] *= scale
    return System.from_wrench_matrix(
        W,
        system.mu,
        external_wrench=g,
        contact_velocities=np.asarray(system.joint_inputs).reshape(-1, 2) * speed,
    )


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


@dataclass(frozen=True)
class FingertipSpec:
    """Finger geometry: ``radius`` [m] of the fingertip circle, initial ``overlap`` [m]
    (None: :func:`sim.scene.preload_depth` of the scene)."""

    radius: float = 0.004
    overlap: float | None = None


def example_scene(
    system: System,
    *,
    speed: float,
    mass: float = 0.1,
    finger: FingertipSpec | None = None,
    mu_kinetic: np.ndarray | None = None,
) -> Scene:
    """Scene of a (scaled) contact-velocity system: polygon workpiece + driven fingertips.

    ``system`` must already be at scene scale (see :func:`scaled_system`); ``speed`` [m/s] is
    only recorded in ``meta``. ``g_obj`` becomes a :class:`Load` at the workpiece COM (origin).
    """
    finger = FingertipSpec() if finger is None else finger
    pts = np.asarray(system.points, dtype=float)
    nrm = np.asarray(system.normals, dtype=float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    size = float(np.max(np.linalg.norm(pts, axis=1)))
    poly = workpiece_polygon(pts, nrm, 1.25 * size)
    overlap = preload_depth(size) if finger.overlap is None else finger.overlap
    area = 0.5 * float(np.sum(poly[:, 0] * np.roll(poly[:, 1], -1)
                              - np.roll(poly[:, 0], -1) * poly[:, 1]))
    # inertia of a uniform polygon about the origin (the COM we impose), polar moment
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y1 - x1 * y
    j_origin = float(np.sum(cr * (x * x + x * x1 + x1 * x1 + y * y + y * y1 + y1 * y1))) / 12.0
    inertia = mass * j_origin / area
    work = Body("workpiece", (Polygon(tuple(map(tuple, poly))),), mass=mass, com=(0.0, 0.0),
                inertia=inertia)
    vel = np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2)
    bodies = [work]
    pairs = []
    for i in range(len(pts)):
        v_world = vel[i, 0] * nrm[i] + vel[i, 1] * tng[i]
        centre = pts[i] - (finger.radius - overlap) * nrm[i]
        bodies.append(Body(f"finger{i + 1}", (Circle((0.0, 0.0), finger.radius),),
                           pose=(float(centre[0]), float(centre[1]), 0.0),
                           kind=BodyKind.DRIVEN,
                           twist=constant_twist((float(v_world[0]), float(v_world[1]), 0.0))))
        muk = None if mu_kinetic is None else float(mu_kinetic[i])
        pairs.append(ContactPair(f"c{i + 1}", f"finger{i + 1}", "workpiece",
                                 mu_static=float(system.mu[i]), mu_kinetic=muk))
    g = np.asarray(system.g_obj, dtype=float)
    span = 4.0 * size
    return Scene(
        bodies=tuple(bodies),
        pairs=tuple(pairs),
        loads=(Load("workpiece", (float(g[0]), float(g[1])), float(g[2])),),
        bounds=(-span, -span, span, span),
        length_scale=size,
        meta={"speed": speed, "polygon": poly.tolist(), "mass": mass,
              "finger_radius": finger.radius},
    )
