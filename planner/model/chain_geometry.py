"""Chain-manipulator geometry a system may carry for the simulators.

A system file's ``manipulator.chain`` gives the planner the contact Jacobians (eqs. 3, 5); the
same chain, its joint positions ``q`` and which link touches each contact tell a simulator
which bodies to build (:func:`sim.scenes.system.system_scene`). Like
:class:`planner.model.workpiece.WorkpieceGeometry`, a :class:`ChainGeometry` on a
:class:`planner.model.system.System` changes no prediction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import InputError
from planner.model.kinematics import Chain


@dataclass(frozen=True, eq=False)
class ChainGeometry:
    """``chain`` (:class:`planner.model.kinematics.Chain`), joint positions ``q`` (n_theta,)
    [rad or m] and ``contact_links`` (n_c,): the body index (0..n_theta-1) touching each
    contact, ``None`` for a contact with the fixed environment; ``link_radius`` [m] of the
    links' capsules (``None``: the simulator derives one from the scene size)."""

    chain: Chain
    q: tuple[float, ...]
    contact_links: tuple[int | None, ...]
    link_radius: float | None = None

    def __post_init__(self) -> None:
        q = tuple(float(v) for v in np.asarray(self.q, dtype=float).reshape(-1))
        if len(q) != self.chain.n_joints or not np.all(np.isfinite(q)):
            raise InputError(f"chain q: expected {self.chain.n_joints} finite joint positions, "
                             f"got {list(self.q)}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "contact_links", tuple(self.contact_links))
        if self.link_radius is not None and not (np.isfinite(self.link_radius)
                                                 and self.link_radius > 0):
            raise InputError(f"link_radius: expected a finite number > 0 [m], got "
                             f"{self.link_radius}")
        for i, b in enumerate(self.contact_links):
            if b is not None and not 0 <= b < self.chain.n_joints:
                raise InputError(f"contact_links[{i}]: expected a link index in "
                                 f"0..{self.chain.n_joints - 1} or null, got {b}")

    def body_poses(self) -> np.ndarray:
        """(n_theta, 3) world poses ``(x, y, phi)`` of the links at ``q`` (body frame of link
        ``j`` at its joint, :meth:`planner.model.kinematics.Chain.frames`)."""
        return self.chain.body_poses(self.q)

    def joint_frames(self) -> np.ndarray:
        """(n_theta, 3, 3) joint frames at ``q`` (before each joint's own motion)."""
        return self.chain.frames(self.q)[0]

    def children(self, link: int) -> list[int]:
        """Joints whose parent is body ``link``."""
        return [j for j, s in enumerate(self.chain.joints) if s.parent == link]
