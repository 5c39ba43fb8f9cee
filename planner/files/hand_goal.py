"""The ``goal`` section of a hand file: where a whole task should end.

A goal names a workpiece pose with a tolerance, the contacts wanted at the end, or both::

    "goal": {"pose": [x, y, phi], "tolerance": {"position": 0.001, "angle": 0.02},
             "contacts": [{"kind": "palm", "vertex": 1}, ...], "max_segments": 4}

``pose``: the workpiece body frame (m, m, rad; world frame, docs/conventions.md);
``tolerance.position`` (m, distance of the body-frame origin) and ``tolerance.angle`` (rad)
default to 1 % of the workpiece size and 0.02 rad; ``contacts`` uses the hand file's contact
objects and is met when every listed contact is among the hand's contacts at the end (others may
be present too); ``max_segments`` bounds the task planner's search depth (default 4).
At least one of ``pose`` and ``contacts`` must be given; ``contacts``, when given, lists at least
one contact.  The contact objects are parsed by the
hand file loader (:mod:`planner.files.hand_file`), which passes its contact parser in.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import FileFormatError
from planner.files.fields import FREE_KEYS, as_object, check_keys, integer, number, short
from planner.model.hand import ContactSpec

#: Defaults of the goal's optional keys (docs/planning.md).
ANGLE_TOLERANCE = 0.02  # rad
POSITION_TOLERANCE_OF_SIZE = 0.01  # of the workpiece's largest extent
MAX_SEGMENTS = 4


@dataclass(frozen=True, eq=False)
class Goal:
    """A task's goal: ``pose`` ``(3,)`` or None, ``position_tol`` (m), ``angle_tol`` (rad),
    ``contacts`` wanted at the end, ``max_segments`` (search depth)."""

    pose: np.ndarray | None
    position_tol: float
    angle_tol: float
    contacts: tuple[ContactSpec, ...]
    max_segments: int = MAX_SEGMENTS

    def pose_error(self, q: np.ndarray) -> float:
        """Largest of position and angle error, each over its tolerance (<= 1: within); 0
        without a goal pose.  ``q``: a configuration (its first three entries are the pose)."""
        if self.pose is None:
            return 0.0
        dpos = float(np.linalg.norm(np.asarray(q[:2]) - self.pose[:2]))
        dang = abs(math.remainder(float(q[2]) - float(self.pose[2]), 2 * math.pi))
        return max(dpos / self.position_tol, dang / self.angle_tol)

    def pose_reached(self, q: np.ndarray, slack: float = 1e-3) -> bool:
        """Within tolerance; ``slack`` (relative) absorbs where an integrated segment that
        ends at the goal puts its last state (the first state inside, located by bisection)."""
        return self.pose_error(q) <= 1.0 + slack

    def missing_contacts(self, contacts: tuple[ContactSpec, ...]) -> tuple[ContactSpec, ...]:
        """The goal contacts not in ``contacts``."""
        return tuple(c for c in self.contacts if c not in contacts)

    def reached(self, q: np.ndarray, contacts: tuple[ContactSpec, ...]) -> bool:
        return self.pose_reached(q) and not self.missing_contacts(contacts)


def parse_goal(raw: Any, size: float,
               contact: Callable[[Any, int], ContactSpec]) -> Goal:
    """The ``goal`` section (module docstring); ``size``: the workpiece's largest extent (m) for
    the default position tolerance; ``contact(obj, i)`` parses ``goal.contacts[i]``."""
    g = as_object(raw, "goal")
    check_keys(g, "goal", optional=("pose", "tolerance", "contacts", "max_segments"),
               free=FREE_KEYS)
    if "pose" not in g and "contacts" not in g:
        raise FileFormatError("goal: expected 'pose', 'contacts' or both, got neither")
    pose = None
    if "pose" in g:
        p = g["pose"]
        if not isinstance(p, list) or len(p) != 3:
            raise FileFormatError(f"goal.pose: expected [x, y, phi], got {short(p)}")
        pose = np.array([number(x, f"goal.pose[{i}]") for i, x in enumerate(p)])
    tol = as_object(g.get("tolerance", {}), "goal.tolerance")
    check_keys(tol, "goal.tolerance", optional=("position", "angle"), free=FREE_KEYS)
    pos_tol = number(tol.get("position", POSITION_TOLERANCE_OF_SIZE * size),
                     "goal.tolerance.position", positive=True)
    ang_tol = number(tol.get("angle", ANGLE_TOLERANCE), "goal.tolerance.angle", positive=True)
    raw_c = g.get("contacts", [])
    if not isinstance(raw_c, list) or ("contacts" in g and not raw_c):
        raise FileFormatError(f"goal.contacts: expected a non-empty list of contacts (omit the "
                              f"key for a goal pose only), got {short(raw_c)}")
    contacts = tuple(contact(c, i) for i, c in enumerate(raw_c))
    depth = integer(g.get("max_segments", MAX_SEGMENTS), "goal.max_segments", 1, 50)
    return Goal(pose, pos_tol, ang_tol, contacts, depth)
