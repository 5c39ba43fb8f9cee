"""Contacts whose position along their feature is uncertain: the vertex geometries and the
kinematic stage over the box of offsets (eqs. 5, 13-16, 23-25, 26).

Contact ``i`` moved by ``s_i`` along its contact frame's tangent ``t_i = rot90(n_i)`` (a straight
feature: the palm, a surface, a link side, a workpiece edge) keeps its normal; its point is
``r_i = r_i0 + s_i t_i`` (world frame).  In the wrench matrix (eq. 3) only the moment of its
*normal* column changes, ``(r_i0 + s_i t_i) x n_i = r_i0 x n_i - s_i`` (``t x n = -1``), while
``r x t_i`` does not (``t_i x t_i = 0``); in the hand Jacobian (eqs. 3, 5) a revolute joint at
``o`` moves the point with ``rot90(r_i - o)``, so ``n_i . rot90(r_i - o)`` gains ``-s_i`` and
``t_i . rot90(r_i - o)`` nothing (``t . rot90(t) = 0``); a prismatic joint's slide axis does not
depend on the point.  Hence ``s_i`` enters *one* row of the kinematic matrix ``P_AI`` (contact
``i``'s normal row, eq. 23, with its right side) and *one* column of the force matrix ``Q_AI``
(its normal column, ``w_n`` or ``w_n - mu xi w_t``, eqs. 18-19, 26), affinely.  Determinants and
Cramer numerators are then *multi-affine* in ``s`` (affine in each ``s_i`` with the others fixed)
and equal, on the box, to the multilinear interpolation of their values at the box's vertices --
a convex combination of those values.  Consequences (proofs: docs/planning.md, "Contact
positions"):

* a determinant with the same strict sign at every vertex keeps it on the whole box;
* a kinematic slack (``v_n`` of a breaking contact, ``v_t`` of a sliding one, eqs. 16, 25) times
  that determinant is multi-affine, so a mode admissible at every vertex with the same sliding
  directions is admissible on the whole box, and one whose same strict condition fails at every
  vertex is admissible nowhere on it (:func:`uniform_stages`; anything else is refused);
* a Coulomb row's value (eq. 28) at fixed ``tau``, ``mu`` and load is a Cramer ratio with that
  determinant, so it holds on the box iff it holds at every vertex, and a rival's torque bound
  ``-s0/s1`` (a ratio of two multi-affine functions) is monotone in each ``s_i`` and attains its
  extremes at vertices (:func:`planner.plan.load_bounds.load_bands` with ``geometries``).

Units: offsets in m (world frame, along ``t_i``).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.errors import DegenerateError
from planner.model.hand import Hand
from planner.model.modes import Mode, enumerate_modes
from planner.model.system import System
from planner.predict.indeterminate import GEN_TOL, coulomb_rows, indeterminate_kinematics
from planner.predict.linalg import lu_det_solve
from planner.predict.row_subsets import all_subsets
from planner.predict.setup import equilibrated_kinematics
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    KinematicStage,
    force_matrices,
    kinematic_stage,
)


def offset_corners(half: Any) -> np.ndarray:
    """``(V, n_c)`` the vertices of the box ``|s_i| <= half_i`` (``half (n_c,)`` [m]); a
    contact with ``half_i = 0`` stays at 0, so ``V = 2^m`` with ``m`` the contacts that move."""
    h = np.asarray(half, dtype=float)
    return np.array(list(itertools.product(*[(-d, d) if d > 0 else (0.0,) for d in h])),
                    dtype=float).reshape(-1, len(h))


@dataclass(frozen=True, eq=False)
class OffsetBox:
    """The box of contact offsets ``|s_i| <= half_i`` at one configuration: ``corners (V, n_c)``
    [m] its vertices (:func:`offset_corners`) and ``systems`` the :class:`System` at each
    (same joints and load as the nominal one)."""

    half: np.ndarray
    corners: np.ndarray
    systems: tuple[System, ...]


def offset_box(hand: Hand, q: np.ndarray, joints: Sequence[Any]) -> OffsetBox | None:
    """``hand``'s contact-offset box at ``q`` with the joint inputs ``joints`` (eqs. 1-5,
    :meth:`Hand.system` with ``offsets``); None when no contact may move."""
    half = hand.contact_offsets()
    if half is None:
        return None
    corners = offset_corners(half)
    return OffsetBox(half, corners,
                     tuple(hand.system(q, 0.0, joints, offsets=s) for s in corners))


def _sign_rows(ks: KinematicStage) -> np.ndarray:
    """``(M, 2 n_c)`` the signed strict kinematic quantities (``v_n`` of a breaking contact,
    ``v_t`` of a sliding one; 0 elsewhere) in units of the stage's velocity scale."""
    v = np.nan_to_num(ks.v) / (ks.velocity_scale if ks.velocity_scale > 0 else 1.0)
    return np.where(ks.candidates.strict_rows, v, 0.0)


