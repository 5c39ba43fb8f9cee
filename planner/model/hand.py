"""Palm-and-fingers hands: geometry -> :class:`planner.model.system.System` at any configuration.

The Section 5.2 system (Figure 9): a fixed straight palm, single-link fingers on revolute
joints, and a convex polygonal workpiece that touches the palm and the fingers at point
contacts.  Everything about a particular hand lives in a data file (e.g.
``scenarios/data/two_finger_hand.json``, format in ``docs/two-finger-task.md``, read by
:mod:`planner.files.hand_file`); this module holds the geometry and works for any such hand.

Configuration ``q = (x, y, phi, theta_1, ..., theta_F)``: workpiece pose (position of the
workpiece body-frame origin, orientation; world frame, docs/conventions.md) and finger joint
angles (angle of each link's axis from world ``+x``, counter-clockwise).

Contact kinds (each contact keeps its feature pair for the whole segment):

* ``palm`` - a workpiece vertex on the palm line.  Normal: the palm's inward normal.
* ``side`` - a workpiece vertex on the straight side of a finger.  A finger is a capsule
  (segment from the pivot along the axis, radius ``width/2``); ``side = +1`` is the side to the
  left of the axis (``rot90`` of the axis direction), ``-1`` the right side.  Normal:
  ``side * rot90(d)``.
* ``tip`` - a finger's rounded tip (circle of radius ``width/2`` at the link end) on a
  workpiece edge ``e`` (vertex ``e`` to ``e + 1``, counter-clockwise).  Normal: the edge's
  inward normal ``rot90(edge direction)``; contact point on the edge.

For each contact a signed gap ``g`` (positive = apart, metres) is defined.  Its time derivative
is the relative normal velocity ``v_in = w_in^T qdot - j_in thetadot`` of eq. (5), so the
Jacobians used by the planner are the exact derivatives of the gaps (tested against finite
differences).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.geometry import rot90
from planner.model.system import System
from planner.model.validation import as_array

CONTACT_KINDS = ("palm", "side", "tip")


def rotation(phi: float) -> np.ndarray:
    """(2, 2) rotation matrix by ``phi`` [rad], counter-clockwise."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class Finger:
    """One single-link finger: revolute joint at ``pivot`` (world, m), link ``length`` (m),
    capsule ``width`` (m, tip radius ``width/2``), link ``mass`` (kg, simulators only)."""

    name: str
    pivot: tuple[float, float]
    length: float
    width: float
    mass: float = 0.05

    @property
    def radius(self) -> float:
        return 0.5 * self.width


@dataclass(frozen=True)
class ContactSpec:
    """One contact's feature pair.  ``kind`` in :data:`CONTACT_KINDS`; ``vertex`` (palm, side)
    or ``edge`` (tip) indexes the workpiece polygon; ``finger`` indexes the fingers (side,
    tip); ``side`` is +1/-1 for ``side`` contacts."""

    kind: str
    vertex: int = -1
    edge: int = -1
    finger: int = -1
    side: int = 1


