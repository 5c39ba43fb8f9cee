"""Manipulator joints of Trinkle & Zeng (1994), Section 3.2: velocity- or effort-controlled.

Each joint's command is either a velocity ``thetadot_j`` (the joint is in ``zdot_II``, eq. 24)
or an effort ``tau_j`` (in ``tau_I``, eq. 26).
"""

from __future__ import annotations

from enum import Enum
from functools import lru_cache
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.validation import as_array, describe_value


class JointControl(str, Enum):
    """Control mode of one manipulator joint (Section 3.2)."""

    VELOCITY = "velocity"
    EFFORT = "effort"


@lru_cache(maxsize=256)
def joint_partition(control: tuple[JointControl, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``(effort_joints, velocity_joints)``: read-only index arrays of a control partition
    (Section 3.2), cached per partition (it depends on nothing else)."""
    E = np.array([j for j, c in enumerate(control) if c is JointControl.EFFORT], dtype=int)
    V = np.array([j for j, c in enumerate(control) if c is JointControl.VELOCITY], dtype=int)
    E.setflags(write=False)
    V.setflags(write=False)
    return E, V


def parse_joint(spec: Any, index: int) -> tuple[JointControl, float]:
    """Parse one joint command: ``{"velocity": v}`` or ``{"effort": tau}`` (exactly one)."""
    if isinstance(spec, tuple) and len(spec) == 2 and isinstance(spec[0], JointControl):
        value = as_array(spec[1], (), f"joint {index + 1}")
        return spec[0], float(value)
    if not isinstance(spec, dict):
        raise InputError(
            f"joint {index + 1}: expected {{\"velocity\": v}} or {{\"effort\": tau}}, "
            f"got {describe_value(spec)}"
        )
    has_v = "velocity" in spec
    has_e = "effort" in spec
    if has_v == has_e:
        raise InputError(
            f"joint {index + 1}: expected exactly one of 'velocity' or 'effort', "
            f"got {sorted(k for k in spec if k in ('velocity', 'effort')) or 'neither'}"
        )
    key = "velocity" if has_v else "effort"
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(
            f"joint {index + 1}: expected a number for '{key}', got {describe_value(value)}"
        )
    try:
        val = float(value)
    except OverflowError:
        val = float("inf")
    if not np.isfinite(val):
        raise InputError(f"joint {index + 1}: expected a finite '{key}', got {str(value)[:40]}")
    return (JointControl.VELOCITY if has_v else JointControl.EFFORT), val
