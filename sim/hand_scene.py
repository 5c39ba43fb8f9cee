"""Two-finger hand on a palm (Figure 9, Sec. 5.2) as an engine-neutral :class:`sim.scene.Scene`.

Horizontal plane: no gravity; ``g_obj`` (e.g. support friction) enters as a constant
:class:`~sim.scene.Load`. Bodies: a static palm made of two segments (one per palm contact, so
each palm vertex contact is its own arbiter), two finger links (capsules on revolute joints to
the world, body frame at the pivot), and the polygonal workpiece.

Geometry dict (assumed layout, to be reconciled with PLANNING's
``scenarios/data/two_finger_hand.json``)::

    palm:      {"left": [[x, y], [x, y]], "right": [[x, y], [x, y]], "radius": r}   [m]
    fingers:   [{"name", "pivot": [x, y], "length", "width", "angle"}, ...]       [m, rad]
    workpiece: {"vertices": [[x, y], ...] (ccw, body frame), "mass", "com": [x, y],
                "pose": [x, y, theta]}
    g_obj:     [fx, fy, m]  [N, N, N m]

Contacts, in data-file order: palm-left, palm-right, finger 0, finger 1.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from planner.errors import InputError
from sim.scene import (
    Body,
    BodyKind,
    Command,
    ContactPair,
    Control,
    Joint,
    JointKind,
    Load,
    Polygon,
    Scene,
    Segment,
)

PAIR_NAMES = ("c1", "c2", "c3", "c4")


def _get(d: Mapping, key: str, where: str):
    if key not in d:
        raise InputError(f"{where}: expected key {key!r}, got keys {sorted(d)}")
    return d[key]


def hand_scene(
    geometry: Mapping,
    mu: Sequence[float],
    controls: Sequence[Control],
    commands: Sequence[Command],
) -> Scene:
    """Build the scene. ``mu`` (4,) per contact; ``controls``/``commands`` (2,) per finger joint
    (velocity [rad/s] or torque [N m] as returned by ``command(t, states)``)."""
    mu = np.asarray(mu, dtype=float)
    if mu.shape != (4,):
        raise InputError(f"mu: expected 4 coefficients (one per contact), got shape {mu.shape}")
    palm = _get(geometry, "palm", "geometry")
    fingers = _get(geometry, "fingers", "geometry")
    if len(fingers) != 2 or len(controls) != 2 or len(commands) != 2:
        raise InputError(f"fingers/controls/commands: expected 2 each, got "
                         f"{len(fingers)}/{len(controls)}/{len(commands)}")
    r = float(palm.get("radius", 0.001))
    palm_body = Body(
        name="palm",
        kind=BodyKind.STATIC,
        shapes=tuple(
            Segment(tuple(_get(palm, k, "palm")[0]), tuple(palm[k][1]), r)
            for k in ("left", "right")
        ),
    )
    wp = _get(geometry, "workpiece", "geometry")
    work = Body(
        name="workpiece",
        shapes=(Polygon(tuple(map(tuple, _get(wp, "vertices", "workpiece"))),),),
        mass=float(_get(wp, "mass", "workpiece")),
        com=tuple(wp.get("com", (0.0, 0.0))),
        pose=tuple(_get(wp, "pose", "workpiece")),
    )
    bodies = [palm_body, work]
    joints = []
    for i, (f, ctrl, cmd) in enumerate(zip(fingers, controls, commands)):
        name = f.get("name", f"finger{i + 1}")
        pivot = tuple(map(float, _get(f, "pivot", name)))
        length, width = float(_get(f, "length", name)), float(_get(f, "width", name))
        bodies.append(Body(
            name=name,
            shapes=(Segment((0.0, 0.0), (length, 0.0), 0.5 * width),),
            mass=float(f.get("mass", 0.05)),
            com=(0.0, 0.0),
            pose=(pivot[0], pivot[1], float(_get(f, "angle", name))),
        ))
        joints.append(Joint(name=f"joint{i + 1}", body=name, kind=JointKind.REVOLUTE,
                            anchor=pivot, control=Control(ctrl), command=cmd))
    pairs = [
        ContactPair(PAIR_NAMES[0], "palm", "workpiece", float(mu[0]), shape_a=0),
        ContactPair(PAIR_NAMES[1], "palm", "workpiece", float(mu[1]), shape_a=1),
        ContactPair(PAIR_NAMES[2], bodies[2].name, "workpiece", float(mu[2])),
        ContactPair(PAIR_NAMES[3], bodies[3].name, "workpiece", float(mu[3])),
    ]
    g = geometry.get("g_obj", (0.0, 0.0, 0.0))
    loads = (Load("workpiece", (float(g[0]), float(g[1])), float(g[2])),)
    scale = float(np.ptp(np.asarray(wp["vertices"], dtype=float), axis=0).max())
    return Scene(bodies=tuple(bodies), pairs=tuple(pairs), joints=tuple(joints), loads=loads,
                 length_scale=scale, meta={"task": "two-finger hand (Sec. 5.2)"})
