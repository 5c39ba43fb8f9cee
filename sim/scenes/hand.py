"""Two-finger hand on a palm (Figure 9, Sec. 5.2) as an engine-neutral :class:`sim.scene.Scene`.

Built from a hand file's content (format ``qsplan-hand``, read by :mod:`planner.model.hand`; e.g.
``scenarios/data/two_finger_hand.json``); the initial configuration is the file's, closed so
every declared contact touches (:func:`planner.files.hand_file.hand_from_dict`, called once by the
caller: the scene takes the parsed :class:`~planner.model.hand.Hand`).

Horizontal plane: no gravity; the file's ``load.force`` (support friction of the table) acts
as a constant :class:`~sim.scene.Load` at the workpiece's centre of mass (``g_obj``, eq. 2).

Bodies and contact sites (one pair per declared contact, in file order ``c1 .. c4``; only these
pairs collide, ``Scene.only_pairs``):

* ``palm``: static; one capsule per palm contact along the whole palm edge, its surface on the
  palm line (so each palm contact is its own pair / arbiter).
* one body per finger (name ``finger:<name>``), body frame at the pivot with ``x`` along the
  link, on a revolute joint to the base (``joint:<name>``): a capsule of the link's width
  (``side`` contacts) and, for a ``tip`` contact, a circle of radius ``width/2`` at the tip
  (the link's end moved by the finger's ``tip_offset`` in the link's frame).
* ``workpiece``: the polygon plus, per ``tip`` contact, a capsule of radius ``vertex_radius``
  along the contact's declared edge, its surface on the edge line (the tip touches the edge
  the plan declares and no other: near an acute vertex a tip paired with the whole polygon can
  meet the neighbouring edge; docs/planning.md, the Figure 9 task), and, per vertex contact,
  a small circle of radius ``r = vertex_radius`` (a sharp vertex has no stable contact point in
  either engine). On a fixed straight surface (``palm``, ``surface`` contacts) the circle is
  centred on the vertex and the surface's capsules lie ``r`` behind its line
  (:func:`_fixed_surface`): a circle of radius ``r`` touches a line moved back by ``r`` exactly
  when its centre lies on the line, at every orientation of the workpiece, so the vertex rides
  on the surface as the plan's sharp vertex does however far the workpiece turns. On a finger's
  side (``side`` contacts; the link's capsule is the finger's own shape) the circle is placed
  so its surface touches the side where the sharp vertex does (centre = vertex + r n, n the
  contact's inward normal at the initial configuration): it moves the contact point by ``r``
  times the change of the contact normal's direction (0.5 mm x 0.16 rad = 80 um over the
  default segment).

Mass and inertia: workpiece mass and COM from the file, rotational inertia of the uniform
polygon about the COM; finger links of the file's mass with the inertia of a uniform rod.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
from planner.model.kinematics import REVOLUTE
from planner.model.validation import as_friction
from sim.run import Recording
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
    preload_depth,
)
from sim.scenes.shapes import polygon_inertia

#: Radius [m] of the circles standing for sharp workpiece vertices.
VERTEX_RADIUS = 5e-4
#: Radius [m] of the palm capsules (surface on the palm line).
PALM_RADIUS = 2e-3


def pair_names(n_contacts: int) -> tuple[str, ...]:
    """Contact pair names in hand-file order: ``c1, c2, ...`` (mode labels index them 1..n)."""
    return tuple(f"c{i + 1}" for i in range(n_contacts))


def finger_body(hand: Hand, k: int, link: int = 0) -> str:
    """Body name of ``link`` of finger ``k``: ``finger:<name>`` for a single-link finger (and
    for a chain's first link), ``finger:<name>.<link name or index>`` for a chain's others."""
    f = hand.fingers[k]
    if link == 0:
        return f"finger:{f.name}"
    return f"finger:{f.name}.{f.chain_links[link].name or link}"


def joint_bodies(hand: Hand) -> tuple[str, ...]:
    """(n_theta,) body names in joint order (every finger's links from the pivot out)."""
    return tuple(finger_body(hand, k, j) for k, f in enumerate(hand.fingers)
                 for j in range(f.n_joints))


def _rot(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def _fixed_surface(name: str, ends: np.ndarray, n_sites: int, back: float = 0.0) -> Body:
    """A static straight surface (the palm, a table): one capsule per contact on it, each
    along the whole edge with its surface ``back`` [m] behind the edge line (the radius of the
    vertex circles that touch it, module docstring; so each contact is its own pair /
    arbiter); the inward normal is ``rot90`` of first -> second point."""
    a, b = np.asarray(ends, dtype=float)
    d = (b - a) / np.linalg.norm(b - a)
    down = -np.array([-d[1], d[0]]) * (PALM_RADIUS + back)
    shape = Capsule(tuple(a + down), tuple(b + down), PALM_RADIUS)
    return Body(name=name, shapes=(shape,) * max(n_sites, 1), kind=BodyKind.STATIC)


def hand_scene(
    hand: Hand,
    q0: np.ndarray,
    mu: float | Sequence[float] | np.ndarray,
    controls: Sequence[str | Control],
    commands: Sequence[Command],
    *,
    vertex_radius: float = VERTEX_RADIUS,
    overlap: float | None = None,
    site_configs: Sequence[np.ndarray] | None = None,
    open_sites: Sequence[int] = (),
) -> Scene:
    """Scene of ``hand`` at its closed initial configuration ``q0`` (``(3 + n_theta,)``:
    workpiece pose, joint coordinates; both from :func:`planner.files.hand_file.hand_from_dict`).

    ``mu``: scalar or (n_c,) Coulomb coefficients per contact (file order); ``controls``
    (n_theta,) ``"velocity"``/``"effort"`` per joint (one per finger for single-link fingers);
    ``commands`` (n_theta,) ``command(t, states)`` returning the joint rate [rad/s or m/s] or
    effort [N m or N] (counter-clockwise / along the slide positive, relative to the previous
    link).
    ``overlap`` [m]: every contact starts this far into its feature (default
    :func:`sim.scene.preload_depth`: half of pymunk's collision slop;
    docs/simulation-measurements.md, "Engine facts": resting contacts that start exactly
    touching flicker, and a computed gap of +1e-17 m is no contact at all): vertex circles
    are placed that deep, fingertip circles are shifted that far along the contact normal into
    the workpiece edge.

    ``site_configs`` (n_c,) configurations ``(3 + n_theta,)``, one per contact: where that
    contact's sites are placed (default ``q0`` for all). A whole task's scene holds every
    contact of every segment; a contact gained later is apart at ``q0`` and its sites are
    placed at the planned configuration where it closes (its segment's start). ``open_sites``:
    indices of such contacts; they get no pre-load (their sites exactly touch at their
    configuration): a pre-loaded fingertip circle would stand ``overlap`` proud of the link's
    side and lift a workpiece edge lying along that side before the tip reaches it.
    """
    n_j, n_c = hand.n_joints, hand.n_contacts
    mu_arr = as_friction(mu, n_c)
    if len(controls) != n_j or len(commands) != n_j:
        per = "finger" if n_j == hand.n_fingers else "joint"
        raise InputError(f"controls/commands: expected {n_j} each (one per {per}), got "
                         f"{len(controls)}/{len(commands)}")
    try:
        ctrl = [Control(c) for c in controls]
    except ValueError:
        raise InputError(f"controls: expected 'velocity' or 'effort' per joint, got "
                         f"{list(controls)}") from None
    if not vertex_radius > 0:
        raise InputError(f"vertex_radius: expected > 0 m, got {vertex_radius}")
    scale = hand.length_scale
    if overlap is None:
        overlap = preload_depth(scale)
    q0 = hand.check_q(q0)
    refs = [q0] * n_c if site_configs is None else [hand.check_q(q) for q in site_configs]
    if len(refs) != n_c:
        raise InputError(f"site_configs: expected {n_c} configurations (one per contact), got "
                         f"{len(refs)}")
    depth = [0.0 if i in set(open_sites) else overlap for i in range(n_c)]
    frames = [hand.contact_frame(refs[i], i) for i in range(n_c)]
    pts = np.array([f[0] for f in frames]).reshape(n_c, 2)
    nrm = np.array([f[1] for f in frames]).reshape(n_c, 2)
    pose0 = (float(q0[0]), float(q0[1]), float(q0[2]))

    # fixed surfaces: the palm and every environment surface, one capsule per contact on it
    palm_ids = [i for i, c in enumerate(hand.contacts) if c.kind == "palm"]
    fixed = [_fixed_surface("palm", hand.palm, len(palm_ids), vertex_radius)]
    site_on: dict[int, tuple[str, int]] = {i: ("palm", k) for k, i in enumerate(palm_ids)}
    for e, (ename, ends) in enumerate(hand.environment):
        ids = [i for i, c in enumerate(hand.contacts) if c.kind == "surface" and c.surface == e]
        fixed.append(_fixed_surface(f"env:{ename}", ends, len(ids), vertex_radius))
        site_on.update({i: (f"env:{ename}", k) for k, i in enumerate(ids)})

    # workpiece: polygon, then one circle per vertex contact
    V = np.asarray(hand.vertices, dtype=float)
    shapes: list[Shape] = [Polygon(tuple(map(tuple, V)))]
    site: dict[int, int] = {}
    for i, c in enumerate(hand.contacts):
        if c.kind in ("palm", "surface", "side"):
            # on a fixed surface: on the vertex (the surface lies r behind its line); on a
            # finger's side: touching where the vertex does (module docstring)
            lift = 0.0 if c.kind in ("palm", "surface") else vertex_radius
            centre = pts[i] + (lift - depth[i]) * nrm[i]
            local = _rot(-float(refs[i][2])) @ (centre - np.asarray(refs[i][:2], dtype=float))
            site[i] = len(shapes)
            shapes.append(Circle((float(local[0]), float(local[1])), vertex_radius))
        elif c.kind == "tip":  # the declared edge only, its surface on the edge line
            inward = vertex_radius * (_rot(-float(refs[i][2])) @ nrm[i])
            a, b = V[c.edge] + inward, V[(c.edge + 1) % len(V)] + inward
            site[i] = len(shapes)
            shapes.append(Capsule((float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                                  vertex_radius))
    com = np.asarray(hand.com, dtype=float)
    mass = hand.mass
    work = Body(name="workpiece", shapes=tuple(shapes), mass=mass,
                com=(float(com[0]), float(com[1])),
                inertia=polygon_inertia(V, mass, com), pose=pose0)

    # fingers: one body per link, frame at the link's start with x along its axis
    bodies = [*fixed, work]
    joints = []
    tip_site: dict[int, int] = {}
    jnames = hand.joint_names()
    for k, f in enumerate(hand.fingers):
        links = hand.links_at(q0, k)
        tips = [i for i, c in enumerate(hand.contacts) if c.kind == "tip" and c.finger == k]
        angle = 0.0
        for j, link in enumerate(f.chain_links):
            start, d = links[j]
            # the link's direction angle as Hand.links_at accumulates it (no atan2 branch)
            angle += link.offset + (float(q0[hand.joint_index(k, j)])
                                    if link.kind == REVOLUTE else 0.0)
            fshapes: list[Shape] = [Capsule((0.0, 0.0), (link.length, 0.0), link.radius)]
            if tips and j == f.n_joints - 1:
                # pre-load: the tip circle shifted by `overlap` along the contact's inward
                # normal (in the link's frame where the contact's site is placed)
                d_ref = hand.links_at(refs[tips[0]], k)[j][1]
                push = _rot(-float(np.arctan2(d_ref[1], d_ref[0]))) @ (depth[tips[0]]
                                                                       * nrm[tips[0]])
                tip_site[k] = len(fshapes)
                along, across = f.tip_offset
                fshapes.append(Circle((link.length + along + float(push[0]),
                                       across + float(push[1])), link.radius))
            name = finger_body(hand, k, j)
            lm = link.mass
            bodies.append(Body(name=name, shapes=tuple(fshapes), mass=lm,
                               com=(0.5 * link.length, 0.0),
                               inertia=lm * (link.length ** 2 + link.width ** 2) / 12.0,
                               pose=(float(start[0]), float(start[1]), angle)))
            ji = hand.joint_index(k, j) - 3
            kind = JointKind.REVOLUTE if link.kind == REVOLUTE else JointKind.PRISMATIC
            joints.append(Joint(name=f"joint:{jnames[ji]}", body=name, kind=kind,
                                anchor=(float(start[0]), float(start[1])), control=ctrl[ji],
                                command=commands[ji], axis=(float(d[0]), float(d[1])),
                                parent=None if j == 0 else finger_body(hand, k, j - 1)))

    pairs = []
    names = pair_names(n_c)
    for i, c in enumerate(hand.contacts):
        if c.kind in ("palm", "surface"):
            body, k = site_on[i]
            pairs.append(ContactPair(names[i], body, "workpiece", float(mu_arr[i]),
                                     shape_a=k, shape_b=site[i]))
        elif c.kind == "side":
            pairs.append(ContactPair(names[i], finger_body(hand, c.finger, c.link), "workpiece",
                                     float(mu_arr[i]), shape_a=0, shape_b=site[i]))
        else:
            last = hand.fingers[c.finger].n_joints - 1
            pairs.append(ContactPair(names[i], finger_body(hand, c.finger, last), "workpiece",
                                     float(mu_arr[i]), shape_a=tip_site[c.finger],
                                     shape_b=site[i]))
    force = np.asarray(hand.load_force, dtype=float)
    loads = (Load("workpiece", (float(force[0]), float(force[1])), 0.0),)
    reach = max(float(np.max(np.abs(hand.palm))),
                *(float(np.max(np.abs(ends))) for _, ends in hand.environment),
                *(np.hypot(*f.pivot) + sum(lk.length for lk in f.chain_links)
                  + sum(abs(float(q0[hand.joint_index(k, j)]))
                        for j, lk in enumerate(f.chain_links) if lk.kind != REVOLUTE)
                  for k, f in enumerate(hand.fingers)))
    bound = 2.0 * reach + scale
    return Scene(
        bodies=tuple(bodies), pairs=tuple(pairs), joints=tuple(joints), loads=loads,
        bounds=(-bound, -bound, bound, bound), length_scale=scale, only_pairs=True,
        meta={"task": "hand (Sec. 5.2)", "hand": hand, "q0": q0.tolist(),
              "vertex_radius": vertex_radius},
    )


def joint_coordinates(poses: np.ndarray, names: Sequence[str], hand: Hand) -> np.ndarray:
    """(T, n_theta) joint coordinates (the hand's ``q[3:]``: rad for revolute, m for
    prismatic joints) from body poses ``(T, B, 3)`` of a :func:`hand_scene` run (body
    ``names``); the inverse of :meth:`planner.model.hand.Hand.links_at`: a revolute
    coordinate is the link's angle minus the previous link's angle minus the link's
    ``offset``; a prismatic one the slide of the link's start from the previous link's end
    along its axis."""
    P = np.asarray(poses, dtype=float)
    out = np.empty((P.shape[0], hand.n_joints))
    for k, f in enumerate(hand.fingers):
        prev_angle = np.zeros(P.shape[0])
        prev_end = np.tile(np.asarray(f.pivot, dtype=float), (P.shape[0], 1))
        for j, link in enumerate(f.chain_links):
            b = P[:, list(names).index(finger_body(hand, k, j))]
            ji = hand.joint_index(k, j) - 3
            if link.kind == REVOLUTE:
                # continuous relative angle, its start on the branch (-pi, pi]
                rel = np.unwrap(b[:, 2] - prev_angle - link.offset)
                out[:, ji] = rel - 2.0 * np.pi * np.round(rel[0] / (2.0 * np.pi))
            else:
                d = np.stack([np.cos(b[:, 2]), np.sin(b[:, 2])], axis=1)
                out[:, ji] = np.sum((b[:, :2] - prev_end) * d, axis=1)
            prev_angle = b[:, 2]
            prev_end = b[:, :2] + link.length * np.stack([np.cos(b[:, 2]), np.sin(b[:, 2])],
                                                         axis=1)
    return out


def finger_angles(rec: Recording, hand: Hand) -> np.ndarray:
    """(T, F) finger joint angles [rad] (the first link's body angle per finger) from a
    recording of :func:`hand_scene`; :func:`joint_coordinates` gives every joint."""
    cols = [rec.body_names.index(finger_body(hand, k)) for k in range(hand.n_fingers)]
    return rec.poses[:, cols, 2]