def uniform_stages(systems: Sequence[System], *, tol: float = DEFAULT_TOL,
                   singular_tol: float = DEFAULT_SINGULAR_TOL
                   ) -> list[tuple[KinematicStage, np.ndarray]]:
    """Kinematic stage (eqs. 13-16, 23-25) at every vertex geometry ``systems``; returns per
    system ``(stage, index)`` as :func:`planner.plan.bounds.admissible_modes`, with the same
    admissible candidates and sliding directions at every vertex -- then the same on the whole
    offset box (module docstring).  Every other candidate must be singular at every vertex or
    have one strict condition that fails at every vertex (then it is admissible nowhere on the
    box).  Raises :class:`DegenerateError` naming a mode for which neither holds: it may be
    admissible inside the box only, or its ``P_AI`` turns singular there."""
    if not systems:
        raise DegenerateError("contact offsets: expected at least one vertex geometry, got none")
    cand = enumerate_modes(systems[0].n_contacts, systems[0].dof)
    stages = [kinematic_stage(s, cand, tol=tol, singular_tol=singular_tol) for s in systems]
    det = np.stack([ks.det for ks in stages])           # (V, M) equilibrated, signed
    ok = np.stack([ks.ok for ks in stages])              # (V, M)
    xi = np.stack([ks.xi for ks in stages])              # (V, M, n_c)
    sig = np.stack([_sign_rows(ks) for ks in stages])    # (V, M, 2 n_c)
    singular = np.abs(det) <= singular_tol
    strict = cand.strict_rows
    for c in range(len(cand)):
        if np.all(singular[:, c]):
            continue
        label = Mode(tuple(int(x) for x in cand.codes[c]),
                     tuple(int(x) for x in xi[np.argmax(ok[:, c]), c])).label
        if np.any(singular[:, c]) or not (np.all(det[:, c] > 0) or np.all(det[:, c] < 0)):
            raise DegenerateError(f"contact offsets: candidate {label} turns singular inside the "
                                  "box of contact positions (its P_AI changes sign), so its "
                                  "admissibility there is not decided at the corners")
        if np.all(ok[:, c]) and np.all(xi[:, c] == xi[0, c]):
            continue
        s = sig[:, c]                                  # (V, 2 n_c)
        breaking_fails = strict[c, 0::2] & np.all(s[:, 0::2] <= tol, axis=0)
        sliding_fails = strict[c, 1::2] & np.all(np.abs(s[:, 1::2]) <= tol, axis=0)
        if not np.any(ok[:, c]) and (np.any(breaking_fails) or np.any(sliding_fails)):
            continue
        raise DegenerateError(f"contact offsets: mode {label} is kinematically admissible at "
                              "some corners of the box of contact positions and not at others "
                              "(the competing modes change inside it)")
    index = np.flatnonzero(ok[0])
    return [(ks, index) for ks in stages]


def check_signs_over(det: np.ndarray, labels: Sequence[str]) -> None:
    """``det (V, L, m)`` ``det Q_AI`` at each vertex geometry, friction point and mode: raise
    :class:`DegenerateError` naming a mode whose determinant is zero at a point or changes sign
    between the vertices at one friction point (its Cramer ratios have a pole inside the box,
    module docstring)."""
    pos = np.all(det > 0, axis=0)
    neg = np.all(det < 0, axis=0)
    bad = ~(pos | neg)                                  # (L, m)
    if np.any(bad):
        j = int(np.flatnonzero(np.any(bad, axis=0))[0])
        raise DegenerateError(f"contact offsets: det Q_AI of mode {labels[j]} vanishes inside "
                              "the box of contact positions (its forces are unbounded there)")


