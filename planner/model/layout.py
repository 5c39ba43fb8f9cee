"""A system described by its geometry: workpieces with mass, gravity, fixed or moving surfaces and
fingers, contacts placed on features, friction groups (docs/file-formats.md, "Geometry first").

From this description the model inputs of Section 3 are computed, not typed by hand:

* the external wrench ``g_obj`` of every workpiece (eq. 2): ``external_wrench`` plus, with
  ``gravity`` ``g`` (m/s^2), the weight ``m g`` at the centre of mass ``c`` and its moment
  about the world origin ``c x (m g)``;
* each contact's point ``r_i`` and inward unit normal ``n_i`` (eq. 1) from a feature of the
  workpiece polygon: a vertex (the normal is the touching surface's or finger face's, or the
  other workpiece's edge normal) or a point on an edge (the edge's inward normal), checked with
  :func:`planner.model.features.check_on_body`;
* each contact's manipulator velocity ``J_i thetadot`` in the contact frame (eq. 5),
  ``(v_n, v_t) = (n_i . u, t_i . u)`` with ``t_i = rot90(n_i)``, from the world-frame motion of
  the surface or finger it touches: ``u = v + omega rot90(r_i - pivot)``;
* the friction coefficient of each contact from a number or a named group.

The :class:`Resolved` arrays feed :meth:`planner.model.system.System.from_geometry`, which
builds an ordinary :class:`~planner.model.system.System` (the simulators read its fields).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.errors import GeometryWarning, InputError
from planner.model.bodies import MANIPULATOR
from planner.model.features import (
    GEOMETRY_TOL,
    check_on_body,
    check_on_boundary,
    fmt_vec,
    inward_normals,
    locate,
    size_of,
    weight_moment_warning,
)
from planner.model.geometry import rot90
from planner.model.validation import as_array, describe_value, unit_normal
from planner.model.workpiece import WorkpieceGeometry, polygon_area_centroid


@dataclass(frozen=True)
class Motion:
    """World-frame rigid motion of a surface or finger: its material point at ``p`` moves with
    ``u(p) = velocity + omega rot90(p - pivot)`` [m/s] (``omega`` rad/s, counter-clockwise)."""

    velocity: Any = (0.0, 0.0)
    omega: float = 0.0
    pivot: Any = (0.0, 0.0)

    def __post_init__(self) -> None:
        v = as_array(self.velocity, (2,), "velocity")
        p = as_array(self.pivot, (2,), "pivot")
        w = as_array(self.omega, (), "omega")
        object.__setattr__(self, "velocity", (float(v[0]), float(v[1])))
        object.__setattr__(self, "pivot", (float(p[0]), float(p[1])))
        object.__setattr__(self, "omega", float(w))

    @property
    def moving(self) -> bool:
        return any(self.velocity) or self.omega != 0.0

    def at(self, p: Any) -> np.ndarray:
        """``(2,)`` [m/s] world velocity of the material point at ``p``."""
        r = np.asarray(p, dtype=float) - np.asarray(self.pivot)
        return np.asarray(self.velocity) + self.omega * np.array([-r[1], r[0]])


@dataclass(frozen=True)
class Surface:
    """A body outside the workpieces that touches them: a flat ``surface`` (a table, a wall: the
    line through the two points ``edge``) or a ``finger`` (a tip when ``edge`` is None, a flat
    face otherwise); fixed unless its ``motion`` moves.  The normal of a flat face at a contact
    points to the side of the line where the touched workpiece lies."""

    name: str
    edge: Any = None
    motion: Motion = field(default_factory=Motion)
    kind: str = "surface"

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"{self.kind} name: expected a non-empty string, got "
                             f"{describe_value(self.name)}")
        if self.kind not in ("surface", "finger"):
            raise InputError(f"kind: expected 'surface' or 'finger', got {self.kind!r}")
        if not isinstance(self.motion, Motion):
            raise InputError(f"{self.kind} {self.name!r}: expected a Motion, got "
                             f"{describe_value(self.motion)}")
        if self.edge is None:
            if self.kind == "surface":
                raise InputError(f"surface {self.name!r}: expected an 'edge' (two points of its "
                                 "line), got none")
            return
        E = as_array(self.edge, (2, 2), f"{self.kind} {self.name!r} edge")
        if float(np.linalg.norm(E[1] - E[0])) == 0.0:
            raise InputError(f"{self.kind} {self.name!r} edge: expected two distinct points, "
                             "got equal points")
        object.__setattr__(self, "edge", tuple(tuple(float(x) for x in e) for e in E))

    def line_normal(self) -> np.ndarray | None:
        """A unit normal of the flat face (``rot90`` of first -> second point), or None."""
        if self.edge is None:
            return None
        a, b = np.asarray(self.edge)
        return rot90((b - a) / np.linalg.norm(b - a))


def finger(name: str, velocity: Any = (0.0, 0.0), omega: float = 0.0, pivot: Any = (0.0, 0.0),
           edge: Any = None) -> Surface:
    """A finger (a :class:`Surface` of kind ``finger``) moving with the given world motion."""
    return Surface(name, edge, Motion(velocity, omega, pivot), "finger")


def surface(name: str, edge: Any, velocity: Any = (0.0, 0.0), omega: float = 0.0,
            pivot: Any = (0.0, 0.0)) -> Surface:
    """A flat surface through the two points ``edge``; fixed unless given a motion."""
    return Surface(name, edge, Motion(velocity, omega, pivot), "surface")


@dataclass(frozen=True)
class FeatureContact:
    """One contact placed by geometry. Where: ``vertex`` (index into the polygon of ``body``),
    ``edge`` with ``at`` (fraction 0..1 from vertex ``edge`` to ``edge + 1``), or ``point``.
    What touches: ``surface`` or ``finger`` (a name), ``other`` (a second workpiece), or
    nothing named (an ``environment`` contact, or a contact whose velocity comes from the
    manipulator).  ``normal``: only where the geometry does not give it.  ``mu``: a
    coefficient or the name of a friction group."""

    mu: float | str
    vertex: int | None = None
    edge: int | None = None
    at: float | None = None
    point: Any = None
    normal: Any = None
    surface: str | None = None
    finger: str | None = None
    body: int = 0
    other: int | None = None
    environment: bool = False


@dataclass(frozen=True, eq=False)
class Layout:
    """Everything a geometry-first system file says (module docstring).

    ``workpieces``: one :class:`WorkpieceGeometry` (or None: no geometry) per body;
    ``external_wrench (n_b, 3)`` [N, N, N m] about the world origin, applied besides the weight;
    ``gravity (2,)`` [m/s^2] or None; ``friction``: group name -> coefficient."""

    workpieces: tuple[WorkpieceGeometry | None, ...]
    contacts: tuple[FeatureContact, ...]
    surfaces: tuple[Surface, ...] = ()
    gravity: Any = None
    external_wrench: Any = None
    friction: Mapping[str, float] = field(default_factory=dict)

    def counterpart(self, c: FeatureContact) -> Surface | None:
        for kind in ("surface", "finger"):
            name = getattr(c, kind)
            if name is not None:
                for s in self.surfaces:
                    if s.kind == kind and s.name == name:
                        return s
                names = [s.name for s in self.surfaces if s.kind == kind]
                raise InputError(f"{kind}: expected one of {names}, got {name!r}")
        return None


@dataclass(frozen=True, eq=False)
class Resolved:
    """The model inputs computed from a :class:`Layout` (module docstring): ``points``,
    ``normals`` ``(n_c, 2)``, ``mu (n_c,)``, ``environment`` and ``bodies`` per contact,
    ``contact_velocities (n_c, 2)`` ``(v_n, v_t)``, ``g_obj (3 n_b,)``, ``groups`` (name,
    0-based members) and a ``labels`` text per contact."""

    points: np.ndarray
    normals: np.ndarray
    mu: np.ndarray
    environment: tuple[bool, ...]
    bodies: tuple[tuple[int, int], ...]
    contact_velocities: np.ndarray
    g_obj: np.ndarray
    groups: tuple[tuple[str, tuple[int, ...]], ...]
    labels: tuple[str, ...]
    moving: tuple[bool, ...]


def body_name(a: int, n_b: int) -> str:
    return "the workpiece" if n_b == 1 else f"workpiece {a}"


def _point_and_feature(c: FeatureContact, V: np.ndarray | None, where: str
                       ) -> tuple[np.ndarray, str, int | None, str]:
    """``(point, feature kind, index, label)`` of a contact on polygon ``V``."""
    given = [k for k in ("vertex", "edge", "point") if getattr(c, k) is not None]
    if len(given) != 1:
        raise InputError(f"{where}: expected exactly one of 'vertex', 'edge' (with 'at') or "
                         f"'point', got {given or 'none'}")
    if c.point is not None:
        p = as_array(c.point, (2,), f"{where} point")
        if V is None:
            return p, "point", None, f"point {fmt_vec(p)}"
        f = check_on_boundary(p, V, where)
        return p, f.kind, f.index, f"point {fmt_vec(p)}"
    if V is None:
        raise InputError(f"{where}: expected a workpiece polygon to place a contact by "
                         f"{given[0]}, got a workpiece without one")
    n_v = len(V)
    k = c.vertex if c.vertex is not None else c.edge
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < n_v:
        raise InputError(f"{where} {given[0]}: expected an index in 0..{n_v - 1}, got "
                         f"{describe_value(k)}")
    if c.vertex is not None:
        if c.at is not None:
            raise InputError(f"{where}: expected 'at' only with 'edge', got it with 'vertex'")
        return V[int(k)].copy(), "vertex", int(k), f"vertex {k}"
    at = c.at
    if isinstance(at, bool) or not isinstance(at, (int, float)) or not 0.0 <= at <= 1.0:
        raise InputError(f"{where} at: expected a fraction in [0, 1] along edge {k} (0 at vertex "
                         f"{k}, 1 at vertex {(k + 1) % n_v}), got {describe_value(at)}")
    a, b = V[int(k)], V[(int(k) + 1) % n_v]
    p = a + float(at) * (b - a)
    kind = "vertex" if at in (0.0, 1.0) else "edge"
    idx = int(k) if at != 1.0 else (int(k) + 1) % n_v
    if kind == "vertex":  # an end of the edge: the edge's normal is still the one meant
        return p, "edge-end", int(k), f"edge {k} at {at:g}"
    return p, kind, idx, f"edge {k} at {at:g}"


def resolve(layout: Layout) -> Resolved:
    """Compute the model inputs of ``layout`` (module docstring); every inconsistency raises
    :class:`InputError` naming the contact, the distance or angle, and the fix."""
    wps = layout.workpieces
    n_b = len(wps)
    polys = [None if w is None else np.asarray(w.polygon) for w in wps]
    names = [s.name for s in layout.surfaces]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"surfaces and fingers: expected distinct names, got {dup} twice")
    groups: dict[str, list[int]] = {g: [] for g in layout.friction}
    pts, nrm, mu, env, pairs, vel, labels, moving = [], [], [], [], [], [], [], []
    for i, c in enumerate(layout.contacts):
        where = f"contact {i + 1}"
        a = c.body
        if isinstance(a, bool) or not isinstance(a, (int, np.integer)) or not 0 <= a < n_b:
            raise InputError(f"{where} body: expected a workpiece index in 0..{n_b - 1}, got "
                             f"{describe_value(a)}")
        b = MANIPULATOR if c.other is None else c.other
        part = layout.counterpart(c)
        named = [k for k, v in (("surface", c.surface), ("finger", c.finger),
                                ("other", c.other)) if v is not None]
        if c.environment:
            named.append("environment")
        if len(named) > 1:
            raise InputError(f"{where}: expected at most one of 'surface', 'finger', 'other' or "
                             f"'environment', got {named}")
        V = polys[a]
        Vb = polys[b] if b != MANIPULATOR else None
        p, kind, idx, label = _point_and_feature(c, V, where)
        face = part.line_normal() if part is not None else None
        if face is not None and V is not None:
            centroid = polygon_area_centroid(V)[1]
            side = float(face @ (centroid - p))
            face = face if side > 0 else -face
        if c.normal is not None:
            n = unit_normal(c.normal, f"{where} normal")
            if c.vertex is not None or c.edge is not None:
                raise InputError(f"{where}: expected no 'normal' with a 'vertex' or 'edge' "
                                 "(the geometry gives it), got one")
        elif V is None:
            raise InputError(f"{where}: expected a 'normal', or a workpiece polygon to derive "
                             "it from, got neither")
        elif kind in ("edge", "edge-end"):
            n = inward_normals(V)[idx]
        elif face is not None:
            n = face
        elif Vb is not None:
            fb = locate(p, Vb)
            if fb.kind != "edge":
                raise InputError(f"{where}: a vertex of {body_name(a, n_b)} on a vertex of "
                                 f"workpiece {b} has no normal from the geometry; give a "
                                 "'normal' or place the contact on an edge")
            n = -inward_normals(Vb)[fb.index]
        else:
            what = (f"{part.kind} {part.name!r} is a tip (no 'edge')" if part is not None
                    else "nothing flat touches it")
            raise InputError(f"{where}: at {label} the normal does not follow from the geometry "
                             f"({what}); give the {part.kind if part else 'contact'} a flat "
                             "'edge', a 'normal', or place the contact on an edge")
        body = body_name(a, n_b)
        if V is not None:
            check_on_body(p, n, V, where, body)
        if Vb is not None:
            check_on_body(p, n, Vb, where, f"workpiece {b}", outward=True)
        if face is not None and part is not None:
            _check_on_face(p, n, face, part, where, size_of(V) if V is not None else 1.0)
        motion = part.motion if part is not None else None
        u = motion.at(p) if motion is not None else np.zeros(2)
        t = rot90(n)
        pts.append(p)
        nrm.append(n)
        vel.append([float(n @ u), float(t @ u)])
        env.append(bool(c.environment or (part is not None and not part.motion.moving)))
        moving.append(bool(part is not None and part.motion.moving))
        pairs.append((int(a), int(b)))
        mu.append(_coefficient(c.mu, layout.friction, groups, i, where))
        against = (f" on {part.kind} {part.name!r}" if part is not None else
                   f" on workpiece {b}" if b != MANIPULATOR else
                   " on the environment" if c.environment else "")
        labels.append(f"{label} of {body}{against}")
    unused = [g for g, members in groups.items() if not members]
    if unused:
        raise InputError(f"friction: expected every group used by a contact, got {unused} "
                         "used by none")
    return Resolved(
        points=np.array(pts), normals=np.array(nrm), mu=np.array(mu), environment=tuple(env),
        bodies=tuple(pairs), contact_velocities=np.array(vel),
        g_obj=body_loads(layout), groups=tuple((g, tuple(m)) for g, m in groups.items()),
        labels=tuple(labels), moving=tuple(moving),
    )


def _check_on_face(p: np.ndarray, n: np.ndarray, face: np.ndarray, part: Surface, where: str,
                   size: float) -> None:
    """The contact lies on the flat face of ``part`` and shares its normal."""
    a = np.asarray(part.edge)[0]
    gap = abs(float(face @ (p - a)))
    if gap > GEOMETRY_TOL * size:
        raise InputError(f"{where}: expected the contact point {fmt_vec(p)} on {part.kind} "
                         f"{part.name!r} (the line through {fmt_vec(part.edge[0])} and "
                         f"{fmt_vec(part.edge[1])}), got it {gap:.4g} m off that line; move the "
                         f"{part.kind} or the workpiece so that they touch")
    angle = math.acos(float(np.clip(face @ n, -1.0, 1.0)))
    if angle > GEOMETRY_TOL:
        raise InputError(f"{where}: expected the contact normal {fmt_vec(n)} along the normal "
                         f"{fmt_vec(face)} of {part.kind} {part.name!r}, got "
                         f"{math.degrees(angle):.3g} deg between them (a flat face on a flat "
                         "edge must be parallel to it)")


def _coefficient(mu: Any, friction: Mapping[str, float], groups: dict[str, list[int]], i: int,
                 where: str) -> float:
    if isinstance(mu, str):
        if mu not in friction:
            raise InputError(f"{where} mu: expected a number or one of the friction groups "
                             f"{sorted(friction)}, got {mu!r}")
        groups[mu].append(i)
        return float(friction[mu])
    if isinstance(mu, bool) or not isinstance(mu, (int, float, np.floating, np.integer)) \
            or not math.isfinite(mu) or mu < 0:
        raise InputError(f"{where} mu: expected a coefficient >= 0 or a friction group name, "
                         f"got {describe_value(mu)}")
    return float(mu)


def body_loads(layout: Layout) -> np.ndarray:
    """``g_obj (3 n_b,)``: every body's ``external_wrench`` plus, with ``gravity``, its weight
    ``m g`` at its centre of mass and the weight's moment about the origin (eq. 2).  Warns
    (:class:`GeometryWarning`) when an ``external_wrench`` looks like a body's weight: without
    gravity when its moment misses the centre of mass, with gravity always (counted twice)."""
    n_b = len(layout.workpieces)
    ext = (np.zeros((n_b, 3)) if layout.external_wrench is None
           else as_array(layout.external_wrench, (n_b, 3), "external_wrench").copy())
    g = None if layout.gravity is None else as_array(layout.gravity, (2,), "gravity")
    out = ext.copy()
    for a, w in enumerate(layout.workpieces):
        where = "workpiece" if n_b == 1 else f"workpieces[{a}]"
        if w is None:
            if g is not None:
                raise InputError(f"{where}: expected a polygon and a mass with 'gravity' (the "
                                 "weight acts at the centre of mass), got none")
            continue
        scale = size_of(np.asarray(w.polygon))
        if g is None:
            text = weight_moment_warning(ext[a], w.mass, np.asarray(w.com), where, scale)
        else:
            weight = w.mass * g
            out[a] += [weight[0], weight[1], w.com[0] * weight[1] - w.com[1] * weight[0]]
            text = None
            f = ext[a, :2]
            if np.linalg.norm(f) > 0 and np.allclose(f, weight, rtol=0.05, atol=0):
                text = (f"{where}: external_wrench {fmt_vec(ext[a])} looks like the weight "
                        f"{fmt_vec(weight)} N that 'gravity' already applies: with 'gravity' it "
                        "is an additional load, so the weight counts twice. Fix: drop it from "
                        "external_wrench")
        if text:
            warnings.warn(text, GeometryWarning, stacklevel=3)
    return out.reshape(-1)


def check_contacts_on_bodies(points: np.ndarray, normals: np.ndarray,
                             bodies: Sequence[tuple[int, int]],
                             workpieces: Sequence[WorkpieceGeometry | None]) -> None:
    """Explicit contact points and normals checked against the workpiece polygons given
    (:func:`planner.model.features.check_on_body`; ``bodies`` ``()`` = one workpiece)."""
    n_b = len(workpieces)
    if not all(w is None or isinstance(w, WorkpieceGeometry) for w in workpieces):
        return  # System's own checks name a wrong type
    pairs = bodies or [(0, MANIPULATOR)] * len(points)
    for i, ((a, b), p, n) in enumerate(zip(pairs, points, normals)):
        wa = workpieces[a] if a < n_b else None
        if wa is not None:
            check_on_body(p, n, np.asarray(wa.polygon), f"contact {i + 1}",
                          body_name(a, n_b))
        wb = workpieces[b] if 0 <= b < n_b else None
        if wb is not None:
            check_on_body(p, n, np.asarray(wb.polygon), f"contact {i + 1}",
                          f"workpiece {b}", outward=True)


def group_mu(base: Any, groups: Sequence[tuple[str, Sequence[int]]],
             values: Mapping[str, float]) -> np.ndarray:
    """``base (n_c,)`` with every contact of each group in ``values`` set to its value."""
    out = np.array(base, dtype=float)
    known = dict(groups)
    for name, v in values.items():
        if name not in known:
            raise InputError(f"friction group: expected one of {sorted(known)}, got {name!r}")
        out[list(known[name])] = float(v)
    return out
