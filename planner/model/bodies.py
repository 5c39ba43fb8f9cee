"""Several workpieces: the block-structured wrench matrix of ``n_b >= 1`` rigid bodies.

Trinkle & Zeng (1994) treat one workpiece and name several as future work (Sec. 6). This
module carries the model over, body by body (derivation in ``docs/notation.md``, "Several
workpieces"; conventions in ``docs/conventions.md``):

* the unknown workpiece velocity is ``qdot = (qdot_1, ..., qdot_nb)``, ``(3 n_b,)``, each
  ``qdot_a = (v_x, v_y, omega)`` of body ``a``'s point at the world origin;
* contact ``i`` joins body ``a_i`` (the normal ``n_i`` points **into** ``a_i``; ``c_i`` is the
  force applied **to** ``a_i``) and an *other side* ``b_i``: another workpiece, or
  :data:`MANIPULATOR` (the manipulator or the fixed environment, as in the paper);
* ``W`` is ``(3 n_b, 2 n_c)``: contact ``i``'s column pair is ``W_i^1 = [n_i, t_i; r_i x n_i,
  r_i x t_i]`` (eq. 1) in the rows of body ``a_i`` and ``-W_i^1`` in the rows of body ``b_i``
  (Newton's third law: the other body receives ``-c_i`` at the same point);
* the equilibrium of every body is then ``W c + g_obj = 0`` with ``g_obj (3 n_b,)`` (eq. 2
  per body), and ``W_i^T qdot`` is the velocity of ``a_i``'s material point at ``r_i`` minus
  that of ``b_i``'s, in the contact frame, so ``v_i = W_i^T qdot - J_i thetadot`` (eq. 5) is the
  relative velocity of the two sides (a contact between workpieces has ``J_i = 0``).

With these, eqs. (12)-(28) hold verbatim with ``3`` replaced by ``n_q = 3 n_b``; the
candidate count of eq. (49) uses ``2 n_R + n_S = 3 n_b + |tau_I|``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.geometry import wrench_matrix
from planner.model.validation import describe_value

#: Other side of a contact that touches no other workpiece: the manipulator or the environment.
MANIPULATOR = -1


def check_contact_bodies(bodies: Any, n_contacts: int, n_bodies: int) -> tuple[tuple[int, int],
                                                                              ...]:
    """Per-contact body pairs ``((a_1, b_1), ...)`` checked: ``0 <= a_i < n_b``, ``b_i`` is
    :data:`MANIPULATOR` or another body ``!= a_i``. ``()`` means every contact is
    ``(0, MANIPULATOR)`` (one workpiece, the paper's case)."""
    if isinstance(n_bodies, bool) or not isinstance(n_bodies, (int, np.integer)) or n_bodies < 1:
        raise InputError(f"n_bodies: expected an integer >= 1, got {describe_value(n_bodies)}")
    if not isinstance(bodies, (tuple, list)):
        raise InputError(
            f"contact bodies: expected one (body, other) pair per contact, "
            f"got {describe_value(bodies)}"
        )
    if len(bodies) == 0:
        if n_bodies != 1:
            raise InputError(
                f"contact bodies: expected one (body, other) pair per contact with "
                f"{n_bodies} workpieces, got none"
            )
        return ((0, MANIPULATOR),) * n_contacts
    if len(bodies) != n_contacts:
        raise InputError(
            f"contact bodies: expected {n_contacts} (body, other) pairs (one per contact), "
            f"got {len(bodies)}"
        )
    out = []
    for i, pair in enumerate(bodies):
        ok = isinstance(pair, (tuple, list)) and len(pair) == 2 and all(
            isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in pair)
        if not ok:
            raise InputError(
                f"contact {i + 1}: expected a (body, other) pair of integers, "
                f"got {describe_value(pair)}"
            )
        a, b = int(pair[0]), int(pair[1])
        if not 0 <= a < n_bodies:
            raise InputError(
                f"contact {i + 1}: expected a body index in 0..{n_bodies - 1}, got {a}"
            )
        if b != MANIPULATOR and not 0 <= b < n_bodies:
            raise InputError(
                f"contact {i + 1}: expected the other side {MANIPULATOR} (manipulator or "
                f"environment) or a body index in 0..{n_bodies - 1}, got {b}"
            )
        if a == b:
            raise InputError(
                f"contact {i + 1}: expected two different bodies, got body {a} on both sides"
            )
        out.append((a, b))
    return tuple(out)


def multibody_wrench_matrix(points: Any, normals: Any,
                            bodies: Sequence[tuple[int, int]], n_bodies: int) -> np.ndarray:
    """Block-structured wrench matrix of ``n_b`` workpieces (eqs. 1-2 per body).

    Parameters
    ----------
    points : (n_c, 2) [m]
        Contact points ``r_i``, world frame.
    normals : (n_c, 2)
        Unit normals ``n_i`` pointing into body ``a_i``.
    bodies : n_c pairs ``(a_i, b_i)``
        Checked by :func:`check_contact_bodies`.
    n_bodies : int
        ``n_b``.

    Returns
    -------
    W : (3 n_b, 2 n_c)
        Rows ``3a:3a+3`` hold body ``a``'s wrenches: column pair ``i`` is ``W_i^1`` (eq. 1) when
        ``a = a_i``, ``-W_i^1`` when ``a = b_i``, zero otherwise.
    """
    W1 = wrench_matrix(points, normals)
    n_c = W1.shape[1] // 2
    pairs = check_contact_bodies(list(bodies), n_c, n_bodies)
    W = np.zeros((3 * n_bodies, 2 * n_c))
    for i, (a, b) in enumerate(pairs):
        W[3 * a:3 * a + 3, 2 * i:2 * i + 2] = W1[:, 2 * i:2 * i + 2]
        if b != MANIPULATOR:
            W[3 * b:3 * b + 3, 2 * i:2 * i + 2] = -W1[:, 2 * i:2 * i + 2]
    return W


def check_body_contacts_still(bodies: Sequence[tuple[int, int]], J: np.ndarray,
                              joint_inputs: np.ndarray, virtual: bool) -> None:
    """A contact between two workpieces does not involve the manipulator: its Jacobian rows
    are zero, or with contact velocities (``virtual``) its ``J_i thetadot`` is ``(0, 0)``
    (eq. 5: ``v_i = W_i^T qdot`` is then the relative velocity of the two bodies)."""
    for i, (_, b) in enumerate(bodies):
        if b == MANIPULATOR:
            continue
        rows = J[2 * i:2 * i + 2]
        if virtual:
            v = joint_inputs[2 * i:2 * i + 2]
            if np.any(v != 0):
                raise InputError(
                    f"contact {i + 1}: expected zero manipulator velocity for a contact between "
                    f"two workpieces, got contact velocity {v.tolist()}"
                )
        elif np.any(rows != 0):
            raise InputError(
                f"contact {i + 1}: expected zero Jacobian rows for a contact between two "
                f"workpieces, got rows {rows.tolist()}"[:300]
            )


def body_velocity_at(qdot: np.ndarray, body: int, point: Any) -> np.ndarray:
    """``(2,)`` [m/s] velocity of body ``body``'s material point at ``point`` (world frame):
    ``v + omega z x r`` from ``qdot_body = (v_x, v_y, omega)`` (Sec. 3)."""
    q = np.asarray(qdot, dtype=float)[3 * body:3 * body + 3]
    r = np.asarray(point, dtype=float)
    return np.array([q[0] - q[2] * r[1], q[1] + q[2] * r[0]])