@dataclass(frozen=True, eq=False)
class Hand:
    """A palm, fingers and a convex polygonal workpiece (Section 5.2, Figure 9).

    ``palm``: (2, 2) endpoints of the palm surface; its inward normal is ``rot90`` of the
    direction from the first to the second point and must point to the workpiece.
    ``vertices``: (V, 2) workpiece polygon in its body frame, counter-clockwise, convex.
    ``com``: (2,) workpiece centre of mass, body frame.  ``g_obj``: (3,) external wrench on the
    workpiece about the world origin *at the initial pose* (see :meth:`g_obj_at`).
    """

    palm: np.ndarray
    fingers: tuple[Finger, ...]
    vertices: np.ndarray
    com: np.ndarray
    mass: float
    contacts: tuple[ContactSpec, ...]
    load_force: np.ndarray
    name: str = "hand"
    meta: Mapping[str, Any] = field(default_factory=dict)

    # ---- geometry --------------------------------------------------------------------------
    @property
    def n_fingers(self) -> int:
        return len(self.fingers)

    @property
    def n_contacts(self) -> int:
        return len(self.contacts)

    @property
    def length_scale(self) -> float:
        """Largest extent of the workpiece polygon (m); used to normalise gap tolerances."""
        return float(np.ptp(self.vertices, axis=0).max())

    @property
    def palm_normal(self) -> np.ndarray:
        d = self.palm[1] - self.palm[0]
        return rot90(d / np.linalg.norm(d))

    def check_q(self, q: Any) -> np.ndarray:
        return as_array(q, (3 + self.n_fingers,), "configuration q (x, y, phi, finger angles)")

    def world_vertices(self, q: np.ndarray) -> np.ndarray:
        """(V, 2) workpiece vertices in the world at configuration ``q``."""
        return self.vertices @ rotation(q[2]).T + q[:2]

    def axis(self, q: np.ndarray, k: int) -> np.ndarray:
        return np.array([math.cos(q[3 + k]), math.sin(q[3 + k])])

    def tip_centre(self, q: np.ndarray, k: int) -> np.ndarray:
        f = self.fingers[k]
        return np.asarray(f.pivot) + f.length * self.axis(q, k)

    def edge(self, q: np.ndarray, e: int) -> tuple[np.ndarray, np.ndarray]:
        """World endpoints of workpiece edge ``e`` (vertex e -> e+1)."""
        V = self.world_vertices(q)
        return V[e], V[(e + 1) % len(V)]

    def contact_frame(self, q: Any, i: int) -> tuple[np.ndarray, np.ndarray, float, float]:
        """Contact ``i`` at ``q``: ``(point, inward normal, gap, s)``.

        ``s`` is the contact point's position along its supporting feature as a fraction:
        0..1 along the palm, along the finger axis, or along the workpiece edge; outside
        [0, 1] the feature pair has come apart (lost contact).
        """
        q = np.asarray(q, dtype=float)
        c = self.contacts[i]
        if c.kind == "palm":
            p = self.world_vertices(q)[c.vertex]
            n = self.palm_normal
            a, b = self.palm
            gap = float(n @ (p - a))
            s = float((p - a) @ (b - a) / ((b - a) @ (b - a)))
            return p, n, gap, s
        f = self.fingers[c.finger]
        pivot = np.asarray(f.pivot)
        d = self.axis(q, c.finger)
        if c.kind == "side":
            p = self.world_vertices(q)[c.vertex]
            n = c.side * rot90(d)
            gap = float(n @ (p - pivot)) - f.radius
            s = float((p - pivot) @ d / f.length)
            return p, n, gap, s
        a, b = self.edge(q, c.edge)
        e = (b - a) / np.linalg.norm(b - a)
        n = rot90(e)
        T = pivot + f.length * d
        gap = float(-(n @ (T - a))) - f.radius
        p = T + f.radius * n
        s = float((p - a) @ (b - a) / ((b - a) @ (b - a)))
        return p, n, gap, s

    def gaps(self, q: Any) -> np.ndarray:
        """(n_c,) signed gaps of the contacts at ``q`` (m; 0 = touching)."""
        return np.array([self.contact_frame(q, i)[2] for i in range(self.n_contacts)])

    def contact_geometry(self, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``points (n_c, 2)``, ``normals (n_c, 2)``, ``fractions (n_c,)`` at ``q``."""
        frames = [self.contact_frame(q, i) for i in range(self.n_contacts)]
        pts = np.array([f[0] for f in frames])
        nrm = np.array([f[1] for f in frames])
        s = np.array([f[3] for f in frames])
        return pts, nrm, s

    def jacobian(self, q: Any) -> np.ndarray:
        """(n_c, 2, F) manipulator contact-point velocities per joint rate, contact frame (eq. 5).

        The finger's material point at the contact moves with ``rot90(p - pivot) thetadot``;
        palm contacts have zero rows (the palm is fixed).
        """
        q = np.asarray(q, dtype=float)
        pts, nrm, _ = self.contact_geometry(q)
        J = np.zeros((self.n_contacts, 2, self.n_fingers))
        for i, c in enumerate(self.contacts):
            if c.kind == "palm":
                continue
            u = rot90(pts[i] - np.asarray(self.fingers[c.finger].pivot))
            J[i, 0, c.finger] = nrm[i] @ u
            J[i, 1, c.finger] = rot90(nrm[i]) @ u
        return J

    def g_obj_at(self, q: Any) -> np.ndarray:
        """External wrench on the workpiece about the world origin (eq. 2): the constant force
        ``load_force`` (N) acting at the centre of mass at pose ``q``."""
        q = np.asarray(q, dtype=float)
        r = rotation(q[2]) @ self.com + q[:2]
        f = self.load_force
        return np.array([f[0], f[1], r[0] * f[1] - r[1] * f[0]])

    def default_fixed(self) -> list[int]:
        """Coordinates kept when closing the initial configuration (:meth:`close`): the
        workpiece ``x`` and, if there are more free coordinates than contacts, the first
        fingers' angles.  Raises :class:`InputError` when there are too many contacts."""
        n_free = 3 + self.n_fingers
        fixed = [0]
        k = 0
        while n_free - len(fixed) > self.n_contacts and k < self.n_fingers:
            fixed.append(3 + k)
            k += 1
        if n_free - len(fixed) < self.n_contacts:
            raise InputError(
                f"contacts: expected at most {n_free - 1} contacts for {self.n_fingers} fingers, "
                f"got {self.n_contacts}"
            )
        return fixed

    def system(
        self,
        q: Any,
        mu: Any,
        joints: Sequence[Any],
    ) -> System:
        """The planner :class:`System` at configuration ``q`` (eqs. 1-5).

        ``joints``: per finger ``{"velocity": rad/s}`` or ``{"effort": N m}``.
        """
        q = self.check_q(q)
        pts, nrm, _ = self.contact_geometry(q)
        return System.from_contacts(
            points=pts, normals=nrm, mu=mu, external_wrench=self.g_obj_at(q),
            jacobian=self.jacobian(q), joints=list(joints),
        )

    # ---- closing a configuration -----------------------------------------------------------
    def close(
        self, q: Any, fixed: Sequence[int], *, tol: float = 1e-12, max_iter: int = 50,
    ) -> np.ndarray:
        """Solve ``gaps(q) = 0`` for the coordinates not in ``fixed`` (Gauss-Newton).

        Used to build the initial configuration from an approximate one and, along a trajectory,
        to project integrated states back onto the contact manifold.  Raises
        :class:`DegenerateError` when the gap Jacobian is singular or Newton does not converge.
        """
        q = self.check_q(q).copy()
        free = [j for j in range(len(q)) if j not in set(fixed)]
        if len(free) != self.n_contacts:
            raise InputError(
                f"close: expected {self.n_contacts} free coordinates (one per contact), "
                f"got {len(free)} (fixed {list(fixed)})"
            )
        scale = self.length_scale
        for _ in range(max_iter):
            g = self.gaps(q)
            if np.max(np.abs(g)) <= tol * scale:
                return q
            G = self.gap_jacobian(q)[:, free]
            if abs(np.linalg.det(G)) < 1e-14 * scale ** 2:
                raise DegenerateError(
                    "close: the contact constraints are singular at this configuration "
                    f"(gap Jacobian det {np.linalg.det(G):.3g})"
                )
            q[free] -= np.linalg.solve(G, g)
        raise DegenerateError(
            f"close: contacts did not close within {max_iter} Newton steps "
            f"(largest gap {np.max(np.abs(self.gaps(q))):.3g} m)"
        )

    def gap_jacobian(self, q: Any) -> np.ndarray:
        """(n_c, 3 + F) derivative of the gaps with respect to ``q`` (analytic, eq. 5).

        ``dg/dt = W^T qdot - J_n thetadot`` with ``qdot`` the twist about the world origin;
        the pose rates map to the twist by ``v0 = (xdot, ydot) - phidot rot90((x, y))``.
        """
        q = np.asarray(q, dtype=float)
        pts, nrm, _ = self.contact_geometry(q)
        Jn = self.jacobian(q)[:, 0, :]
        out = np.zeros((self.n_contacts, 3 + self.n_fingers))
        o = q[:2]
        for i in range(self.n_contacts):
            n, p = nrm[i], pts[i]
            m = p[0] * n[1] - p[1] * n[0]
            # twist (v0, w): dg = n.v0 + m w ; v0 = (xd, yd) - w rot90(o)
            out[i, 0:2] = n
            out[i, 2] = m - n @ rot90(o)
            out[i, 3:] = -Jn[i]
        return out

    def twist_from_pose_rates(self, q: np.ndarray, qd_pose: np.ndarray) -> np.ndarray:
        """Twist ``(v0x, v0y, omega)`` about the world origin from pose rates ``(xd, yd, phid)``."""
        return np.concatenate([qd_pose[:2] - qd_pose[2] * rot90(q[:2]), qd_pose[2:3]])

    def pose_rates_from_twist(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """Pose rates ``(xd, yd, phid)`` from the twist about the world origin (inverse of
        :meth:`twist_from_pose_rates`)."""
        return np.concatenate([qdot[:2] + qdot[2] * rot90(q[:2]), qdot[2:3]])

    # ---- clearance of the features not in contact (events) ---------------------------------
    def clearances(self, q: Any) -> dict[str, float]:
        """Signed distances (m) of feature pairs that are *not* declared contacts.

        Workpiece vertices against the palm line (within the palm) and against each finger
        capsule; finger tips against the workpiece polygon.  A value <= 0 means a new contact
        (an event that ends a quasistatic segment).
        """
        q = np.asarray(q, dtype=float)
        V = self.world_vertices(q)
        taken = {(c.kind if c.kind != "side" else "finger", c.vertex, c.finger)
                 for c in self.contacts if c.kind in ("palm", "side")}
        out: dict[str, float] = {}
        a, b = self.palm
        n = self.palm_normal
        for v in range(len(V)):
            if ("palm", v, -1) not in taken:
                s = (V[v] - a) @ (b - a) / ((b - a) @ (b - a))
                if 0.0 <= s <= 1.0:
                    out[f"vertex {v} - palm"] = float(n @ (V[v] - a))
            for k, f in enumerate(self.fingers):
                if ("finger", v, k) in taken:
                    continue
                out[f"vertex {v} - {f.name}"] = _capsule_distance(
                    V[v], np.asarray(f.pivot), self.tip_centre(q, k), f.radius)
        tips = {c.finger for c in self.contacts if c.kind == "tip"}
        for k, f in enumerate(self.fingers):
            if k in tips:
                continue
            tip = self.tip_centre(q, k)
            out[f"{f.name} tip - workpiece"] = _polygon_distance(tip, V) - f.radius
        return out


def _capsule_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, r: float) -> float:
    ab = b - a
    t = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab))) - r


def _polygon_distance(p: np.ndarray, V: np.ndarray) -> float:
    """Signed distance of ``p`` to a convex counter-clockwise polygon (negative inside)."""
    n = len(V)
    inside = True
    best = np.inf
    for i in range(n):
        a, b = V[i], V[(i + 1) % n]
        ab = b - a
        if (ab[0] * (p - a)[1] - ab[1] * (p - a)[0]) < 0:
            inside = False
        t = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
        best = min(best, float(np.linalg.norm(p - (a + t * ab))))
    return -best if inside else best
