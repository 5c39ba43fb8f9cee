"""System files: JSON in, :class:`planner.model.system.System` out (and back).

Format (documented key by key in ``docs/file-formats.md``; JSON Schema
``planner/files/schemas/system.schema.json``)::

    {
      "format": "qsplan-system", "version": 1,           -- optional; checked when present
      "contacts": [{"point": [x, y], "normal": [nx, ny], "mu": 0.3,
                    "environment": false}, ...],          -- environment optional, default false
          -- or instead of "contacts":
      "wrench_matrix": [[...2n_c...], [...], [...]],  "mu": [mu_1, ..., mu_nc],
      "environment": [false, ...],                       -- optional with wrench_matrix
      "external_wrench": [fx, fy, m],                    -- default zeros
      "manipulator": {
          "contact_velocities": [[v_n, v_t], ...]        -- J_i thetadot per contact; or
          "jacobian": [[[row_n...], [row_t...]], ...],   -- per contact, 2 x n_theta; or
          "chain": {"joints": [{"type": "revolute"|"prismatic", "parent": -1, "origin": [x, y],
                                "angle": a}, ...], "base_pose": [x, y, phi]},
          "q": [...], "contact_links": [body index per contact, null = environment],
          "link_radius": m,                              -- chain only, simulators; optional
          "joints": [{"velocity": 0.1}, {"effort": 2.0}, ...],     -- one per column/joint
          "joint_loads": [...]                                      -- g_man, default zeros
      },
      "workpiece": {"polygon": [[x, y], ...], "mass": kg, "com": [x, y]}   -- optional
    }

Several workpieces: a ``"workpieces"`` list instead of ``workpiece`` and ``external_wrench``,
and per contact ``"body"``/``"other"`` (:mod:`planner.files.multibody_file`).

A missing key is an error unless a default is listed above; a key the format does not know is an
error naming it, except the free-text keys :data:`planner.files.fields.FREE_KEYS` (``name``,
``description``, ``reference``, ``units``, ``note``, ``notes``, ``comment``), allowed in every
object and ignored.  Units: SI (m, N, N m, rad, s, kg).  Files are read by
:func:`planner.files.reader.read_json` (nothing executed); every problem raises
:class:`planner.errors.FileFormatError` naming the file, the key, what was expected and what came.
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, GeometryWarning, InputError
from planner.files.atomic import atomic_write_json
from planner.files.fields import (
    FREE_KEYS,
    as_object,
    boolean,
    check_keys,
    number,
    short,
    type_name,
)
from planner.files.geometry_file import GEOMETRY_KEYS, geometry_system, is_geometry_first
from planner.files.multibody_file import (
    BODY_KEYS,
    contact_bodies_to_dict,
    parse_contact_bodies,
    parse_workpieces,
    refuse_body_keys,
    workpieces_to_dict,
)
from planner.files.reader import check_memory, dense_bytes, parse_json, read_json
from planner.model.chain_geometry import ChainGeometry
from planner.model.features import size_of, weight_moment_warning
from planner.model.kinematics import chain_from_dict
from planner.model.system import JointControl, System
from planner.model.workpiece import WorkpieceGeometry

#: Optional format tag of system files; files without it are read as version 1.
SYSTEM_FORMAT = "qsplan-system"
SYSTEM_VERSION = 1

_TOP = ("format", "version", "contacts", "wrench_matrix", "mu", "environment",
        "external_wrench", "manipulator", "workpiece", "workpieces", *GEOMETRY_KEYS)
_FORMS = ("contact_velocities", "jacobian", "chain")
_FORM_KEYS = {
    "contact_velocities": ("contact_velocities", "joint_loads"),
    "jacobian": ("jacobian", "joints", "joint_loads"),
    "chain": ("chain", "q", "contact_links", "joints", "joint_loads", "link_radius"),
}


def load_system(path: str | os.PathLike[str]) -> System:
    """Read a system file (format in the module docstring); what it will allocate is checked
    against the memory budget first (:func:`dense_cost`)."""
    data = read_json(path, "system file", cost=dense_cost)
    return system_from_dict(data, source=f"system file {str(path)!r}")


def system_from_json(text: str | bytes, source: str = "<string>") -> System:
    """Parse system-file text (same rules as a file, :func:`planner.files.reader.parse_json`)."""
    data = parse_json(text, f"system file {source}")
    need, request = dense_cost(data)
    check_memory(need, f"system file {source}: {request}", "use a smaller problem")
    return system_from_dict(data, source=f"system file {source}")


def dense_cost(data: Any) -> tuple[int, str]:
    """``(bytes, description)`` of the largest dense array the loader builds from parsed (not
    yet checked) content: the ``(2 n_c, 2 n_c)`` Jacobian of ``contact_velocities`` or the
    ``(n_c, 2, n_theta)`` contact Jacobians of a ``chain`` (float64; ``n_c`` counts ``contacts``
    or ``mu``); malformed content costs 0 here and is refused by the field checks."""
    raw = data.get("contacts", data.get("mu")) if isinstance(data, Mapping) else None
    n_c = len(raw) if isinstance(raw, list) else 0
    manip = data.get("manipulator") if isinstance(data, Mapping) else None
    if not isinstance(manip, Mapping):
        return 0, "nothing"
    if "contact_velocities" in manip:
        return (dense_bytes(2 * n_c, 2 * n_c),
                f"the ({2 * n_c}, {2 * n_c}) Jacobian of {n_c} contacts' velocities")
    chain = manip.get("chain")
    joints = chain.get("joints") if isinstance(chain, Mapping) else None
    if isinstance(joints, list):
        return (dense_bytes(n_c, 2, len(joints)),
                f"the ({n_c}, 2, {len(joints)}) contact Jacobians of a chain")
    return 0, "nothing"


def _numbers(value: Any, key: str) -> Any:
    """Reject bools, strings, nulls and objects hiding in numeric fields (json gives them as
    Python types that numpy would convert)."""
    stack = [value]  # iterative: no RecursionError on absurdly deep nesting
    while stack:
        v = stack.pop()
        if isinstance(v, (bool, str, dict)) or v is None:
            raise FileFormatError(f"{key}: expected numbers, got {type_name(v)}")
        if isinstance(v, list):
            stack.extend(v)
    return value


def system_from_dict(data: Any, source: str = "system") -> System:
    """Build a :class:`System` from the parsed JSON object (format in the module docstring).

    Errors are :class:`FileFormatError` whose message starts with ``source``."""
    try:
        return _system(data)
    except InputError as exc:  # FileFormatError included
        raise FileFormatError(f"{source}: {exc}") from None


def _system(data: Any) -> System:
    if not isinstance(data, Mapping):
        raise FileFormatError(f"expected a JSON object at top level, got {type_name(data)}")
    geometry = is_geometry_first(data)
    check_keys(data, "top level", required=() if geometry else ("manipulator",), optional=_TOP,
               free=FREE_KEYS)
    fmt, ver = data.get("format", SYSTEM_FORMAT), data.get("version", SYSTEM_VERSION)
    if fmt != SYSTEM_FORMAT or ver != SYSTEM_VERSION or isinstance(ver, bool):
        raise FileFormatError(
            f"expected format {SYSTEM_FORMAT!r} version {SYSTEM_VERSION}, "
            f"got {short(fmt)} version {short(ver)}"
        )
    if ("contacts" in data) == ("wrench_matrix" in data):
        raise FileFormatError("expected exactly one of 'contacts' or 'wrench_matrix'")
    if geometry:
        return geometry_system(data, _workpiece, _manipulator_kwargs)
    system = _legacy_system(data)
    _warn_weight_without_moment(system)
    return system


def _warn_weight_without_moment(system: System) -> None:
    """:class:`GeometryWarning` for every workpiece whose external wrench looks like its weight
    but misses the weight's moment (:func:`planner.model.features.weight_moment_warning`)."""
    wps = system.workpieces or ((system.workpiece,) if system.workpiece is not None else ())
    for a, w in enumerate(wps):
        where = "workpiece" if len(wps) == 1 else f"workpieces[{a}]"
        text = weight_moment_warning(system.g_obj[3 * a:3 * a + 3], w.mass, w.com, where,
                                     size_of(w.polygon))
        if text:
            warnings.warn(text, GeometryWarning, stacklevel=4)


