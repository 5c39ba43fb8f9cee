"""A physical scene for any :class:`~planner.model.system.System`: one or several workpieces,
fingertips driven at their contact velocities or a chain of links, fixed environment surfaces and
contacts between workpieces.

What is built (in the world frame of the system file; :mod:`sim.similarity` scales it):

* **workpieces** (:func:`workpiece_names`: ``workpiece`` for one body, ``work0 ..`` for
  several): the convex polygons of ``System.workpiece`` / ``System.workpieces`` with their mass
  and centre of mass; for one workpiece without geometry, the polygon bounded by the contact
  tangent lines (:func:`sim.scenes.shapes.workpiece_polygon`) with its centre of mass at the
  world origin (the paper's origin is the centre of gravity, Sec. 4) and
  :data:`DEFAULT_MASS`. Body frame = world frame at the start, so a recorded twist is the
  planner's ``qdot`` block of that body (docs/conventions.md);
* **environment contacts** (``"environment": true``): a fixed flat surface along the contact's
  tangent (:func:`sim.scenes.shapes.environment_surface`): a static capsule whose flat top is
  the tangent line, reaching far past the contact where the workpiece does not lie and only a
  little under it, so a corner resting on it can lift off or pivot. Rounded ends rather than a
  box: MuJoCo's box-box contact of a flat edge on a box slab stuck and slipped (a pushed box
  moved in jumps of up to 20x the drive speed); on the capsule it slides at the drive speed.
  Every contact touches the workpiece's polygon, at an acute corner too (MuJoCo's polygon has
  no spur there: :mod:`sim.backends.mujoco_polygon`);
* **manipulator contacts**: small driven fingertip circles touching at ``r_i`` and moving with
  the commanded contact velocity ``J_i thetadot = v_in n_i + v_it t_i`` (eq. 5) times
  ``speed_scale`` (slow motion); for a chain manipulator (``System.chain``) the chain's links
  instead (:func:`chain_links`);
* **contacts between two workpieces** ``(a_i, b_i)`` (normal into ``a_i``): a shape fixed to
  body ``b_i`` that touches body ``a_i``'s polygon at ``r_i``: where ``r_i`` is a vertex of
  ``a_i`` (a block's corner resting on another block), ``b_i``'s face under it -- the capsule
  of an environment surface, its flat top cut where ``b_i``'s boundary leaves the tangent line
  (:func:`sim.scenes.shapes.support_surface`), so the corner slides along the face as it
  does on a table; elsewhere (``a_i``'s edge on ``b_i``'s corner or face), and for a corner
  on a corner, a small circle (a *foot*, the fingertips' radius) whose rim touches ``a_i`` at
  ``r_i``: a foot under a corner would let the corner slide off its rim within
  ``sqrt(2 R preload)`` (0.002 x size). Only declared pairs collide (``only_pairs``), so the
  two polygons never touch: the foot or face is the contact, and the engine reading of the
  pair (``body_a`` = ``b_i``, ``body_b`` = ``a_i``) has the planner's signs (normal into
  ``a_i``, force on ``a_i``, slip of ``a_i`` minus ``b_i``, eq. 5);
* **loads**: each body's ``g_obj`` block (eq. 2, about the world origin) as a force through its
  centre of mass ``c`` plus the moment ``m_z - (c_x f_y - c_y f_x)`` -- the same wrench;
* **pre-load**: every contact starts overlapped by ``PRELOAD * size`` [m].

``size`` (the scene's ``length_scale``) is the largest distance of a workpiece vertex from its
centre of mass.
"""

from __future__ import annotations

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.model.workpiece import point_in_convex_polygon
from sim.scene import (
    Body,
    BodyKind,
    Capsule,
    Circle,
    Command,
    ContactPair,
    Control,
    Joint,
    JointKind,
    Load,
    Polygon,
    Scene,
    Shape,
)
from sim.scenes.shapes import (
    FINGER_RADIUS,
    PRELOAD,
    at_vertex,
    constant_twist,
    environment_surface,
    polygon_inertia,
    support_surface,
    workpiece_polygon,
)

