"""Relaxed utility (end of Section 3.2): statically indeterminate, force-indeterminate modes.

When a mode has more kinematic constraints than ``3 + |tau_I|`` (e.g. two rolling contacts on
one rigid link, mode ``2R``), ``Q_A`` has a null space and the contact forces are not unique.
The paper keeps condition (29)'s lower bound, drops ``Q_AI`` from (32) and asks only that the
left null space of ``Q_A`` be trivial (full row rank).  Here:

* kinematics: ``P_A`` (``(2 n_R + n_S) x (3 + |tau_I|)``) must have full column rank
  (unique ``qdot``, eq. 24 in the generalised-inverse sense) and the over-determined system
  ``P_A zdot_I = J_AV thetadot_V`` must be consistent (residual within ``tol``); breaking contacts
  separate and sliding contacts slip as in the determinate case (eqs. 16, 25);
* forces: ``c_A = Q_A^+ rhs + N y`` (generalised inverse plus null space); feasibility of
  ``B_A c_A >= 0`` is a linear program (scipy HiGHS) maximising the smallest normalised slack.

The candidates are not enumerated (``3^n_c`` modes): :func:`scan_indeterminate` solves every
``k``-row subset of ``K`` (polynomial in ``n_c``), keeps the velocities at which more than ``k``
rows vanish, and reads the modes off them; the exact kinematic test and the LP run only for
those few modes.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.optimize import linprog  # type: ignore[import-untyped]

from planner.model.modes import BREAK, ROLL, SLIDE, Mode, candidates_from_codes
from planner.model.system import System
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    FeasibleMode,
    equilibrated_kinematics,
    force_matrices,
    force_rhs,
    lu_det_solve,
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


#: Largest number of ``k``-row subsets of ``K`` (``C(2 n_c, 3 + |tau_I|)``) the relaxed-utility
#: pass examines by default; above it the pass is skipped and the result says so.
DEFAULT_MAX_ROW_SUBSETS = 4_000_000
#: Row subsets solved per batch (bounds the pass's memory at any ``n_c``).
SUBSET_CHUNK = 4096
#: Generation tolerance, relative to the largest equilibrated right side: a row with
#: ``|v| <= GEN_TOL max|bn|`` at a subset's solution may vanish in the mode (it covers the
#: difference between the subset's exact solution and the mode's generalised-inverse one,
#: ``cond(K_S) * tol``); every generated mode is then decided by the exact test.
GEN_TOL = 1e-6
#: Largest number of modes one subset's velocity may generate (contacts within ``GEN_TOL`` of
#: two states multiply); above it the pass reports a limit.
MAX_MODES_PER_VELOCITY = 4096


@dataclass(frozen=True, eq=False)
class IndeterminateScan:
    """Result of :func:`scan_indeterminate`.

    ``kinematics``: the kinematically admissible force-indeterminate candidates; ``subsets``:
    ``k``-row subsets of ``K`` examined; ``generated``: distinct candidate modes given to the
    exact test; ``limit``: empty when the scan is complete, else why it is not."""

    kinematics: tuple[IndeterminateKinematics, ...]
    subsets: int
    generated: int
    limit: str = ""


def row_subset_count(system: System) -> int:
    """``C(2 n_c, 3 + |tau_I|)``: the ``k``-row subsets :func:`scan_indeterminate` solves."""
    return comb(2 * system.n_contacts, system.dof)


def scan_indeterminate(
    system: System,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    max_subsets: int = DEFAULT_MAX_ROW_SUBSETS,
) -> IndeterminateScan:
    """Every kinematically admissible force-indeterminate candidate (relaxed utility, end of
    Sec. 3.2), at any ``n_c``, without enumerating the ``3^n_c`` modes.

    A relaxed-utility mode has rows ``A`` with ``|A| > k = 3 + |tau_I|`` and ``P_A`` of full
    column rank, so its velocity ``z = (qdot, thetadot_E)`` is unique (eq. 24) and already
    fixed by some ``k`` linearly independent rows of ``A``.  Conversely ``z`` fixes the mode:
    ``v = K z - b`` (eq. 5) vanishes on exactly the rows of ``A``; contacts with ``v_n > 0``
    break (eq. 25), with ``v_n = 0, v_t != 0`` slide with ``xi = sgn(v_t)`` (eq. 16), with
    ``v = 0`` roll.  Hence:

    1. solve ``K_S z = b_S`` for every ``k``-subset ``S`` of the ``2 n_c`` rows of ``K``
       (``C(2 n_c, k)`` small systems, batched, in chunks of :data:`SUBSET_CHUNK`): the rank
       test (30)-(32) on ``K_S`` drops singular subsets;
    2. keep the ``z`` at which more than ``k`` rows vanish (within :data:`GEN_TOL`: the cheap
       test; at generic ``z`` exactly ``k`` rows vanish and the subset is dropped) and read
       the mode(s) off ``v`` (a contact within ``GEN_TOL`` of two states yields both);
    3. decide every generated mode by the exact test of :func:`indeterminate_kinematics_of`
       (full column rank of ``P_A``, generalised-inverse velocities, consistency within
       ``tol``, strict margins), the same as testing it among all ``3^n_c`` modes.

    The work is polynomial in ``n_c`` for a fixed number of effort joints.  When
    ``C(2 n_c, k) > max_subsets`` nothing is scanned and ``limit`` says so.
    """
    n_c, k = system.n_contacts, system.dof
    count = row_subset_count(system)
    if 2 * n_c <= k:  # no mode can have more than k rows
        return IndeterminateScan((), 0, 0)
    if count > max_subsets:
        return IndeterminateScan((), 0, 0, (
            f"force-indeterminate (relaxed-utility) modes not searched: C(2 n_c, 3 + |tau_I|) "
            f"= C({2 * n_c}, {k}) = {count} row subsets exceed max_subsets = {max_subsets}"
        ))
    eq = equilibrated_kinematics(system)
    Kn, bn = eq.Kn, eq.bn
    b_scale = float(np.max(np.abs(bn))) if bn.size else 0.0
    gen = GEN_TOL * b_scale
    scale = eq.velocity_scale if eq.velocity_scale > 0 else 1.0
    strict = tol * scale / eq.row  # (2 n_c,) equilibrated threshold of eqs. (16), (25)
    aug = np.ascontiguousarray(np.concatenate([Kn, bn[:, None]], axis=1).T)  # (k+1, 2 n_c)
    found: set[bytes] = set()
    codes_out: list[np.ndarray] = []
    limit = ""
    combos = itertools.combinations(range(2 * n_c), k)
    while True:
        flat = np.fromiter(itertools.chain.from_iterable(itertools.islice(combos, SUBSET_CHUNK)),
                           dtype=np.int64)
        if flat.size == 0:
            break
        S = flat.reshape(-1, k)
        det, z = lu_det_solve(np.take(aug, S.T, axis=1))
        good = np.abs(det) > singular_tol * 1e-3  # loose: the exact test decides the rank
        if not np.any(good):
            continue
        z = z[:, good]
        v = Kn @ z - bn[:, None]  # (2 n_c, C) equilibrated velocities, eq. (5)
        zero = np.abs(v) <= gen
        many = np.flatnonzero(zero.sum(axis=0) > k)
        if many.size == 0:
            continue
        # What each contact may be at each kept z (B; in contact; rolling; sliding): many
        # subsets of one mode give the same pattern, which is expanded once.
        vm, zm = v[:, many], zero[:, many]
        pattern = np.concatenate([
            vm[0::2] > strict[0::2, None], zm[0::2], zm[1::2],
            np.abs(vm[1::2]) > strict[1::2, None],
        ]).T
        for row in np.unique(pattern, axis=0):
            for code in _modes_of_pattern(row.reshape(4, n_c)):
                if code is None:
                    limit = (f"a velocity near {MAX_MODES_PER_VELOCITY}+ mode boundaries: "
                             "some force-indeterminate candidates were not generated")
                    continue
                key = code.tobytes()
                if key not in found:
                    found.add(key)
                    codes_out.append(code)
    kins = indeterminate_kinematics_of(system, codes_out, tol=tol, singular_tol=singular_tol)
    return IndeterminateScan(tuple(kins), count, len(codes_out), limit)


def _modes_of_pattern(pattern: np.ndarray) -> Iterator[np.ndarray | None]:
    """Mode codes ``(n_c,) int8`` allowed by ``pattern (4, n_c)`` (rows: may break; normal
    vanishes; tangent vanishes; may slip) -- a superset of the modes whose rows all vanish;
    one None instead once more than :data:`MAX_MODES_PER_VELOCITY` would be generated."""
    can_b, zn, zt, can_s = pattern
    options: list[list[int]] = []
    size = 1
    for i in range(pattern.shape[1]):
        opts = [BREAK] if can_b[i] else []
        if zn[i]:
            if zt[i]:
                opts.append(ROLL)
            if can_s[i]:
                opts.append(SLIDE)
        if not opts:  # penetrating (v_n < 0): no mode
            return
        options.append(opts)
        size *= len(opts)
    if size > MAX_MODES_PER_VELOCITY:
        yield None
        return
    for combo in itertools.product(*options):
        yield np.array(combo, dtype=np.int8)


def indeterminate_kinematics(
    system: System,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
) -> list[IndeterminateKinematics]:
    """Candidates with ``2 n_R + n_S > 3 + |tau_I|`` that pass the kinematic tests (unique,
    consistent velocities; eqs. 16, 24-25 in the generalised-inverse sense).  Friction- and
    effort-independent.  Found by :func:`scan_indeterminate` (with no subset budget)."""
    scan = scan_indeterminate(system, tol=tol, singular_tol=singular_tol,
                              max_subsets=row_subset_count(system))
    return list(scan.kinematics)


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
    out: list[IndeterminateKinematics] = []
    n_c, k = system.n_contacts, system.dof
    codes = np.asarray(codes, dtype=np.int8).reshape(-1, n_c)
    if codes.shape[0] == 0:
        return out
    E, V = system.effort_joints, system.velocity_joints
    eq = equilibrated_kinematics(system)
    Kn, bn, col = eq.Kn, eq.bn, eq.col
    scale = eq.velocity_scale if eq.velocity_scale > 0 else 1.0
    n_rows_all = 2 * (codes == ROLL).sum(axis=1) + (codes == SLIDE).sum(axis=1)
    order = canonical_mode_order(codes)
    codes, n_rows_all = codes[order], n_rows_all[order]
    for k_rows in range(k + 1, 2 * n_c + 1):
        sel = n_rows_all == k_rows
        if not np.any(sel):
            continue
        cand = candidates_from_codes(codes[sel], k_rows)
        P = Kn[cand.rows]  # (M, k_rows, k)
        b = bn[cand.rows]
        s = np.linalg.svd(P, compute_uv=False)
        full_rank = s[:, -1] > np.sqrt(singular_tol) * s[:, 0]
        if not np.any(full_rank):
            continue
        idx = np.flatnonzero(full_rank)
        Pf, bf = P[idx], b[idx]
        z = (np.linalg.pinv(Pf) @ bf[..., None])[..., 0]  # generalised inverse (Sec. 3.2)
        resid = np.max(np.abs((Pf @ z[..., None])[..., 0] - bf), axis=1)
        b_scale = float(np.max(np.abs(bn)))  # relative to the commanded motion (no floor)
        consistent = resid <= tol * (b_scale if b_scale > 0 else 1.0)
        idx, z = idx[consistent], z[consistent]
        if idx.size == 0:
            continue
        z = z / col
        qdot = z[:, :3]
        thetadot = np.empty((idx.size, system.n_joints))
        thetadot[:, V] = system.joint_inputs[V]
        thetadot[:, E] = z[:, 3:]
        v = qdot @ system.W - thetadot @ system.J.T
        v_n, v_t = v[:, 0::2], v[:, 1::2]
        codes_k = cand.codes[idx]
        strict = np.where(codes_k == BREAK, v_n,
                          np.where(codes_k == SLIDE, np.abs(v_t), np.inf))
        kin_margin = np.min(strict, axis=1) / scale
        xi = np.where(codes_k == SLIDE, np.sign(v_t), 0).astype(np.int8)
        for j in np.flatnonzero(kin_margin > tol):
            i = idx[j]
            out.append(IndeterminateKinematics(
                cand.rows[i], cand.sliding[i], cand.contact[i], codes_k[j], xi[j],
                qdot[j].copy(), thetadot[j].copy(), v[j].copy(), float(kin_margin[j]),
            ))
    return out


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


def indeterminate_modes(
    system: System,
    mu: np.ndarray,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    kinematics: tuple[IndeterminateKinematics, ...] | list[IndeterminateKinematics] | None = None,
) -> list[FeasibleMode]:
    """Feasible modes with ``2 n_R + n_S > 3 + |tau_I|`` (force-indeterminate): the force LP
    of :func:`force_lp` on every kinematically admissible one (``kinematics``, default
    :func:`indeterminate_kinematics`)."""
    out: list[FeasibleMode] = []
    if kinematics is None:
        kinematics = indeterminate_kinematics(system, tol=tol, singular_tol=singular_tol)
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
    A_ub = np.hstack([-B, np.ones((B.shape[0], 1))])
    res = linprog(
        c=np.r_[np.zeros(k_rows), -1.0], A_ub=A_ub, b_ub=np.zeros(B.shape[0]),
        A_eq=np.hstack([Qs, np.zeros((Qs.shape[0], 1))]), b_eq=rhs / rs,
        bounds=[(-bound, bound)] * k_rows + [(None, f_scale)], method="highs",
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