def _manipulator_form(manip_raw: Any) -> str:
    """The form of a ``manipulator`` object (checked: exactly one form, known keys)."""
    if not isinstance(manip_raw, Mapping):
        raise FileFormatError(
            f"expected a 'manipulator' object, got {type_name(manip_raw)}"
        )
    manip = manip_raw
    forms = [k for k in _FORMS if k in manip]
    if len(forms) != 1:
        raise FileFormatError(
            "manipulator: expected exactly one of 'contact_velocities', 'jacobian' or 'chain', "
            f"got {forms or 'none'}"
        )
    form = forms[0]
    check_keys(manip, f"manipulator ({form} form)", required=(form,),
               optional=_FORM_KEYS[form], free=FREE_KEYS)
    if "joints" in manip and not isinstance(manip["joints"], list):
        raise FileFormatError(
            f"manipulator.joints: expected a list, got {type_name(manip['joints'])}"
        )
    for j, spec in enumerate(manip.get("joints") or []):
        if isinstance(spec, Mapping):
            check_keys(spec, f"joint {j + 1}", optional=("velocity", "effort"), free=FREE_KEYS)
    return form


def _manipulator_kwargs(manip: Any, pts: Any, nrm: Any, off_chain: list[bool]
                        ) -> tuple[dict[str, Any], ChainGeometry | None]:
    """Keyword arguments of :meth:`System.from_contacts` for a ``manipulator`` object at the
    contacts ``pts``, ``nrm`` (and the chain geometry of the chain form)."""
    form = _manipulator_form(manip)
    kwargs: dict[str, Any] = {}
    if "joint_loads" in manip:
        kwargs["joint_loads"] = _numbers(manip["joint_loads"], "manipulator.joint_loads")
    if form == "contact_velocities":
        kwargs["contact_velocities"] = _numbers(manip[form], "contact_velocities")
        return kwargs, None
    kwargs["joints"] = manip.get("joints")
    if form == "jacobian":
        kwargs["jacobian"] = _numbers(manip[form], "jacobian")
        return kwargs, None
    kwargs["jacobian"], geom = _chain_jacobian(manip, pts, nrm, off_chain)
    return kwargs, geom


