"""Features of a workpiece polygon -- vertices and edges -- and the checks that tie a contact to
them: a contact point lies on the boundary, and its normal points into the body.

A convex polygon ``V (n_v, 2)`` listed counter-clockwise (world frame, m) has edge ``e`` from
vertex ``e`` to vertex ``e + 1`` (indices 0-based, modulo ``n_v``) with inward unit normal
``rot90(V[e+1] - V[e]) / |...|`` (docs/conventions.md: normals point into the workpiece).

A contact at ``p`` with normal ``n`` is *consistent with the body* when the line through ``p``
perpendicular to ``n`` supports the polygon with the body on its ``+n`` side: ``p`` on the
boundary and ``n`` in the polygon's inward normal cone at ``p`` -- the edge's inward normal on an
edge's interior, any direction between the two adjacent edges' inward normals at a vertex.
Anything else means the other side (a finger, a surface) would overlap the body.

Tolerance (docs/conventions.md, "Geometry of contacts"): :data:`GEOMETRY_TOL`, the relative
precision a unit normal is held to (:data:`planner.model.validation.NORMAL_TOL`): distances
relative to the polygon's size, angles in radians.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from planner.errors import InputError
from planner.model.validation import NORMAL_TOL

#: Relative tolerance of the contact-geometry checks (distance / polygon size, angle in rad).
GEOMETRY_TOL = NORMAL_TOL

#: Standard gravity [m/s^2] (used only to recognise a weight written by hand, see
#: :func:`weight_moment_warning`).
STANDARD_GRAVITY = 9.80665
#: A force counts as "looks like the weight" when ``|f| / mass`` is within this fraction of
#: :data:`STANDARD_GRAVITY` (covers the values people write: 9.8, 9.81, 10) and it points down
#: within 5 degrees.
WEIGHT_LIKE = 0.05
#: The moment of a hand-written weight matches the centre of mass when it is within this
#: fraction of ``|f| x size`` (a moment written to three significant digits).
MOMENT_TOL = 1e-3


def size_of(V: np.ndarray) -> float:
    """Largest extent of the polygon [m] (the length scale of the tolerances)."""
    return float(np.ptp(V, axis=0).max())


def inward_normals(V: np.ndarray) -> np.ndarray:
    """``(n_v, 2)`` inward unit normals of the edges (edge ``e``: vertex ``e`` -> ``e + 1``)."""
    E = np.roll(V, -1, axis=0) - V
    N = np.stack([-E[:, 1], E[:, 0]], axis=1)
    return N / np.linalg.norm(N, axis=1)[:, None]


def fmt_vec(v: np.ndarray | tuple[float, ...] | list[float]) -> str:
    """``[0.1, -0.2]``: a short vector for messages (4 significant digits, no ``-0``)."""
    return "[" + ", ".join(f"{(float(x) if abs(float(x)) > 1e-15 else 0.0):.4g}" for x in v) + "]"


class Feature(NamedTuple):
    """Where a point sits on a polygon: ``kind`` ``"vertex"`` or ``"edge"``, its ``index``,
    the point's ``distance`` from the boundary [m] and the nearest boundary point ``foot``."""

    kind: str
    index: int  # type: ignore[assignment]  # the field shadows tuple.index
    distance: float
    foot: np.ndarray

    def describe(self, n_v: int) -> str:
        if self.kind == "vertex":
            return f"vertex {self.index}"
        return f"edge {self.index} (vertex {self.index} -> {(self.index + 1) % n_v})"


