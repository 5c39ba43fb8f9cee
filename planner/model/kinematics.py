"""Planar manipulator kinematics: serial and branching chains of revolute and prismatic joints.

Produces the contact Jacobians ``J_i`` of eqs. (3) and (5): the linear velocity of the
manipulator point that coincides with contact ``i``, expressed in contact frame ``i``
(rows: normal, tangent), one column per joint.

Frames: each joint ``j`` has a parent body (``-1`` = the fixed base, whose pose is
``base_pose``).  Body ``j`` (the link moved by joint ``j``) has the pose

``T_j(q) = T_parent(q) * Trans(origin_j) * Rot(angle_j) * M_j(q_j)``

with ``M_j = Rot(q_j)`` for a revolute joint and ``Trans(q_j, 0)`` (along the joint frame's x
axis) for a prismatic joint.  Angles counter-clockwise, lengths in metres.

References
----------
J. J. Craig, *Introduction to Robotics*, 2nd ed. (the paper's [6]); Trinkle & Zeng (1994),
eqs. (3), (5).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.geometry import rot90
from planner.model.validation import as_array, describe_value, unit_normal

REVOLUTE, PRISMATIC = "revolute", "prismatic"


@dataclass(frozen=True)
class JointSpec:
    """One joint of a planar chain.

    Attributes
    ----------
    kind : "revolute" or "prismatic"
    parent : int
        Index of the parent joint's body, ``-1`` for the fixed base. Must be smaller than this
        joint's own index (joints are listed parents first).
    origin : (2,) [m]
        Joint position in the parent body frame.
    angle : float [rad]
        Fixed rotation of the joint frame relative to the parent body frame; a prismatic
        joint slides along the joint frame's x axis.
    name : str
    """

    kind: str
    parent: int = -1
    origin: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    name: str = ""


def _pose_matrix(x: float, y: float, phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, eq=False)
class Chain:
    """A planar kinematic tree (serial or branching) on a fixed base.

    Parameters
    ----------
    joints : sequence of JointSpec, length n_theta
    base_pose : (3,) ``(x, y, phi)`` of the base in the world frame.
    """

    joints: tuple[JointSpec, ...]
    base_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        joints = tuple(self.joints)
        if not joints:
            raise InputError("chain: expected at least one joint, got none")
        for j, spec in enumerate(joints):
            if spec.kind not in (REVOLUTE, PRISMATIC):
                raise InputError(
                    f"chain joint {j + 1}: expected kind 'revolute' or 'prismatic', "
                    f"got {describe_value(spec.kind)}"
                )
            if not (-1 <= spec.parent < j):
                raise InputError(
                    f"chain joint {j + 1}: expected parent in -1..{j - 1} (parents listed first), "
                    f"got {spec.parent}"
                )
            as_array(spec.origin, (2,), f"chain joint {j + 1} origin")
            as_array(spec.angle, (), f"chain joint {j + 1} angle")
        as_array(self.base_pose, (3,), "chain base_pose")
        object.__setattr__(self, "joints", joints)

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    def _check_q(self, q: Any) -> np.ndarray:
        return as_array(q, (self.n_joints,), "joint positions q")

    def frames(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """Joint frames (before the joint's own motion) and body frames, each ``(n, 3, 3)``."""
        qv = self._check_q(q)
        base = _pose_matrix(*self.base_pose)
        joint_frames = np.empty((self.n_joints, 3, 3))
        body_frames = np.empty((self.n_joints, 3, 3))
        for j, spec in enumerate(self.joints):
            parent = base if spec.parent < 0 else body_frames[spec.parent]
            jf = parent @ _pose_matrix(spec.origin[0], spec.origin[1], spec.angle)
            joint_frames[j] = jf
            if spec.kind == REVOLUTE:
                body_frames[j] = jf @ _pose_matrix(0.0, 0.0, qv[j])
            else:
                body_frames[j] = jf @ _pose_matrix(qv[j], 0.0, 0.0)
        return joint_frames, body_frames

    def body_poses(self, q: Any) -> np.ndarray:
        """``(n_theta, 3)`` world poses ``(x, y, phi)`` of the bodies moved by each joint."""
        _, bodies = self.frames(q)
        return np.stack(
            [bodies[:, 0, 2], bodies[:, 1, 2], np.arctan2(bodies[:, 1, 0], bodies[:, 0, 0])], axis=1
        )

    def point_world(self, q: Any, body: int, point_local: Any) -> np.ndarray:
        """World position ``(2,)`` of a point given in the frame of ``body``."""
        self._check_body(body)
        p = as_array(point_local, (2,), "point_local")
        _, bodies = self.frames(q)
        return (bodies[body] @ np.r_[p, 1.0])[:2]

    def point_local(self, q: Any, body: int, point_world: Any) -> np.ndarray:
        """Inverse of :meth:`point_world`."""
        self._check_body(body)
        p = as_array(point_world, (2,), "point_world")
        _, bodies = self.frames(q)
        return (np.linalg.inv(bodies[body]) @ np.r_[p, 1.0])[:2]

    def ancestors(self, body: int) -> list[int]:
        """Joints whose motion moves ``body`` (including its own), root first."""
        self._check_body(body)
        chain = []
        j = body
        while j >= 0:
            chain.append(j)
            j = self.joints[j].parent
        return chain[::-1]

    def point_jacobian(self, q: Any, body: int, point_world: Any) -> np.ndarray:
        """``(2, n_theta)`` Jacobian of the world velocity of a point fixed to ``body``.

        Revolute joint ``j`` at world position ``o_j``: column ``rot90(p - o_j)``;
        prismatic joint: its world axis.  Joints that do not move ``body`` give zero columns.
        """
        p = as_array(point_world, (2,), "point_world")
        joint_frames, _ = self.frames(q)
        Jp = np.zeros((2, self.n_joints))
        for j in self.ancestors(body):
            jf = joint_frames[j]
            if self.joints[j].kind == REVOLUTE:
                Jp[:, j] = rot90(p - jf[:2, 2])
            else:
                Jp[:, j] = jf[:2, 0]
        return Jp

    def contact_jacobian(
        self, q: Any, bodies: Sequence[int], points: Any, normals: Any
    ) -> np.ndarray:
        """Contact Jacobians ``(n_c, 2, n_theta)`` in the contact frames (eqs. 3, 5).

        Row 0 is ``n_i^T J_p``, row 1 is ``t_i^T J_p`` with ``t_i = rot90(n_i)``; ``J_p`` is the
        point Jacobian of the manipulator point at contact ``i`` on body ``bodies[i]``.
        """
        pts = as_array(points, (len(bodies), 2), "contact points")
        nrm = np.array(
            [unit_normal(n, f"normal of contact {i + 1}") for i, n in
             enumerate(as_array(normals, (len(bodies), 2), "contact normals"))]
        ).reshape(len(bodies), 2)
        out = np.empty((len(bodies), 2, self.n_joints))
        for i, (b, p, n) in enumerate(zip(bodies, pts, nrm)):
            Jp = self.point_jacobian(q, int(b), p)
            out[i, 0] = n @ Jp
            out[i, 1] = rot90(n) @ Jp
        return out

    def _check_body(self, body: int) -> None:
        if not isinstance(body, (int, np.integer)) or not (0 <= body < self.n_joints):
            raise InputError(
                f"body: expected a joint/body index in 0..{self.n_joints - 1}, "
                f"got {describe_value(body)}"
            )


def chain_from_dict(data: Any) -> Chain:
    """Build a :class:`Chain` from ``{"joints": [{"type", "parent", "origin", "angle"}...],
    "base_pose": [x, y, phi]}`` (the ``manipulator.chain`` entry of a system file)."""
    if not isinstance(data, dict) or not isinstance(data.get("joints"), list):
        raise InputError(
            "manipulator.chain: expected an object with a 'joints' list, got "
            f"{type(data).__name__}"
        )
    specs = []
    for j, item in enumerate(data["joints"]):
        if not isinstance(item, dict):
            raise InputError(f"chain joint {j + 1}: expected an object, got {describe_value(item)}")
        kind = item.get("type", item.get("kind"))
        if not isinstance(kind, str):
            raise InputError(
                f"chain joint {j + 1}: expected a 'type' of 'revolute' or 'prismatic', "
                f"got {describe_value(kind)}"
            )
        parent = item.get("parent", -1)
        if isinstance(parent, bool) or not isinstance(parent, int):
            raise InputError(
                f"chain joint {j + 1}: expected an integer parent, got {describe_value(parent)}"
            )
        origin = as_array(item.get("origin", [0.0, 0.0]), (2,), f"chain joint {j + 1} origin")
        angle = float(as_array(item.get("angle", 0.0), (), f"chain joint {j + 1} angle"))
        specs.append(
            JointSpec(kind=kind, parent=parent, origin=(float(origin[0]), float(origin[1])),
                      angle=angle, name=str(item.get("name", "")))
        )
    base = as_array(data.get("base_pose", [0.0, 0.0, 0.0]), (3,), "chain base_pose")
    return Chain(tuple(specs), (float(base[0]), float(base[1]), float(base[2])))