def _legacy_system(data: Mapping[str, Any]) -> System:
    """A system file in the explicit form (points, normals, a hand-written load)."""
    manip = data["manipulator"]
    form = _manipulator_form(manip)
    kwargs: dict[str, Any] = {
        "external_wrench": _numbers(data.get("external_wrench", [0.0, 0.0, 0.0]),
                                    "external_wrench"),
    }
    if "joint_loads" in manip:
        kwargs["joint_loads"] = _numbers(manip["joint_loads"], "manipulator.joint_loads")
    if form == "contact_velocities":
        kwargs["contact_velocities"] = _numbers(manip[form], "contact_velocities")
    elif form == "jacobian":
        kwargs["jacobian"] = _numbers(manip[form], "jacobian")
        kwargs["joints"] = manip.get("joints")
    if "workpiece" in data:
        kwargs["workpiece"] = _workpiece(data["workpiece"])
    multi = "workpieces" in data
    if multi:
        for key in ("workpiece", "external_wrench", "wrench_matrix"):
            if key in data:
                raise FileFormatError(
                    f"top-level {key!r}: expected no {key!r} beside 'workpieces' (each workpiece "
                    f"carries its own load and geometry; contacts are given geometrically), "
                    f"got both"
                )
        loads, geoms = parse_workpieces(data["workpieces"])
        kwargs["external_wrench"] = loads
        kwargs["n_bodies"] = len(loads)
        if len(loads) == 1:
            kwargs["workpiece"] = geoms[0] if geoms else None
        else:
            kwargs["workpieces"] = geoms
    elif "contacts" in data:
        refuse_body_keys(data["contacts"])

    if "contacts" in data:
        for key in ("mu", "environment"):
            if key in data:
                raise FileFormatError(
                    f"top-level {key!r}: expected it only with 'wrench_matrix'; with 'contacts' "
                    f"each contact carries its own {key!r}, got a top-level {key!r} as well"
                )
        pts, nrm, mu, env = _contacts(data["contacts"])
        geom = None
        off_chain = list(env)
        if multi:
            kwargs["bodies"] = parse_contact_bodies(data["contacts"], kwargs["n_bodies"], env)
            off_chain = [e or b[1] >= 0 for e, b in zip(env, kwargs["bodies"])]
        if form == "chain":
            kwargs["jacobian"], geom = _chain_jacobian(manip, pts, nrm, off_chain)
            kwargs["joints"] = manip.get("joints")
        system = System.from_contacts(points=pts, normals=nrm, mu=mu, environment=env, **kwargs)
        return system if geom is None else dataclasses.replace(system, chain=geom)
    if "mu" not in data:
        raise FileFormatError(
            "'wrench_matrix': expected a top-level 'mu' (one per contact) beside it, got no 'mu'"
        )
    W = _numbers(data["wrench_matrix"], "wrench_matrix")
    env_raw = data.get("environment")
    if env_raw is not None and (not isinstance(env_raw, list)
                                or not all(isinstance(e, bool) for e in env_raw)):
        raise FileFormatError(
            f"environment: expected a list of true/false, one per contact, got {short(env_raw)}"
        )
    if form == "chain":
        from planner.model.geometry import check_wrench_matrix, contact_points_from_wrench

        Wm = check_wrench_matrix(W)
        n_c = Wm.shape[1] // 2
        env = list(env_raw) if env_raw is not None else [False] * n_c
        if len(env) != n_c:
            raise FileFormatError(
                f"environment: expected {n_c} flags (one per contact), got {len(env)}"
            )
        kwargs["jacobian"], geom = _chain_jacobian(
            manip, contact_points_from_wrench(Wm).tolist(), Wm[0:2, 0::2].T.tolist(), env
        )
        kwargs["joints"] = manip.get("joints")
        return dataclasses.replace(System.from_wrench_matrix(
            W, _numbers(data["mu"], "mu"), environment=env_raw, **kwargs), chain=geom)
    return System.from_wrench_matrix(W, _numbers(data["mu"], "mu"), environment=env_raw,
                                     **kwargs)


