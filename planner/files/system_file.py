"""System files: JSON in, :class:`planner.model.system.System` out (and back).

Format (keys exactly these; extra keys are allowed and ignored)::

    {
      "format": "qsplan-system", "version": 1,           -- optional; checked when present
      "contacts": [{"point": [x, y], "normal": [nx, ny], "mu": 0.3}, ...],
          -- or instead of "contacts":
      "wrench_matrix": [[...2n_c...], [...], [...]],  "mu": [mu_1, ..., mu_nc],
      "external_wrench": [fx, fy, m],
      "manipulator": {
          "contact_velocities": [[v_n, v_t], ...]        -- J_i thetadot per contact; or
          "jacobian": [[[row_n...], [row_t...]], ...],   -- per contact, 2 x n_theta; or
          "chain": {"joints": [{"type": "revolute"|"prismatic", "parent": -1, "origin": [x, y],
                                "angle": a}, ...], "base_pose": [x, y, phi]},
          "q": [...], "contact_links": [body index per contact],   -- Jacobian from geometry
          "joints": [{"velocity": 0.1}, {"effort": 2.0}, ...],     -- one per column/joint
          "joint_loads": [...]                                      -- g_man, default zeros
      }
    }

Units: SI (m, N, N m, rad, s). The loader never executes content: it is plain ``json`` plus
explicit checks, and every problem raises :class:`planner.errors.FileFormatError` or
:class:`planner.errors.InputError` naming the key, what was expected and what came.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, InputError
from planner.files.atomic import atomic_write_json
from planner.model.kinematics import chain_from_dict
from planner.model.system import JointControl, System
from planner.model.validation import describe_value

#: Largest system file accepted (bytes); larger files are refused before parsing.
MAX_FILE_BYTES = 20_000_000


#: Optional format tag of system files; files without it are read as version 1.
SYSTEM_FORMAT = "qsplan-system"
SYSTEM_VERSION = 1


def load_system(path: str | os.PathLike[str]) -> System:
    """Read a system file (format in the module docstring)."""
    p = Path(path)
    if not p.is_file():
        raise FileFormatError(f"system file {str(p)!r}: expected an existing file, got none there")
    size = p.stat().st_size
    if size > MAX_FILE_BYTES:
        raise FileFormatError(
            f"system file {str(p)!r}: expected at most {MAX_FILE_BYTES} bytes, got {size}"
        )
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"system file {str(p)!r}: expected UTF-8 text ({exc})") from exc
    return system_from_json(text, source=str(p))


def system_from_json(text: str, source: str = "<string>") -> System:
    """Parse system-file text."""
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"system file {source}: expected valid JSON, got a syntax error at line {exc.lineno} "
            f"column {exc.colno}: {exc.msg}"
        ) from exc
    except RecursionError as exc:
        raise FileFormatError(f"system file {source}: JSON nested too deeply") from exc
    return system_from_dict(data, source=source)


def _reject_constant(name: str) -> Any:
    raise FileFormatError(f"expected finite numbers, got {name}")


def _numbers(value: Any, key: str) -> Any:
    """Reject bools and strings hiding in numeric fields (json gives them as Python types)."""

    stack = [value]  # iterative: no RecursionError on absurdly deep nesting
    while stack:
        v = stack.pop()
        if isinstance(v, bool) or isinstance(v, str) or v is None or isinstance(v, dict):
            text = repr(v) if not isinstance(v, dict) else "an object"
            raise InputError(f"{key}: expected numbers, got {text[:60]}")
        if isinstance(v, list):
            stack.extend(v)
    return value


def system_from_dict(data: Any, source: str = "<dict>") -> System:
    """Build a :class:`System` from the parsed JSON object (format in the module docstring)."""
    if not isinstance(data, dict):
        raise FileFormatError(
            f"system file {source}: expected a JSON object at top level, got {type(data).__name__}"
        )
    fmt, ver = data.get("format", SYSTEM_FORMAT), data.get("version", SYSTEM_VERSION)
    if fmt != SYSTEM_FORMAT or ver != SYSTEM_VERSION:
        raise FileFormatError(
            f"system file {source}: expected format {SYSTEM_FORMAT!r} version {SYSTEM_VERSION}, "
            f"got {describe_value(fmt)} version {describe_value(ver)}"
        )
    has_contacts = "contacts" in data
    has_w = "wrench_matrix" in data
    if has_contacts == has_w:
        raise FileFormatError(
            f"system file {source}: expected exactly one of 'contacts' or 'wrench_matrix'"
        )
    manip = data.get("manipulator")
    if not isinstance(manip, dict):
        raise FileFormatError(
            f"system file {source}: expected a 'manipulator' object, got {type(manip).__name__}"
        )
    g = _numbers(data.get("external_wrench", [0.0, 0.0, 0.0]), "external_wrench")
    kwargs: dict[str, Any] = {"external_wrench": g}
    forms = [k for k in ("contact_velocities", "jacobian", "chain") if k in manip]
    if len(forms) != 1:
        raise FileFormatError(
            f"system file {source}: manipulator: expected exactly one of 'contact_velocities', "
            f"'jacobian' or 'chain', got {forms or 'none'}"
        )
    if "joints" in manip and not isinstance(manip["joints"], list):
        raise FileFormatError(f"system file {source}: manipulator.joints: expected a list")
    if "contact_velocities" in manip:
        kwargs["contact_velocities"] = _numbers(manip["contact_velocities"], "contact_velocities")
    elif "jacobian" in manip:
        kwargs["jacobian"] = _numbers(manip["jacobian"], "jacobian")
        kwargs["joints"] = manip.get("joints")
    if "joint_loads" in manip:
        kwargs["joint_loads"] = _numbers(manip["joint_loads"], "joint_loads")

    if has_contacts:
        contacts = data["contacts"]
        if not isinstance(contacts, list) or not contacts:
            raise FileFormatError(
                f"system file {source}: contacts: expected a non-empty list of "
                "{'point', 'normal', 'mu'} objects"
            )
        pts, nrm, mu = [], [], []
        for i, c in enumerate(contacts):
            if not isinstance(c, dict) or not {"point", "normal"} <= set(c):
                raise FileFormatError(
                    f"system file {source}: contact {i + 1}: expected an object with 'point', "
                    f"'normal' and 'mu', got {describe_value(c)}"[:300]
                )
            pts.append(_numbers(c["point"], f"contact {i + 1} point"))
            nrm.append(_numbers(c["normal"], f"contact {i + 1} normal"))
            mu.append(_numbers(c.get("mu", 0.0), f"contact {i + 1} mu"))
        if "chain" in manip:
            kwargs["jacobian"] = _chain_jacobian(manip, pts, nrm, source)
            kwargs["joints"] = manip.get("joints")
        return System.from_contacts(points=pts, normals=nrm, mu=mu, **kwargs)
    if "mu" not in data:
        raise FileFormatError(f"system file {source}: 'wrench_matrix' needs 'mu' (one per contact)")
    W = _numbers(data["wrench_matrix"], "wrench_matrix")
    if "chain" in manip:
        from planner.model.geometry import check_wrench_matrix, contact_points_from_wrench

        Wm = check_wrench_matrix(W)
        kwargs["jacobian"] = _chain_jacobian(
            manip, contact_points_from_wrench(Wm).tolist(), Wm[0:2, 0::2].T.tolist(), source
        )
        kwargs["joints"] = manip.get("joints")
    return System.from_wrench_matrix(W, _numbers(data["mu"], "mu"), **kwargs)


def _chain_jacobian(manip: dict[str, Any], pts: Any, nrm: Any, source: str) -> np.ndarray:
    chain = chain_from_dict(manip["chain"])
    links = manip.get("contact_links")
    if not isinstance(links, list) or len(links) != len(pts):
        raise FileFormatError(
            f"system file {source}: manipulator.contact_links: expected one link index per "
            f"contact ({len(pts)}), got {describe_value(links)}"[:300]
        )
    for i, b in enumerate(links):
        if isinstance(b, bool) or not isinstance(b, int):
            raise FileFormatError(
                f"system file {source}: contact_links[{i}]: expected an integer, "
                f"got {describe_value(b)}"
            )
    q = _numbers(manip.get("q", [0.0] * chain.n_joints), "manipulator.q")
    return chain.contact_jacobian(q, links, pts, nrm)


def system_to_dict(system: System) -> dict[str, Any]:
    """The system as a system-file object (geometric contacts when points are known)."""
    from planner.model.geometry import wrench_matrix

    out: dict[str, Any]
    if np.allclose(wrench_matrix(system.points, system.normals), system.W, rtol=0, atol=1e-12):
        out = {
            "contacts": [
                {"point": p.tolist(), "normal": n.tolist(), "mu": float(m)}
                for p, n, m in zip(system.points, system.normals, system.mu)
            ],
        }
    else:  # given as a (rounded) wrench matrix: keep it exactly
        out = {"wrench_matrix": system.W.tolist(), "mu": system.mu.tolist()}
    out["external_wrench"] = system.g_obj.tolist()
    if system.virtual_joints:
        out["manipulator"] = {
            "contact_velocities": system.joint_inputs.reshape(-1, 2).tolist(),
        }
    else:
        out["manipulator"] = {
            "jacobian": system.J.reshape(system.n_contacts, 2, -1).tolist(),
            "joints": [
                {"velocity" if c is JointControl.VELOCITY else "effort": float(v)}
                for c, v in zip(system.control, system.joint_inputs)
            ],
            "joint_loads": system.g_man.tolist(),
        }
    return out


def save_system(system: System, path: str | os.PathLike[str]) -> Path:
    """Write a system file atomically (with its ``format`` and ``version``)."""
    return atomic_write_json(path, {"format": SYSTEM_FORMAT, "version": SYSTEM_VERSION,
                                    **system_to_dict(system)})
