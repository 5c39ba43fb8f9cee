"""The role of each contact pair in a scene, from the scene alone (engine-neutral).

A soft-contact engine (MuJoCo) needs a different contact impedance depending on what sets a
contact's normal force (measured in docs/simulation.md, "MuJoCo: contact roles"):

``squeeze``
    the manipulator's prescribed motion has a component along the contact normal (a fingertip
    driven into the workpiece, a jointed link): the normal force comes from the kinematics, and
    any softness shows as penetration instead of workpiece motion -- it needs the stiff default.
``support``
    the manipulator is a static body (a table, a palm): the normal force comes from the load.
``carry``
    the manipulator is driven, but only along the contact tangent (the ruler's fingers, a finger
    sliding under a part): the normal force comes from the load, and the contact slides or
    sticks while it carries it.

The role is decided at the start of a run from the first contact readings (the pairs start
pre-loaded, so every pair touches): the manipulator is ``body_a`` of the pair
(:mod:`sim.scene`), its contact-point velocity is its prescribed twist at ``t = 0`` evaluated at
the contact point, and a pair is ``carry`` when that velocity's normal component is at most
:data:`TANGENTIAL` times its size.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.scene import BodyKind, BodyState, ContactReading, Scene

SQUEEZE, SUPPORT, CARRY = "squeeze", "support", "carry"

#: A driven manipulator whose contact-point velocity has a normal component of at most this
#: fraction of its size moves along the tangent (``carry``); scenes set the velocity exactly,
#: so this only absorbs rounding.
TANGENTIAL = 1e-9


def contact_roles(scene: Scene, readings: Mapping[str, ContactReading],
                  states: Mapping[str, BodyState]) -> dict[str, str]:
    """``{pair name: role}`` (module docstring) from the first ``readings`` and body ``states``
    (pose and twist of each body's origin, world frame). A pair with a static body is
    ``support``; a pair whose manipulator (``body_a``) is a driven body without a joint and
    whose contact point moves along the contact tangent (or not at all: then too the load sets
    its normal force) is ``carry``; everything else (a
    prescribed normal motion, a jointed or free manipulator, a pair not touching) is
    ``squeeze``."""
    bodies = {b.name: b for b in scene.bodies}
    jointed = {j.body for j in scene.joints}
    roles: dict[str, str] = {}
    for p in scene.pairs:
        a, b = bodies[p.body_a], bodies[p.body_b]
        reading = readings.get(p.name)
        if BodyKind.STATIC in (a.kind, b.kind):
            roles[p.name] = SUPPORT
            continue
        roles[p.name] = SQUEEZE
        if (a.kind != BodyKind.DRIVEN or a.twist is None or a.name in jointed
                or reading is None or not reading.present):
            continue
        # the command's direction, not its value at t = 0: a drive ramped from rest
        # (sim.run.ramped) is still zero there
        command = getattr(a.twist, "unramped", a.twist)
        vx, vy, w = (float(c) for c in command(0.0, states))
        x0, y0, _ = states[a.name].pose
        px, py = reading.point
        v = np.array([vx - w * (py - y0), vy + w * (px - x0)])
        normal = float(v @ np.asarray(reading.normal, dtype=float))
        if abs(normal) <= TANGENTIAL * float(np.linalg.norm(v)):
            roles[p.name] = CARRY
    return roles