def _contacts(contacts: Any) -> tuple[list[Any], list[Any], list[Any], list[bool]]:
    if not isinstance(contacts, list) or not contacts:
        raise FileFormatError(
            "contacts: expected a non-empty list of {'point', 'normal', 'mu'} objects, "
            f"got {short(contacts)}"
        )
    pts, nrm, mu, env = [], [], [], []
    for i, c in enumerate(contacts):
        where = f"contact {i + 1}"
        c = as_object(c, where)
        check_keys(c, where, required=("point", "normal", "mu"),
                   optional=("environment", *BODY_KEYS), free=FREE_KEYS)
        pts.append(_numbers(c["point"], f"{where} point"))
        nrm.append(_numbers(c["normal"], f"{where} normal"))
        mu.append(_numbers(c["mu"], f"{where} mu"))
        env.append(boolean(c.get("environment", False), f"{where} environment"))
    return pts, nrm, mu, env


def _workpiece(raw: Any) -> WorkpieceGeometry:
    wp = as_object(raw, "workpiece")
    check_keys(wp, "workpiece", required=("polygon", "mass"), optional=("com",), free=FREE_KEYS)
    mass = number(wp["mass"], "workpiece.mass", positive=True)
    com = _numbers(wp["com"], "workpiece.com") if "com" in wp else None
    return WorkpieceGeometry(_numbers(wp["polygon"], "workpiece.polygon"), mass, com)


