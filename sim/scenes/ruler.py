"""The ruler on two approaching fingers (Trinkle & Zeng 1994, Section 5.1) as a scene.

A rod of length ``length`` [m] and weight ``weight`` [N] rests on two fingertips below it that
move toward each other at ``speed`` [m/s] each (its predicted switch positions:
:mod:`planner.predict.ruler`; its judge: :mod:`sim.judge_switches`).
"""

from __future__ import annotations

from planner.predict.ruler import THICKNESS_RATIO
from sim.scene import (
    Body,
    BodyKind,
    Circle,
    ContactPair,
    Load,
    Polygon,
    Scene,
    preload_depth,
)

__all__ = ["THICKNESS_RATIO", "ruler_scene"]


def ruler_scene(*, length: float, weight: float, mass: float, x_left: float, x_right: float,
                speed: float, mu_s: float, mu_k: float | None, finger_radius: float) -> Scene:
    """Rod (COM at the origin) on two driven fingertips at ``x_left < 0 < x_right`` [m]."""
    h = THICKNESS_RATIO * length
    rod = Polygon(((-length / 2, -h / 2), (length / 2, -h / 2), (length / 2, h / 2),
                   (-length / 2, h / 2)))
    work = Body("workpiece", (rod,), mass=mass, com=(0.0, 0.0),
                inertia=mass * (length ** 2 + h ** 2) / 12.0)
    y = -h / 2 - finger_radius + preload_depth(length)
    left = Body("finger1", (Circle((0.0, 0.0), finger_radius),), pose=(x_left, y, 0.0),
                kind=BodyKind.DRIVEN, twist=lambda t, s: (speed, 0.0, 0.0))
    right = Body("finger2", (Circle((0.0, 0.0), finger_radius),), pose=(x_right, y, 0.0),
                 kind=BodyKind.DRIVEN, twist=lambda t, s: (-speed, 0.0, 0.0))
    pairs = (ContactPair("c1", "finger1", "workpiece", mu_static=mu_s, mu_kinetic=mu_k),
             ContactPair("c2", "finger2", "workpiece", mu_static=mu_s, mu_kinetic=mu_k))
    return Scene(bodies=(work, left, right), pairs=pairs,
                 loads=(Load("workpiece", (0.0, -weight), 0.0),),
                 bounds=(-length, -length, length, length), length_scale=length,
                 meta={"thickness": h})
