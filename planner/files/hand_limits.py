"""Joint limits of a hand file: the ``limits`` section (docs/file-formats.md, "Hand file").

A robot's joints cannot exert any effort or change it at any rate.  The section gives, per joint
(keyed by its name, :meth:`planner.model.hand.Hand.joint_names`: the finger's name, or
``finger.link`` in a chain), any of

* ``effort``: ``[min, max]`` or one number ``M`` meaning ``[-M, M]`` -- the effort the joint
  can exert (N m revolute, N prismatic; ``min < max``);
* ``effort_rate``: the largest change of its effort command per second (N m/s or N/s, > 0);
* ``speed``: the largest rate of a velocity-controlled joint (rad/s or m/s, > 0).

A joint that is not listed is unlimited.  ``{"limits": {"effort": {"left": 2.0, "right": [-1,
0.5]}, "effort_rate": {"left": 4.0}}}``.  The planner keeps every command inside the limits or
says which joint lacks how much (:mod:`planner.plan.policies`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import FileFormatError
from planner.files.fields import FREE_KEYS, as_object, check_keys, number, short

LIMIT_KINDS = ("effort", "effort_rate", "speed")


@dataclass(frozen=True)
class JointLimits:
    """Per joint (joint order): ``effort_lo``, ``effort_hi`` ``(n_joints,)`` (N m or N; ``-inf``
    / ``inf`` when unlimited), ``effort_rate`` ``(n_joints,)`` (N m/s or N/s; ``inf``) and
    ``speed`` ``(n_joints,)`` (rad/s or m/s; ``inf``)."""

    effort_lo: tuple[float, ...]
    effort_hi: tuple[float, ...]
    effort_rate: tuple[float, ...]
    speed: tuple[float, ...]

    @classmethod
    def none(cls, n_joints: int) -> JointLimits:
        """No limit on any of ``n_joints`` joints."""
        inf = (math.inf,) * n_joints
        return cls((-math.inf,) * n_joints, inf, inf, inf)

    @property
    def limited(self) -> bool:
        """True when any joint has any finite limit."""
        return not all(math.isinf(x) for x in (*self.effort_lo, *self.effort_hi,
                                              *self.effort_rate, *self.speed))

    def effort_box(self, joints: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` ``(len(joints),)`` the effort limits of ``joints``."""
        return (np.array([self.effort_lo[j] for j in joints], dtype=float),
                np.array([self.effort_hi[j] for j in joints], dtype=float))


def parse_limits(raw: Any, joint_names: Sequence[str], where: str = "limits") -> JointLimits:
    """The ``limits`` section (module docstring) for a hand whose joints are ``joint_names``.
    Raises :class:`FileFormatError` naming the key, what was expected and what came."""
    sec = as_object(raw, where)
    check_keys(sec, where, optional=LIMIT_KINDS, free=FREE_KEYS)
    n = len(joint_names)
    out = JointLimits.none(n)
    lo, hi = list(out.effort_lo), list(out.effort_hi)
    rate, speed = list(out.effort_rate), list(out.speed)
    for kind in LIMIT_KINDS:
        if kind not in sec:
            continue
        per = as_object(sec[kind], f"{where}.{kind}")
        for name, value in per.items():
            at = f"{where}.{kind}.{name}"
            if name not in joint_names:
                raise FileFormatError(f"{at}: expected a joint name, one of "
                                      f"{list(joint_names)}, got {short(name)}")
            j = list(joint_names).index(name)
            if kind == "effort":
                lo[j], hi[j] = _effort_range(value, at)
            elif kind == "effort_rate":
                rate[j] = number(value, at, positive=True)
            else:
                speed[j] = number(value, at, positive=True)
    return JointLimits(tuple(lo), tuple(hi), tuple(rate), tuple(speed))


def _effort_range(value: Any, where: str) -> tuple[float, float]:
    if isinstance(value, list):
        if len(value) != 2:
            raise FileFormatError(f"{where}: expected [min, max] or one number M (meaning "
                                  f"[-M, M]), got {short(value)}")
        a, b = number(value[0], f"{where}[0]"), number(value[1], f"{where}[1]")
        if not a < b:
            raise FileFormatError(f"{where}: expected min < max, got {short(value)}")
        return a, b
    m = number(value, where, positive=True)
    return -m, m


def hand_limits(data: Mapping[str, Any], joint_names: Sequence[str]) -> JointLimits:
    """The limits of a hand file's parsed content ``data`` (none when it has no section)."""
    if "limits" not in data:
        return JointLimits.none(len(joint_names))
    return parse_limits(data["limits"], joint_names)
