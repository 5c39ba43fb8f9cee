"""Palm-and-fingers hands: geometry -> :class:`planner.model.system.System` at any configuration.

The Section 5.2 system (Figure 9): a fixed straight palm, fingers, and a convex polygonal
workpiece that touches the palm, the fingers and fixed environment surfaces (a table) at point
contacts.  A finger is a planar serial chain of revolute and prismatic joints, each moving one
capsule link (:class:`Link`); the paper's fingers are single revolute links.  Everything about
a particular hand lives in a data file (e.g.
``scenarios/data/two_finger_hand.json``, format in ``docs/two-finger-task.md``, read by
:mod:`planner.files.hand_file`); this module holds the geometry and works for any such hand.

Configuration ``q = (x, y, phi, theta_1, ..., theta_n)``: workpiece pose (position of the
workpiece body-frame origin, orientation; world frame, docs/conventions.md) and the joint
coordinates of every finger in turn (finger 0's joints from the pivot out, then finger 1's...).
A revolute joint's coordinate is its link's angle relative to the previous link's axis plus the
link's fixed ``offset`` (for a finger's first link: the angle of the link's axis from world
``+x``, counter-clockwise, rad); a prismatic joint's coordinate is the slide (m) of its link's
start along the direction ``previous axis + offset``.  Link ``j`` is the capsule from its start
along its axis, ``length`` long, radius ``width/2``; link ``j + 1`` starts at link ``j``'s end.

Contact kinds (each contact keeps its feature pair for the whole segment):

* ``palm`` - a workpiece vertex on the palm line.  Normal: the palm's inward normal.
* ``surface`` - a workpiece vertex on fixed environment surface ``surface`` (a table: a
  straight segment like the palm, its inward normal ``rot90`` of first -> second point).
* ``side`` - a workpiece vertex on the straight side of link ``link`` of a finger (a capsule,
  radius ``width/2``); ``side = +1`` is the side to the left of the link axis (``rot90`` of the
  axis direction), ``-1`` the right side.  Normal: ``side * rot90(d)``.
* ``tip`` - a finger's rounded tip (circle of radius ``width/2`` at its last link's end) on a
  workpiece edge ``e`` (vertex ``e`` to ``e + 1``, counter-clockwise).  Normal: the edge's
  inward normal ``rot90(edge direction)``; contact point on the edge.

For each contact a signed gap ``g`` (positive = apart, metres) is defined.  Its time derivative
is the relative normal velocity ``v_in = w_in^T qdot - j_in thetadot`` of eq. (5), so the
Jacobians used by the planner are the exact derivatives of the gaps (tested against finite
differences).

The parts (:class:`Link`, :class:`Finger`, :class:`ContactSpec`) live in
:mod:`planner.model.hand_parts` and are re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.model import closure
from planner.model.geometry import rot90
from planner.model.hand_parts import (
    CONTACT_KINDS,
    JOINT_KINDS,
    ContactSpec,
    Finger,
    Link,
    capsule_distance,
    polygon_distance,
    rotation,
)
from planner.model.kinematics import REVOLUTE
from planner.model.load_set import LoadSet
from planner.model.system import System
from planner.model.validation import as_array


@dataclass(frozen=True, eq=False)
class Hand:
    """A palm, fingers and a convex polygonal workpiece (Section 5.2, Figure 9).

    ``palm``: (2, 2) endpoints of the palm surface; its inward normal is ``rot90`` of the
    direction from the first to the second point and must point to the workpiece.
    ``vertices``: (V, 2) workpiece polygon in its body frame, counter-clockwise, convex.
    ``com``: (2,) workpiece centre of mass, body frame.  ``load_force``: (2,) N, the constant
    external force at the centre of mass (:meth:`g_obj_at`).  ``environment``: fixed surfaces
    besides the palm, each ``(name, (2, 2) endpoints)`` with the same normal rule as the palm.
    ``load_set``: the uncertain mass and centre of mass (:class:`LoadSet`; None: the nominal
    point), whose vertex wrenches :meth:`load_vertices` gives the planner.
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
    environment: tuple[tuple[str, np.ndarray], ...] = ()
    load_set: LoadSet | None = None

    # ---- geometry --------------------------------------------------------------------------
    @property
    def n_fingers(self) -> int:
        return len(self.fingers)

    @property
    def n_joints(self) -> int:
        """Number of finger joints ``n_theta`` (one per link)."""
        return sum(f.n_joints for f in self.fingers)

    def joint_index(self, finger: int, link: int = 0) -> int:
        """Index in ``q`` of the joint of ``link`` of ``finger`` (``3 + ...``)."""
        return 3 + sum(f.n_joints for f in self.fingers[:finger]) + link

    def joint_names(self) -> tuple[str, ...]:
        """One name per joint: the finger's name, with ``.link`` for multi-link fingers."""
        out = []
        for f in self.fingers:
            if f.n_joints == 1:
                out.append(f.name)
            else:
                out.extend(f"{f.name}.{lk.name or j}" for j, lk in enumerate(f.chain_links))
        return tuple(out)

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

    def surface(self, c: ContactSpec) -> tuple[np.ndarray, np.ndarray]:
        """``((2, 2) endpoints, inward normal)`` of the fixed surface of a palm/surface contact."""
        if c.kind == "palm":
            return self.palm, self.palm_normal
        ends = self.environment[c.surface][1]
        d = ends[1] - ends[0]
        return ends, rot90(d / np.linalg.norm(d))

    def check_q(self, q: Any) -> np.ndarray:
        return as_array(q, (3 + self.n_joints,), "configuration q (x, y, phi, joint coordinates)")

    def world_vertices(self, q: np.ndarray) -> np.ndarray:
        """(V, 2) workpiece vertices in the world at configuration ``q``."""
        return self.vertices @ rotation(q[2]).T + q[:2]

    def links_at(self, q: np.ndarray, k: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per link of finger ``k``: ``(start (2,), unit axis (2,))`` in the world (m)."""
        f = self.fingers[k]
        j0 = self.joint_index(k)
        start = np.asarray(f.pivot)
        a = 0.0
        out = []
        for j, link in enumerate(f.chain_links):
            a = a + link.offset
            if link.kind == REVOLUTE:
                a = a + q[j0 + j]
                d = np.array([math.cos(a), math.sin(a)])
            else:
                d = np.array([math.cos(a), math.sin(a)])
                start = start + q[j0 + j] * d
            out.append((start, d))
            start = start + link.length * d
        return out

    def axis(self, q: np.ndarray, k: int) -> np.ndarray:
        """Unit axis (2,) of finger ``k``'s last link."""
        return self.links_at(q, k)[-1][1]

    def tip_centre(self, q: np.ndarray, k: int) -> np.ndarray:
        """Centre (2,) of finger ``k``'s rounded tip (end of its last link, moved by the
        finger's ``tip_offset`` in that link's frame), m."""
        start, d = self.links_at(q, k)[-1]
        f = self.fingers[k]
        along, across = f.tip_offset
        return start + (f.chain_links[-1].length + along) * d + across * rot90(d)

    def edge(self, q: np.ndarray, e: int) -> tuple[np.ndarray, np.ndarray]:
        """World endpoints of workpiece edge ``e`` (vertex e -> e+1)."""
        V = self.world_vertices(q)
        return V[e], V[(e + 1) % len(V)]

    def contact_frame(self, q: Any, i: int) -> tuple[np.ndarray, np.ndarray, float, float]:
        """Contact ``i`` at ``q``: ``(point, inward normal, gap, s)``.

        ``s`` is the contact point's position along its supporting feature as a fraction:
        0..1 along the palm or surface, along the link axis, or along the workpiece edge;
        outside [0, 1] the feature pair has come apart (lost contact).
        """
        q = np.asarray(q, dtype=float)
        return self._frame(q, i, self.world_vertices(q))

    def _frame(self, q: np.ndarray, i: int, V: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, float, float]:
        """:meth:`contact_frame` with the world vertices ``V`` at ``q`` given (computed once
        for all contacts by :meth:`contact_geometry`)."""
        c = self.contacts[i]
        if c.kind in ("palm", "surface"):
            p = V[c.vertex]
            (a, b), n = self.surface(c)
            gap = float(n @ (p - a))
            s = float((p - a) @ (b - a) / ((b - a) @ (b - a)))
            return p, n, gap, s
        f = self.fingers[c.finger]
        if c.kind == "side":
            link = f.chain_links[c.link]
            start, d = self.links_at(q, c.finger)[c.link]
            p = V[c.vertex]
            n = c.side * rot90(d)
            gap = float(n @ (p - start)) - link.radius
            s = float((p - start) @ d / link.length)
            return p, n, gap, s
        a, b = V[c.edge], V[(c.edge + 1) % len(V)]
        e = (b - a) / np.linalg.norm(b - a)
        n = rot90(e)
        T = self.tip_centre(q, c.finger)
        r = f.tip_radius
        gap = float(-(n @ (T - a))) - r
        p = T + r * n
        s = float((p - a) @ (b - a) / ((b - a) @ (b - a)))
        return p, n, gap, s

    def gaps(self, q: Any) -> np.ndarray:
        """(n_c,) signed gaps of the contacts at ``q`` (m; 0 = touching)."""
        return np.array([self.contact_frame(q, i)[2] for i in range(self.n_contacts)])

    def contact_geometry(self, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``points (n_c, 2)``, ``normals (n_c, 2)``, ``fractions (n_c,)`` at ``q``."""
        q = np.asarray(q, dtype=float)
        V = self.world_vertices(q)
        frames = [self._frame(q, i, V) for i in range(self.n_contacts)]
        pts = np.array([f[0] for f in frames])
        nrm = np.array([f[1] for f in frames])
        s = np.array([f[3] for f in frames])
        return pts, nrm, s

    def jacobian(self, q: Any, points: np.ndarray | None = None,
                 normals: np.ndarray | None = None) -> np.ndarray:
        """(n_c, 2, n_theta) manipulator contact-point velocities per joint rate, contact frame
        (eqs. 3, 5); ``points (n_c, 2)`` [m, world] the contact points (default where the
        features touch at ``q``; :meth:`system` moves them along their features) and
        ``normals (n_c, 2)`` their inward normals (default the features' at ``q``).

        The finger point at the contact moves with the chain's point Jacobian
        (:meth:`planner.model.kinematics.Chain.point_jacobian`: ``rot90(p - o_j)`` per revolute
        joint at ``o_j``, the slide axis per prismatic joint); rows ``n^T J_p`` and ``t^T J_p``.
        Palm and surface contacts have zero rows (fixed).
        """
        q = np.asarray(q, dtype=float)
        if points is None or normals is None:
            pts, nrm, _ = self.contact_geometry(q)
        if points is not None:
            pts = np.asarray(points, dtype=float)
        if normals is not None:
            nrm = np.asarray(normals, dtype=float)
        J = np.zeros((self.n_contacts, 2, self.n_joints))
        for i, c in enumerate(self.contacts):
            if c.kind in ("palm", "surface"):
                continue
            f = self.fingers[c.finger]
            j0 = self.joint_index(c.finger) - 3
            body = c.link if c.kind == "side" else f.n_joints - 1
            Jp = f.chain().point_jacobian(q[3 + j0:3 + j0 + f.n_joints], body, pts[i])
            t = rot90(nrm[i])
            for j in range(f.n_joints):
                u = Jp[:, j].copy()
                J[i, 0, j0 + j] = nrm[i] @ u
                J[i, 1, j0 + j] = t @ u
        return J

    def g_obj_at(self, q: Any) -> np.ndarray:
        """External wrench on the workpiece about the world origin (eq. 2): the constant force
        ``load_force`` (N) acting at the centre of mass at pose ``q``."""
        q = np.asarray(q, dtype=float)
        r = rotation(q[2]) @ self.com + q[:2]
        f = self.load_force
        return np.array([f[0], f[1], r[0] * f[1] - r[1] * f[0]])

    def load_vertices(self, q: Any) -> np.ndarray | None:
        """``(K, 3)`` the external wrench at every vertex of the mass / centre-of-mass set at
        pose ``q`` (:meth:`LoadSet.vertices`, load proportional to the mass); None when the set
        is the nominal point (the wrench is :meth:`g_obj_at`)."""
        if self.load_set is None or self.load_set.trivial:
            return None
        return self.load_set.vertices(self.load_force, np.asarray(q, dtype=float)[:3])

    def default_fixed(self, q: Any = None) -> list[int]:
        """Coordinates held when closing the start configuration
        (:func:`planner.model.closure.default_fixed`: the workpiece ``x`` and the first joints,
        each only while the free coordinates keep the rank of the contact constraints)."""
        return closure.default_fixed(self, q)

    def system(
        self,
        q: Any,
        mu: Any,
        joints: Sequence[Any],
        offsets: Any = None,
    ) -> System:
        """The planner :class:`System` at configuration ``q`` (eqs. 1-5).

        ``joints``: per joint ``{"velocity": rad/s or m/s}`` or ``{"effort": N m or N}``.
        ``offsets (n_c,)`` [m]: each contact point moved by that distance along its contact
        frame's tangent ``t = rot90(n)`` (along its straight feature; the normal kept), ``W``
        and ``J`` taken at the moved point (docs/planning.md, "Contact positions"); default
        none.
        """
        q = self.check_q(q)
        pts, nrm, _ = self.contact_geometry(q)
        if offsets is not None:
            s = as_array(offsets, (self.n_contacts,), "contact offsets")
            pts = pts + s[:, None] * np.stack([rot90(n) for n in nrm])
        return System.from_contacts(
            points=pts, normals=nrm, mu=mu, external_wrench=self.g_obj_at(q),
            jacobian=self.jacobian(q, pts, nrm), joints=list(joints),
        )

    def body_name(self, c: ContactSpec) -> str:
        """The body a contact touches besides the workpiece: ``palm``, an environment surface's
        name, or the finger's name (side and tip contacts)."""
        if c.kind == "palm":
            return "palm"
        if c.kind == "surface":
            return self.environment[c.surface][0]
        return self.fingers[c.finger].name

    def contact_offsets(self) -> np.ndarray | None:
        """``(n_c,)`` half-width [m] of each contact's position along its feature
        (:meth:`LoadSet.offsets`); None when no contact may move."""
        if self.load_set is None or not self.load_set.has_offsets:
            return None
        d = self.load_set.offsets(tuple(self.body_name(c) for c in self.contacts))
        return d if np.any(d > 0) else None

    # ---- closing a configuration -----------------------------------------------------------
    def close(
        self, q: Any, fixed: Sequence[int], *, sticking: Sequence[int] = (),
        tol: float = 1e-12, max_iter: int = 50,
    ) -> np.ndarray:
        """Solve the contact constraints of a mode for the coordinates not in ``fixed``
        (eqs. 13-16; :func:`planner.model.closure.close_configuration`): every contact's gap
        zero and, for the contacts in ``sticking`` (mode ``R``), no tangential slip.

        Used to build the initial configuration from an approximate one and, along a trajectory,
        to project integrated states back onto the contact manifold.  Raises
        :class:`DegenerateError` naming the contacts that stay open when the constraints are
        inconsistent, singular (square systems) or Newton does not converge.
        """
        return closure.close_configuration(self, q, fixed, sticking=sticking, tol=tol,
                                           max_iter=max_iter)

    def gap_jacobian(self, q: Any) -> np.ndarray:
        """(n_c, 3 + F) derivative of the gaps with respect to ``q`` (analytic, eq. 5).

        ``dg/dt = W^T qdot - J_n thetadot`` with ``qdot`` the twist about the world origin;
        the pose rates map to the twist by ``v0 = (xdot, ydot) - phidot rot90((x, y))``.
        """
        return closure.contact_rate_rows(self, q, 0)

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

        Workpiece vertices against the palm and surface lines (within them) and against each
        link capsule; finger tips against the workpiece polygon.  A value <= 0 means a new
        contact (an event that ends a quasistatic segment).
        """
        q = np.asarray(q, dtype=float)
        V = self.world_vertices(q)
        on_fixed = {(c.kind, c.surface, c.vertex) for c in self.contacts
                    if c.kind in ("palm", "surface")}
        on_link = {(c.vertex, c.finger, c.link) for c in self.contacts if c.kind == "side"}
        fixed = [("palm", -1, "palm", self.palm, self.palm_normal)]
        for e, (name, ends) in enumerate(self.environment):
            d = ends[1] - ends[0]
            fixed.append(("surface", e, name, ends, rot90(d / np.linalg.norm(d))))
        links = [self.links_at(q, k) for k in range(self.n_fingers)]
        out: dict[str, float] = {}
        for v in range(len(V)):
            for kind, e, name, (a, b), n in fixed:
                if (kind, e, v) in on_fixed:
                    continue
                s = (V[v] - a) @ (b - a) / ((b - a) @ (b - a))
                if 0.0 <= s <= 1.0:
                    out[f"vertex {v} - {name}"] = float(n @ (V[v] - a))
            for k, f in enumerate(self.fingers):
                for j, link in enumerate(f.chain_links):
                    if (v, k, j) in on_link:
                        continue
                    start, d = links[k][j]
                    where = f.name if f.n_joints == 1 else f"{f.name} link {j}"
                    out[f"vertex {v} - {where}"] = capsule_distance(
                        V[v], start, start + link.length * d, link.radius)
        tips = {c.finger for c in self.contacts if c.kind == "tip"}
        for k, f in enumerate(self.fingers):
            if k in tips:
                continue
            tip = self.tip_centre(q, k)
            out[f"{f.name} tip - workpiece"] = polygon_distance(tip, V) - f.tip_radius
        return out


__all__ = ["CONTACT_KINDS", "JOINT_KINDS", "ContactSpec", "Finger", "Hand", "Link", "rotation"]
