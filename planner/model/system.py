"""The quasistatic system of Trinkle & Zeng (1994), Section 3: workpiece, contacts, manipulator.

Conventions (see ``docs/conventions.md``): world frame x right, y up, angles counter-clockwise;
contact normal ``n_i`` points INTO the workpiece; tangent ``t_i = rot90(n_i) = (-n_y, n_x)``
so that ``n_i x t_i = +1`` (out of the plane); ``qdot = (v_x, v_y, omega)`` is the velocity of
the workpiece point at the world origin; contact force ``c_i = (c_in, c_it)`` is the force the
manipulator applies to the workpiece, in the contact frame; relative velocity
``v_i = W_i^T qdot - J_i thetadot`` (eq. 5).

References
----------
J. C. Trinkle and D. C. Zeng, *Prediction of the Quasistatic Planar Motion of a Contacted Rigid
Body*, 1994. Equations (1)-(5).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from functools import lru_cache
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.chain_geometry import ChainGeometry
from planner.model.geometry import (
    check_wrench_matrix,
    contact_points_from_wrench,
    rot90,
    wrench_matrix,
)
from planner.model.validation import (
    as_array,
    as_friction,
    describe_value,
    is_numeric,
    unit_normal,
)
from planner.model.workpiece import WorkpieceGeometry, check_environment


class JointControl(str, Enum):
    """Control mode of one manipulator joint (Section 3.2)."""

    VELOCITY = "velocity"
    EFFORT = "effort"


@dataclass(frozen=True)
class Contact:
    """One point contact given geometrically.

    Parameters
    ----------
    point : (2,) [m]
        Contact point ``r_i`` in the world frame.
    normal : (2,)
        Unit contact normal ``n_i`` pointing into the workpiece, world frame.
    mu : float
        Coulomb friction coefficient ``mu_i >= 0``.
    """

    point: tuple[float, float]
    normal: tuple[float, float]
    mu: float

    def __post_init__(self) -> None:
        p = as_array(self.point, (2,), "contact point")
        n = unit_normal(self.normal, "contact normal")
        mu = as_friction(self.mu, 1, "contact mu")[0]
        object.__setattr__(self, "point", (float(p[0]), float(p[1])))
        object.__setattr__(self, "normal", (float(n[0]), float(n[1])))
        object.__setattr__(self, "mu", float(mu))

    @property
    def tangent(self) -> tuple[float, float]:
        """``t_i = rot90(n_i)``, so that ``n_i x t_i = +1`` (eq. 1)."""
        return (-self.normal[1], self.normal[0])


@dataclass(frozen=True, eq=False)
class System:
    """A planar workpiece in contact with a manipulator (Section 3).

    Attributes
    ----------
    W : (3, 2 n_c)
        Global wrench matrix, columns ``[w_1n w_1t ... ]`` (eqs. 1-2).
    mu : (n_c,)
        Friction coefficients (diagonal of ``U``, eq. 8).
    g_obj : (3,) [N, N, N m]
        External wrench on the workpiece about the world origin (eq. 2).
    J : (2 n_c, n_theta)
        Contact Jacobians stacked per contact, rows ``[j_1n; j_1t; j_2n; ...]``, each
        expressed in its contact frame (eqs. 3, 5).
    control : tuple of JointControl, length n_theta
        Which joints are velocity- and which effort-controlled (Section 3.2).
    joint_inputs : (n_theta,)
        For velocity-controlled joints the commanded ``thetadot_j`` [rad/s or m/s]; for
        effort-controlled joints the commanded effort ``tau_j`` [N m or N].
    g_man : (n_theta,)
        Joint efforts induced by external loads on the links (eq. 3).
    points, normals : (n_c, 2) or None
        Contact geometry when known (always derivable from ``W``).
    virtual_joints : bool
        True when the manipulator was given as contact-point velocities ``J_i thetadot``;
        then ``J`` is the identity and each contact point is a velocity-driven 2-DOF "joint".
    workpiece : WorkpieceGeometry or None
        Scene data for simulators (polygon, mass, centre of mass); changes no prediction.
    environment : tuple of bool, length n_c
        True for a contact with the fixed environment (its manipulator velocity is zero:
        zero Jacobian rows, or a zero contact velocity); scene data, changes no prediction.
    chain : ChainGeometry or None
        The chain, joint positions and contact links a ``manipulator.chain`` system file gave
        ``J`` from; scene data for simulators, changes no prediction.
    """

    W: np.ndarray
    mu: np.ndarray
    g_obj: np.ndarray
    J: np.ndarray
    control: tuple[JointControl, ...]
    joint_inputs: np.ndarray
    g_man: np.ndarray
    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    virtual_joints: bool = False
    workpiece: WorkpieceGeometry | None = None
    environment: tuple[bool, ...] = ()
    chain: ChainGeometry | None = None

    def __post_init__(self) -> None:
        for name in ("W", "mu", "g_obj", "J", "joint_inputs", "g_man", "points", "normals"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "control", tuple(self.control))
        n_c = self.n_contacts
        if self.mu.shape != (n_c,):
            raise InputError(f"mu: expected {n_c} coefficients, got shape {self.mu.shape}")
        if self.J.ndim != 2 or self.J.shape[0] != 2 * n_c:
            raise InputError(
                f"jacobian: expected {2 * n_c} rows (normal and tangent row per contact), "
                f"got shape {self.J.shape}"
            )
        n_t = self.J.shape[1]
        if len(self.control) != n_t or self.joint_inputs.shape != (n_t,):
            raise InputError(
                f"joints: expected one joint per Jacobian column ({n_t}), "
                f"got {len(self.control)} joints"
            )
        if self.g_man.shape != (n_t,):
            raise InputError(f"joint_loads: expected {n_t} values, got shape {self.g_man.shape}")
        env = check_environment(self.environment, self.J, self.joint_inputs, self.virtual_joints)
        object.__setattr__(self, "environment", env)
        if self.workpiece is not None and not isinstance(self.workpiece, WorkpieceGeometry):
            raise InputError(
                "workpiece: expected a WorkpieceGeometry or None, "
                f"got {describe_value(self.workpiece)}"
            )

    # -- sizes and partitions ------------------------------------------------------------
    @property
    def n_contacts(self) -> int:
        """Number of contacts ``n_c``."""
        return self.W.shape[1] // 2

    @property
    def n_joints(self) -> int:
        """Number of manipulator joints ``n_theta``."""
        return self.J.shape[1]

    @property
    def effort_joints(self) -> np.ndarray:
        """Indices of effort-controlled joints (``tau_I`` is input, Section 3.2); read-only,
        shared by every system with the same :attr:`control`."""
        return joint_partition(self.control)[0]

    @property
    def velocity_joints(self) -> np.ndarray:
        """Indices of velocity-controlled joints (``zdot_II`` is input, eq. 24); read-only."""
        return joint_partition(self.control)[1]

    @property
    def dof(self) -> int:
        """``3 + |tau_I|``: kinematic constraints every candidate mode must supply (Sec. 4.7)."""
        return 3 + len(joint_partition(self.control)[0])

    @property
    def tangents(self) -> np.ndarray:
        """``(n_c, 2)`` contact tangents ``t_i = rot90(n_i)``."""
        return rot90(self.normals)

    def with_mu(self, mu: Any) -> System:
        """A copy with other friction coefficients (scalar or ``(n_c,)``)."""
        return dataclasses.replace(self, mu=as_friction(mu, self.n_contacts))

    def with_joint_inputs(self, joint_inputs: Any) -> System:
        """A copy with other joint commands (velocities / efforts per :attr:`control`)."""
        arr = as_array(joint_inputs, (self.n_joints,), "joint_inputs")
        return dataclasses.replace(self, joint_inputs=arr)

    # -- constructors --------------------------------------------------------------------
    @classmethod
    def from_contacts(
        cls,
        contacts: Sequence[Contact] | None = None,
        *,
        points: Any = None,
        normals: Any = None,
        mu: Any = None,
        external_wrench: Any = (0.0, 0.0, 0.0),
        contact_velocities: Any = None,
        jacobian: Any = None,
        joints: Sequence[Any] | None = None,
        joint_loads: Any = None,
        workpiece: WorkpieceGeometry | None = None,
        environment: Sequence[bool] | None = None,
    ) -> System:
        """Build a system from geometric contacts (point, inward unit normal, mu).

        Give either ``contacts`` or ``points``/``normals``/``mu``; and the manipulator either
        as ``contact_velocities`` ((n_c, 2): ``J_i thetadot`` in each contact frame, all
        velocity-controlled) or as ``jacobian`` ((n_c, 2, n_theta)) with ``joints`` (one
        ``{"velocity": v}`` or ``{"effort": tau}`` per column; or a :class:`JointControl`,
        value pair) and optional ``joint_loads`` ``g_man``.  ``workpiece`` and ``environment``
        (one flag per contact) are scene data (see the class docstring).
        """
        if contacts is not None:
            if points is not None or normals is not None:
                raise InputError("give either contacts or points/normals, not both")
            contacts = list(contacts)
            if not contacts:
                raise InputError("contacts: expected at least one contact, got none")
            pts = np.array([c.point for c in contacts], dtype=float)
            nrm = np.array([c.normal for c in contacts], dtype=float)
            mu_arr = np.array([c.mu for c in contacts], dtype=float)
        else:
            if points is None or normals is None:
                raise InputError("expected contacts, or points and normals")
            pts = as_array(points, (None, 2), "points")
            if pts.shape[0] == 0:
                raise InputError("points: expected at least one contact, got none")
            raw_n = as_array(normals, (pts.shape[0], 2), "normals")
            nrm = np.array(
                [unit_normal(v, f"normal of contact {i + 1}") for i, v in enumerate(raw_n)]
            )
            mu_arr = as_friction(0.0 if mu is None else mu, pts.shape[0])
        W = wrench_matrix(pts, nrm)
        return cls._assemble(
            W, mu_arr, external_wrench, contact_velocities, jacobian, joints, joint_loads,
            pts, nrm, workpiece, environment,
        )

    @classmethod
    def from_wrench_matrix(
        cls,
        W: Any,
        mu: Any,
        *,
        external_wrench: Any = (0.0, 0.0, 0.0),
        contact_velocities: Any = None,
        jacobian: Any = None,
        joints: Sequence[Any] | None = None,
        joint_loads: Any = None,
        workpiece: WorkpieceGeometry | None = None,
        environment: Sequence[bool] | None = None,
    ) -> System:
        """Build a system from the paper's wrench matrix ``W`` (eq. 1, as in eqs. 37 and 42).

        ``W`` is checked with :func:`check_wrench_matrix` and used as given. The contact
        points follow from it (:func:`contact_points_from_wrench`).
        """
        Wm = check_wrench_matrix(W)
        n_c = Wm.shape[1] // 2
        mu_arr = as_friction(mu, n_c)
        nrm = Wm[0:2, 0::2].T.copy()
        pts = contact_points_from_wrench(Wm)
        return cls._assemble(
            Wm, mu_arr, external_wrench, contact_velocities, jacobian, joints, joint_loads,
            pts, nrm, workpiece, environment,
        )

    @classmethod
    def _assemble(
        cls,
        W: np.ndarray,
        mu: np.ndarray,
        external_wrench: Any,
        contact_velocities: Any,
        jacobian: Any,
        joints: Sequence[Any] | None,
        joint_loads: Any,
        points: np.ndarray,
        normals: np.ndarray,
        workpiece: WorkpieceGeometry | None = None,
        environment: Sequence[bool] | None = None,
    ) -> System:
        n_c = W.shape[1] // 2
        g_obj = as_array(external_wrench, (3,), "external_wrench")
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
        return cls(
            W=W, mu=mu, g_obj=g_obj, J=J, control=control, joint_inputs=inputs, g_man=g_man,
            points=points, normals=normals, virtual_joints=virtual, workpiece=workpiece,
            environment=() if environment is None else environment,  # type: ignore[arg-type]
        )


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
