"""Geometry-first system files: ``gravity``, ``surfaces``, ``fingers``, ``friction`` groups and
contacts placed by feature (format in ``docs/file-formats.md``, "Geometry first")::

    "gravity": [0, -9.81],                                  -- m/s^2; the weight and its moment
    "workpiece": {"polygon": [[x, y], ...], "mass": kg, "com": [x, y]},
    "friction": {"table": 0.3, "finger": 0.5},              -- named coefficients
    "surfaces": [{"name": "table", "edge": [[x, y], [x, y]],
                  "velocity": [vx, vy], "omega": w, "pivot": [x, y]}],   -- motion optional
    "fingers":  [{"name": "pusher", "velocity": [vx, vy], "omega": w, "pivot": [x, y],
                  "edge": [[x, y], [x, y]]}],                            -- edge: a flat face
    "contacts": [{"vertex": 0, "surface": "table", "mu": "table"},
                 {"edge": 3, "at": 0.5, "finger": "pusher", "mu": 0.0},
                 {"point": [x, y], "finger": "pusher", "mu": "finger"}, ...]

``manipulator`` is then optional: without it the contact velocities are computed from the
surfaces' and fingers' world-frame motion (:mod:`planner.model.layout`).  A file is read in this
form when it has any of the keys above or a contact without ``normal``; any other file is read
with its normals and wrench as written (:mod:`planner.files.system_file`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

from planner.errors import FileFormatError
from planner.files.fields import FREE_KEYS, as_object, boolean, check_keys, number, short
from planner.model.layout import FeatureContact, Motion, Surface
from planner.model.system import System
from planner.model.workpiece import WorkpieceGeometry

#: Top-level keys that make a file geometry-first.
GEOMETRY_KEYS = ("gravity", "surfaces", "fingers", "friction")
#: Keys of a contact placed by feature (besides point, normal, mu, environment, body, other).
FEATURE_KEYS = ("vertex", "edge", "at", "surface", "finger")
_MOTION_KEYS = ("velocity", "omega", "pivot")


def is_geometry_first(data: Mapping[str, Any]) -> bool:
    """True when a system file uses the geometry-first keys (module docstring)."""
    if any(k in data for k in GEOMETRY_KEYS):
        return True
    contacts = data.get("contacts")
    return isinstance(contacts, list) and any(
        isinstance(c, Mapping) and ("normal" not in c or any(k in c for k in FEATURE_KEYS)
                                    or isinstance(c.get("mu"), str))
        for c in contacts)


def _vector(value: Any, where: str, n: int = 2) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        raise FileFormatError(f"{where}: expected a list of {n} numbers, got {short(value)}")
    return [number(x, where) for x in value]


def _motion(d: Mapping[str, Any], where: str) -> Motion:
    return Motion(
        _vector(d.get("velocity", [0.0, 0.0]), f"{where}.velocity"),
        number(d.get("omega", 0.0), f"{where}.omega"),
        _vector(d.get("pivot", [0.0, 0.0]), f"{where}.pivot"),
    )


def _surfaces(raw: Any, kind: str) -> list[Surface]:
    key = kind + "s"
    if not isinstance(raw, list):
        raise FileFormatError(f"{key}: expected a list of {kind} objects, got {short(raw)}")
    out = []
    for k, item in enumerate(raw):
        where = f"{key}[{k}]"
        d = as_object(item, where)
        check_keys(d, where, required=("name", "edge") if kind == "surface" else ("name",),
                   optional=("edge", *_MOTION_KEYS), free=tuple(f for f in FREE_KEYS
                                                               if f != "name"))
        if not isinstance(d["name"], str) or not d["name"]:
            raise FileFormatError(f"{where}.name: expected a non-empty string, got "
                                  f"{short(d['name'])}")
        edge = None
        if "edge" in d:
            e = d["edge"]
            if not isinstance(e, list) or len(e) != 2:
                raise FileFormatError(f"{where}.edge: expected two points [[x, y], [x, y]], got "
                                      f"{short(e)}")
            edge = [_vector(p, f"{where}.edge") for p in e]
        out.append(Surface(d["name"], edge, _motion(d, where), kind))
    return out


def _feature_contact(c: Mapping[str, Any], i: int, multi: bool) -> FeatureContact:
    where = f"contact {i + 1}"
    check_keys(c, where, required=("mu",), optional=(
        "point", "normal", "environment", *FEATURE_KEYS, *(("body", "other") if multi else ())),
        free=FREE_KEYS)
    mu = c["mu"]
    if not isinstance(mu, str):
        mu = number(mu, f"{where} mu")
    index: dict[str, Any] = {}
    for key in ("vertex", "edge", "body", "other"):
        if key in c:
            v = c[key]
            if isinstance(v, bool) or not isinstance(v, int):
                raise FileFormatError(f"{where} {key}: expected an integer index, got {short(v)}")
            index[key] = v
    for key in ("surface", "finger"):
        if key in c and not isinstance(c[key], str):
            raise FileFormatError(f"{where} {key}: expected a name, got {short(c[key])}")
    return FeatureContact(
        mu=mu, vertex=index.get("vertex"), edge=index.get("edge"),
        at=number(c["at"], f"{where} at") if "at" in c else None,
        point=_vector(c["point"], f"{where} point") if "point" in c else None,
        normal=_vector(c["normal"], f"{where} normal") if "normal" in c else None,
        surface=c.get("surface"), finger=c.get("finger"), body=index.get("body", 0),
        other=index.get("other"),
        environment=boolean(c.get("environment", False), f"{where} environment"),
    )


def geometry_system(data: Mapping[str, Any], workpiece: Callable[[Any], WorkpieceGeometry],
                    manipulator_kwargs: Callable[..., tuple[dict[str, Any], Any]]) -> System:
    """The :class:`System` of a geometry-first file (``data`` already checked for unknown
    top-level keys).  ``workpiece`` parses one ``workpiece`` object; ``manipulator_kwargs(
    manip, points, normals, off_chain)`` returns the keyword arguments (and chain geometry) of a
    ``manipulator`` given in one of the forms of :mod:`planner.files.system_file`."""
    from planner.files.multibody_file import parse_workpieces

    if "wrench_matrix" in data:
        raise FileFormatError("wrench_matrix: expected 'contacts' in a geometry-first file "
                              f"(keys {[k for k in GEOMETRY_KEYS if k in data]}), got a matrix")
    multi = "workpieces" in data
    if multi:
        if "workpiece" in data or "external_wrench" in data:
            raise FileFormatError("workpieces: expected no top-level 'workpiece' or "
                                  "'external_wrench' beside 'workpieces', got both")
        loads, geoms = parse_workpieces(data["workpieces"])
        wps: tuple[WorkpieceGeometry | None, ...] = geoms or (None,) * len(loads)
        ext: Any = loads
    else:
        wps = (workpiece(data["workpiece"]) if "workpiece" in data else None,)
        ext = [_vector(data.get("external_wrench", [0.0, 0.0, 0.0]), "external_wrench", 3)]
    friction = as_object(data.get("friction", {}), "friction")
    groups = {str(k): number(v, f"friction.{k}", minimum=0.0) for k, v in friction.items()}
    surfaces = (_surfaces(data.get("surfaces", []), "surface")
                + _surfaces(data.get("fingers", []), "finger"))
    raw = data.get("contacts")
    if not isinstance(raw, list) or not raw:
        raise FileFormatError(f"contacts: expected a non-empty list of contact objects, got "
                              f"{short(raw)}")
    contacts = [_feature_contact(as_object(c, f"contact {i + 1}"), i, multi)
                for i, c in enumerate(raw)]
    gravity = _vector(data["gravity"], "gravity") if "gravity" in data else None
    if "manipulator" not in data:
        return System.from_geometry(wps, contacts, surfaces=surfaces, gravity=gravity,
                                    external_wrench=ext, friction=groups)
    # A manipulator given by hand: place the contacts first, then build its Jacobian there.
    probe = System.from_geometry(wps, contacts, surfaces=surfaces, gravity=gravity,
                                 external_wrench=ext, friction=groups)
    if any(s.motion.moving for s in surfaces):
        raise FileFormatError("manipulator: expected either a 'manipulator' or moving surfaces "
                              "and fingers, got both")
    off_chain = [e or b[1] >= 0 for e, b in zip(probe.environment, probe.contact_bodies)]
    kwargs, chain = manipulator_kwargs(data["manipulator"], probe.points.tolist(),
                                       probe.normals.tolist(), off_chain)
    system = System.from_geometry(wps, contacts, surfaces=surfaces, gravity=gravity,
                                  external_wrench=ext, friction=groups, **kwargs)
    return system if chain is None else dataclasses.replace(system, chain=chain)

