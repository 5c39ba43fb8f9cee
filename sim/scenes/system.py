"""A physical scene for ANY :class:`~planner.model.system.System` given by contact velocities or
by a chain (issue 14).

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
  the contact (a box corner on a table) can lift off or pivot there. It touches the workpiece's
  own feature at the contact (:func:`contact_feature`: a small circle at a vertex, a capsule on
  an edge), not the whole polygon (MuJoCo's per-edge boxes reach past an acute vertex).
  Rounded ends rather than a box: MuJoCo's box-box contact of a flat workpiece edge on a box
  slab stuck and slipped (the box on a table, pushed, moved in jumps of up to 20x the drive
  speed); on the capsule it slides at the drive speed, as in pymunk;
* **manipulator contacts**: small driven fingertip circles touching at ``r_i`` and moving with
  the commanded contact velocity ``J_i thetadot = v_in n_i + v_it t_i`` (eq. 5) times
  ``speed_scale`` (slow motion; positive scaling leaves the quasistatic mode set unchanged);
  for a chain manipulator (``System.chain``) the chain's links instead, each a body on its
  joint (:func:`chain_links`: capsules from the joint to its contacts and child joints, joints
  velocity-controlled at ``speed_scale`` times their rate or effort-controlled);
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
#: Radius of a contact's workpiece feature (vertex circle, edge capsule), fraction of size.
FEATURE_RADIUS = 0.005


def near_acute_vertex(r: np.ndarray, poly: np.ndarray, size: float) -> bool:
    """True when the contact at ``r`` sits at, or on an edge ending at, a vertex of interior
    angle below 90 deg -- where MuJoCo's per-edge boxes reach past the polygon
    (:func:`contact_feature`); elsewhere the polygon is exact in both engines."""
    tol = 1e-6 * size
    prv, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
    u, w = prv - poly, nxt - poly
    acute = np.einsum("ij,ij->i", u, w) > 1e-9 * np.linalg.norm(u, axis=1) * np.linalg.norm(
        w, axis=1)  # cos(theta) > 0
    edges = nxt - poly
    length = np.linalg.norm(edges, axis=1)
    along = np.einsum("ij,ij->i", r - poly, edges) / length
    d = r - poly
    off = np.abs(edges[:, 0] * d[:, 1] - edges[:, 1] * d[:, 0]) / length
    on = (off <= tol) & (along >= -tol) & (along <= length + tol)  # r on edge k -> k+1
    return bool(np.any(on & (acute | np.roll(acute, -1))))


def contact_feature(r: np.ndarray, n: np.ndarray, poly: np.ndarray, size: float) -> Shape:
    """The workpiece's side of a contact at ``r`` (2,) with inward normal ``n`` (workpiece
    frame = world frame at the start), instead of the whole polygon: a circle of radius
    ``FEATURE_RADIUS * size`` whose surface touches the vertex where the contact sits at a
    polygon vertex (centre ``v + rho n``), else a capsule of that radius along the polygon
    edge through ``r`` whose inward normal is ``n``, its surface on the edge line.

    Why not the polygon: MuJoCo builds a polygon as one thin box per edge, and at a vertex of
    interior angle ``theta < 90 deg`` an edge's box reaches past the neighbouring edge by
    ``h cos theta`` (``h`` the box's thickness): a triangle on a table rested on a box corner
    1.5 mm below its vertex and turned (docs/simulation.md, "A contact's workpiece feature").
    The hand scenes pair their tips and vertices the same way (:mod:`sim.scenes.hand`)."""
    rho = FEATURE_RADIUS * size
    tol = 1e-6 * size
    n = np.asarray(n, dtype=float) / float(np.linalg.norm(n))
    d = np.linalg.norm(poly - r, axis=1)
    k = int(np.argmin(d))
    nxt = np.roll(poly, -1, axis=0)
    edges = nxt - poly
    length = np.linalg.norm(edges, axis=1)
    inward = np.stack([-edges[:, 1], edges[:, 0]], axis=1) / length[:, None]
    along = np.einsum("ij,ij->i", r - poly, edges) / length
    off = np.abs(np.einsum("ij,ij->i", r - poly, inward))
    on_edge = (off <= tol) & (along >= -tol) & (along <= length + tol)
    same = np.linalg.norm(inward - n, axis=1) <= 1e-6
    cand = np.flatnonzero(on_edge & same)
    if d[k] > tol and len(cand):
        e = int(cand[0])
        a, b = poly[e] + rho * n, nxt[e] + rho * n
        return Capsule((float(a[0]), float(a[1])), (float(b[0]), float(b[1])), rho)
    if d[k] <= tol:
        c = poly[k] + rho * n
        return Circle((float(c[0]), float(c[1])), rho)
    raise InputError(f"contact at {r.tolist()}: expected a polygon vertex or a point on an edge "
                     f"with inward normal {n.tolist()}, got neither")


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
    """Scene of ``system`` (contact velocities, eq. 5, or a chain) at the system's ``mu``.

    ``speed_scale`` [-] multiplies every commanded contact velocity / velocity-joint rate;
    ``mu_kinetic`` (n_c,) optional kinetic coefficients (static = ``system.mu``). Raises
    :class:`InputError` for a manipulator given only as a Jacobian (no geometry), a contact off
    the workpiece boundary or a chain link that would cut into the workpiece.
    """
    if not system.virtual_joints and system.chain is None:
        raise InputError("simulate: expected a system given by contact velocities "
                         "(manipulator.contact_velocities) or by a chain (manipulator.chain), "
                         "got a bare Jacobian: it has no link geometry to build")
    if not (np.isfinite(speed_scale) and speed_scale > 0):
        raise InputError(f"speed scale: expected a finite number > 0, got {speed_scale}")
    if system.n_bodies > 1:
        raise InputError(f"simulate: expected one workpiece, got {system.n_bodies}; several "
                         "workpieces are built by sim.scenes.multibody.multibody_scene and "
                         "judged by sim.multibody_run.simulate_multibody")
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
    # environment contacts touch their own feature (contact_feature); fingers and links the
    # polygon (index 0), exact in pymunk and, away from an acute vertex, in MuJoCo
    env_ids = [i for i in range(n_c) if env[i] and near_acute_vertex(pts[i], poly, size)]
    features = [contact_feature(pts[i], nrm[i], poly, size) for i in env_ids]
    feature_of = {i: 1 + k for k, i in enumerate(env_ids)}
    work = Body("workpiece", (Polygon(tuple(map(tuple, poly.tolist()))), *features),
                mass=mass, com=(float(com[0]), float(com[1])), inertia=inertia,
                pose=(0.0, 0.0, 0.0))
    radius = FINGER_RADIUS * size
    bodies = [work]
    pairs = []
    joints: tuple[Joint, ...] = ()
    sites: dict[int, tuple[str, int]] = {}
    if system.virtual_joints:
        vel = np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2) * speed_scale
    else:
        links, joints, sites = chain_links(system, poly, size, speed_scale)
        bodies.extend(links)
        vel = np.zeros((n_c, 2))
    for i in range(n_c):
        name = f"env{i + 1}" if env[i] else f"finger{i + 1}"
        if i in sites:
            name, shape = sites[i]
            muk = None if mu_kinetic is None else float(mu_kinetic[i])
            pairs.append(ContactPair(f"c{i + 1}", name, "workpiece", shape_a=shape,
                                     mu_static=float(system.mu[i]), mu_kinetic=muk))
            continue
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
        pairs.append(ContactPair(f"c{i + 1}", name, "workpiece", shape_b=feature_of.get(i, 0),
                                 mu_static=float(system.mu[i]), mu_kinetic=muk))
    g = np.asarray(system.g_obj, dtype=float)
    moment = float(g[2] - (com[0] * g[1] - com[1] * g[0]))
    span = 4.0 * size
    cx, cy = float(com[0]), float(com[1])
    fastest = commanded_contact_speed(system) * speed_scale
    return Scene(
        bodies=tuple(bodies),
        pairs=tuple(pairs),
        joints=joints,
        loads=(Load("workpiece", (float(g[0]), float(g[1])), moment),),
        bounds=(cx - span, cy - span, cx + span, cy + span),
        length_scale=size,
        only_pairs=True,
        meta={"polygon": poly.tolist(), "com": com.tolist(), "mass": mass,
              "derived_workpiece": derived, "area_centroid": centroid.tolist(),
              "finger_radius": radius, "preload_m": PRELOAD * size,
              "environment": list(env), "drive_speed": fastest},
    )


# ---- chain manipulators (issue 14: "chain manipulators are built as their links") ----------
#: Mass of every chain link as a fraction of the workpiece mass [-] (the hands' ratio, 0.05 kg
#: fingers on a 0.1 kg workpiece; masses change only the dynamics).
LINK_MASS_OF_WORKPIECE = 0.5


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
