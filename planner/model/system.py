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
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.bodies import (
    check_body_contacts_still,
    check_contact_bodies,
    multibody_wrench_matrix,
)
from planner.model.chain_geometry import ChainGeometry
from planner.model.contact import Contact
from planner.model.geometry import (
    check_wrench_matrix,
    contact_points_from_wrench,
    rot90,
    wrench_matrix,
)
from planner.model.joints import JointControl, joint_partition, manipulator_matrices
from planner.model.layout import (
    FeatureContact,
    Layout,
    Surface,
    check_contacts_on_bodies,
    resolve,
)
from planner.model.validation import (
    as_array,
    as_friction,
    describe_value,
    is_numeric,
    unit_normal,
)
from planner.model.workpiece import WorkpieceGeometry, check_environment

__all__ = ["Contact", "JointControl", "System"]


@dataclass(frozen=True, eq=False)
class System:
    """Planar workpieces in contact with a manipulator (Section 3; ``n_b >= 1`` workpieces,
    Sec. 6, see :mod:`planner.model.bodies`).

    Attributes
    ----------
    W : (n_q, 2 n_c), n_q = 3 n_b
        Global wrench matrix, columns ``[w_1n w_1t ... ]`` (eqs. 1-2); with several workpieces
        block-structured, rows ``3a:3a+3`` for body ``a`` (:func:`multibody_wrench_matrix`).
    mu : (n_c,)
        Friction coefficients (diagonal of ``U``, eq. 8).
    g_obj : (n_q,) [N, N, N m]
        External wrench on each workpiece about the world origin (eq. 2), stacked per body.
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
    contact_bodies : tuple of (a_i, b_i), length n_c
        Body ``a_i`` the normal points into and the other side ``b_i`` (another body, or
        ``MANIPULATOR = -1`` for the manipulator or environment); ``()`` at construction means
        one workpiece, every contact ``(0, -1)``. Consistent with ``W``'s blocks.
    workpieces : tuple of WorkpieceGeometry
        Scene data of each body when ``n_b > 1`` (``()`` or one per body; with one body use
        ``workpiece``); changes no prediction.
    friction_groups : tuple of (name, contact indices)
        Named coefficients shared by several contacts (0-based indices; ``()``: none).
    layout : planner.model.layout.Layout or None
        The geometry-first description the system was computed from (:meth:`from_geometry`;
        surfaces, fingers, gravity, features); scene data, changes no prediction.
    contact_labels : tuple of str
        Per contact, where it sits and what touches it (``()`` when not known).
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
    contact_bodies: tuple[tuple[int, int], ...] = ()
    workpieces: tuple[WorkpieceGeometry, ...] = ()
    friction_groups: tuple[tuple[str, tuple[int, ...]], ...] = ()
    layout: Layout | None = None
    contact_labels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("W", "mu", "g_obj", "J", "joint_inputs", "g_man", "points", "normals"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "control", tuple(self.control))
        n_c = self.n_contacts
        if self.W.ndim != 2 or self.W.shape[0] < 3 or self.W.shape[0] % 3:
            raise InputError(
                f"W: expected shape (3 n_b, 2 n_c) (three rows per workpiece), got {self.W.shape}"
            )
        if self.g_obj.shape != (self.n_q,):
            raise InputError(
                f"external_wrench: expected {self.n_q} values (f_x, f_y, m_z per workpiece), "
                f"got shape {self.g_obj.shape}"
            )
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
        pairs = check_contact_bodies(self.contact_bodies, n_c, self.n_bodies)
        object.__setattr__(self, "contact_bodies", pairs)
        check_body_contacts_still(pairs, self.J, self.joint_inputs, self.virtual_joints)
        wps = tuple(self.workpieces)
        if wps and (len(wps) != self.n_bodies
                    or not all(isinstance(w, WorkpieceGeometry) for w in wps)):
            raise InputError(
                f"workpieces: expected {self.n_bodies} WorkpieceGeometry (one per body) or none, "
                f"got {describe_value(self.workpieces)}"
            )
        object.__setattr__(self, "workpieces", wps)
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
    def n_q(self) -> int:
        """``3 n_b``: workpiece velocity unknowns ``qdot`` (rows of ``W``)."""
        return self.W.shape[0]

    @property
    def n_bodies(self) -> int:
        """Number of workpieces ``n_b`` (1 in the paper)."""
        return self.W.shape[0] // 3

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
        """``3 n_b + |tau_I|``: kinematic constraints every candidate mode must supply
        (Sec. 4.7, eq. 49; ``3 + |tau_I|`` for one workpiece)."""
        return self.n_q + len(joint_partition(self.control)[0])

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
        external_wrench: Any = None,
        contact_velocities: Any = None,
        jacobian: Any = None,
        joints: Sequence[Any] | None = None,
        joint_loads: Any = None,
        workpiece: WorkpieceGeometry | None = None,
        environment: Sequence[bool] | None = None,
        bodies: Sequence[tuple[int, int]] | None = None,
        n_bodies: int | None = None,
        workpieces: Sequence[WorkpieceGeometry] = (),
    ) -> System:
        """Build a system from geometric contacts (point, inward unit normal, mu).

        Give either ``contacts`` or ``points``/``normals``/``mu``; and the manipulator either
        as ``contact_velocities`` ((n_c, 2): ``J_i thetadot`` in each contact frame, all
        velocity-controlled) or as ``jacobian`` ((n_c, 2, n_theta)) with ``joints`` (one
        ``{"velocity": v}`` or ``{"effort": tau}`` per column; or a :class:`JointControl`,
        value pair) and optional ``joint_loads`` ``g_man``.  ``workpiece`` and ``environment``
        (one flag per contact) are scene data (see the class docstring).

        Several workpieces (:mod:`planner.model.bodies`): ``bodies`` gives per contact
        ``(a_i, b_i)``, the body the normal points into and the other side (a body index or
        ``-1`` for the manipulator or environment); ``n_bodies`` defaults to one more than the
        largest body index; ``external_wrench`` is then ``(3 n_b,)`` or ``(n_b, 3)`` (one load
        per body, default zeros) and ``workpieces`` one geometry per body (scene data).
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
        if bodies is None and n_bodies in (None, 1):
            W = wrench_matrix(pts, nrm)
            pairs: tuple[tuple[int, int], ...] = ()
        else:
            raw = [] if bodies is None else list(bodies)
            if n_bodies is None:
                n_bodies = 1 + max((max(int(x) for x in p) for p in raw
                                    if isinstance(p, (tuple, list)) and len(p) == 2
                                    and all(isinstance(x, (int, np.integer)) for x in p)),
                                   default=0)
            pairs = check_contact_bodies(raw, pts.shape[0], n_bodies)
            W = multibody_wrench_matrix(pts, nrm, pairs, n_bodies)
        if workpiece is not None or workpieces:
            check_contacts_on_bodies(pts, nrm, pairs, tuple(workpieces) or (workpiece,))
        return cls._assemble(
            W, mu_arr, external_wrench, contact_velocities, jacobian, joints, joint_loads,
            pts, nrm, workpiece, environment, pairs, tuple(workpieces),
        )

    @classmethod
    def from_geometry(
        cls,
        workpieces: WorkpieceGeometry | Sequence[WorkpieceGeometry | None] | None,
        contacts: Sequence[FeatureContact],
        *,
        surfaces: Sequence[Surface] = (),
        gravity: Any = None,
        external_wrench: Any = None,
        friction: dict[str, float] | None = None,
        **manipulator: Any,
    ) -> System:
        """Build a system from its geometry (:mod:`planner.model.layout`): the weight and its
        moment from ``gravity`` (m/s^2) and each workpiece's mass and centre of mass, contact
        points and normals from features, contact velocities from the world-frame motion of the
        ``surfaces`` and fingers they touch, coefficients from numbers or ``friction`` groups.

        ``workpieces``: one :class:`WorkpieceGeometry` or one per body (None: a body without
        geometry, its contacts then need ``point`` and ``normal``); ``external_wrench``:
        ``(3,)`` or ``(n_b, 3)`` besides the weight.  ``manipulator``: ``jacobian``/``joints``/
        ``joint_loads`` as in :meth:`from_contacts` instead of the surfaces' motion (no contact
        may then touch a moving surface or finger).
        """
        wps = ((workpieces,) if isinstance(workpieces, WorkpieceGeometry) or workpieces is None
               else tuple(workpieces))
        ext = None if external_wrench is None else np.reshape(
            as_array(external_wrench, (None,), "external_wrench")
            if np.ndim(external_wrench) == 1 else np.asarray(external_wrench, float), (-1, 3))
        layout = Layout(wps, tuple(contacts), tuple(surfaces), gravity, ext, dict(friction or {}))
        r = resolve(layout)
        if manipulator and any(r.moving):
            raise InputError("manipulator: expected no moving surface or finger when the "
                             "manipulator is given, got contacts "
                             f"{[i + 1 for i, m in enumerate(r.moving) if m]} on moving ones")
        kw: dict[str, Any] = manipulator or {"contact_velocities": r.contact_velocities}
        multi = len(wps) > 1
        system = cls.from_contacts(
            points=r.points, normals=r.normals, mu=r.mu, external_wrench=r.g_obj,
            environment=r.environment, bodies=r.bodies if multi else None,
            n_bodies=len(wps) if multi else None, workpiece=None if multi else wps[0],
            workpieces=tuple(w for w in wps if w is not None) if multi else (), **kw)
        return dataclasses.replace(system, friction_groups=r.groups, layout=layout,
                                   contact_labels=r.labels)

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
        contact_bodies: tuple[tuple[int, int], ...] = (),
        workpieces: tuple[WorkpieceGeometry, ...] = (),
    ) -> System:
        n_c, n_q = W.shape[1] // 2, W.shape[0]
        g_raw = np.asarray(external_wrench, dtype=float) if is_numeric(external_wrench) else None
        if external_wrench is None:
            external_wrench = np.zeros(n_q)
        elif g_raw is not None and g_raw.shape == (n_q // 3, 3):
            external_wrench = g_raw.reshape(-1)
        g_obj = as_array(external_wrench, (n_q,), "external_wrench")
        J, control, inputs, g_man, virtual = manipulator_matrices(
            n_c, contact_velocities, jacobian, joints, joint_loads)
        return cls(
            W=W, mu=mu, g_obj=g_obj, J=J, control=control, joint_inputs=inputs, g_man=g_man,
            points=points, normals=normals, virtual_joints=virtual, workpiece=workpiece,
            environment=() if environment is None else environment,  # type: ignore[arg-type]
            contact_bodies=contact_bodies, workpieces=workpieces,
        )
