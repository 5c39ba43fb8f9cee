"""Exact tests of given relaxed-utility (force-indeterminate) modes, end of Section 3.2.

A mode with more kinematic constraints than ``3 + |tau_I|`` (e.g. ``2R`` on one rigid link)
has a ``Q_A`` with a null space: its contact forces are not unique.  The paper keeps condition
(29)'s lower bound, drops ``Q_AI`` from (32) and asks only that the left null space of ``Q_A``
be trivial (full row rank).  Here, for modes given by their codes:

* kinematics (:func:`indeterminate_kinematics_of`): ``P_A`` (``(2 n_R + n_S) x (3 + |tau_I|)``)
  of full column rank (unique ``qdot``, eq. 24 in the generalised-inverse sense), the
  over-determined system ``P_A zdot_I = J_AV thetadot_V`` consistent (residual within ``tol``),
  breaking contacts separate and sliding contacts slip as in the determinate case (eqs. 16, 25);
* forces (:func:`force_lp`): ``c_A`` with ``Q_A c_A = rhs`` and ``B_A c_A >= 0`` by a linear
  program (scipy HiGHS) maximising the smallest normalised slack.

Which modes to test is decided by :mod:`planner.predict.indeterminate`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from planner.model.modes import BREAK, ROLL, SLIDE, Mode, candidates_from_codes
from planner.model.system import System
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    FeasibleMode,
    equilibrated_kinematics,
    force_matrices,
    force_rhs,
)


@dataclass(frozen=True, eq=False)
class IndeterminateKinematics:
    """A kinematically admissible force-indeterminate candidate: constraint ``rows``,
    ``sliding``, ``contact`` (as in :class:`planner.model.modes.CandidateSet`), ``codes``, ``xi``,
    velocities ``qdot (3,)``, ``thetadot (n_theta,)``, ``v (2 n_c,)`` and the kinematic margin."""

    rows: np.ndarray
    sliding: np.ndarray
    contact: np.ndarray
    codes: np.ndarray
    xi: np.ndarray
    qdot: np.ndarray
    thetadot: np.ndarray
    v: np.ndarray
    margin: float

    @property
    def mode(self) -> Mode:
        return Mode(tuple(int(c) for c in self.codes), tuple(int(x) for x in self.xi))


def indeterminate_kinematics_of(
    system: System,
    codes: list[np.ndarray] | np.ndarray,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
) -> list[IndeterminateKinematics]:
    """The exact kinematic test of the given modes ``codes (m, n_c)`` with more than
    ``3 + |tau_I|`` rows (others are ignored): ``P_A`` of full column rank, ``z = P_A^+ b_A``
    (generalised inverse, Sec. 3.2) consistent within ``tol``, breaking contacts separate and
    sliding contacts slip (eqs. 16, 25).  Returned in :func:`enumerate_modes` order."""
    n_c = system.n_contacts
    codes = np.asarray(codes, dtype=np.int8).reshape(-1, n_c)
    eq = equilibrated_kinematics(system)
    return stacked_relaxed_kinematics(
        eq.Kn[None], eq.bn[None], eq.col[None], np.array([eq.velocity_scale]),
        system.W[None], system.J[None], system.joint_inputs[None], system.effort_joints,
        system.velocity_joints, np.zeros(len(codes), dtype=np.int64), codes, 1,
        tol=tol, singular_tol=singular_tol,
    )[0]


def stacked_relaxed_kinematics(
    Kn: np.ndarray, bn: np.ndarray, col: np.ndarray, velocity_scale: np.ndarray,
    W: np.ndarray, J: np.ndarray, inputs: np.ndarray, E: np.ndarray, V: np.ndarray,
    config: np.ndarray, codes: np.ndarray, n_configs: int, *,
    tol: float, singular_tol: float,
) -> list[list[IndeterminateKinematics]]:
    """:func:`indeterminate_kinematics_of` for modes ``codes (G, n_c)`` of configurations
    ``config (G,)`` of stacked systems (equilibrated ``Kn (B, 2 n_c, k)``, ``bn``, ``col``,
    ``velocity_scale (B,)``, ``W (B, 3, 2 n_c)``, ``J (B, 2 n_c, n_theta)``, joint
    ``inputs (B, n_theta)``); one list per configuration, in :func:`enumerate_modes` order."""
    out: list[list[IndeterminateKinematics]] = [[] for _ in range(n_configs)]
    if codes.shape[0] == 0:
        return out
    n_c, k = codes.shape[1], Kn.shape[2]
    n_joints = inputs.shape[1]
    n_rows_all = 2 * (codes == ROLL).sum(axis=1) + (codes == SLIDE).sum(axis=1)
    order = np.lexsort((canonical_rank(codes), config))
    codes, n_rows_all, config = codes[order], n_rows_all[order], config[order]
    scale_all = np.where(velocity_scale > 0, velocity_scale, 1.0)
    b_all = np.max(np.abs(bn), axis=1)  # relative to the commanded motion (no floor)
    found: list[tuple[int, int, IndeterminateKinematics]] = []
    for k_rows in range(k + 1, 2 * n_c + 1):
        sel = np.flatnonzero(n_rows_all == k_rows)
        if sel.size == 0:
            continue
        cand = candidates_from_codes(codes[sel], k_rows)
        cfg = config[sel]
        P = Kn[cfg[:, None], cand.rows]  # (G, k_rows, k)
        b = bn[cfg[:, None], cand.rows]
        s = np.linalg.svd(P, compute_uv=False)
        full_rank = s[:, -1] > np.sqrt(singular_tol) * s[:, 0]
        if not np.any(full_rank):
            continue
        idx = np.flatnonzero(full_rank)
        Pf, bf = P[idx], b[idx]
        z = (np.linalg.pinv(Pf) @ bf[..., None])[..., 0]  # generalised inverse (Sec. 3.2)
        resid = np.max(np.abs((Pf @ z[..., None])[..., 0] - bf), axis=1)
        b_scale = b_all[cfg[idx]]
        consistent = resid <= tol * np.where(b_scale > 0, b_scale, 1.0)
        idx, z = idx[consistent], z[consistent]
        if idx.size == 0:
            continue
        c = cfg[idx]
        z = z / col[c]
        n_q = W.shape[1]  # 3 n_b
        qdot = z[:, :n_q]
        thetadot = np.empty((idx.size, n_joints))
        thetadot[:, V] = inputs[c][:, V]
        thetadot[:, E] = z[:, n_q:]
        v = (np.einsum("gi,gir->gr", qdot, W[c])
             - np.einsum("gj,grj->gr", thetadot, J[c]))  # eq. (5)
        v_n, v_t = v[:, 0::2], v[:, 1::2]
        codes_k = cand.codes[idx]
        strict = np.where(codes_k == BREAK, v_n,
                          np.where(codes_k == SLIDE, np.abs(v_t), np.inf))
        kin_margin = np.min(strict, axis=1) / scale_all[c]
        xi = np.where(codes_k == SLIDE, np.sign(v_t), 0).astype(np.int8)
        for j in np.flatnonzero(kin_margin > tol):
            i = idx[j]
            found.append((int(c[j]), int(sel[i]), IndeterminateKinematics(
                cand.rows[i], cand.sliding[i], cand.contact[i], codes_k[j], xi[j],
                qdot[j].copy(), thetadot[j].copy(), v[j].copy(), float(kin_margin[j]),
            )))
    for c, _pos, kin in sorted(found, key=lambda t: (n_rows_all[t[1]], t[1])):
        out[c].append(kin)
    return out


def canonical_rank(codes: np.ndarray) -> np.ndarray:
    """Rank of each mode ``codes (m, n_c)`` in :func:`enumerate_modes` order within its row
    count (see :func:`canonical_mode_order`)."""
    rank = np.empty(len(codes), dtype=np.int64)
    rank[canonical_mode_order(codes)] = np.arange(len(codes))
    return rank


def canonical_mode_order(codes: np.ndarray) -> np.ndarray:
    """Indices sorting mode codes ``(m, n_c)`` as :func:`enumerate_modes` does within one row
    count: by ``n_R``, then lexicographically by the rolling and the sliding set."""
    if len(codes) == 0:
        return np.zeros(0, dtype=np.int64)
    n_c = codes.shape[1]
    keys = [-(codes[:, i] == SLIDE).astype(int) for i in reversed(range(n_c))]
    keys += [-(codes[:, i] == ROLL).astype(int) for i in reversed(range(n_c))]
    keys.append((codes == ROLL).sum(axis=1))
    return np.lexsort(keys)


def feasible_relaxed_modes(
    system: System,
    mu: np.ndarray,
    kinematics: tuple[IndeterminateKinematics, ...] | list[IndeterminateKinematics],
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
) -> list[FeasibleMode]:
    """The force-feasible ones among kinematically admissible relaxed-utility modes
    (``kinematics``): the linear program of :func:`force_lp` per mode (eqs. 21-22, 26)."""
    out: list[FeasibleMode] = []
    for kin in kinematics:
        result = force_lp(system, kin.rows, kin.sliding, kin.contact, kin.codes, kin.xi, mu,
                           singular_tol)
        if result is None:
            continue
        forces, efforts, f_margin = result
        margin = min(kin.margin, f_margin)
        if margin < -tol:
            continue
        out.append(
            FeasibleMode(
                mode=kin.mode,
                qdot=kin.qdot,
                joint_velocities=kin.thetadot,
                contact_velocities=kin.v.reshape(-1, 2).copy(),
                contact_forces=forces,
                joint_efforts=efforts,
                margin=margin,
                on_boundary=abs(margin) <= tol,
                force_indeterminate=True,
            )
        )
    return out


def force_lp(
    system: System, rows: np.ndarray, sliding: np.ndarray, contact: np.ndarray,
    codes: np.ndarray, xi: np.ndarray, mu: np.ndarray, singular_tol: float,
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Max-margin feasible forces of one indeterminate mode, or None if rank-deficient."""
    n_c = system.n_contacts
    QT = force_matrices(system, rows[None], sliding[None], contact[None], xi[None], mu[None])[0, 0]
    Q = QT.T  # (3+|E|, k_rows)
    rhs = force_rhs(system)
    rs = np.max(np.abs(Q), axis=1)
    rs[rs == 0] = 1.0
    Qs = Q / rs[:, None]
    sv = np.linalg.svd(Qs, compute_uv=False)
    if sv[-1] <= np.sqrt(singular_tol) * sv[0]:
        return None  # left null space of Q_A non-trivial
    k_rows = rows.size
    B = coulomb_rows(rows, sliding, contact, codes, mu)
    f_scale = max(float(np.max(np.abs(rhs / rs))), 1e-300)
    # Variables [c_A (scaled), s]; maximise s s.t. B c - s >= 0, Q c = rhs, |c| <= C, s <= f.
    bound = 1e3 * f_scale / max(float(np.min(np.linalg.svd(Qs, compute_uv=False))), 1e-12)
    # A rolling frictionless contact: c_t = 0 is an equality (fixed variable), not a cone whose
    # zero slack would pin the margin at 0 (it has no slip boundary).
    fixed = np.array([r % 2 == 1 and codes[contact[j]] == ROLL and mu[contact[j]] == 0.0
                      for j, r in enumerate(rows)], dtype=bool)
    if np.any(fixed):
        B = B[np.any(B[:, ~fixed] != 0, axis=1)]
    A_ub = np.hstack([-B, np.ones((B.shape[0], 1))])
    res = linprog(
        c=np.r_[np.zeros(k_rows), -1.0], A_ub=A_ub, b_ub=np.zeros(B.shape[0]),
        A_eq=np.hstack([Qs, np.zeros((Qs.shape[0], 1))]), b_eq=rhs / rs,
        bounds=[(0.0, 0.0) if f else (-bound, bound) for f in fixed] + [(None, f_scale)],
        method="highs",
    )
    if res.status != 0:
        return None
    c_A = res.x[:k_rows]
    c_full = np.zeros(2 * n_c)
    c_full[rows] = c_A
    is_s = codes == SLIDE
    c_full[1::2] += np.where(is_s, -mu * xi * c_full[0::2], 0.0)
    efforts = c_full @ system.J + system.g_man
    norm = max(float(np.max(np.abs(c_A))), 1e-300) if np.any(c_A) else 1.0
    margin = float(res.x[-1]) / norm if np.any(c_A) else 0.0
    return c_full.reshape(n_c, 2), efforts, margin


def coulomb_rows(
    rows: np.ndarray, sliding: np.ndarray, contact: np.ndarray, codes: np.ndarray,
    mu: np.ndarray,
) -> np.ndarray:
    """``B_A`` of eqs. (21)-(22) acting on ``c_A`` (the mode's applicable force components):
    rolling ``mu c_n -+ c_t >= 0`` and ``c_n >= 0``, sliding ``c_n >= 0``."""
    k_rows = rows.size
    B = []
    for j in range(k_rows):
        r = rows[j]
        if r % 2 == 0 and codes[contact[j]] == ROLL:
            jt = int(np.flatnonzero(rows == r + 1)[0])
            for sign in (1.0, -1.0):
                line = np.zeros(k_rows)
                line[j] = mu[contact[j]]
                line[jt] = sign
                B.append(line)
            line = np.zeros(k_rows)
            line[j] = 1.0  # c_n >= 0 (implied by the cone only when mu > 0)
            B.append(line)
        elif sliding[j]:
            line = np.zeros(k_rows)
            line[j] = 1.0
            B.append(line)
    return np.array(B).reshape(-1, k_rows)
