"""Simulator backends behind the :class:`sim.scene.Backend` protocol, and their one factory.

:mod:`sim.backends.pymunk_engine` (Chipmunk2D) and :mod:`sim.backends.mujoco_engine` are imported
lazily, so importing :mod:`sim` costs neither engine.
"""

from __future__ import annotations

from planner.errors import InputError
from sim.scene import Backend

#: Every engine :func:`make_backend` knows, in the order reports list them.
ENGINES = ("pymunk", "mujoco")


def make_backend(engine: str) -> Backend:
    """``"pymunk"`` or ``"mujoco"`` backend (imported lazily)."""
    if engine == "pymunk":
        from sim.backends.pymunk_engine import PymunkBackend

        return PymunkBackend()
    if engine == "mujoco":
        from sim.backends.mujoco_engine import MujocoBackend

        return MujocoBackend()
    raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")

