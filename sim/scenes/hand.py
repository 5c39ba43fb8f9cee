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
  (``side`` contacts) and, for a ``tip`` contact, a circle of radius ``width/2`` at the tip.
* ``workpiece``: the polygon (``tip`` contacts touch it) plus, per ``palm`` / ``side`` contact,
  a small circle of radius ``vertex_radius`` at the touching vertex, placed so its surface
  touches the feature where the sharp vertex does (centre = vertex + r n, n the contact's
  inward normal at the initial configuration). A sharp vertex has no stable contact point in
  either engine; the circle moves the contact point by ``r`` times the change of the contact
  normal's direction (0.5 mm x 0.16 rad = 80 um over the default segment).

Mass and inertia: workpiece mass and COM from the file, rotational inertia of the uniform
polygon about the COM; finger links of the file's mass with the inertia of a uniform rod.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
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

#: Radius [m] of the circles standing for sharp workpiece vertices.
VERTEX_RADIUS = 5e-4
#: Radius [m] of the palm capsules (surface on the palm line).
PALM_RADIUS = 2e-3


def pair_names(n_contacts: int) -> tuple[str, ...]:
    """Contact pair names in hand-file order: ``c1, c2, ...`` (mode labels index them 1..n)."""
    return tuple(f"c{i + 1}" for i in range(n_contacts))


def finger_body(hand: Hand, k: int) -> str:
    return f"finger:{hand.fingers[k].name}"


