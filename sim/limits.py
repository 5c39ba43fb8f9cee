"""What the simulators can represent: engine-neutral checks of a scene before it is built.

:func:`check_scene` raises :class:`planner.errors.InputError` -- naming the body or shape, the
value and the limit -- for a :class:`sim.scene.Scene` that one of the engines would refuse with
an error (MuJoCo's compiler), end with an abort (a Chipmunk assertion kills the process with
SIGABRT) or silently turn into NaN or a different shape.  It checks the scene as the backends
hand it to the engines (``sim.backends.pymunk_engine``, ``sim.backends.mujoco_engine``), so a
scene that passes builds in both.  The limits come from the engines' own checks and were
measured by ``benchmarks/engine_limits.py`` (one scene, one quantity pushed to extremes, each
probe in its own process; the table and the derivations are in docs/robustness.md, "Engine
limits"):

* every number finite;
* coordinates (body poses, polygon vertices, circle centres, capsule ends, joint anchors, the
  scene bounds) at most :data:`COORD_MAX` in magnitude -- MuJoCo's ``mjMAXVAL`` (its states
  beyond it are "bad" and reset: NaN from scenes 1e10 m across); Chipmunk's moment of a polygon
  is NaN from vertices near 1e154 m, and ``cpBodySetMoment`` aborts ("Moment of Inertia must be
  positive"); and at most :data:`COORD_OF_SCALE` times the scene's ``length_scale``: double
  precision must resolve a slow-motion step (below);
* ``length_scale`` at least :data:`LENGTH_SCALE_MIN` (Chipmunk's collision detection loses
  contacts of scenes 1e-6 m across);
* dynamic bodies: mass in [:data:`MASS_MIN`, :data:`MASS_MAX`], and the rotational inertia each
  backend gives its engine (the explicit one, else pymunk's from the first shape at uniform
  density and MuJoCo's ``mass length_scale^2 / 6``) finite and at least :data:`MASS_MIN`;
  relative to ``mass extent^2`` (``extent``: the body's reach from its centre of mass) at
  least :data:`INERTIA_RATIO_MIN` for pymunk and at most :data:`INERTIA_RATIO_MAX` for MuJoCo;
* loads: acceleration ``|force| / mass`` and ``|moment| / inertia`` at most :data:`ACCEL_MAX`;
* shapes: polygons convex, without repeated vertices (MuJoCo: "size 0 must be positive in
  geom"), at least :data:`THICKNESS_OF_SCALE` times ``length_scale`` thick (the depth of
  MuJoCo's per-edge boxes); capsules at least :data:`CAPSULE_LENGTH_MIN` long (MuJoCo: "fromto
  points too close in geom"); radii positive;
* prismatic joint axes of unit length (MuJoCo: "axis too small in joint");
* friction coefficients at most :data:`MU_MAX`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from planner.errors import InputError
from sim.scene import Body, BodyKind, Capsule, Circle, JointKind, Polygon, Scene
from sim.settings import HEAVY_RATIO

COORD_MAX = 1e10
"""Largest coordinate magnitude [m]: MuJoCo's ``mjMAXVAL`` (measured: NaN from a scene 1e10 m
across, coordinates 2e11 m; Chipmunk aborts from about 1e154 m)."""
STEP_OF_SCALE = 1e-6
"""The smallest motion per step the project simulates, relative to ``length_scale``: slow
motion at 1e-3 length scales per second (the system scenes' drive, ``sim.settings``, is
5e-3-2e-2) with 1 ms steps."""
COORD_OF_SCALE = 1e-3 * STEP_OF_SCALE / np.finfo(float).eps
"""Largest coordinate magnitude relative to ``length_scale`` (4.5e6): the rounding of a
coordinate (``eps |x|``) stays below 1e-3 of the smallest motion per step. Measured: the
pushed box stops moving at 1e11 length scales from the origin in pymunk, 1e13 in MuJoCo."""
LENGTH_SCALE_MIN = 1e-5
"""Smallest ``length_scale`` [m]: pymunk loses the contacts of a scene 1e-6 m across (at any
areal density; 1e-5 m works); MuJoCo's limit there is the inertia (:data:`MASS_MIN`)."""
MASS_MIN = 1e-15
"""Smallest mass [kg] and rotational inertia [kg m^2] of a moving body: MuJoCo's ``mjMINVAL``
("mass and inertia of moving bodies must be larger than mjMINVAL"); pymunk refuses 5e-324
(its moment underflows to 0)."""
FLOAT_HEADROOM = 1e300
"""Products the engines form must stay below this (the float range ends at 1.8e308)."""
MASS_MAX = FLOAT_HEADROOM / (HEAVY_RATIO * COORD_MAX ** 2)
"""Largest mass [kg] (1e274): MuJoCo's driven bodies weigh ``HEAVY_RATIO`` times the heaviest
body and their inertia is that times ``length_scale^2``. Measured: NaN at 1e305 in both."""
INERTIA_RATIO_MIN = 5e-3
"""Smallest ``inertia / (mass extent^2)`` pymunk is given: a pushed box of ratio 2.4e-3 and
below moves 2.5-20 times faster than the finger or backwards, from 8e-5 its contacts
penetrate; 8e-3 works (a uniform body has 1/3 to 1; MuJoCo works down to 1e-12)."""
INERTIA_RATIO_MAX = 1e8
"""Largest ``inertia / (mass extent^2)`` MuJoCo is given: its solver stops moving a body at
1e12 (1e9 works; pymunk measured up to 1e12)."""
ACCEL_MAX = 1e10
"""Largest load acceleration [m/s^2 or rad/s^2]: MuJoCo's ``mjMAXVAL`` on accelerations (its
``mjWARN_BADQACC``; measured NaN from 1e10)."""
THICKNESS_OF_SCALE = 0.02
"""Smallest polygon thickness relative to ``length_scale``: the MuJoCo backend models a polygon
as one box per edge reaching this deep inside (``sim.backends.mujoco_engine``); a thinner
polygon's boxes stick out of its other side (measured: a box 0.002 length scales thick is not
pushed, 0.02 is)."""
CAPSULE_LENGTH_MIN = 1e-7
"""Shortest capsule [m]: MuJoCo refuses ``fromto`` points 1e-7 m apart or closer ("fromto
points too close in geom"; 1.01e-7 m compiles)."""
MU_MAX = 1e6
"""Largest friction coefficient (the command line's limit too): MuJoCo's state is NaN at 1e100
(finite at 1e10)."""


