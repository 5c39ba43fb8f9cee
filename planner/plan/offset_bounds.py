"""Contacts whose position along their feature is uncertain: the vertex geometries, the
kinematic stage over the box of offsets and the lifted force program (eqs. 5, 13-28).

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
  directions (and ``det P_AI`` of one sign) is admissible on the whole box, and one whose same
  strict condition fails at every vertex is admissible nowhere on it (:func:`uniform_stages`;
  anything else is refused);
* a Coulomb row's value (eq. 28) at fixed ``tau``, ``mu`` and load is a Cramer ratio with that
  determinant, so it holds on the box iff it holds at every vertex, and a rival's torque bound
  ``-s0/s1`` (a ratio of two multi-affine functions) is monotone in each ``s_i`` and attains its
  extremes at vertices (:func:`planner.plan.load_bounds.load_bands` with ``box``);
* every product of an offset or a friction coefficient with a force meets the contact's normal
  force ``c_in >= 0``, so a mode's torque set over the friction box, the offset box and the load
  hull is one linear program in lifted unknowns (:func:`lifted_range`).

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
from planner.model.modes import ROLL, Mode, enumerate_modes
from planner.model.system import System
from planner.plan.intervals import EMPTY, Interval
from planner.predict.indeterminate import GEN_TOL, indeterminate_kinematics
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


def _classify(det: np.ndarray, v: np.ndarray, zero: Any) -> np.ndarray:
    """Per quantity, how ``det * v`` (multi-affine on the box) behaves over the vertices:
    ``det (V,)``, ``v (V, r)``, ``zero`` the size below which ``v`` counts as 0 (scalar or
    ``(V, 1)``).  Returns ``(r,)`` codes: 0 -- zero at every vertex (so on the box); +1 / -1 --
    ``det * v`` has that strict sign at every vertex (so on the box: ``v`` never vanishes where
    ``det != 0``); 2 -- mixed (``v`` may vanish inside the box)."""
    sv = np.where(np.abs(v) <= zero, 0, np.sign(v)) * np.sign(det)[:, None]
    out = np.full(v.shape[1], 2)
    out[np.all(sv == 0, axis=0)] = 0
    out[np.all(sv > 0, axis=0)] = 1
    out[np.all(sv < 0, axis=0)] = -1
    return out


def uniform_stages(systems: Sequence[System], *, tol: float = DEFAULT_TOL,
                   singular_tol: float = DEFAULT_SINGULAR_TOL
                   ) -> list[tuple[KinematicStage, np.ndarray]]:
    """Kinematic stage (eqs. 13-16, 23-25) at every vertex geometry ``systems``; returns per
    system ``(stage, index)`` as :func:`planner.plan.bounds.admissible_modes`, with the same
    admissible candidates and sliding directions at every vertex and ``det P_AI`` of one strict
    sign there -- then the same on the whole offset box (module docstring).  Every other
    candidate must be admissible nowhere on the box: ``P_AI`` singular at every vertex; or
    ``det P_AI`` of one strict sign and one strict condition (``v_n > 0`` breaking,
    ``v_t != 0`` sliding) failing at every vertex; or ``det P_AI`` changing sign with every
    strict condition's ``det * v`` of one strict sign or zero at every vertex (then on each
    side of ``det = 0`` the conditions' signs are those of the vertices on that side, where it
    is not admissible).  Raises :class:`DegenerateError` naming a mode for which none holds:
    it may be admissible inside the box only."""
    if not systems:
        raise DegenerateError("contact offsets: expected at least one vertex geometry, got none")
    cand = enumerate_modes(systems[0].n_contacts, systems[0].dof)
    stages = [kinematic_stage(s, cand, tol=tol, singular_tol=singular_tol) for s in systems]
    det = np.stack([ks.det for ks in stages])           # (V, M) equilibrated, signed
    ok = np.stack([ks.ok for ks in stages])              # (V, M)
    xi = np.stack([ks.xi for ks in stages])              # (V, M, n_c)
    v = np.nan_to_num(np.stack([ks.v for ks in stages]))  # (V, M, 2 n_c)
    zero = np.array([tol * (ks.velocity_scale or 1.0) for ks in stages])[:, None]
    singular = np.abs(det) <= singular_tol
    strict = cand.strict_rows
    for c in range(len(cand)):
        if np.all(singular[:, c]):
            continue
        one_sign = bool(np.all(det[:, c] > singular_tol) or np.all(det[:, c] < -singular_tol))
        if one_sign and np.all(ok[:, c]) and np.all(xi[:, c] == xi[0, c]):
            continue
        label = Mode(tuple(int(x) for x in cand.codes[c]),
                     tuple(int(x) for x in xi[int(np.argmax(ok[:, c])), c])).label
        if not np.any(ok[:, c]):
            rows = np.flatnonzero(strict[c])
            vc = v[:, c, rows].copy()
            vc[:, rows % 2 == 1] = np.abs(vc[:, rows % 2 == 1])  # sliding: |v_t| > 0
            if one_sign:
                if np.any(np.all(vc <= zero, axis=0)):
                    continue  # one condition fails at every vertex, so on the box
            elif np.all(_classify(det[:, c], v[:, c, rows], zero) != 2):
                continue
        raise DegenerateError(f"contact offsets: mode {label} may be kinematically admissible "
                              "at some points of the box of contact positions and not at others "
                              "(the competing modes change inside it)")
    index = np.flatnonzero(ok[0])
    return [(ks, index) for ks in stages]


def sign_changes(det: np.ndarray) -> np.ndarray:
    """``det (V, L, m)`` ``det Q_AI`` at each vertex geometry, friction point and mode:
    ``(m,)`` True for a mode whose determinant changes sign or vanishes at some vertices only,
    at some friction point -- its Cramer ratios have a pole inside the box (module docstring),
    so its rows are not used there.  Zero at every vertex (``1e-12`` of the mode's largest) is
    singular on the box at that point (multi-affine), skipped as at a nominal point."""
    tiny = 1e-12 * np.max(np.abs(det), axis=(0, 1), keepdims=True)
    zero = np.abs(det) <= tiny
    pos = np.all(det > tiny, axis=0)
    neg = np.all(det < -tiny, axis=0)
    return np.any(~(pos | neg | np.all(zero, axis=0)), axis=0)


@dataclass(frozen=True)
class ModeArrays:
    """A determinate candidate's arrays in the shape :func:`lifted_range` reads (as
    :class:`planner.predict.indeterminate.IndeterminateKinematics`)."""

    rows: np.ndarray
    sliding: np.ndarray
    contact: np.ndarray
    codes: np.ndarray
    xi: np.ndarray

    @property
    def mode(self) -> Mode:
        return Mode(tuple(int(c) for c in self.codes), tuple(int(x) for x in self.xi))


def candidate_arrays(stage: KinematicStage, i: int) -> ModeArrays:
    """Candidate ``i`` of a kinematic stage as :class:`ModeArrays`."""
    c = stage.candidates
    return ModeArrays(c.rows[i], c.sliding[i], c.contact[i], c.codes[i], stage.xi[i])


def check_indeterminate_generation(box: OffsetBox, *, singular_tol: float = DEFAULT_SINGULAR_TOL
                                   ) -> None:
    """The force-indeterminate modes (relaxed utility, Sec. 3.2) change on the box only where
    some vertex shows it.  :func:`planner.predict.indeterminate.scan_indeterminate` reads them
    off the velocity ``z_S`` of a ``k``-subset ``S`` of the rows of ``K = [W^T, -J_E]`` (``k = 3
    + |tau_I|``) at which more than ``k`` rows vanish.  ``det K_S`` and ``det K_S * v_r`` (each
    other row's residual, eq. 5) are multi-affine in the offsets, so when, for every ``S`` not
    singular at every vertex, each ``det K_S * v_r`` is zero at every vertex or of one strict
    sign there (:func:`_classify`), the rows that vanish with ``S`` are the same wherever
    ``K_S`` is regular, and the signs of the others are those of the vertices on the same side
    of ``det K_S = 0``: a mode appears inside the box only if it appears at a vertex.  A subset
    with ``det K_S`` of one sign and some contact's normal residual negative at every vertex
    (penetration, no mode) is skipped.  Raises :class:`DegenerateError` otherwise."""
    s0 = box.systems[0]
    n_r, k = 2 * s0.n_contacts, s0.dof
    if n_r <= k:
        return
    eqs = [equilibrated_kinematics(s) for s in box.systems]
    zero = np.array([GEN_TOL * eq.b_scale for eq in eqs])[:, None]
    for S in all_subsets(n_r, k):
        dets, vs = [], []
        for eq in eqs:
            aug = np.ascontiguousarray(np.concatenate([eq.Kn, eq.bn[:, None]], axis=1).T)
            det, z = lu_det_solve(np.take(aug, S.T, axis=1))
            dets.append(det)
            vs.append(np.einsum("rk,kc->cr", eq.Kn, np.nan_to_num(z)) - eq.bn[None])
        det = np.stack(dets)                                   # (V, C)
        v = np.stack(vs)                                       # (V, C, 2 n_c)
        for c in range(S.shape[0]):
            sing = np.abs(det[:, c]) <= singular_tol
            if np.all(sing):
                continue
            outside = np.setdiff1d(np.arange(n_r), S[c])
            normal = outside[outside % 2 == 0]
            one_sign = np.all(det[:, c] > singular_tol) or np.all(det[:, c] < -singular_tol)
            if one_sign and np.any(np.all(v[:, c, normal] < -zero, axis=0)):
                continue                                       # a contact penetrates everywhere
            codes = _classify(det[:, c], v[:, c, outside], zero)
            if np.all(codes != 0):
                continue                                       # no extra row vanishes anywhere
            if np.any(codes == 2):
                raise DegenerateError(
                    f"contact offsets: the velocity row {int(outside[codes == 2][0])} of the rows "
                    f"{S[c].tolist()} vanishes inside the box of contact positions, so a "
                    "force-indeterminate mode may appear there")


def lifted_range(box: OffsetBox, kin: Any, mu_lo: np.ndarray, mu_hi: np.ndarray,
                 loads: np.ndarray, sign: float) -> tuple[int, float]:
    """``min sign * tau`` (one effort joint) over a mode's forces for *every* friction in the
    box ``[mu_lo, mu_hi]`` (one interval per contact), contact position in ``box`` and load in
    the hull of ``loads (K, n_q)`` (eqs. 18-22, 26): one linear program.

    ``kin``: the mode's ``rows``, ``sliding``, ``contact``, ``codes``, ``xi`` (as
    :class:`planner.predict.indeterminate.IndeterminateKinematics`; a determinate mode's
    candidate arrays do too).  ``Q_A(mu, s) = Q_00 + sum_i s_i Delta_i + sum_i mu_i Gamma_i``:
    contact ``i``'s offset moves only its normal column (module docstring) and its friction
    enters only a sliding contact's normal column (``w_n + mu xi w_t``, ``w_t`` free of
    ``s_i``: no product ``s_i mu_i``).  Every product meets the contact's normal force ``c_in
    >= 0``, so with ``u_i = s_i c_in`` and ``w_i = mu_i c_in`` the union over the boxes is exactly
    the polyhedron ``Q_00 c_A + sum_i Delta_i u_i + sum_i Gamma_i w_i - e tau + [sum_k lambda_k
    g_k; 0] = [0; -g_man_I]`` with ``|u_i| <= half_i c_in``, ``mu_lo,i c_in <= w_i <= mu_hi,i
    c_in`` and the Coulomb rows of a rolling contact as ``w_i -+ c_it >= 0`` (given a point,
    ``s_i = u_i / c_in`` and ``mu_i = w_i / c_in``; anything when ``c_in = 0``, where ``u_i =
    w_i = c_it = 0``).  Returns ``(status, value)`` as :func:`scipy.optimize.linprog`."""
    s0 = box.systems[0]
    n_c = s0.n_contacts
    rows, sliding, contact, codes = kin.rows, kin.sliding, kin.contact, kin.codes

    def q_at(system: System, mu: np.ndarray) -> np.ndarray:
        return force_matrices(system, rows[None], sliding[None], contact[None], kin.xi[None],
                              mu[None])[0, 0].T

    zero = np.zeros(n_c)
    Qs = np.stack([q_at(s, zero) for s in box.systems])
    Q0 = Qs.mean(axis=0)                       # the centre s = 0 (Q_A is affine in s)
    Gam = q_at(s0, np.ones(n_c)) - q_at(s0, zero)
    k, n_rows = Q0.shape
    normal = [j for j in range(n_rows) if rows[j] % 2 == 0]
    moved = [j for j in normal if box.half[contact[j]] > 0]
    fric = [j for j in normal if sliding[j] or codes[contact[j]] == ROLL]
    cols = []
    for j in moved:
        w = box.corners[:, contact[j]]
        cols.append(np.einsum("v,vk->k", w, Qs[:, :, j]) / float(w @ w))
    cols += [Gam[:, j] for j in fric]
    m_u, m_w = len(moved), len(fric)
    K, n_q = loads.shape
    n_x = n_rows + 1 + K + m_u + m_w
    e = np.zeros(k)
    e[n_q] = 1.0
    L = np.zeros((k, K))
    L[:n_q] = loads.T
    A_eq = np.vstack([np.hstack([Q0, -e[:, None], L,
                                 np.array(cols).reshape(m_u + m_w, k).T]),
                      np.r_[np.zeros(n_rows + 1), np.ones(K), np.zeros(m_u + m_w)][None]])
    b_eq = np.r_[np.zeros(n_q), -s0.g_man[s0.effort_joints], 1.0]
    rs = np.max(np.abs(A_eq), axis=1)
    rs[rs == 0] = 1.0
    ub = []

    def row(pairs: list[tuple[int, float]]) -> None:
        line = np.zeros(n_x)
        for idx, val in pairs:
            line[idx] += val
        ub.append(line)

    u0, w0 = n_rows + 1 + K, n_rows + 1 + K + m_u
    for j in normal:
        row([(j, -1.0)])                                           # c_in >= 0
    for a, j in enumerate(moved):
        h = float(box.half[contact[j]])
        row([(u0 + a, 1.0), (j, -h)])
        row([(u0 + a, -1.0), (j, -h)])
    for a, j in enumerate(fric):
        i = contact[j]
        row([(w0 + a, 1.0), (j, -float(mu_hi[i]))])
        row([(w0 + a, -1.0), (j, float(mu_lo[i]))])
        if codes[i] == ROLL:
            jt = int(np.flatnonzero(rows == rows[j] + 1)[0])
            row([(w0 + a, -1.0), (jt, 1.0)])                       # w_i - c_it >= 0
            row([(w0 + a, -1.0), (jt, -1.0)])                      # w_i + c_it >= 0
    cost = np.zeros(n_x)
    cost[n_rows] = sign
    res = linprog(cost, A_ub=np.array(ub), b_ub=np.zeros(len(ub)), A_eq=A_eq / rs[:, None],
                  b_eq=b_eq / rs,
                  bounds=[(None, None)] * (n_rows + 1) + [(0.0, None)] * K
                  + [(None, None)] * (m_u + m_w), method="highs")
    return int(res.status), float(res.fun) if res.status == 0 else np.nan


def uniform_indeterminate(box: OffsetBox, *, tol: float = DEFAULT_TOL) -> list[Any]:
    """The force-indeterminate modes of every point of the box (:func:`check_indeterminate_
    generation`, then :func:`planner.predict.indeterminate.indeterminate_kinematics` at every
    vertex, which must agree); the first vertex's kinematics."""
    check_indeterminate_generation(box)
    per = [indeterminate_kinematics(s, tol=tol) for s in box.systems]
    labels = [[k.mode.label for k in ks] for ks in per]
    if any(lab != labels[0] for lab in labels[1:]):
        raise DegenerateError("contact offsets: the force-indeterminate modes differ between "
                              f"corners of the box of contact positions: {labels[0]} and "
                              f"{next(lab for lab in labels if lab != labels[0])}")
    return per[0]


def lifted_interval(box: OffsetBox, kin: Any, mu_lo: np.ndarray, mu_hi: np.ndarray,
                    loads: np.ndarray) -> Interval:
    """A mode's torque range (one effort joint) over the friction box, the box of contact
    positions and the load hull: two programs of :func:`lifted_range` -- the exact union when
    friction is a box (``independent``); for one shared coefficient it contains the union (a
    box holds the diagonal).  EMPTY when the mode is infeasible everywhere."""
    ends = []
    for sign in (1.0, -1.0):
        status, val = lifted_range(box, kin, mu_lo, mu_hi, loads, sign)
        if status == 2:
            return EMPTY
        if status == 3:
            ends.append(-np.inf if sign > 0 else np.inf)
        elif status == 0:
            ends.append(sign * val)
        else:
            raise DegenerateError(f"torque range LP failed for mode {kin.mode.label} over the "
                                  "box of contact positions")
    return Interval(ends[0], ends[1])
