"""What the random user-written system files of :mod:`planner.sweeps.user_systems` are made of:
a draw (:class:`UserDraw`: the JSON content of a geometry-first system file, docs/file-formats.md
"Geometry first"), the hand-derived claim about its prediction (:class:`Claim`), the mirror image
of a file about the world ``y`` axis (:func:`mirror_system`, :func:`mirror_label`) and the draws
every kind shares (size, mass, finger, speed, direction).

Units: SI (m, kg, N, rad, s).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Standard gravity [m/s^2] of every drawn file.
G = 9.81
#: Relative margin of every claim: a closed-form threshold is claimed only when the drawn value
#: is at least this fraction away from it (the planner's own tolerances are far smaller).
MARGIN = 0.05


@dataclass(frozen=True)
class Claim:
    """What a hand derivation says the planner predicts for a draw: ``contains`` labels that
    must be feasible, ``excludes`` labels that must not, ``empty`` whether the predicted set is
    empty (a jam when driven, "moves" when static; ``None``: no claim), ``why`` the
    derivation's numbers."""

    contains: tuple[str, ...] = ()
    excludes: tuple[str, ...] = ()
    empty: bool | None = None
    why: str = ""

    def mirrored(self) -> Claim:
        return Claim(tuple(map(mirror_label, self.contains)),
                     tuple(map(mirror_label, self.excludes)), self.empty, self.why)


@dataclass(frozen=True)
class UserDraw:
    """One drawn system file: ``kind``, ``data`` (JSON content), the ``claim``, whether it was
    ``mirrored``, the drawn ``params`` (for the record) and ``groups``: each friction group's
    range [lo, hi] (a negative control redraws the groups from these)."""

    kind: str
    data: dict[str, Any]
    claim: Claim
    mirrored: bool
    params: dict[str, Any] = field(default_factory=dict)
    groups: dict[str, tuple[float, float]] = field(default_factory=dict)


def mirror_label(label: str) -> str:
    """A mode label mirrored about the world ``y`` axis: ``S+`` and ``S-`` swap (``t =
    rot90(n)`` reverses its world direction relative to the motion)."""
    return label.replace("S+", "S#").replace("S-", "S+").replace("S#", "S-")


def _mx(p: Any) -> list[float]:
    return [-float(p[0]), float(p[1])]


def _mirror_polygon(d: dict[str, Any]) -> None:
    d["polygon"] = [_mx(v) for v in reversed(d["polygon"])]
    if "com" in d:
        d["com"] = _mx(d["com"])


def mirror_system(data: dict[str, Any]) -> dict[str, Any]:
    """The geometry-first system file ``data`` mirrored about the world ``y`` axis (x -> -x); a
    new dict. Polygons are listed in reverse (counter-clockwise again): vertex ``k`` of ``n``
    becomes ``n - 1 - k``, edge ``e`` becomes ``n - 2 - e`` (mod n) with ``at -> 1 - at``;
    velocities, gravity and forces change the sign of x, angular rates and moments change sign."""
    d = copy.deepcopy(data)
    bodies = d["workpieces"] if "workpieces" in d else [d["workpiece"]]
    sizes = [len(b["polygon"]) for b in bodies]
    for b in bodies:
        _mirror_polygon(b)
    if "gravity" in d:
        d["gravity"] = _mx(d["gravity"])
    for key in ("surfaces", "fingers"):
        for s in d.get(key, []):
            if "edge" in s:
                s["edge"] = [_mx(p) for p in s["edge"]]
            if "velocity" in s:
                s["velocity"] = _mx(s["velocity"])
            if "pivot" in s:
                s["pivot"] = _mx(s["pivot"])
            if "omega" in s:
                s["omega"] = -float(s["omega"])
    for c in d["contacts"]:
        n = sizes[c.get("body", 0)]
        if "vertex" in c:
            c["vertex"] = n - 1 - c["vertex"]
        if "edge" in c:
            c["edge"] = (n - 2 - c["edge"]) % n
            c["at"] = 1.0 - float(c["at"])
        for key in ("point", "normal"):
            if key in c:
                c[key] = _mx(c[key])
    return d


# ---- common draws ----------------------------------------------------------------------------
def draw_size(rng: np.random.Generator) -> float:
    return float(np.exp(rng.uniform(math.log(0.002), math.log(3.0))))


def draw_mass(poly: np.ndarray, size: float, rng: np.random.Generator) -> float:
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
    return float(rng.uniform(200.0, 3000.0) * area * 0.5 * size)


def draw_speed(rng: np.random.Generator) -> float:
    return float(np.exp(rng.uniform(math.log(1e-4), math.log(0.1))))


def centroid(poly: np.ndarray) -> np.ndarray:
    x, y = poly[:, 0], poly[:, 1]
    cr = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = 0.5 * cr.sum()
    return np.array([((x + np.roll(x, -1)) * cr).sum(), ((y + np.roll(y, -1)) * cr).sum()]) / (
        6.0 * a)


def draw_finger(rng: np.random.Generator, groups: dict[str, tuple[float, float]],
            friction: dict[str, float]) -> tuple[Any, float]:
    """A frictionless (``0.0``) or rough finger (group ``finger``, mu in [0.1, 1])."""
    if rng.integers(2):
        return 0.0, 0.0
    groups["finger"] = (0.1, 1.0)
    friction["finger"] = float(rng.uniform(0.1, 1.0))
    return "finger", friction["finger"]


def draw_direction(rng: np.random.Generator) -> float:
    """A finger's direction of motion [rad] from +x: horizontal on half the draws, else up to
    25 deg off it."""
    return 0.0 if rng.integers(2) else float(np.radians(rng.uniform(-25.0, 25.0)))


def finish_draw(kind: str, data: dict[str, Any], claim: Claim, rng: np.random.Generator,
            params: dict[str, Any], groups: dict[str, tuple[float, float]]) -> UserDraw:
    mirrored = bool(rng.integers(2))
    if mirrored:
        data, claim = mirror_system(data), claim.mirrored()
    data = {"format": "qsplan-system", "version": 1, "name": f"random {kind}", **data}
    return UserDraw(kind, data, claim, mirrored, {**params, "mirrored": mirrored}, groups)


def pushed_labels(n_table: int, finger: str = "R") -> str:
    return " ".join([f"S-{i + 1}" for i in range(n_table)] + [f"{finger}{n_table + 1}"])
