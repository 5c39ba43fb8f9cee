"""Feasible modes of many configurations of one structure at once.

A planner asks for the modes of thousands of configurations that share their structure: the
waypoints of a trajectory (same contacts, same joints, same control partition; ``W``, ``J``,
loads and inputs change), or one configuration at many friction vectors.  The single-call
path (:func:`planner.predict.feasibility.feasible_modes`) pays its set-up and NumPy's per-call
overhead once per configuration; here the eq. (49) candidates are enumerated once, and the
kinematic stage (eqs. 13-16, 23-25) and the force stage (eqs. 17-22, 26-28) run as one stacked
computation over ``(configuration, candidate)`` pairs: the same arithmetic per candidate as the
single call (each small system factorised on its own), so the same modes and certificates to
rounding.  The relaxed-utility modes (end of Sec. 3.2) follow the single-call rules: the
structural test (:func:`planner.predict.indeterminate.closed_bases_suffice`, stacked here) and
the velocities of the determinate candidates, else the row-subset scan per configuration.

For many friction vectors of one configuration, the force stage of
:func:`planner.predict.stages.force_stage` already takes ``mu (L, n_c)``;
:func:`feasible_modes_batch` accepts ``mu (N, n_c)`` with one system repeated.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import comb
from typing import Any

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.modes import (
    BREAK,
    ROLL,
    SLIDE,
    CandidateSet,
    Mode,
    candidate_count,
    enumerate_modes,
)
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.boundary import force_checked
from planner.predict.feasibility import STREAM_ELEMENTS, Prediction, finish_prediction
from planner.predict.indeterminate import (
    DEFAULT_MAX_ROW_SUBSETS,
    GEN_TOL,
    MAX_MODES_PER_VELOCITY,
    certified_by_determinants,
    closed_bases_stacked,
    modes_of_pattern,
)
from planner.predict.linalg import batch_det_solve, det_solve
from planner.predict.relaxed_modes import IndeterminateKinematics, stacked_relaxed_kinematics
from planner.predict.stages import DEFAULT_SINGULAR_TOL, DEFAULT_TOL, FeasibleMode


def feasible_modes_batch(
    systems: Sequence[System],
    mu: Any = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    indeterminate: bool | None = None,
    max_subsets: int = DEFAULT_MAX_ROW_SUBSETS,
) -> list[Prediction]:
    """``[feasible_modes(s, m) for s, m in zip(systems, mu)]``, computed together.

    Parameters
    ----------
    systems : sequence of N System
        Same number of contacts, joints and bodies and the same control partition (which joints are
        effort- and which velocity-controlled); everything else may differ.
    mu : None, float, (n_c,) or (N, n_c)
        Friction: each system's own (None), one for all, or one row per system.
    tol, singular_tol, indeterminate, max_subsets
        As in :func:`planner.predict.feasibility.feasible_modes`.

    Returns
    -------
    list of N Prediction, equal to the single calls' (modes, order, certificates to rounding,
    status, reason, limits).
    """
    systems = list(systems)
    if not systems:
        return []
    for i, s in enumerate(systems):
        if not isinstance(s, System):
            raise InputError(f"systems[{i}]: expected a planner System, got {type(s).__name__}")
    first = systems[0]
    n_c, k, n_j = first.n_contacts, first.dof, first.n_joints
    E, V = first.effort_joints, first.velocity_joints
    for i, s in enumerate(systems):
        if ((s.n_contacts, s.n_joints, s.n_bodies) != (n_c, n_j, first.n_bodies)
                or s.control != first.control):
            raise InputError(
                f"systems[{i}]: expected the structure of systems[0] ({n_c} contacts, {n_j} "
                f"joints, {first.n_bodies} bodies, control "
                f"{[c.value for c in first.control]}), got {s.n_contacts} contacts, "
                f"{s.n_joints} joints, {s.n_bodies} bodies, control "
                f"{[c.value for c in s.control]}"
            )
    if not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"tol: expected a finite number >= 0, got {tol}")
    N = len(systems)
    mus = _friction_rows(systems, mu)
    cand = enumerate_modes(n_c, k)
    M = len(cand)
    if M == 0 or candidate_count(n_c, k) * N * 2 * n_c > 64 * STREAM_ELEMENTS:
        # nothing to stack, or too much at once: the single calls (they stream)
        from planner.predict.feasibility import feasible_modes

        return [feasible_modes(s, m, tol=tol, singular_tol=singular_tol,
                               indeterminate=indeterminate, max_subsets=max_subsets)
                for s, m in zip(systems, mus)]
    block = max(1, STREAM_ELEMENTS // max(M * 2 * n_c, 1))
    out: list[Prediction] = []
    for a in range(0, N, block):
        out += _block(systems[a:a + block], mus[a:a + block], cand, E, V, tol, singular_tol,
                      indeterminate, max_subsets)
    return out


def _friction_rows(systems: list[System], mu: Any) -> np.ndarray:
    N, n_c = len(systems), systems[0].n_contacts
    if mu is None:
        return np.stack([s.mu for s in systems])
    arr = np.asarray(mu, dtype=float)
    if arr.ndim == 2:
        if arr.shape != (N, n_c):
            raise InputError(f"mu: expected shape ({N}, {n_c}) (one row per system), "
                             f"got {arr.shape}")
        return np.stack([as_friction(row, n_c) for row in arr])
    return np.broadcast_to(as_friction(mu, n_c), (N, n_c))


def _block(
    systems: list[System], mus: np.ndarray, cand: CandidateSet, E: np.ndarray, V: np.ndarray,
    tol: float, singular_tol: float, indeterminate: bool | None, max_subsets: int,
) -> list[Prediction]:
    """Predictions of one block of configurations (stacked stages, module docstring)."""
    B = len(systems)
    n_c, k, M = cand.n_contacts, cand.n_rows, len(cand)
    W = np.stack([s.W for s in systems])  # (B, 3 n_b, 2 n_c)
    J = np.stack([s.J for s in systems])  # (B, 2 n_c, n_theta)
    inputs = np.stack([s.joint_inputs for s in systems])
    # Equilibrated K (as planner.predict.stages.equilibrated_kinematics, per system).
    K = np.concatenate([W.transpose(0, 2, 1), -J[:, :, E]], axis=2)  # (B, 2 n_c, k)
    rhs = np.einsum("brj,bj->br", J[:, :, V], inputs[:, V])
    vel_scale = np.max(np.abs(rhs), axis=1) if n_c else np.zeros(B)
    col = np.max(np.abs(K), axis=1)
    col[col == 0] = 1.0
    Kc = K / col[:, None, :]
    row = np.linalg.norm(Kc, axis=2)
    row[row == 0] = 1.0
    Kn, bn = Kc / row[:, :, None], rhs / row
    # Kinematic stage, eqs. (13)-(16), (23)-(25).
    # One LU per (configuration, candidate): rows of the stacked Kn (B 2 n_c, k).
    flat_rows = (np.arange(0, B * 2 * n_c, 2 * n_c)[:, None, None] + cand.rows).reshape(B * M, k)
    det, z = det_solve(Kn.reshape(B * 2 * n_c, k), bn.reshape(-1), flat_rows)
    nonsingular = (np.abs(det) > singular_tol).reshape(B, M)
    z = z.reshape(B, M, k)
    z[~nonsingular] = np.nan
    z = z / col[:, None, :]
    n_q = W.shape[1]  # 3 n_b
    qdot = z[..., :n_q]
    thetadot = np.empty((B, M, inputs.shape[1]))
    thetadot[..., V] = inputs[:, None, V]
    thetadot[..., E] = z[..., n_q:]
    v = qdot @ W - thetadot @ J.transpose(0, 2, 1)  # (B, M, 2 n_c), eq. (5)
    codes = cand.codes
    is_slide = codes == SLIDE
    scale = np.where(vel_scale > 0, vel_scale, 1.0)
    strict = np.where(codes == BREAK, v[..., 0::2], np.where(is_slide, np.abs(v[..., 1::2]),
                                                             np.inf))
    margin_k = np.min(strict, axis=2) / scale[:, None]
    margin_k = np.where(nonsingular, margin_k, -np.inf)
    vt = v[..., 1::2]
    xi = ((vt > 0).view(np.int8) - (vt < 0).view(np.int8)) * (is_slide & nonsingular[..., None])
    ok = nonsingular & (margin_k > tol)
    boundary = nonsingular & (np.abs(margin_k) <= tol)
    # Force stage, eqs. (17)-(22), (26)-(28), on the admissible (configuration, candidate) pairs.
    bi, mi = np.nonzero(ok)
    G = np.concatenate([W.transpose(0, 2, 1), J[:, :, E]], axis=2)  # (B, 2 n_c, q)
    rows, contact, sliding = cand.rows[mi], cand.contact[mi], cand.sliding[mi]
    xi_rows = np.take_along_axis(xi[bi, mi], contact, axis=1).astype(float)
    coef = mus[bi[:, None], contact] * xi_rows * sliding
    QT = G[bi[:, None], rows] - coef[..., None] * G[bi[:, None], 2 * contact + 1]
    h = np.concatenate([-np.stack([s.g_obj for s in systems]),
                        inputs[:, E] - np.stack([s.g_man for s in systems])[:, E]], axis=1)
    rs = np.max(np.abs(G), axis=1)
    rs[rs == 0] = 1.0
    QTn = QT / rs[bi][:, None, :]
    cnorm = np.linalg.norm(QTn, axis=-1)
    cnorm[cnorm == 0] = 1.0
    QTn = QTn / cnorm[..., None]
    fdet, y = batch_det_solve(QTn.transpose(0, 2, 1), (h / rs)[bi])
    f_ok = np.abs(fdet) > singular_tol
    y[~f_ok] = np.nan
    c_A = y / cnorm
    P = len(bi)
    c_full = np.zeros((P, 2 * n_c))
    np.put_along_axis(c_full, rows, c_A, axis=1)
    pair_codes = codes[mi]
    c_full[:, 1::2] += np.where(pair_codes == SLIDE, -mus[bi] * xi[bi, mi] * c_full[:, 0::2], 0.0)
    forces = c_full.reshape(P, n_c, 2)
    g_man = np.stack([s.g_man for s in systems])
    efforts = np.einsum("pr,prj->pj", c_full, J[bi]) + g_man[bi]
    fn, ft = forces[..., 0], forces[..., 1]
    slack = np.where(pair_codes == ROLL, np.minimum(mus[bi] * fn - np.abs(ft), fn),
                     np.where(pair_codes == SLIDE, fn, np.inf))
    f_scale = np.max(np.abs(c_A), axis=-1) if k else np.zeros(P)
    f_scale = np.where(f_scale > 0, f_scale, 1.0)
    margin_f = np.where(f_ok, np.min(slack, axis=-1) / f_scale, -np.inf)
    margin = np.minimum(margin_f, margin_k[bi, mi])
    feasible = f_ok & (margin >= -tol)
    finite = np.isfinite(qdot[bi, mi]).all(axis=1) & np.isfinite(c_A).all(axis=1)
    if np.any(f_ok & ~finite):
        raise DegenerateError(
            "numerical overflow while solving eqs. (24)/(26): expected inputs whose magnitudes "
            "fit in double precision products (rescale lengths, forces or speeds)"
        )
    f_singular = np.bincount(bi[~f_ok], minlength=B)
    relaxed_kin: list[list[IndeterminateKinematics]] | None = None
    relaxed_limit = [""] * B
    structure_ok = np.zeros(B, bool)
    if indeterminate is not False:
        structure_ok = _closed_bases_stacked(Kn, n_c, k, det.reshape(B, M))
        cfg, gen_codes, relaxed_limit = _generate(
            v / row[:, None, :], nonsingular, structure_ok, row, vel_scale, bn, k, tol)
        relaxed_kin = stacked_relaxed_kinematics(
            Kn, bn, col, vel_scale, W, J, inputs, E, V, cfg, gen_codes, B,
            tol=tol, singular_tol=singular_tol)
    # Per configuration: its feasible pairs and boundary candidates (bi and the boundary rows
    # are sorted by configuration).
    feas = np.flatnonzero(feasible)
    feas_start = np.searchsorted(bi[feas], np.arange(B + 1)).tolist()
    bb, bm = np.nonzero(boundary)
    bound_start = np.searchsorted(bb, np.arange(B + 1)).tolist()
    degenerate_all = (M - np.count_nonzero(nonsingular, axis=1) + f_singular).tolist()
    code_list, mi_list = codes.tolist(), mi.tolist()
    out = []
    for b, system in enumerate(systems):
        modes = []
        for p in feas[feas_start[b]:feas_start[b + 1]].tolist():
            i = mi_list[p]
            m_p = float(margin[p])
            modes.append(FeasibleMode(
                mode=Mode(tuple(code_list[i]), tuple(xi[b, i].tolist())),
                qdot=qdot[b, i].copy(),
                joint_velocities=thetadot[b, i].copy(),
                contact_velocities=v[b, i].reshape(-1, 2).copy(),
                contact_forces=forces[p].copy(),
                joint_efforts=efforts[p].copy(),
                margin=m_p,
                on_boundary=abs(m_p) <= tol,
            ))
        mine = bm[bound_start[b]:bound_start[b + 1]]
        bound = force_checked(system, codes[mine], xi[b, mine], mus[b], tol=tol,
                              singular_tol=singular_tol)
        known = None
        if relaxed_kin is not None and structure_ok[b]:
            known = (tuple(relaxed_kin[b]), relaxed_limit[b])
        out.append(finish_prediction(
            system, mus[b], tuple(modes), bound, degenerate_all[b],
            float(vel_scale[b]), tol=tol, singular_tol=singular_tol,
            indeterminate=indeterminate, max_subsets=max_subsets, relaxed=None,
            method="exhaustive, batched", relaxed_kinematics=known,
        ))
    return out


def _generate(
    v: np.ndarray, nonsingular: np.ndarray, structure_ok: np.ndarray, row: np.ndarray,
    vel_scale: np.ndarray, bn: np.ndarray, k: int, tol: float,
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """:func:`planner.predict.indeterminate.codes_from_velocities`, stacked: the relaxed-utility
    candidates ``(config (G,), codes (G, n_c))`` read off the equilibrated velocities
    ``v (B, M, 2 n_c)`` of the nonsingular determinate candidates of the configurations whose
    structural test holds, and a limit message per configuration."""
    B, M, two_n = v.shape
    n_c = two_n // 2
    scale = np.where(vel_scale > 0, vel_scale, 1.0)
    strict = tol * scale[:, None] / row  # (B, 2 n_c)
    gen = GEN_TOL * np.max(np.abs(bn), axis=1)  # (B,)
    zero = np.abs(v) <= gen[:, None, None]
    hit = (zero.sum(axis=2) > k) & nonsingular & structure_ok[:, None]
    b_idx, m_idx = np.nonzero(hit)
    limits = [""] * B
    if b_idx.size == 0:
        return np.zeros(0, np.int64), np.zeros((0, n_c), np.int8), limits
    vm, zm, st = v[b_idx, m_idx], zero[b_idx, m_idx], strict[b_idx]
    pattern = np.concatenate([
        vm[:, 0::2] > st[:, 0::2], zm[:, 0::2], zm[:, 1::2], np.abs(vm[:, 1::2]) > st[:, 1::2],
    ], axis=1)
    # Distinct (configuration, pattern) rows: one integer key per row when it fits in 63 bits
    # (a 1-D sort), else the row-wise unique.
    n_bits = 4 * n_c
    if n_bits + B.bit_length() <= 62:
        key = pattern @ (np.int64(1) << np.arange(n_bits, dtype=np.int64))
        key += b_idx.astype(np.int64) << n_bits
        first = np.unique(key, return_index=True)[1]
        cfg, pat = b_idx[first], pattern[first].reshape(-1, 4, n_c)
    else:
        uniq = np.unique(np.concatenate([b_idx[:, None], pattern], axis=1), axis=0)
        cfg, pat = uniq[:, 0], uniq[:, 1:].astype(bool).reshape(-1, 4, n_c)
    can_b, zn, zt, can_s = pat[:, 0], pat[:, 1], pat[:, 2], pat[:, 3]
    n_opt = can_b.astype(int) + zn * (zt.astype(int) + can_s)
    single = np.all(n_opt == 1, axis=1)  # one state per contact: read off directly
    codes = [np.where(can_b[single], BREAK, np.where(zt[single], ROLL, SLIDE)).astype(np.int8)]
    cfgs = [cfg[single]]
    for u in np.flatnonzero(~single & np.all(n_opt >= 1, axis=1)):
        for code in modes_of_pattern(pat[u]):
            if code is None:
                limits[int(cfg[u])] = (f"a velocity near {MAX_MODES_PER_VELOCITY}+ mode "
                                       "boundaries: some force-indeterminate candidates were "
                                       "not generated")
                continue
            codes.append(code[None])
            cfgs.append(np.array([cfg[u]]))
    all_codes = np.concatenate(codes)
    all_cfg = np.concatenate(cfgs).astype(np.int64)
    both = np.unique(np.concatenate([all_cfg[:, None], all_codes], axis=1), axis=0)
    return both[:, 0].astype(np.int64), both[:, 1:].astype(np.int8), limits


def _closed_bases_stacked(Kn: np.ndarray, n_c: int, k: int, det: np.ndarray) -> np.ndarray:
    """:func:`planner.predict.indeterminate.closed_bases_suffice` for every configuration of
    the stacked equilibrated ``Kn (B, 2 n_c, k)``: proved by the determinants ``det (B, M)`` of
    the eq. (49) candidates where they suffice, else one batched Gram test per pair count."""
    B = Kn.shape[0]
    p_max = (k - 1) // 2
    if sum(n_c * comb(n_c - 1, p) for p in range(1, p_max + 1)) * B > 4_000_000:
        return np.zeros(B, bool)  # too many tests: the row-subset scan decides
    ok = certified_by_determinants(det, n_c, k)
    rest = np.flatnonzero(~ok)
    if rest.size:
        ok[rest] = closed_bases_stacked(Kn[rest])
    return ok
