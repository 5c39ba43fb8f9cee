"""A scene simulated at another size: the similar scene (every length times ``s``) and its
recording mapped back to the original's units.

Under a uniform scaling of lengths by ``s`` with time unchanged, the quasistatic problem keeps
its solution: the wrench matrix's moment row and ``g_obj``'s moment scale by ``s`` (eqs. 1-2),
so the contact forces, the feasible modes and the workpiece's rotation rate are unchanged and
its linear velocities scale by ``s`` (eqs. 4-5). The scene is mapped accordingly
(:func:`scaled_scene`): positions, shapes and joint anchors times ``s``, rotational inertia
times ``s^2`` (masses unchanged), moments and revolute efforts times ``s``, forces and
prismatic efforts unchanged, linear drive velocities (driven twists, prismatic rates) times
``s``, angular ones unchanged. The recording is mapped back (:func:`unscaled_recording`):
positions, contact points, slip velocities and depths divided by ``s``; forces, normals, angles
and times unchanged. Why a scene is scaled at all: the engines' absolute tolerances are not
scale-free (:data:`sim.settings.SIZE_RANGE`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from planner.errors import InputError
from sim.run import Recording
from sim.scene import (
    BodyKind,
    BodyState,
    Capsule,
    Circle,
    Command,
    Control,
    Joint,
    JointKind,
    Load,
    Polygon,
    Scene,
    Shape,
)


def _xy(p: Any, s: float) -> tuple[float, float]:
    return (float(p[0]) * s, float(p[1]) * s)


def _shape(shape: Shape, s: float) -> Shape:
    if isinstance(shape, Polygon):
        return Polygon(tuple(_xy(v, s) for v in shape.vertices))
    if isinstance(shape, Circle):
        return Circle(_xy(shape.center, s), shape.radius * s)
    return Capsule(_xy(shape.a, s), _xy(shape.b, s), shape.radius * s)


def _state_back(states: Mapping[str, BodyState], s: float) -> dict[str, BodyState]:
    """Body states of the scaled scene in the original's units (what commands expect)."""
    return {k: BodyState((v.pose[0] / s, v.pose[1] / s, v.pose[2]),
                         (v.twist[0] / s, v.twist[1] / s, v.twist[2]))
            for k, v in states.items()}


def _twist(command: Command, s: float) -> Command:
    def scaled(t: float, states: Mapping[str, BodyState]) -> tuple[float, float, float]:
        vx, vy, w = command(t, _state_back(states, s))
        return (float(vx) * s, float(vy) * s, float(w))
    return scaled


def _joint_command(command: Command, factor: float, s: float) -> Command:
    def scaled(t: float, states: Mapping[str, BodyState]) -> float:
        return float(command(t, _state_back(states, s))) * factor
    return scaled


def _joint_factor(joint: Joint, s: float) -> float:
    """Factor of a joint's command: a prismatic rate [m/s] and a revolute effort [N m] are
    lengths times something; a revolute rate and a prismatic force are not."""
    linear = joint.kind == JointKind.PRISMATIC
    return s if (joint.control == Control.VELOCITY) == linear else 1.0


def scaled_scene(scene: Scene, s: float) -> Scene:
    """The scene similar to ``scene`` with every length times ``s`` (module docstring)."""
    if s == 1.0:
        return scene
    bodies = tuple(replace(
        b, shapes=tuple(_shape(sh, s) for sh in b.shapes), com=_xy(b.com, s),
        inertia=None if b.inertia is None else b.inertia * s * s,
        pose=(b.pose[0] * s, b.pose[1] * s, b.pose[2]),
        twist=None if b.twist is None else _twist(b.twist, s)) for b in scene.bodies)
    joints = tuple(replace(j, anchor=_xy(j.anchor, s),
                           command=_joint_command(j.command, _joint_factor(j, s), s))
                   for j in scene.joints)
    loads = tuple(Load(ld.body, ld.force, ld.moment * s) for ld in scene.loads)
    return replace(scene, bodies=bodies, joints=joints, loads=loads,
                   bounds=tuple(v * s for v in scene.bounds),  # type: ignore[arg-type]
                   length_scale=scene.length_scale * s)


def unscaled_recording(rec: Recording, s: float) -> Recording:
    """A recording of a scene scaled by ``s`` in the original scene's units."""
    if s == 1.0:
        return rec
    poses = rec.poses.copy()
    poses[..., :2] /= s
    corr = rec.correction
    if corr is not None:
        corr = corr.copy()
        corr[..., :2] /= s
    return replace(rec, poses=poses, points=rec.points / s,
                   slip_velocity=rec.slip_velocity / s, depth=rec.depth / s, correction=corr)


def scaled_masses(scene: Scene, factor: float) -> Scene:
    """``scene`` with every dynamic body's mass and rotational inertia times ``factor`` (the
    engine settings' ``mass_scale``: dynamics only -- loads and efforts are explicit forces, so
    the quasistatic prediction does not depend on mass)."""
    if factor == 1.0:
        return scene
    if not (np.isfinite(factor) and factor > 0):
        raise InputError(f"mass scale: expected a finite number > 0, got {factor}")
    return replace(scene, bodies=tuple(
        replace(b, mass=b.mass * factor,
                inertia=None if b.inertia is None else b.inertia * factor)
        if b.kind == BodyKind.DYNAMIC else b for b in scene.bodies))
