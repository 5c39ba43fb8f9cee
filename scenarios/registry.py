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

import numpy as np

from planner.errors import InputError
from sim.verdict import Expect

__all__ = ["DATA_DIR", "Expect", "Parameter", "PlanRun", "RulerRun", "RunSpec", "Scenario",
           "SystemRun", "all_scenarios", "get", "parse_settings", "register", "shipped_file"]

#: The shipped system and hand files (``example_4_1``, ``two_finger_hand``, ...).
DATA_DIR = Path(__file__).resolve().parent / "data"
RUN_ENTRIES = ("summary.json", "timeline.png", "animation.gif", "problem.png")
"""The entries of a run folder (:func:`scenarios.runs.write_run`: the summary, the pictures
of :func:`sim.render.draw_run` and the drawing of the problem's file); without rendering only
the summary."""


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


#: Parameter types: ``float``, ``int``, ``str`` and ``floats`` (comma-separated numbers).
PARAMETER_TYPES = ("float", "int", "str", "floats")


@dataclass(frozen=True)
class Parameter:
    """A typed scenario parameter set with ``--set name=value``.

    ``kind`` one of :data:`PARAMETER_TYPES`; ``default`` its value when not set; ``unit`` for
    display (``"-"`` dimensionless); ``lo``/``hi`` the closed range of every number (None: open).
    """

    name: str
    kind: str
    default: Any
    unit: str = "-"
    lo: float | None = None
    hi: float | None = None
    help: str = ""

    def parse(self, text: str) -> Any:
        """The typed value of ``text``; :class:`InputError` naming expected vs got."""
        rng = f" in [{self.lo}, {self.hi}]" if self.lo is not None or self.hi is not None else ""
        if self.kind == "str":
            return text
        parts = text.split(",") if self.kind == "floats" else [text]
        values: list[Any] = []
        for part in parts:
            try:
                v: Any = int(part) if self.kind == "int" else float(part)
            except ValueError:
                raise InputError(f"--set {self.name}: expected {self.describe()}{rng}, "
                                 f"got {text!r}") from None
            if not np.isfinite(v) or (self.lo is not None and v < self.lo) or (
                    self.hi is not None and v > self.hi):
                raise InputError(f"--set {self.name}: expected {self.describe()}{rng}, "
                                 f"got {text!r}")
            values.append(v)
        return tuple(values) if self.kind == "floats" else values[0]

    def describe(self) -> str:
        return {"float": "a number", "int": "an integer", "str": "a string",
                "floats": "comma-separated numbers"}[self.kind]


@dataclass(frozen=True)
class SystemRun:
    """A simulator scenario of a shipped system file: ``source`` (its name in
    ``scenarios/data``) simulated at friction ``mu`` (one per contact), judged at ``judge_mu``
    and/or against the prediction of ``judge_source`` (negative controls; default the same)."""

    source: str
    mu: tuple[float, ...]
    judge_mu: tuple[float, ...] | None = None
    judge_source: str | None = None


@dataclass(frozen=True)
class PlanRun:
    """A simulator scenario of a plan: the shipped hand ``source`` planned for friction in
    ``mu_interval`` with command ``policy`` (``rival:LABEL`` makes a negative control), run at
    ``mu`` over its first ``waypoints`` waypoints (None: all)."""

    source: str
    mu: float
    mu_interval: tuple[float, float] = (0.0, 0.2)
    policy: str = "midband"
    waypoints: int | None = None


@dataclass(frozen=True)
class RulerRun:
    """The ruler of Sec. 5.1 at static / kinetic friction ``mu_s`` / ``mu_k``, judged against the
    switches the planner predicts at kinetic ``predict_mu_k`` (default ``mu_k``), of which the
    first ``required`` must be observed."""

    mu_s: float
    mu_k: float
    predict_mu_k: float | None = None
    required: int = 5


#: What a simulator scenario runs (data; :func:`scenarios.runs.run_spec` runs it the way
#: ``qsplan simulate`` / ``validate`` run a user's file).
RunSpec = SystemRun | PlanRun | RulerRun


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
        and returns a JSON-ready summary (``status``: a :class:`sim.verdict.Outcome` value, or
        ``"info"`` for ``INFO`` scenarios; ``passed``: the expectation held). A simulator
        scenario gives ``spec`` instead (data, :data:`RunSpec`), run by
        :func:`scenarios.runs.run_scenario`.
    engines : tuple of str
        Engines it runs on (empty when it does not simulate).
    tags : tuple of str
    parameters : tuple of Parameter
        What ``--set`` may change; passed to ``run`` as keywords.
    outputs : tuple of str
        The top-level entries ``run`` writes into its folder (a trailing ``/`` for a folder),
        declared so ``scenarios run --out`` checks them before any work
        (:func:`planner.files.outputs.output_set`); a ``spec`` scenario writes the run folder
        of :func:`scenarios.runs.write_run`.
    """

    name: str
    summary: str
    reference: str
    expect: Expect
    run: Callable[..., dict[str, Any]] | None = None
    engines: tuple[str, ...] = ()
    tags: tuple[str, ...] = field(default_factory=tuple)
    parameters: tuple[Parameter, ...] = ()
    spec: RunSpec | None = None
    outputs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if (self.run is None) == (self.spec is None):
            raise InputError(f"scenario {self.name!r}: expected a run function or a run "
                             "spec, not both or neither")

    def defaults(self) -> dict[str, Any]:
        """``{name: default}`` of every parameter."""
        return {p.name: p.default for p in self.parameters}


def parse_settings(scenario: Scenario, settings: list[str] | None) -> dict[str, Any]:
    """``["key=value", ...]`` -> typed ``{key: value}`` for ``scenario``; unknown keys and bad
    values are :class:`InputError` naming what was expected and what came."""
    known = {p.name: p for p in scenario.parameters}
    out: dict[str, Any] = {}
    for item in settings or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep:
            raise InputError(f"--set: expected key=value, got {item!r}")
        if key not in known:
            names = ", ".join(known) or "none"
            raise InputError(f"--set: unknown parameter {key!r} of scenario {scenario.name!r}; "
                             f"expected one of: {names}; got {key!r}")
        out[key] = known[key].parse(value.strip())
    return out


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
        raise InputError(f"unknown scenario {name!r}; expected one of: {', '.join(table)}; got "
                         f"{name!r}")
    return table[name]
