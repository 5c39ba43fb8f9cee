"""Several workpieces in a system file: the ``workpieces`` list and each contact's bodies.

A system file with a top-level ``"workpieces"`` list describes ``n_b >= 1`` workpieces
(:mod:`planner.model.bodies`; format in ``docs/file-formats.md``, "Several workpieces")::

    "workpieces": [{"external_wrench": [fx, fy, m],          -- g_obj of the body, default zeros
                    "polygon": [[x, y], ...], "mass": kg,     -- optional scene geometry
                    "com": [x, y]}, ...],
    "contacts": [{"point": .., "normal": .., "mu": ..,
                  "body": 0,          -- the workpiece the normal points into (default 0)
                  "other": 1}, ...]   -- another workpiece; absent: the manipulator, or the
                                         environment with "environment": true

It replaces the single-workpiece keys ``workpiece`` and ``external_wrench``; a file without it
is read as a single-workpiece file (one workpiece, every contact with the manipulator or
environment).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from planner.errors import FileFormatError
from planner.files.fields import FREE_KEYS, as_object, check_keys, number, short, type_name
from planner.model.bodies import MANIPULATOR
from planner.model.system import System
from planner.model.workpiece import WorkpieceGeometry

#: Keys of one entry of ``workpieces``.
WORKPIECE_KEYS = ("external_wrench", "polygon", "mass", "com")
#: Keys a contact may carry only in a file with ``workpieces``.
BODY_KEYS = ("body", "other")


def _vec(value: Any, n: int, where: str) -> list[float]:
    if (not isinstance(value, list) or len(value) != n
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
        raise FileFormatError(f"{where}: expected a list of {n} numbers, got {short(value)}")
    return [float(x) for x in value]


def parse_workpieces(raw: Any) -> tuple[np.ndarray, tuple[WorkpieceGeometry, ...]]:
    """``(loads (n_b, 3), geometries)`` of a ``workpieces`` list: each body's external wrench
    ``g_obj`` about the world origin (eq. 2) and its scene geometry (all bodies or none)."""
    if not isinstance(raw, list) or not raw:
        raise FileFormatError(
            f"workpieces: expected a non-empty list of workpiece objects, got {short(raw)}"
        )
    loads, geoms = [], []
    for a, item in enumerate(raw):
        where = f"workpieces[{a}]"
        wp = as_object(item, where)
        check_keys(wp, where, optional=WORKPIECE_KEYS, free=FREE_KEYS)
        loads.append(_vec(wp.get("external_wrench", [0.0, 0.0, 0.0]), 3,
                          f"{where}.external_wrench"))
        has_geometry = "polygon" in wp or "mass" in wp
        if has_geometry:
            if "polygon" not in wp or "mass" not in wp:
                raise FileFormatError(
                    f"{where}: expected 'polygon' and 'mass' together (scene geometry), got only "
                    f"{'polygon' if 'polygon' in wp else 'mass'}"
                )
            mass = number(wp["mass"], f"{where}.mass", positive=True)
            geoms.append(WorkpieceGeometry(wp["polygon"], mass, wp.get("com")))
        elif "com" in wp:
            raise FileFormatError(f"{where}: expected 'com' only with 'polygon' and 'mass'")
    if geoms and len(geoms) != len(raw):
        raise FileFormatError(
            f"workpieces: expected scene geometry (polygon, mass) for every workpiece or none, "
            f"got it for {len(geoms)} of {len(raw)}"
        )
    return np.array(loads), tuple(geoms)


def parse_contact_bodies(contacts: Sequence[Mapping[str, Any]], n_bodies: int,
                         environment: Sequence[bool]) -> list[tuple[int, int]]:
    """Per contact ``(body, other)``: ``body`` default 0; ``other`` a workpiece index, or
    :data:`MANIPULATOR` when absent (the manipulator, or the environment when flagged)."""
    pairs = []
    for i, c in enumerate(contacts):
        where = f"contact {i + 1}"
        values = []
        for key, default in (("body", 0), ("other", MANIPULATOR)):
            v = c.get(key, default)
            if isinstance(v, bool) or not isinstance(v, int) or not (
                    0 <= v < n_bodies or (key == "other" and v == MANIPULATOR)):
                raise FileFormatError(
                    f"{where} {key}: expected a workpiece index in 0..{n_bodies - 1}, "
                    f"got {type_name(v)}"
                )
            values.append(v)
        if values[1] != MANIPULATOR and environment[i]:
            raise FileFormatError(
                f"{where}: expected either 'other' (a second workpiece) or 'environment': true, "
                "got both"
            )
        pairs.append((values[0], values[1]))
    return pairs


def refuse_body_keys(contacts: Any) -> None:
    """A file without ``workpieces`` has one workpiece: ``body``/``other`` make no sense."""
    for i, c in enumerate(contacts if isinstance(contacts, list) else []):
        if isinstance(c, Mapping):
            for key in BODY_KEYS:
                if key in c:
                    raise FileFormatError(
                        f"contact {i + 1} {key}: expected {key!r} only in a file with a "
                        f"top-level 'workpieces' list, got it in a one-workpiece file"
                    )


def workpieces_to_dict(system: System) -> list[dict[str, Any]]:
    """The ``workpieces`` list of a system with several bodies (loads and geometry)."""
    out = []
    for a in range(system.n_bodies):
        item: dict[str, Any] = {"external_wrench": system.g_obj[3 * a:3 * a + 3].tolist()}
        if system.workpieces:
            item.update(system.workpieces[a].to_dict())
        out.append(item)
    return out


def contact_bodies_to_dict(system: System, i: int) -> dict[str, Any]:
    """The ``body``/``other`` keys of contact ``i`` (empty for the defaults)."""
    a, b = system.contact_bodies[i]
    out: dict[str, Any] = {}
    if a != 0:
        out["body"] = a
    if b != MANIPULATOR:
        out["other"] = b
    return out