#: Mass [kg] of a derived workpiece (no ``workpiece`` key in the file).
DEFAULT_MASS = 0.1
#: Mass of every chain link as a fraction of the workpiece mass [-] (the hands' ratio, 0.05 kg
#: fingers on a 0.1 kg workpiece; masses change only the dynamics).
LINK_MASS_OF_WORKPIECE = 0.5


def workpiece_names(n_bodies: int) -> tuple[str, ...]:
    """Scene names of the workpieces in the system's order: ``("workpiece",)`` for one body,
    ``("work0", "work1", ..)`` for several."""
    return ("workpiece",) if n_bodies == 1 else tuple(f"work{a}" for a in range(n_bodies))


def system_geometry(system: System) -> tuple[list[np.ndarray], list[np.ndarray], list[float],
                                             bool]:
    """Per workpiece its polygon (V, 2) [m], centre of mass (2,) [m] and mass [kg], and whether
    the (single) workpiece was derived from the contacts (module docstring)."""
    if system.workpieces:
        geoms = system.workpieces
    elif system.workpiece is not None and system.n_bodies == 1:
        geoms = (system.workpiece,)
    elif system.n_bodies == 1:
        pts = np.asarray(system.points, dtype=float)
        reach = float(np.max(np.linalg.norm(pts, axis=1)))
        if not reach > 0:
            raise InputError("simulate: expected contact points away from the origin to "
                             "derive a workpiece, got all at the origin")
        poly = workpiece_polygon(pts, np.asarray(system.normals, dtype=float), 1.25 * reach)
        return [poly], [np.zeros(2)], [DEFAULT_MASS], True
    else:
        raise InputError(f"simulate: expected scene geometry (polygon and mass) for every one "
                         f"of the {system.n_bodies} workpieces, got none")
    return ([np.asarray(g.polygon, dtype=float) for g in geoms],
            [np.asarray(g.com, dtype=float) for g in geoms], [float(g.mass) for g in geoms],
            False)


def system_size(system: System) -> float:
    """The scene size [m] of ``system``: the largest distance of a workpiece vertex from its
    centre of mass."""
    polys, coms, _, _ = system_geometry(system)
    return max(float(np.max(np.linalg.norm(p - c, axis=1))) for p, c in zip(polys, coms))