def _fail(where: str, what: str, limit: str, got: float | str) -> InputError:
    expected = f"{what} {limit}" if limit else what
    return InputError(f"{where}: expected {expected}, got {got}")


def _pt(v: Iterable[float]) -> str:
    return "(" + ", ".join(f"{float(x):g}" for x in v) + ")"


def _finite(values: Iterable[float], where: str, what: str) -> np.ndarray:
    arr = np.asarray(list(values), dtype=float)
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)][0]
        raise _fail(where, what, "finite", bad)
    return arr


def _coords(points: Iterable[float], where: str, scale: float) -> None:
    arr = _finite(points, where, "coordinates")
    if arr.size == 0:
        return
    worst = float(np.max(np.abs(arr)))
    if worst > COORD_MAX:
        raise _fail(where, "coordinates of magnitude at most", f"{COORD_MAX:g} m (what both "
                    "simulators represent)", f"{worst:g} m")
    if worst > COORD_OF_SCALE * scale:
        raise _fail(where, "coordinates of magnitude at most", f"{COORD_OF_SCALE:.3g} times "
                    f"the scene's length scale ({COORD_OF_SCALE * scale:.3g} m: double "
                    "precision must resolve a slow-motion step)", f"{worst:g} m")


def polygon_inertia(vertices: np.ndarray, mass: float, com: np.ndarray) -> float:
    """Rotational inertia [kg m^2] of a uniform polygon of ``mass`` about ``com`` (the value
    pymunk's ``moment_for_poly`` computes), overflow-safe: computed on vertices scaled to unit
    size; ``inf`` where the true value is beyond the float range."""
    v = np.asarray(vertices, dtype=float) - np.asarray(com, dtype=float)
    s = float(np.max(np.abs(v)))
    if s == 0.0:
        return 0.0
    u = v / s
    a, b = u, np.roll(u, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dots = (a * a).sum(1) + (a * b).sum(1) + (b * b).sum(1)
    area2 = float(np.sum(cross))
    unit = float(np.sum(cross * dots)) / (6.0 * area2) if area2 != 0.0 else 0.0
    log = math.log10(abs(mass)) + 2 * math.log10(s) + math.log10(abs(unit)) if unit and \
        mass else -math.inf
    return mass * unit * s * s if log < 300 else math.inf


def _polygon(p: Polygon, where: str, scale: float) -> None:
    v = _finite(np.ravel(p.vertices), where, "vertices").reshape(-1, 2)
    edges = np.roll(v, -1, axis=0) - v
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    if np.any(lengths == 0.0):
        k = int(np.argmin(lengths))
        raise _fail(where, "distinct consecutive vertices", "(a zero-length edge cannot be "
                    "simulated)",
                    f"vertex {(k + 1) % len(v) + 1} repeating vertex {k + 1} at {_pt(v[k])}")
    turns = edges[:, 0] * np.roll(edges[:, 1], -1) - edges[:, 1] * np.roll(edges[:, 0], -1)
    tol = 1e-12 * float(np.max(lengths)) ** 2
    if np.any(turns < -tol):
        k = int(np.argmin(turns))
        raise _fail(where, "a convex polygon", "(pymunk would simulate its convex hull)",
                    f"a reflex vertex {(k + 1) % len(v) + 1} at {_pt(v[(k + 1) % len(v)])}")
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / lengths[:, None]
    width = min(float(np.max((v - v[i]) @ normals[i]) - np.min((v - v[i]) @ normals[i]))
                for i in range(len(v)))
    if width < THICKNESS_OF_SCALE * scale:
        raise _fail(where, "a polygon at least", f"{THICKNESS_OF_SCALE:g} times the scene's "
                    f"length scale thick ({THICKNESS_OF_SCALE * scale:.3g} m: MuJoCo's edge "
                    "boxes reach that deep)", f"a sliver {width:.3g} m thick")


def _shape(shape: object, where: str, scale: float) -> None:
    if isinstance(shape, Polygon):
        _coords(np.ravel(shape.vertices), where, scale)
        _polygon(shape, where, scale)
    elif isinstance(shape, Circle):
        _coords(shape.center, where, scale)
        _finite([shape.radius], where, "radius")
    elif isinstance(shape, Capsule):
        _coords([*shape.a, *shape.b], where, scale)
        _finite([shape.radius], where, "radius")
        length = math.hypot(shape.b[0] - shape.a[0], shape.b[1] - shape.a[1])
        if not length > CAPSULE_LENGTH_MIN:
            raise _fail(where, "a capsule longer than", f"{CAPSULE_LENGTH_MIN:g} m (MuJoCo's "
                        "shortest; a circle where the ends meet)", f"length {length:g} m")


def body_extent(body: Body) -> float:
    """Largest distance [m] of ``body``'s shapes (radii included) from its centre of mass."""
    com = np.asarray(body.com, dtype=float)
    reach = 0.0
    for shape in body.shapes:
        if isinstance(shape, Polygon):
            pts, r = np.asarray(shape.vertices, dtype=float), 0.0
        elif isinstance(shape, Circle):
            pts, r = np.asarray([shape.center], dtype=float), shape.radius
        else:
            pts, r = np.asarray([shape.a, shape.b], dtype=float), shape.radius
        reach = max(reach, float(np.max(np.hypot(*(pts - com).T))) + r)
    return reach


def effective_inertias(body: Body, scale: float) -> dict[str, float]:
    """The rotational inertia [kg m^2] each backend gives its engine for a dynamic ``body``,
    by engine: the explicit one, else pymunk's from the body's first shape at uniform density
    (``moment_for_poly`` / ``_circle`` / ``_segment``) and MuJoCo's ``mass scale^2 / 6``."""
    if body.inertia is not None:
        return {"pymunk": float(body.inertia), "mujoco": float(body.inertia)}
    m, com = body.mass, np.asarray(body.com, dtype=float)
    shape = body.shapes[0]
    if isinstance(shape, Polygon):
        own = polygon_inertia(np.asarray(shape.vertices, dtype=float), m, com)
    elif isinstance(shape, Circle):
        off = np.asarray(shape.center, dtype=float) - com
        own = m * (shape.radius ** 2 / 2.0 + float(off @ off))
    else:
        a, b = np.asarray(shape.a, dtype=float), np.asarray(shape.b, dtype=float)
        off = 0.5 * (a + b) - com
        length = float(np.hypot(*(b - a))) + 2.0 * shape.radius
        own = m * ((length ** 2 + 4.0 * shape.radius ** 2) / 12.0 + float(off @ off))
    return {"pymunk": own, "mujoco": m * scale * scale / 6.0}


def _dynamic(body: Body, where: str, scale: float) -> float:
    mass = float(_finite([body.mass], where, "mass")[0])
    if not MASS_MIN <= mass <= MASS_MAX:
        raise _fail(where, "a mass in", f"[{MASS_MIN:g}, {MASS_MAX:.3g}] kg (what both "
                    "simulators represent)", f"{mass:g} kg")
    extent = body_extent(body)
    inertias = effective_inertias(body, scale)
    for engine, inertia in inertias.items():
        if not math.isfinite(inertia) or not inertia >= MASS_MIN:
            raise _fail(where, f"a rotational inertia ({engine}) finite and at least",
                        f"{MASS_MIN:g} kg m^2", f"{inertia:g} kg m^2")
        ratio = inertia / (mass * extent * extent) if extent > 0 else 1.0
        lo = INERTIA_RATIO_MIN if engine == "pymunk" else 0.0
        hi = INERTIA_RATIO_MAX if engine == "mujoco" else math.inf
        if not lo <= ratio <= hi:
            bound = f"at least {lo:g}" if ratio < lo else f"at most {hi:g}"
            raise _fail(where, f"a rotational inertia ({engine}) {bound} times mass x "
                        f"extent^2 ({mass * extent * extent:.3g} kg m^2, extent {extent:.3g} m "
                        "from the centre of mass)", "", f"{inertia:.3g} kg m^2")
    return min(inertias.values())


def check_scene(scene: Scene) -> None:
    """Raise :class:`InputError` for the first part of ``scene`` beyond what pymunk and MuJoCo
    represent (module docstring); return None when both can build and step it."""
    scale = float(_finite([scene.length_scale], "scene", "length_scale")[0])
    if not LENGTH_SCALE_MIN <= scale <= COORD_MAX:
        raise _fail("scene", "a length scale in", f"[{LENGTH_SCALE_MIN:g}, {COORD_MAX:g}] m",
                    f"{scale:g} m")
    _coords(scene.bounds, "scene bounds", scale)
    inertia: dict[str, float] = {}
    for body in scene.bodies:
        where = f"body {body.name!r}"
        _coords(body.pose[:2], f"{where} pose", scale)
        _finite([body.pose[2], *body.com], f"{where} pose", "angle and centre of mass")
        _coords(body.com, f"{where} centre of mass", scale)
        for k, shape in enumerate(body.shapes):
            _shape(shape, f"{where} shape {k + 1} ({type(shape).__name__.lower()})", scale)
        if body.kind == BodyKind.DYNAMIC:
            inertia[body.name] = _dynamic(body, where, scale)
    for joint in scene.joints:
        where = f"joint {joint.name!r}"
        _coords(joint.anchor, f"{where} anchor", scale)
        if joint.kind == JointKind.PRISMATIC:
            axis = _finite(joint.axis, where, "axis")
            norm = float(np.hypot(*axis))
            if not abs(norm - 1.0) <= 1e-6:
                raise _fail(where, "a unit axis", "(MuJoCo: 'axis too small')",
                            f"{_pt(axis)} of length {norm:g}")
    for pair in scene.pairs:
        for mu in (pair.mu_static, pair.mu_kinetic):
            if mu is not None and not mu <= MU_MAX:
                raise _fail(f"pair {pair.name!r}", "a friction coefficient at most",
                            f"{MU_MAX:g}", mu)
    masses = {b.name: b.mass for b in scene.bodies}
    for load in scene.loads:
        where = f"load on body {load.body!r}"
        force = _finite([*load.force, load.moment], where, "force and moment")
        if load.body not in inertia:
            continue  # on a static or driven body: no acceleration
        accel = (float(np.hypot(force[0], force[1])) / masses[load.body],
                 abs(float(force[2])) / inertia[load.body])
        if max(accel) > ACCEL_MAX:
            raise _fail(where, "an acceleration (force / mass, moment / inertia) at most",
                        f"{ACCEL_MAX:g} (MuJoCo's largest)", f"{max(accel):g}")
