"""Scenes of the paper's examples for tests that drive a backend directly (faults, readings,
recorded traces): the shipped file scaled by hand, built by the pipeline's scene builder."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from planner.errors import InputError
from planner.files.system_file import load_system
from planner.model.system import System
from scenarios.registry import DATA_DIR
from sim.scene import BodyKind, Scene
from sim.scenes.system import system_scene


def scaled_system(system: System, scale: float, speed: float = 1.0) -> System:
    """``system`` (contact velocities) with lengths times ``scale`` [-] and contact velocities
    times ``speed``; ``g_obj``'s moment scaled too (the feasible mode set is unchanged)."""
    if not system.virtual_joints:
        raise InputError("scaled_system: expected a system given by contact velocities")
    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"scale: expected a finite number > 0, got {scale}")
    g = np.array(system.g_obj, dtype=float) * np.array([1.0, 1.0, scale])
    W = np.array(system.W, dtype=float)
    W[2] *= scale
    return System.from_wrench_matrix(
        W, system.mu, external_wrench=g,
        contact_velocities=np.asarray(system.joint_inputs).reshape(-1, 2) * speed)


def example(name: str, scale: float, speed: float = 1.0) -> System:
    """A shipped example scaled by ``scale`` with contact velocities times ``speed``."""
    return scaled_system(load_system(DATA_DIR / f"{name}.json"), scale, speed)


def example_scene(name: str, scale: float, speed: float, mu, mass: float = 0.1,
                  gap: float = 0.0) -> Scene:
    """The scene of a scaled example at friction ``mu``; ``gap`` [m] moves every fingertip
    that far out of contact along its contact normal."""
    system = example(name, scale, speed).with_mu(mu)
    scene = system_scene(system)
    nrm = np.asarray(system.normals, dtype=float)
    bodies = []
    for b in scene.bodies:
        if b.kind == BodyKind.DYNAMIC:
            b = replace(b, mass=mass, inertia=None if b.inertia is None else
                        b.inertia * mass / b.mass)
        elif b.kind == BodyKind.DRIVEN and gap:
            n = nrm[int(b.name.removeprefix("finger")) - 1]
            b = replace(b, pose=(b.pose[0] - gap * n[0], b.pose[1] - gap * n[1], b.pose[2]))
        bodies.append(b)
    return replace(scene, bodies=tuple(bodies))
