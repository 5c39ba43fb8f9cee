"""Registry of runnable scenarios ("scenarios are data in a registry").

A scenario module inside :mod:`scenarios` registers its scenarios at import with
:func:`register`.  :func:`all_scenarios` imports every module of the package (auto-discovery),
so adding a scenario never needs an edit of a shared file.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from planner.errors import InputError
from sim.compare import Expect

__all__ = ["DATA_DIR", "Expect", "Scenario", "all_scenarios", "get", "register", "shipped_file"]

#: The shipped system and hand files (``example_4_1``, ``two_finger_hand``, ...).
DATA_DIR = Path(__file__).resolve().parent / "data"


def shipped_file(name: str | os.PathLike[str], what: str = "hand") -> Path:
    """A path to an existing file, or the name of a shipped ``what`` file in ``scenarios/data``
    (``what``: ``"hand"`` or ``"system"``)."""
    p = Path(name)
    if p.is_file():
        return p
    cand = DATA_DIR / f"{name}.json"
    if cand.is_file():
        return cand
    known = sorted(f.stem for f in DATA_DIR.glob("*.json")
                   if ('"qsplan-hand"' in f.read_text()) == (what == "hand"))
    raise InputError(f"{what}: expected a {what} file path or one of {known}, got {str(name)!r}")


@dataclass(frozen=True)
class Scenario:
    """A registered scenario.

    Attributes
    ----------
    name : str
        Unique name used on the command line.
    summary : str
        One line: what it shows.
    reference : str
        The paper figure/section it reproduces, e.g. ``"Sec. 4.1, eq. 37, Fig. 3"``.
    expect : Expect
        ``AGREE`` or ``DISAGREE`` (negative control) for simulator scenarios; ``INFO`` for
        scenarios that only produce figures or tables.
    run : callable
        ``run(out_dir: pathlib.Path, **options) -> dict`` writes its outputs into ``out_dir``
        and returns a JSON-ready summary (``status``: a :class:`sim.compare.Outcome` value, or
        ``"info"`` for ``INFO`` scenarios; ``passed``: the expectation held).
    engines : tuple of str
        Engines it runs on (empty when it does not simulate).
    tags : tuple of str
    """

    name: str
    summary: str
    reference: str
    expect: Expect
    run: Callable[..., dict[str, Any]]
    engines: tuple[str, ...] = ()
    tags: tuple[str, ...] = field(default_factory=tuple)


_REGISTRY: dict[str, Scenario] = {}


def register(scenario: Scenario) -> Scenario:
    """Add a scenario; names must be unique."""
    if scenario.name in _REGISTRY and _REGISTRY[scenario.name] is not scenario:
        raise InputError(f"scenario {scenario.name!r} is registered twice")
    _REGISTRY[scenario.name] = scenario
    return scenario


def all_scenarios() -> dict[str, Scenario]:
    """Every scenario of every module in the package, by name (sorted)."""
    import scenarios as pkg

    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name not in {"registry", "__main__"} and not info.name.startswith("_"):
            importlib.import_module(f"scenarios.{info.name}")
    return dict(sorted(_REGISTRY.items()))


def get(name: str) -> Scenario:
    """The scenario called ``name``; a clear error listing the known names otherwise."""
    table = all_scenarios()
    if name not in table:
        raise InputError(f"unknown scenario {name!r}; expected one of: {', '.join(table)}")
    return table[name]