def _chain_jacobian(manip: Mapping[str, Any], pts: Any, nrm: Any, env: list[bool]
                    ) -> tuple[np.ndarray, ChainGeometry]:
    """The contact Jacobians (n_c, 2, n_theta) of a ``manipulator.chain`` and the chain's
    geometry (scene data for the simulators)."""
    chain_raw = as_object(manip["chain"], "manipulator.chain")
    check_keys(chain_raw, "manipulator.chain", required=("joints",), optional=("base_pose",),
               free=FREE_KEYS)
    if isinstance(chain_raw["joints"], list):
        for j, item in enumerate(chain_raw["joints"]):
            check_keys(as_object(item, f"chain joint {j + 1}"), f"chain joint {j + 1}",
                       optional=("type", "kind", "parent", "origin", "angle"), free=FREE_KEYS)
    chain = chain_from_dict(dict(chain_raw))
    links = manip.get("contact_links")
    if not isinstance(links, list) or len(links) != len(pts):
        raise FileFormatError(
            f"manipulator.contact_links: expected one link index per contact ({len(pts)}), "
            f"got {short(links)}"
        )
    for i, b in enumerate(links):
        if env[i]:
            if b is not None:
                raise FileFormatError(
                    f"contact_links[{i}]: expected null for contact {i + 1} (a contact with the "
                    f"fixed environment or between two workpieces touches no link), got {short(b)}"
                )
        elif isinstance(b, bool) or not isinstance(b, int):
            raise FileFormatError(
                f"contact_links[{i}]: expected an integer, got {type_name(b)}"
            )
    q = _numbers(manip.get("q", [0.0] * chain.n_joints), "manipulator.q")
    moving = [i for i in range(len(pts)) if not env[i]]
    out = np.zeros((len(pts), 2, chain.n_joints))
    if moving:
        out[moving] = chain.contact_jacobian(q, [links[i] for i in moving],
                                             [pts[i] for i in moving], [nrm[i] for i in moving])
    radius = (number(manip["link_radius"], "manipulator.link_radius", positive=True)
              if "link_radius" in manip else None)
    return out, ChainGeometry(chain, q, tuple(None if env[i] else links[i]
                                              for i in range(len(pts))), radius)


def system_to_dict(system: System) -> dict[str, Any]:
    """The system as a system-file object (geometric contacts when points are known)."""
    from planner.model.geometry import wrench_matrix

    out: dict[str, Any]
    env = system.environment
    multi = system.n_bodies > 1
    geometric = multi or np.allclose(wrench_matrix(system.points, system.normals), system.W,
                                     rtol=0, atol=1e-12)
    if geometric:
        out = {
            "contacts": [
                {"point": p.tolist(), "normal": n.tolist(), "mu": float(m),
                 **({"environment": True} if e else {}),
                 **(contact_bodies_to_dict(system, i) if multi else {})}
                for i, (p, n, m, e) in enumerate(zip(system.points, system.normals, system.mu,
                                                      env))
            ],
        }
    else:  # given as a (rounded) wrench matrix: keep it exactly
        out = {"wrench_matrix": system.W.tolist(), "mu": system.mu.tolist()}
        if any(env):
            out["environment"] = list(env)
    if multi:
        out["workpieces"] = workpieces_to_dict(system)
    else:
        out["external_wrench"] = system.g_obj.tolist()
    if system.virtual_joints:
        out["manipulator"] = {
            "contact_velocities": system.joint_inputs.reshape(-1, 2).tolist(),
        }
        if np.any(system.g_man != 0):
            out["manipulator"]["joint_loads"] = system.g_man.tolist()
    elif system.chain is not None:  # the geometry it came from (simulators build the links)
        geom = system.chain
        out["manipulator"] = {
            "chain": {"joints": [{"type": j.kind, "parent": j.parent, "origin": list(j.origin),
                                  "angle": j.angle, **({"name": j.name} if j.name else {})}
                                 for j in geom.chain.joints],
                      "base_pose": list(geom.chain.base_pose)},
            "q": list(geom.q),
            "contact_links": list(geom.contact_links),
            "joints": [
                {"velocity" if c is JointControl.VELOCITY else "effort": float(v)}
                for c, v in zip(system.control, system.joint_inputs)
            ],
            "joint_loads": system.g_man.tolist(),
        }
        if geom.link_radius is not None:
            out["manipulator"]["link_radius"] = geom.link_radius
    else:
        out["manipulator"] = {
            "jacobian": system.J.reshape(system.n_contacts, 2, -1).tolist(),
            "joints": [
                {"velocity" if c is JointControl.VELOCITY else "effort": float(v)}
                for c, v in zip(system.control, system.joint_inputs)
            ],
            "joint_loads": system.g_man.tolist(),
        }
    if system.workpiece is not None:
        out["workpiece"] = system.workpiece.to_dict()
    return out


def save_system(system: System, path: str | os.PathLike[str]) -> Path:
    """Write a system file atomically (with its ``format`` and ``version``)."""
    return atomic_write_json(path, {"format": SYSTEM_FORMAT, "version": SYSTEM_VERSION,
                                    **system_to_dict(system)})