def system_scene(system: System, *, speed_scale: float = 1.0,
                 mu_kinetic: np.ndarray | None = None) -> Scene:
    """Scene of ``system`` (contact velocities, eq. 5, or a chain) at the system's ``mu``.

    ``speed_scale`` [-] multiplies every commanded contact velocity / velocity-joint rate;
    ``mu_kinetic`` (n_c,) optional kinetic coefficients (static = ``system.mu``). Raises
    :class:`InputError` for a manipulator given only as a Jacobian (no geometry), a contact off
    the boundary of the body its normal points into, or a chain link that would cut into the
    workpiece.
    """
    if not system.virtual_joints and system.chain is None:
        raise InputError("simulate: expected a system given by contact velocities "
                         "(manipulator.contact_velocities) or by a chain (manipulator.chain), "
                         "got a bare Jacobian: it has no link geometry to build")
    if not (np.isfinite(speed_scale) and speed_scale > 0):
        raise InputError(f"speed scale: expected a finite number > 0, got {speed_scale}")
    if system.chain is not None and system.n_bodies > 1:
        raise InputError(f"simulate: expected one workpiece for a chain manipulator, got "
                         f"{system.n_bodies}")
    polys, coms, masses, derived = system_geometry(system)
    names = workpiece_names(system.n_bodies)
    size = max(float(np.max(np.linalg.norm(p - c, axis=1))) for p, c in zip(polys, coms))
    pts = np.asarray(system.points, dtype=float)
    nrm = np.asarray(system.normals, dtype=float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    n_c = len(pts)
    env = system.environment or (False,) * n_c
    for i, (a, _) in enumerate(system.contact_bodies):
        gap = float(np.min((polys[a] - pts[i]) @ nrm[i]))  # 0 when the tangent line supports it
        if abs(gap) > 1e-6 * size or not point_in_convex_polygon(pts[i], polys[a]):
            where = "the workpiece" if system.n_bodies == 1 else f"workpiece {a}"
            raise InputError(f"contact {i + 1}: expected a point on the boundary of {where} "
                             f"with the polygon on the side of its normal, got point "
                             f"{pts[i].tolist()} (polygon reaches {gap:.3g} m along the normal)")
    # every contact touches the polygon (shape 0), exact in both engines at any corner
    # (sim.backends.mujoco_polygon, sim.backends.pymunk_edges)
    shapes: list[list[Shape]] = [[Polygon(tuple(map(tuple, p.tolist())))] for p in polys]
    radius = FINGER_RADIUS * size
    extra: list[Body] = []
    pairs: list[ContactPair] = []
    joints: tuple[Joint, ...] = ()
    sites: dict[int, tuple[str, int]] = {}
    if system.virtual_joints:
        vel = np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2) * speed_scale
    else:
        links, joints, sites = chain_links(system, polys[0], size, speed_scale)
        extra.extend(links)
        vel = np.zeros((n_c, 2))
    for i, (a, b) in enumerate(system.contact_bodies):
        muk = None if mu_kinetic is None else float(mu_kinetic[i])
        centre = pts[i] - (radius - PRELOAD * size) * nrm[i]
        if b >= 0:  # body b's face under a corner of body a, else a foot on body b
            face = (support_surface(pts[i], nrm[i], polys[a], polys[b], size)
                    if at_vertex(pts[i], polys[a], size) else None)
            shapes[b].append(face or Circle((float(centre[0]), float(centre[1])), radius))
            pairs.append(ContactPair(f"c{i + 1}", names[b], names[a], float(system.mu[i]),
                                     muk, shape_a=len(shapes[b]) - 1, shape_b=0))
            continue
        if i in sites:
            body, shape = sites[i]
            pairs.append(ContactPair(f"c{i + 1}", body, names[a], float(system.mu[i]), muk,
                                     shape_a=shape))
            continue
        if env[i]:
            body = f"env{i + 1}"
            extra.append(Body(body, (environment_surface(pts[i], nrm[i], polys[a], size),),
                              kind=BodyKind.STATIC))
        else:
            body = f"finger{i + 1}"
            v = vel[i, 0] * nrm[i] + vel[i, 1] * tng[i]
            extra.append(Body(body, (Circle((0.0, 0.0), radius),),
                              pose=(float(centre[0]), float(centre[1]), 0.0),
                              kind=BodyKind.DRIVEN,
                              twist=constant_twist((float(v[0]), float(v[1]), 0.0))))
        pairs.append(ContactPair(f"c{i + 1}", body, names[a], float(system.mu[i]), muk))
    works = [Body(names[a], tuple(shapes[a]), mass=masses[a],
                  com=(float(coms[a][0]), float(coms[a][1])),
                  inertia=polygon_inertia(polys[a], masses[a], coms[a]), pose=(0.0, 0.0, 0.0))
             for a in range(len(polys))]
    loads = []
    g = np.asarray(system.g_obj, dtype=float).reshape(-1, 3)
    for a, c in enumerate(coms):
        loads.append(Load(names[a], (float(g[a, 0]), float(g[a, 1])),
                          float(g[a, 2] - (c[0] * g[a, 1] - c[1] * g[a, 0]))))
    # the bounds cover every body (a chain's base may be far from a small workpiece)
    reach = np.vstack([*polys, *(np.array(b.pose[:2])[None] for b in extra)])
    lo, hi = reach.min(axis=0) - 3.0 * size, reach.max(axis=0) + 3.0 * size
    fastest = commanded_contact_speed(system) * speed_scale
    return Scene(
        bodies=tuple(works + extra), pairs=tuple(pairs), joints=joints, loads=tuple(loads),
        bounds=(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])),
        length_scale=size, only_pairs=True,
        meta={"workpieces": list(names), "polygons": [p.tolist() for p in polys],
              "coms": [c.tolist() for c in coms], "masses": masses,
              "derived_workpiece": derived, "finger_radius": radius,
              "preload_m": PRELOAD * size, "environment": list(env), "drive_speed": fastest},
    )


