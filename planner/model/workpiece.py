"""Workpiece shape and mass: the scene geometry a system may carry for the simulators.

The planner's prediction (Sections 3-4) needs only the contact frames and the external wrench;
a :class:`WorkpieceGeometry` on a :class:`planner.model.system.System` changes no prediction. It
tells a simulator which body to build: a convex polygon in the world frame (metres,
counter-clockwise), its mass (kg) and centre of mass (world frame, m; default the polygon's
area centroid).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.validation import as_array, describe_value


def check_convex_ccw(vertices: Any, name: str) -> np.ndarray:
    """``(V, 2)`` finite vertices of a strictly convex polygon listed counter-clockwise.

    Every turn ``(b - a) x (c - b)`` must be positive (no flat or clockwise turn), and the
    polygon must wind once (total turning 2 pi), so a star or a doubly wound outline is refused.
    Raises :class:`InputError` naming ``name``.
    """
    V = as_array(vertices, (None, 2), name)
    n = len(V)
    if n < 3:
        raise InputError(f"{name}: expected at least 3 vertices, got {n}")
    turning = 0.0
    for i in range(n):
        a, b, c = V[i], V[(i + 1) % n], V[(i + 2) % n]
        u, w = b - a, c - b
        cross = u[0] * w[1] - u[1] * w[0]
        if cross <= 0:
            raise InputError(
                f"{name}: expected a convex polygon listed counter-clockwise, "
                f"got a clockwise or flat turn at vertex {(i + 1) % n}"
            )
        turning += float(np.arctan2(cross, u @ w))
    if abs(turning - 2 * np.pi) > 1e-6:
        raise InputError(
            f"{name}: expected a simple convex polygon (turning once around), "
            f"got total turning {turning / (2 * np.pi):.3g} turns"
        )
    return V


def polygon_area_centroid(vertices: np.ndarray) -> tuple[float, np.ndarray]:
    """Area [m^2] (positive when counter-clockwise) and area centroid ``(2,)`` of a polygon."""
    V = np.asarray(vertices, dtype=float)
    ref = V[0]
    P = V - ref  # shift for accuracy far from the origin
    x, y = P[:, 0], P[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * float(cross.sum())
    cx = float(((x + xn) * cross).sum()) / (6.0 * area)
    cy = float(((y + yn) * cross).sum()) / (6.0 * area)
    return area, ref + np.array([cx, cy])


def point_in_convex_polygon(p: np.ndarray, vertices: np.ndarray) -> bool:
    """True when ``p`` lies in the closed counter-clockwise convex polygon ``vertices``."""
    V = np.asarray(vertices, dtype=float)
    scale = float(np.ptp(V, axis=0).max())
    for i in range(len(V)):
        a, b = V[i], V[(i + 1) % len(V)]
        e, r = b - a, p - a
        if e[0] * r[1] - e[1] * r[0] < -1e-12 * scale * scale:
            return False
    return True


@dataclass(frozen=True, eq=False)
class WorkpieceGeometry:
    """The workpiece as a rigid convex polygon (scene data for simulators).

    Attributes
    ----------
    polygon : (V, 2) [m]
        Vertices in the world frame, counter-clockwise, strictly convex, ``V >= 3``.
    mass : float [kg]
        ``> 0``.
    com : (2,) [m]
        Centre of mass in the world frame, inside the polygon; ``None`` at construction means
        the polygon's area centroid.
    """

    polygon: np.ndarray
    mass: float
    com: Any = None

    def __post_init__(self) -> None:
        V = check_convex_ccw(self.polygon, "workpiece.polygon").copy()
        V.setflags(write=False)
        m = self.mass
        if isinstance(m, bool) or not isinstance(m, (int, float, np.floating, np.integer)) \
                or not np.isfinite(m) or m <= 0:
            raise InputError(
                f"workpiece.mass: expected a finite mass > 0 [kg], got {describe_value(m)}"
            )
        if self.com is None:
            com = polygon_area_centroid(V)[1]
        else:
            com = as_array(self.com, (2,), "workpiece.com").copy()
            if not point_in_convex_polygon(com, V):
                raise InputError(
                    f"workpiece.com: expected a point inside the polygon, got {com.tolist()}"
                )
        com.setflags(write=False)
        object.__setattr__(self, "polygon", V)
        object.__setattr__(self, "mass", float(m))
        object.__setattr__(self, "com", com)

    @property
    def area(self) -> float:
        """Polygon area [m^2]."""
        return polygon_area_centroid(self.polygon)[0]

    def to_dict(self) -> dict[str, Any]:
        """The system-file form ``{"polygon", "mass", "com"}``."""
        return {"polygon": self.polygon.tolist(), "mass": self.mass, "com": self.com.tolist()}


def check_environment(
    environment: Any, J: np.ndarray, joint_inputs: np.ndarray, virtual: bool,
) -> tuple[bool, ...]:
    """Per-contact environment flags (``()`` = none), checked: an environment contact does not
    move with the manipulator, so its Jacobian rows are zero, or, with contact velocities
    (``virtual``), its commanded velocity ``J_i thetadot`` is ``(0, 0)`` (eq. 5)."""
    n_c = J.shape[0] // 2
    if not isinstance(environment, (tuple, list, np.ndarray)):
        raise InputError(
            f"environment: expected one flag per contact, got {describe_value(environment)}"
        )
    if len(environment) == 0:
        return (False,) * n_c
    if len(environment) != n_c or not all(isinstance(e, (bool, np.bool_)) for e in environment):
        raise InputError(
            f"environment: expected {n_c} true/false flags (one per contact), "
            f"got {describe_value(environment)}"
        )
    for i, env in enumerate(environment):
        if not env:
            continue
        if virtual:
            v = joint_inputs[2 * i:2 * i + 2]
            if np.any(v != 0):
                raise InputError(
                    f"contact {i + 1}: expected zero manipulator velocity for a contact with the "
                    f"fixed environment, got contact velocity {v.tolist()}"
                )
        elif np.any(J[2 * i:2 * i + 2] != 0):
            raise InputError(
                f"contact {i + 1}: expected zero manipulator velocity for a contact with the fixed "
                f"environment (zero Jacobian rows), got rows {J[2 * i:2 * i + 2].tolist()}"[:300]
            )
    return tuple(bool(e) for e in environment)
