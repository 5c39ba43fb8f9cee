"""Closing a hand configuration on the constraints of a contact mode (eqs. 13-16).

A segment keeps a contact mode.  At the position level its kinematic constraints are

* every maintained contact (``R`` rolling/sticking or ``S`` sliding) keeps its gap zero:
  ``g_i(q) = 0``, whose rate is the normal relative velocity ``v_in = w_in^T qdot - j_in
  thetadot`` (eqs. 5, 13-14);
* a rolling/sticking contact also keeps its tangential relative velocity zero, ``v_it = w_it^T
  qdot - j_it thetadot = 0`` (eq. 13 with both rows of an ``R`` contact, Sec. 4.1);
* a breaking contact (``B``, eq. 16 with ``v_in > 0``) is released: it is not a constraint (the
  caller leaves it out of the hand's contacts).

:func:`close_configuration` solves them for the coordinates not held (Gauss-Newton): the gap
rows at the position level, the sticking rows linearised (each step keeps the sticking
contacts' material points together to first order; the segment's integrator follows the mode's
velocities, which satisfy them exactly).  Each step is the minimum-norm least-squares solution
of the stacked rows, with the rank taken from the singular values
(:data:`RANK_RTOL`), so a constraint set with more rows than free coordinates (redundant
contacts: a block lying in the corner of a table and a wall) or fewer (a finger left free to
move along the contact) closes as long as it is consistent; the number of coordinates the
constraints fix is that rank, not the number of contacts (:func:`constraint_rank`).  A square,
full-rank gap system without sticking rows takes the plain Newton step, the same as a
determinate closure.

Differences to the paper: the paper states eqs. 13-16 for velocities; the closure enforces the
gaps at the position level (they are exact functions of ``q``, :meth:`Hand.gaps`) and the
tangential rows at the velocity level only.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.geometry import rot90


class ContactHand(Protocol):
    """What the closure needs of :class:`planner.model.hand.Hand` (which delegates here; a
    protocol keeps the two modules free of an import circle)."""

    @property
    def contacts(self) -> Any: ...

    @property
    def environment(self) -> Any: ...

    @property
    def fingers(self) -> Any: ...

    @property
    def n_contacts(self) -> int: ...

    @property
    def n_joints(self) -> int: ...

    @property
    def length_scale(self) -> float: ...

    def check_q(self, q: Any) -> np.ndarray: ...

    def gaps(self, q: Any) -> np.ndarray: ...

    def gap_jacobian(self, q: Any) -> np.ndarray: ...

    def jacobian(self, q: Any) -> np.ndarray: ...

    def contact_geometry(self, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

#: Relative singular-value cut-off of the constraint rank (of the largest singular value of the
#: equilibrated rows: each row has unit norm).  Rows whose independent part is below it are
#: counted as dependent (redundant contacts); derived in docs/planning.md ("Closure").
RANK_RTOL = 1e-9
#: Largest gap (fraction of the workpiece size) at which a least-squares closure that stops
#: improving (the gap falls by less than half in a Newton step) is accepted as converged: the
#: round-off floor of the stacked, row-scaled solve lies far below it, and 1e-10 of the size is
#: below every tolerance the planner judges contacts by (1e-6 of the size, docs/planning.md).
STALL = 1e-10


def contact_name(hand: ContactHand, i: int) -> str:
    """Contact ``i`` (0-based) as the outputs number it -- ``contact i + 1``, the index in mode
    labels -- with its features: ``"contact 2 (vertex 3 on the palm)"``."""
    c = hand.contacts[i]
    if c.kind == "palm":
        what = f"vertex {c.vertex} on the palm"
    elif c.kind == "surface":
        what = f"vertex {c.vertex} on the {hand.environment[c.surface][0]}"
    elif c.kind == "side":
        what = f"vertex {c.vertex} on {hand.fingers[c.finger].name}'s side"
    else:
        what = f"{hand.fingers[c.finger].name}'s tip on edge {c.edge}"
    return f"contact {i + 1} ({what})"


def contact_rate_rows(hand: ContactHand, q: Any, component: int) -> np.ndarray:
    """``(n_c, 3 + F)``: eq. 5's rows of each contact along its normal (``component`` 0,
    ``n_i``: the gap rate) or its tangent (1, ``t_i = rot90(n_i)``) per state rate ``d/dt (x,
    y, phi, theta)``: ``d^T qdot - j_i thetadot`` with ``qdot`` the twist about the world
    origin, which the pose rates give by ``v0 = (xdot, ydot) - phidot rot90((x, y))``."""
    q = np.asarray(q, dtype=float)
    pts, nrm, _ = hand.contact_geometry(q)
    Jc = hand.jacobian(q)[:, component, :]
    out = np.zeros((hand.n_contacts, 3 + hand.n_joints))
    o = q[:2]
    for i in range(hand.n_contacts):
        d, p = (nrm[i] if component == 0 else rot90(nrm[i])), pts[i]
        m = p[0] * d[1] - p[1] * d[0]
        # twist (v0, w): d.v0 + m w ; v0 = (xd, yd) - w rot90(o)
        out[i, 0:2] = d
        out[i, 2] = m - d @ rot90(o)
        out[i, 3:] = -Jc[i]
    return out


def tangent_jacobian(hand: ContactHand, q: Any) -> np.ndarray:
    """``(n_c, 3 + F)``: the tangential relative velocity ``v_it`` of each contact per state rate
    ``d/dt (x, y, phi, theta)`` (eq. 5's tangential rows ``w_it^T qdot - j_it thetadot``; ``t =
    rot90(n)``, docs/conventions.md).  Units: m/s per (m/s, m/s, rad/s, joint rate)."""
    return contact_rate_rows(hand, q, 1)


def constraint_rows(hand: ContactHand, q: np.ndarray, sticking: Sequence[int]) -> np.ndarray:
    """``(n_c + n_R, 3 + F)``: the gap rows of every contact, then the tangential rows of the
    sticking ones (module docstring)."""
    G = hand.gap_jacobian(q)
    if not len(sticking):
        return G
    return np.vstack([G, tangent_jacobian(hand, q)[list(sticking)]])


def constraint_rank(A: np.ndarray) -> int:
    """Numerical rank of constraint rows ``A`` (each row scaled to unit norm first; singular
    values below :data:`RANK_RTOL` of the largest are dropped)."""
    if A.size == 0:
        return 0
    norms = np.linalg.norm(A, axis=1)
    An = A[norms > 0] / norms[norms > 0, None]
    if An.size == 0:
        return 0
    s = np.linalg.svd(An, compute_uv=False)
    return int(np.count_nonzero(s > RANK_RTOL * s[0]))


def _check_sticking(hand: ContactHand, sticking: Sequence[int]) -> tuple[int, ...]:
    out = tuple(int(i) for i in sticking)
    bad = [i for i in out if not 0 <= i < hand.n_contacts]
    if bad or len(set(out)) != len(out):
        raise InputError(f"close: expected distinct sticking contact indices in [0, "
                         f"{hand.n_contacts - 1}], got {list(out)}")
    return out


def close_configuration(hand: ContactHand, q: Any, fixed: Sequence[int], *,
                        sticking: Sequence[int] = (), tol: float = 1e-12,
                        max_iter: int = 50) -> np.ndarray:
    """Solve the mode's constraints (module docstring) for the coordinates not in ``fixed``.

    ``q``: (3 + F,) start (m, rad); ``fixed``: indices of ``q`` held; ``sticking``: indices of
    the contacts in mode ``R``.  Converged when every gap is within ``tol`` of the workpiece
    size.  Raises :class:`DegenerateError` naming the contacts that stay open when the
    constraints are inconsistent or Newton does not converge, and when a square gap system is
    singular."""
    q = hand.check_q(q).copy()
    held = {int(j) for j in fixed}
    free = [j for j in range(len(q)) if j not in held]
    sticking = _check_sticking(hand, sticking)
    if not free:
        raise InputError(f"close: expected at least one free coordinate, got every one of "
                         f"{len(q)} held (fixed {sorted(held)})")
    scale = hand.length_scale
    square = not sticking and len(free) == hand.n_contacts
    n_r = len(sticking)
    last = np.inf
    for _ in range(max_iter):
        g = hand.gaps(q)
        worst = float(np.max(np.abs(g)))
        if worst <= tol * scale or (not square and worst <= STALL * scale and worst > 0.5 * last):
            return q  # converged, or (least squares) stalled at round-off
        last = worst
        if square:
            G = hand.gap_jacobian(q)[:, free]
            if abs(np.linalg.det(G)) < 1e-14 * scale ** 2:
                raise DegenerateError(
                    "close: the contact constraints are singular at this configuration "
                    f"(gap Jacobian det {np.linalg.det(G):.3g})"
                )
            q[free] -= np.linalg.solve(G, g)
        else:
            A = constraint_rows(hand, q, sticking)[:, free]
            rhs = np.concatenate([g, np.zeros(n_r)])
            norms = np.linalg.norm(A, axis=1)
            norms[norms == 0] = 1.0
            step = np.linalg.lstsq(A / norms[:, None], rhs / norms, rcond=RANK_RTOL)[0]
            q[free] -= step
        if not np.all(np.isfinite(q)):
            raise DegenerateError(
                "close: Newton diverged (a coordinate left the float range); expected a "
                "configuration near one where every contact touches"
            )
    g = hand.gaps(q)
    order = np.argsort(-np.abs(g))
    open_ = [f"{contact_name(hand, int(i))} gap {g[i]:.3g} m" for i in order
             if abs(g[i]) > tol * scale][:3]
    raise DegenerateError(
        f"close: contacts did not close within {max_iter} Newton steps "
        f"(largest gap {np.max(np.abs(g)):.3g} m: {'; '.join(open_)}); the constraints of "
        "these contacts cannot all hold with the coordinates left free"
    )


def default_fixed(hand: ContactHand, q: Any = None) -> list[int]:
    """Coordinates held when closing a start configuration: the workpiece ``x``, then the
    joints' coordinates in order, each only while the coordinates left free still fix as many
    constraints as all coordinates do (the rank of the gap rows, :func:`constraint_rank`; at
    ``q`` when given, else the count of contacts).  Starts with more contacts than free
    coordinates (redundant contacts) therefore hold fewer coordinates (or none)."""
    n_q = 3 + hand.n_joints
    if q is None:
        need = hand.n_contacts
        held = [0] if n_q - 1 >= need else []
        for k in range(hand.n_joints):
            if n_q - len(held) - 1 >= need:
                held.append(3 + k)
        return held
    G = hand.gap_jacobian(hand.check_q(q))
    need = constraint_rank(G)
    fixed: list[int] = []
    for j in [0, *range(3, n_q)]:
        trial = [*fixed, j]
        free = [c for c in range(n_q) if c not in trial]
        if len(free) >= need and constraint_rank(G[:, free]) == need:
            fixed = trial
    return fixed