# ---- chain manipulators --------------------------------------------------------------------
def commanded_contact_speed(system: System) -> float:
    """Fastest commanded manipulator contact-point speed [m/s]: ``max_i |J_i thetadot|`` with
    the velocity-controlled joints at their commands and the others at rest (eqs. 3, 5; for
    contact velocities, the largest ``|(v_n, v_t)|``)."""
    J = np.asarray(system.J, dtype=float).reshape(system.n_contacts, 2, -1)
    rates = np.zeros(system.n_joints)
    V = system.velocity_joints
    rates[V] = np.asarray(system.joint_inputs, dtype=float)[V]
    v = J @ rates
    return float(np.max(np.linalg.norm(v, axis=1))) if len(v) else 0.0


def scale_velocities(system: System, scale: float) -> System:
    """``system`` with every velocity-controlled joint's command times ``scale`` (slow motion:
    a positive scaling leaves the quasistatic modes unchanged); efforts unchanged."""
    inputs = np.array(system.joint_inputs, dtype=float)
    inputs[system.velocity_joints] *= scale
    return system.with_joint_inputs(inputs)


def _cross(u: np.ndarray, v: np.ndarray) -> float:
    """z component of the planar cross product ``u x v``."""
    return float(u[0] * v[1] - u[1] * v[0])


def _segment_polygon_distance(a: np.ndarray, b: np.ndarray, poly: np.ndarray) -> float:
    """Distance [m] of segment ``a``-``b`` from a convex polygon (0 when they meet)."""
    def inside(p: np.ndarray) -> bool:
        e = np.roll(poly, -1, axis=0) - poly
        return bool(np.all(e[:, 0] * (p[1] - poly[:, 1]) - e[:, 1] * (p[0] - poly[:, 0]) >= 0))

    if inside(a) or inside(b):
        return 0.0
    best = np.inf
    for k in range(len(poly)):
        c, d = poly[k], poly[(k + 1) % len(poly)]
        # the segments cross: opposite orientations both ways
        o = [_cross(b - a, c - a), _cross(b - a, d - a), _cross(d - c, a - c),
             _cross(d - c, b - c)]
        if o[0] * o[1] < 0 and o[2] * o[3] < 0:
            return 0.0
        for p, (u, w) in ((a, (c, d)), (b, (c, d)), (c, (a, b)), (d, (a, b))):
            uw = w - u
            t = float(np.clip((p - u) @ uw / max(float(uw @ uw), 1e-300), 0.0, 1.0))
            best = min(best, float(np.linalg.norm(p - (u + t * uw))))
    return best


