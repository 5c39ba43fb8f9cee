"""Simulator backends behind the :class:`sim.scene.Backend` protocol and their one factory.

Each engine is one module (:mod:`sim.backends.pymunk_engine`, :mod:`sim.backends.mujoco_engine`),
imported lazily so importing :mod:`sim` costs no engine, plus one row per scene kind in the
settings table (:data:`sim.settings.SETTINGS`). :data:`BACKENDS` maps an engine name to the
module and class that implement it and to the function that turns its
:class:`~sim.settings.EngineSettings` into constructor options.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from sim.scene import Backend
from sim.settings import ENGINES, EngineSettings, check_engine

__all__ = ["BACKENDS", "ENGINES", "EngineSettings", "check_engine", "make_backend"]


def _pymunk_options(es: EngineSettings) -> dict[str, Any]:
    return {"iterations": es.iterations}


def _mujoco_options(es: EngineSettings) -> dict[str, Any]:
    return {"solref": es.solref, "out_of_plane_stiffness": es.z_stiffness,
            "support_solimp": es.support_solimp, "carry_solref": es.carry_solref,
            "carry_impratio": es.carry_impratio, "squeeze_d0": es.squeeze_d0,
            "squeeze_solref": es.squeeze_solref, "heavy_ratio": es.heavy_ratio,
            "support_solref": es.support_solref, "support_impratio": es.support_impratio}


#: ``engine -> (module, class name, options from settings)``.
BACKENDS: dict[str, tuple[str, str, Callable[[EngineSettings], dict[str, Any]]]] = {
    "pymunk": ("sim.backends.pymunk_engine", "PymunkBackend", _pymunk_options),
    "mujoco": ("sim.backends.mujoco_engine", "MujocoBackend", _mujoco_options),
}


def make_backend(engine: str, settings: EngineSettings | None = None) -> Backend:
    """A new backend of ``engine`` (imported on first use) with ``settings``' options
    (default: :class:`~sim.settings.EngineSettings`'s defaults)."""
    module, cls, options = BACKENDS[check_engine(engine)]
    backend: Backend = getattr(importlib.import_module(module), cls)(
        **options(settings or EngineSettings()))
    return backend