def polygon_inertia(vertices: np.ndarray, mass: float, com: np.ndarray) -> float:
    """Rotational inertia [kg m^2] about ``com`` of a uniform polygon ``vertices (V, 2)`` [m]
    (counter-clockwise) of total ``mass`` [kg]."""
    v = np.asarray(vertices, dtype=float) - np.asarray(com, dtype=float)
    a, b = v, np.roll(v, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    area = 0.5 * float(np.sum(cross))
    second = float(np.sum(cross * (np.sum(a * a, axis=1) + np.sum(a * b, axis=1)
                                   + np.sum(b * b, axis=1)))) / 12.0
    return mass * second / area


def _rot(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def hand_scene(
    hand: Hand,
    q0: np.ndarray,
    mu: float | Sequence[float] | np.ndarray,
    controls: Sequence[str | Control],
    commands: Sequence[Command],
    *,
    mass_scale: float = 1.0,
    vertex_radius: float = VERTEX_RADIUS,
    overlap: float | None = None,
) -> Scene:
    """Scene of ``hand`` at its closed initial configuration ``q0`` (``(3 + F,)``: workpiece
    pose, finger angles; both from :func:`planner.files.hand_file.hand_from_dict`).

    ``mu``: scalar or (n_c,) Coulomb coefficients per contact (file order); ``controls`` (F,)
    ``"velocity"``/``"effort"`` per finger joint; ``commands`` (F,) ``command(t, states)``
    returning the joint rate [rad/s] or torque [N m] (counter-clockwise positive).
    ``mass_scale``: factor on the workpiece and finger masses (dynamics only).
    ``overlap`` [m]: every contact starts this far into its feature (default
    :func:`sim.scene.preload_depth`: half of pymunk's collision slop, SIM-NOTES: resting
    contacts that start exactly touching flicker, and a computed gap of +1e-17 m is no
    contact at all): vertex circles are placed that deep, fingertip circles are shifted that
    far along the contact normal into the workpiece edge.
    """
    F, n_c = hand.n_fingers, hand.n_contacts
    mu_arr = as_friction(mu, n_c)
    if not (np.isfinite(mass_scale) and mass_scale > 0):
        raise InputError(f"mass_scale: expected a finite number > 0, got {mass_scale}")
    if len(controls) != F or len(commands) != F:
        raise InputError(f"controls/commands: expected {F} each (one per finger), got "
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
    pts, nrm, _ = hand.contact_geometry(q0)
    pose0 = (float(q0[0]), float(q0[1]), float(q0[2]))
    to_body = _rot(-pose0[2])

    # palm: one capsule per palm contact, surface on the palm line
    a, b = np.asarray(hand.palm, dtype=float)
    down = -hand.palm_normal * PALM_RADIUS
    palm_ids = [i for i, c in enumerate(hand.contacts) if c.kind == "palm"]
    palm_shapes = tuple(Capsule(tuple(a + down), tuple(b + down), PALM_RADIUS)
                        for _ in palm_ids) or (Capsule(tuple(a + down), tuple(b + down),
                                                       PALM_RADIUS),)
    palm = Body(name="palm", shapes=palm_shapes, kind=BodyKind.STATIC)

    # workpiece: polygon, then one circle per vertex contact
    V = np.asarray(hand.vertices, dtype=float)
    shapes: list[Shape] = [Polygon(tuple(map(tuple, V)))]
    site: dict[int, int] = {}
    for i, c in enumerate(hand.contacts):
        if c.kind in ("palm", "side"):
            centre = pts[i] + (vertex_radius - overlap) * nrm[i]
            local = to_body @ (centre - np.asarray(pose0[:2]))
            site[i] = len(shapes)
            shapes.append(Circle((float(local[0]), float(local[1])), vertex_radius))
    com = np.asarray(hand.com, dtype=float)
    mass = hand.mass * mass_scale
    work = Body(name="workpiece", shapes=tuple(shapes), mass=mass,
                com=(float(com[0]), float(com[1])),
                inertia=polygon_inertia(V, mass, com), pose=pose0)

    # fingers
    bodies = [palm, work]
    joints = []
    tip_site: dict[int, int] = {}
    for k, f in enumerate(hand.fingers):
        fshapes: list[Shape] = [Capsule((0.0, 0.0), (f.length, 0.0), f.radius)]
        tips = [i for i, c in enumerate(hand.contacts) if c.kind == "tip" and c.finger == k]
        if tips:
            # pre-load: the tip circle shifted by `overlap` along the contact's inward normal
            push = _rot(-float(q0[3 + k])) @ (overlap * nrm[tips[0]])
            tip_site[k] = len(fshapes)
            fshapes.append(Circle((f.length + float(push[0]), float(push[1])), f.radius))
        name = finger_body(hand, k)
        fm = f.mass * mass_scale
        bodies.append(Body(name=name, shapes=tuple(fshapes), mass=fm,
                           com=(0.5 * f.length, 0.0),
                           inertia=fm * (f.length ** 2 + f.width ** 2) / 12.0,
                           pose=(float(f.pivot[0]), float(f.pivot[1]), float(q0[3 + k]))))
        joints.append(Joint(name=f"joint:{f.name}", body=name, kind=JointKind.REVOLUTE,
                            anchor=(float(f.pivot[0]), float(f.pivot[1])), control=ctrl[k],
                            command=commands[k]))

    pairs = []
    names = pair_names(n_c)
    for i, c in enumerate(hand.contacts):
        if c.kind == "palm":
            pairs.append(ContactPair(names[i], "palm", "workpiece", float(mu_arr[i]),
                                     shape_a=palm_ids.index(i), shape_b=site[i]))
        elif c.kind == "side":
            pairs.append(ContactPair(names[i], finger_body(hand, c.finger), "workpiece",
                                     float(mu_arr[i]), shape_a=0, shape_b=site[i]))
        else:
            pairs.append(ContactPair(names[i], finger_body(hand, c.finger), "workpiece",
                                     float(mu_arr[i]), shape_a=tip_site[c.finger], shape_b=0))
    force = np.asarray(hand.load_force, dtype=float)
    loads = (Load("workpiece", (float(force[0]), float(force[1])), 0.0),)
    reach = max(float(np.max(np.abs(hand.palm))), *(np.hypot(*f.pivot) + f.length
                                                   for f in hand.fingers))
    bound = 2.0 * reach + scale
    return Scene(
        bodies=tuple(bodies), pairs=tuple(pairs), joints=tuple(joints), loads=loads,
        bounds=(-bound, -bound, bound, bound), length_scale=scale, only_pairs=True,
        meta={"task": "two-finger hand (Sec. 5.2)", "hand": hand, "q0": q0.tolist(),
              "vertex_radius": vertex_radius},
    )


def finger_angles(rec: Recording, hand: Hand) -> np.ndarray:
    """(T, F) finger joint angles [rad] from a recording of :func:`hand_scene`."""
    cols = [rec.body_names.index(finger_body(hand, k)) for k in range(hand.n_fingers)]
    return rec.poses[:, cols, 2]
