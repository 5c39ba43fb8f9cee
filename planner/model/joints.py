"""Manipulator joints of Trinkle & Zeng (1994), Section 3.2: velocity- or effort-controlled.

Each joint's command is either a velocity ``thetadot_j`` (the joint is in ``zdot_II``, eq. 24)
or an effort ``tau_j`` (in ``tau_I``, eq. 26).
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum
from functools import lru_cache
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.validation import as_array, describe_value, is_numeric


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


def manipulator_matrices(
    n_c: int, contact_velocities: Any, jacobian: Any, joints: Sequence[Any] | None,
    joint_loads: Any,
) -> tuple[np.ndarray, tuple[JointControl, ...], np.ndarray, np.ndarray, bool]:
    """``(J (2 n_c, n_theta), control, joint_inputs, g_man, virtual)`` of a manipulator given
    as ``contact_velocities`` ``(n_c, 2)`` (virtual joints, ``J = I``) or as ``jacobian``
    ``(n_c, 2, n_theta)`` with one ``joints`` command per column (eqs. 3, 5)."""
    if (contact_velocities is None) == (jacobian is None):
        raise InputError(
            "manipulator: expected exactly one of contact_velocities or jacobian"
        )
    if contact_velocities is not None:
        if joints is not None:
            raise InputError(
                "manipulator: joints are given with a jacobian, not with contact_velocities"
            )
        u = as_array(contact_velocities, (n_c, 2), "contact_velocities")
        J = np.eye(2 * n_c)
        control = (JointControl.VELOCITY,) * (2 * n_c)
        inputs = u.reshape(-1)
        g_man = (
            np.zeros(2 * n_c)
            if joint_loads is None
            else as_array(joint_loads, (2 * n_c,), "joint_loads")
        )
        virtual = True
    else:
        Jarr = np.asarray(jacobian, dtype=float) if is_numeric(jacobian) else None
        if Jarr is None or Jarr.ndim != 3 or Jarr.shape[:2] != (n_c, 2):
            got = None if Jarr is None else Jarr.shape
            raise InputError(
                f"jacobian: expected shape ({n_c}, 2, n_theta) (per contact a normal row "
                f"and a tangent row), got {got}"
            )
        Jarr = as_array(Jarr, (n_c, 2, None), "jacobian")
        n_t = Jarr.shape[2]
        J = Jarr.reshape(2 * n_c, n_t)
        if joints is None or len(joints) != n_t:
            raise InputError(
                f"joints: expected {n_t} joints (one per Jacobian column), "
                f"got {0 if joints is None else len(joints)}"
            )
        control_list, input_list = [], []
        for j, spec in enumerate(joints):
            c, v = parse_joint(spec, j)
            control_list.append(c)
            input_list.append(v)
        control = tuple(control_list)
        inputs = np.array(input_list, dtype=float)
        g_man = (
            np.zeros(n_t)
            if joint_loads is None
            else as_array(joint_loads, (n_t,), "joint_loads")
        )
        virtual = False
    return J, control, inputs, g_man, virtual
