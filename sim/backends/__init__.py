"""Simulator backends behind the :class:`sim.scene.Backend` protocol and their one factory.

Each engine is one module (:mod:`sim.backends.pymunk_engine`, :mod:`sim.backends.mujoco_engine`,
:mod:`sim.backends.dart_engine`), imported lazily so importing :mod:`sim` costs no engine, plus
one row per scene kind in the settings table (:data:`sim.settings.SETTINGS`). :data:`BACKENDS`
maps an engine name to the module and class that implement it and to the function that turns
its :class:`~sim.settings.EngineSettings` into constructor options; :data:`PACKAGES` names the
Python package each engine needs and how to install it (an engine of an optional extra may be
missing: :func:`require_engine` says so before a run, :func:`make_backend` at the latest).
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable
from typing import Any

from planner.errors import InputError
from sim.scene import Backend
from sim.settings import DEFAULT_ENGINES, ENGINES, EngineSettings, check_engine

__all__ = ["BACKENDS", "DEFAULT_ENGINES", "ENGINES", "PACKAGES", "EngineSettings",
           "check_engine", "installed", "installed_engines", "make_backend", "require_engine"]


def _pymunk_options(es: EngineSettings) -> dict[str, Any]:
    return {"iterations": es.iterations}


def _mujoco_options(es: EngineSettings) -> dict[str, Any]:
    return {"solref": es.solref, "out_of_plane_stiffness": es.z_stiffness,
            "support_solimp": es.support_solimp, "carry_solref": es.carry_solref,
            "carry_impratio": es.carry_impratio, "squeeze_d0": es.squeeze_d0,
            "squeeze_solref": es.squeeze_solref, "heavy_ratio": es.heavy_ratio,
            "support_solref": es.support_solref, "support_impratio": es.support_impratio,
            "contact_force": es.contact_force, "stick_speed": es.stick_speed}


def _dart_options(es: EngineSettings) -> dict[str, Any]:
    return {}  # every DART setting is derived from the scene (docs/engine-dart.md)


#: ``engine -> (module, class name, options from settings)``.
BACKENDS: dict[str, tuple[str, str, Callable[[EngineSettings], dict[str, Any]]]] = {
    "pymunk": ("sim.backends.pymunk_engine", "PymunkBackend", _pymunk_options),
    "mujoco": ("sim.backends.mujoco_engine", "MujocoBackend", _mujoco_options),
    "dart": ("sim.backends.dart_engine", "DartBackend", _dart_options),
}

#: ``engine -> (Python package it imports, what installs it)``.
PACKAGES: dict[str, tuple[str, str]] = {
    "pymunk": ("pymunk", "pip install qsplan"),
    "mujoco": ("mujoco", "pip install qsplan"),
    "dart": ("dartpy", "pip install 'qsplan[dart]'"),
}


def installed(engine: str) -> bool:
    """Whether the Python package ``engine`` needs can be imported (without importing it)."""
    return importlib.util.find_spec(PACKAGES[check_engine(engine)][0]) is not None


def installed_engines() -> tuple[str, ...]:
    """Every engine of the settings table whose package is installed, in :data:`ENGINES`'
    order (what ``qsplan demo`` runs when no engine is named)."""
    return tuple(e for e in ENGINES if installed(e))


def require_engine(engine: str, what: str = "engine") -> str:
    """``engine`` if the settings table knows it and its package is installed, else an
    :class:`InputError` naming the choices or the install command (``what`` names the
    option in the message, e.g. ``"--engine"``)."""
    if engine not in ENGINES:
        raise InputError(f"{what}: expected one of {', '.join(ENGINES)}, got {engine!r}")
    if not installed(engine):
        package, how = PACKAGES[engine]
        raise InputError(f"{what}: engine {engine!r} needs the Python package {package!r}, "
                         f"which is not installed; install it with: {how}")
    return engine


def make_backend(engine: str, settings: EngineSettings | None = None) -> Backend:
    """A new backend of ``engine`` (imported on first use) with ``settings``' options
    (default: :class:`~sim.settings.EngineSettings`'s defaults); an :class:`InputError` when
    the engine's package is not installed (:func:`require_engine`)."""
    module, cls, options = BACKENDS[require_engine(engine)]
    backend: Backend = getattr(importlib.import_module(module), cls)(
        **options(settings or EngineSettings()))
    return backend