def check_indeterminate_generation(box: OffsetBox, *, tol: float = DEFAULT_TOL,
                                   singular_tol: float = DEFAULT_SINGULAR_TOL) -> None:
    """The force-indeterminate modes (relaxed utility, Sec. 3.2) are the same at every point
    of the box when, for every ``k``-subset ``S`` of the rows of ``K = [W^T, -J_E]`` (``k = 3 +
    |tau_I|``; :func:`planner.predict.indeterminate.scan_indeterminate` reads the modes off the
    velocity ``z_S`` at which more than ``k`` rows vanish), either ``K_S`` is singular at every
    vertex (then everywhere: ``det K_S`` is multi-affine), or some contact's normal residual is
    negative at every vertex (then everywhere: a penetrating ``z_S`` gives no mode), or ``det
    K_S`` keeps its sign and each other row's residual ``v_r`` (eq. 5; ``det K_S * v_r`` is
    multi-affine) vanishes at every vertex or keeps a strict sign there -- so the rows that
    vanish, and the modes read off them, do not change on the box.  Raises
    :class:`DegenerateError` otherwise (a mode may appear inside the box only)."""
    s0 = box.systems[0]
    n_r, k = 2 * s0.n_contacts, s0.dof
    if n_r <= k:
        return
    eqs = [equilibrated_kinematics(s) for s in box.systems]
    for S in all_subsets(n_r, k):
        dets, vs = [], []
        for eq in eqs:
            aug = np.ascontiguousarray(np.concatenate([eq.Kn, eq.bn[:, None]], axis=1).T)
            det, z = lu_det_solve(np.take(aug, S.T, axis=1))
            dets.append(det)
            v = np.einsum("rk,kc->cr", eq.Kn, np.nan_to_num(z)) - eq.bn[None]
            vs.append(v / max(GEN_TOL * eq.b_scale, 1e-300))   # in units of the zero threshold
        det = np.stack(dets)                                   # (V, C)
        v = np.stack(vs)                                       # (V, C, 2 n_c)
        for c in range(S.shape[0]):
            sing = np.abs(det[:, c]) <= singular_tol
            if np.all(sing):
                continue
            outside = np.setdiff1d(np.arange(n_r), S[c])
            normal = outside[outside % 2 == 0]
            if np.any(np.all(v[:, c, normal] < -1.0, axis=0)):
                continue                                       # a contact penetrates everywhere
            if np.any(sing) or not (np.all(det[:, c] > 0) or np.all(det[:, c] < 0)):
                raise DegenerateError(f"contact offsets: the velocity rows {S[c].tolist()} turn "
                                      "singular inside the box of contact positions, so the "
                                      "force-indeterminate modes there are not decided at its "
                                      "corners")
            r = v[:, c, outside]
            zero = np.abs(r) <= 1.0
            steady = np.all(zero, axis=0) | (np.all(r > 1.0, axis=0) | np.all(r < -1.0, axis=0))
            if not np.all(steady):
                raise DegenerateError(
                    f"contact offsets: the velocity row {int(outside[~steady][0])} of the rows "
                    f"{S[c].tolist()} vanishes inside the box of contact positions, so a "
                    "force-indeterminate mode may appear there")


