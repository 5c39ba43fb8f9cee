"""Joints whose control mode switches during a run (a whole task's segments may drive other
joints by velocity and by effort): the engine-neutral part of ``set_control`` of every backend
(:mod:`sim.backends.pymunk_engine`, :mod:`sim.backends.mujoco_engine`,
:mod:`sim.backends.dart_engine`)."""

from __future__ import annotations

from dataclasses import replace

from planner.errors import InputError
from sim.scene import Control, Joint, JointKind, Scene


def switch_joint(scene: Scene, joint: str, control: Control | str) -> Joint | None:
    """The joint of ``scene`` named ``joint`` if it must switch to ``control``; ``None`` when
    it already has that control. Raises InputError for an unknown joint, an unknown control
    or a prismatic joint (only revolute joints switch)."""
    try:
        ctrl = Control(control)
    except ValueError:
        raise InputError(f"set_control: expected 'velocity' or 'effort', got {control!r}") from None
    by_name = {j.name: j for j in scene.joints}
    if joint not in by_name:
        raise InputError(f"set_control: expected a joint of the scene {sorted(by_name)}, got "
                         f"{joint!r}")
    j = by_name[joint]
    if j.control == ctrl:
        return None
    if j.kind != JointKind.REVOLUTE:
        raise InputError(f"set_control: expected a revolute joint, got {j.kind.value} joint "
                         f"{joint!r} (prismatic joints keep their control for the whole run)")
    return j


def replace_joint(scene: Scene, joint: Joint, control: Control | str) -> Scene:
    """``scene`` with ``joint``'s control set to ``control`` (the backends read it per step)."""
    ctrl = Control(control)
    return replace(scene, joints=tuple(replace(j, control=ctrl) if j.name == joint.name else j
                                       for j in scene.joints))