def chain_links(system: System, poly: np.ndarray, size: float, speed_scale: float
                ) -> tuple[list[Body], tuple[Joint, ...], dict[int, tuple[str, int]]]:
    """Bodies and joints of a chain manipulator (``system.chain``) and, per contact it
    touches, ``(body name, shape index)`` of its contact site.

    Link ``j`` (body ``link<j+1>``, frame at its joint, :meth:`planner.model.kinematics.Chain.
    frames` at the file's ``q``) is a set of capsules of radius ``link_radius`` (the file's
    ``manipulator.link_radius``; default ``FINGER_RADIUS * size``, the fingertips') from
    its joint origin: to the cap centre ``r_i - (radius - PRELOAD * size) n_i`` of every
    contact ``i`` on it (the capsule's end cap touches the workpiece at ``r_i`` with normal
    ``n_i``, pre-loaded like the fingertips; one shape per contact, so one arbiter each), to
    every child joint's origin, or -- a link with neither -- a stub ``2 radius`` along its
    ``x`` axis. A contact capsule that would cut into the workpiece elsewhere (its joint on the
    workpiece's side of the contact) is refused. Joints: revolute / prismatic as in the chain,
    on the base or on the parent link; velocity-controlled at ``speed_scale`` times their
    command, effort-controlled at ``tau_j - g_man_j`` (eq. 3: ``J^T c = tau - g_man``; the
    scene has no loads on the links). Link mass ``LINK_MASS_OF_WORKPIECE`` times the
    workpiece's, inertia of a uniform rod."""
    geom = system.chain
    if geom is None:
        raise InputError("chain_links: expected a system with chain geometry, got none")
    radius = FINGER_RADIUS * size if geom.link_radius is None else float(geom.link_radius)
    pre = PRELOAD * size
    poses = geom.body_poses()
    frames = geom.joint_frames()
    pts = np.asarray(system.points, dtype=float)
    nrm = np.asarray(system.normals, dtype=float)
    work_mass = system.workpiece.mass if system.workpiece is not None else DEFAULT_MASS
    mass = LINK_MASS_OF_WORKPIECE * work_mass
    bodies: list[Body] = []
    joints: list[Joint] = []
    sites: dict[int, tuple[str, int]] = {}
    for j, spec in enumerate(geom.chain.joints):
        x, y, phi = poses[j]
        c, s = np.cos(phi), np.sin(phi)
        origin = np.array([x, y])

        def local(p: np.ndarray, c: float = c, s: float = s, o: np.ndarray = origin
                  ) -> tuple[float, float]:
            d = p - o
            return (float(c * d[0] + s * d[1]), float(-s * d[0] + c * d[1]))

        name = f"link{j + 1}"
        shapes: list[Shape] = []
        for i, link in enumerate(geom.contact_links):
            if link != j:
                continue
            cap = pts[i] - (radius - pre) * nrm[i]
            if _segment_polygon_distance(origin, cap, poly) < radius - pre - 1e-6 * size:
                raise InputError(f"contact {i + 1}: the link from joint {j + 1} at "
                                 f"{origin.tolist()} to the contact cuts into the workpiece; "
                                 "expected the joint outside the workpiece's side of the contact")
            sites[i] = (name, len(shapes))
            if np.linalg.norm(cap - origin) <= 1e-9 * size:
                shapes.append(Circle((0.0, 0.0), radius))
            else:
                shapes.append(Capsule((0.0, 0.0), local(cap), radius))
        ends = [frames[k][:2, 2] for k in geom.children(j)]
        shapes.extend(Capsule((0.0, 0.0), local(e), radius) for e in ends
                      if np.linalg.norm(e - origin) > 1e-9 * size)
        if not shapes:
            shapes.append(Capsule((0.0, 0.0), (2.0 * radius, 0.0), radius))
        tips = [np.asarray(sh.b if isinstance(sh, Capsule) else (0.0, 0.0)) for sh in shapes]
        length = max(float(np.linalg.norm(t)) for t in tips) or 2.0 * radius
        far = tips[int(np.argmax([np.linalg.norm(t) for t in tips]))]
        com = 0.5 * far if np.linalg.norm(far) > 0 else np.zeros(2)
        bodies.append(Body(name, tuple(shapes), mass=mass,
                           com=(float(com[0]), float(com[1])),
                           inertia=mass * (length ** 2 + (2 * radius) ** 2) / 12.0,
                           pose=(float(x), float(y), float(phi))))
        jf = frames[j]
        if system.control[j].value == "velocity":
            value = float(system.joint_inputs[j]) * speed_scale
            control = Control.VELOCITY
        else:
            value = float(system.joint_inputs[j] - system.g_man[j])
            control = Control.EFFORT
        joints.append(Joint(
            f"joint{j + 1}", name,
            JointKind.REVOLUTE if spec.kind == "revolute" else JointKind.PRISMATIC,
            (float(jf[0, 2]), float(jf[1, 2])), control, _constant(value),
            axis=(float(jf[0, 0]), float(jf[1, 0])),
            parent=None if spec.parent < 0 else f"link{spec.parent + 1}"))
    return bodies, tuple(joints), sites


def _constant(value: float) -> Command:
    """A joint command holding ``value``."""
    return lambda t, states: value