def locate(p: np.ndarray, V: np.ndarray) -> Feature:
    """The feature of ``V`` nearest to ``p``: a vertex when ``p`` is within
    ``GEOMETRY_TOL * size`` of it, else the nearest edge."""
    p = np.asarray(p, dtype=float)
    tol = GEOMETRY_TOL * size_of(V)
    dv = np.linalg.norm(V - p, axis=1)
    k = int(np.argmin(dv))
    if dv[k] <= tol:
        return Feature("vertex", k, float(dv[k]), V[k].copy())
    best: Feature | None = None
    for e in range(len(V)):
        a, b = V[e], V[(e + 1) % len(V)]
        s = float(np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        foot = a + s * (b - a)
        d = float(np.linalg.norm(p - foot))
        if best is None or d < best.distance:
            best = Feature("edge", e, d, foot)
    assert best is not None
    if best.distance > tol:  # off the boundary: report the nearest feature honestly
        f = best.foot
        k2 = int(np.argmin(np.linalg.norm(V - f, axis=1)))
        if np.linalg.norm(V[k2] - f) <= tol:
            return Feature("vertex", k2, best.distance, V[k2].copy())
    return best


def cone_angle(n: np.ndarray, V: np.ndarray, feature: Feature) -> tuple[float, np.ndarray]:
    """``(angle, nearest)``: how far [rad] the unit normal ``n`` lies outside the polygon's
    inward normal cone at ``feature``, and the nearest admissible normal (``n`` itself when
    inside)."""
    N = inward_normals(V)
    if feature.kind == "edge":
        m = N[feature.index]
        return float(math.acos(float(np.clip(n @ m, -1.0, 1.0)))), m
    a, b = N[(feature.index - 1) % len(V)], N[feature.index]  # the cone from a to b (ccw)
    span = math.atan2(a[0] * b[1] - a[1] * b[0], a @ b)
    rel = math.atan2(a[0] * n[1] - a[1] * n[0], a @ n)
    if 0.0 <= rel <= span:
        return 0.0, np.asarray(n, dtype=float)
    to_a, to_b = abs(rel), abs(math.remainder(rel - span, 2 * math.pi))
    return (to_a, a) if to_a <= to_b else (to_b, b)


def check_on_body(p: np.ndarray, n: np.ndarray, V: np.ndarray, where: str,
                  body: str = "the workpiece", outward: bool = False) -> Feature:
    """Check a contact at ``p`` with unit normal ``n`` against the polygon ``V``: ``p`` on its
    boundary, ``n`` pointing into it (``outward``: ``-n`` does, for the body on the other side
    of a contact between two workpieces).  Returns the feature; raises :class:`InputError`
    naming ``where``, the distance or angle, and the fix."""
    f = check_on_boundary(p, V, where, body)
    m = -np.asarray(n, dtype=float) if outward else np.asarray(n, dtype=float)
    angle, nearest = cone_angle(m, V, f)
    if angle > GEOMETRY_TOL:
        into = "out of" if angle > math.pi / 2 else "not into"
        want = -nearest if outward else nearest
        raise InputError(
            f"{where}: expected a normal pointing into {body}"
            + (" (from the other workpiece: -n into it)" if outward else "")
            + f", got {fmt_vec(n)}, which points {into} it: {math.degrees(angle):.3g} deg "
            f"from the nearest inward normal {fmt_vec(want)} at {f.describe(len(V))}; use "
            f"{fmt_vec(want)} or leave \"normal\" out and place the contact by feature"
        )
    return f


def check_on_boundary(p: np.ndarray, V: np.ndarray, where: str, body: str = "the workpiece"
                      ) -> Feature:
    """The feature of ``V`` at ``p``; :class:`InputError` when ``p`` is off the boundary by
    more than ``GEOMETRY_TOL`` times the polygon's size."""
    f = locate(p, V)
    if f.distance > GEOMETRY_TOL * size_of(V):
        raise InputError(
            f"{where}: expected a point on the boundary of {body}, got {fmt_vec(p)}, "
            f"{f.distance:.4g} m off it (nearest boundary point {fmt_vec(f.foot)} on "
            f"{f.describe(len(V))}); move the point onto the polygon or place the contact by "
            "feature ({\"vertex\": k} or {\"edge\": e, \"at\": s})"
        )
    return f


def weight_moment_warning(wrench: np.ndarray, mass: float, com: np.ndarray, where: str,
                          scale: float) -> str | None:
    """A warning text when ``wrench = (f_x, f_y, m_z)`` looks like the weight of a body of
    ``mass`` (kg) -- pointing down, ``|f| / mass`` within :data:`WEIGHT_LIKE` of standard
    gravity -- but its moment about the origin is not the weight's moment at the centre of mass
    ``com`` (``com x f``) to ``MOMENT_TOL * |f| * scale``; else None."""
    f = np.asarray(wrench[:2], dtype=float)
    size = float(np.hypot(*f))
    if size == 0.0 or abs(size / mass / STANDARD_GRAVITY - 1.0) > WEIGHT_LIKE:
        return None
    if -f[1] / size < math.cos(math.radians(5.0)):
        return None
    want = float(com[0] * f[1] - com[1] * f[0])
    if abs(float(wrench[2]) - want) <= MOMENT_TOL * size * scale:
        return None
    return (
        f"{where}: external_wrench {fmt_vec(wrench)} looks like the weight of the workpiece "
        f"({size:.4g} N = {mass:.4g} kg x {size / mass:.4g} m/s^2) but its moment "
        f"{float(wrench[2]):.4g} N m about the origin is not the weight's moment {want:.4g} N m "
        f"at the centre of mass {fmt_vec(com)}; the prediction and the simulators use the "
        f"moment as given. Fix: give \"gravity\": [0, -9.81] (the weight and its moment are "
        f"then computed) and drop the weight from external_wrench, or set the moment to "
        f"{want:.4g}"
    )