def lifted_range(box: OffsetBox, kin: Any, mu: Any, loads: np.ndarray, sel: np.ndarray,
                 objective: np.ndarray, tau: np.ndarray | None = None) -> tuple[int, float]:
    """One linear program over a force-indeterminate mode's forces at friction ``mu (n_c,)``,
    *every* contact position of the box and every load in the hull of ``loads (K, n_q)``
    (eqs. 21-22, 26).  ``Q_A(s) = Q_0 + sum_i s_i Delta_i`` (only contact ``i``'s normal column
    moves, module docstring) and its force ``c_in >= 0``, so with ``u_i = s_i c_in`` the union
    over the box of ``{Q_A(s) c_A - sel tau + [sum_k lambda_k g_k; 0] = [0; -g_man_I], B_A c_A
    >= 0}`` is exactly the polyhedron with ``Q_0 c_A + sum_i Delta_i u_i`` and ``|u_i| <= half_i
    c_in`` (given ``u``, ``c``: ``s_i = u_i / c_in``, any ``s_i`` when ``c_in = 0``).  Minimises
    ``objective . tau`` (``tau (p,)`` free; ``sel (k, p)`` places them), or with ``tau`` given
    tests feasibility.  Returns ``(status, value)`` as :func:`scipy.optimize.linprog`."""
    mu_v = np.asarray(mu, dtype=float)
    Qs = np.stack([force_matrices(s, kin.rows[None], kin.sliding[None], kin.contact[None],
                                  kin.xi[None], mu_v[None])[0, 0].T for s in box.systems])
    Q0 = Qs.mean(axis=0)                       # the centre s = 0 (Q_A is affine in s)
    k, n_rows = Q0.shape
    normal = [int(j) for j in range(n_rows) if kin.rows[j] % 2 == 0
              and box.half[kin.contact[j]] > 0]
    D = []
    for j in normal:
        i = int(kin.contact[j])
        w = box.corners[:, i]
        D.append(np.einsum("v,vk->k", w, Qs[:, :, j]) / float(w @ w))
    D_arr = np.array(D).reshape(len(normal), k).T           # (k, m)
    m = len(normal)
    K, n_q = loads.shape
    E = box.systems[0].effort_joints
    p = sel.shape[1] if tau is None else 0
    L = np.zeros((k, K))
    L[:n_q] = loads.T
    rhs = np.r_[np.zeros(n_q), -box.systems[0].g_man[E]]
    if tau is not None:
        rhs = rhs + sel @ tau
    A_eq = np.vstack([np.hstack([Q0, -sel[:, :p], L, D_arr]),
                      np.r_[np.zeros(n_rows + p), np.ones(K), np.zeros(m)][None]])
    b_eq = np.r_[rhs, 1.0]
    rs = np.max(np.abs(A_eq), axis=1)
    rs[rs == 0] = 1.0
    B = coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes, mu_v)
    U = np.zeros((2 * m, n_rows + p + K + m))
    for a, j in enumerate(normal):
        h = box.half[kin.contact[j]]
        U[2 * a, n_rows + p + K + a], U[2 * a, j] = 1.0, -h
        U[2 * a + 1, n_rows + p + K + a], U[2 * a + 1, j] = -1.0, -h
    A_ub = np.vstack([np.hstack([-B, np.zeros((len(B), p + K + m))]), U])
    cost = np.r_[np.zeros(n_rows), objective if tau is None else np.zeros(0), np.zeros(K + m)]
    res = linprog(cost, A_ub=A_ub, b_ub=np.zeros(len(A_ub)), A_eq=A_eq / rs[:, None],
                  b_eq=b_eq / rs,
                  bounds=[(None, None)] * (n_rows + p) + [(0.0, None)] * K
                  + [(None, None)] * m, method="highs")
    return int(res.status), float(res.fun) if res.status == 0 else np.nan


def uniform_indeterminate(box: OffsetBox, *, tol: float = DEFAULT_TOL) -> list[Any]:
    """The force-indeterminate modes of every point of the box (:func:`check_indeterminate_
    generation`, then :func:`planner.predict.indeterminate.indeterminate_kinematics` at every
    vertex, which must agree); the first vertex's kinematics."""
    check_indeterminate_generation(box, tol=tol)
    per = [indeterminate_kinematics(s, tol=tol) for s in box.systems]
    labels = [[k.mode.label for k in ks] for ks in per]
    if any(lab != labels[0] for lab in labels[1:]):
        raise DegenerateError("contact offsets: the force-indeterminate modes differ between "
                              f"corners of the box of contact positions: {labels[0]} and "
                              f"{next(lab for lab in labels if lab != labels[0])}")
    return per[0]


def lifted_interval(box: OffsetBox, kin: Any, mu: Any, loads: np.ndarray) -> tuple[float, float]:
    """``(lower, upper)`` of a force-indeterminate mode's torque (one effort joint) over the
    box of contact positions and the load hull at friction ``mu`` (:func:`lifted_range`, two
    programs); ``(inf, -inf)`` when it is infeasible there."""
    k = box.systems[0].dof
    sel = np.zeros((k, 1))
    sel[3:, 0] = 1.0
    ends = []
    for sign in (1.0, -1.0):
        status, val = lifted_range(box, kin, mu, loads, sel, np.array([sign]))
        if status == 2:
            return np.inf, -np.inf
        if status == 3:
            ends.append(-np.inf if sign > 0 else np.inf)
        elif status == 0:
            ends.append(sign * val)
        else:
            raise DegenerateError(f"torque range LP failed for mode {kin.mode.label} over the "
                                  "box of contact positions")
    return ends[0], ends[1]
