"""All feasible modes without testing every candidate: exact pruned search (issue 6).

The paper tests all eq. (49) candidates (Sec. 4.7: 20 min at ``n_c = 12``) and names as future
work finding all solutions without enumerating the modes (Secs. 4.7, 6).  This module does that
with a depth-first branch-and-bound over *partial* mode assignments, contact by contact.

Algorithm
---------
Write ``z = (qdot, thetadot_E)`` (the unknowns of eq. 24), ``K = [W^T  -J_E]`` (2 n_c x k,
``k = 3 + |tau_I|``) and ``b = J_V thetadot_V``; the relative velocity is ``v = K z - b``
(eq. 5).  A candidate that passes the kinematic test of eqs. (23)-(25) has a ``z`` with

* ``v_in = 0`` and ``v_it = 0`` at rolling contacts (eq. 9),
* ``v_in = 0`` at sliding contacts (eq. 10),
* ``v_in > 0`` at breaking contacts (eqs. 11, 25).

Relax the strict inequality to ``v_in >= -eps`` and keep only the constraints of the contacts
already assigned, plus ``v_in >= -eps`` for every unassigned contact (in *every* mode each contact
has ``v_in >= 0``).  This is a linear feasibility problem in ``z`` (solved with scipy HiGHS).
If it is infeasible, no completion of the partial assignment can pass eqs. (23)-(25), so the whole
subtree is pruned.  A subtree is also pruned when its constraint count cannot reach
``2 n_R + n_S = k`` (eq. 29 with the Sec. 4.7 partition).  When a subtree holds at most
``batch_size`` candidates, they are all generated and tested by the *same* batched code as the
exhaustive path (:func:`planner.feasibility.kinematic_stage`, then
:func:`planner.feasibility.force_stage` on the kinematically admissible ones).

Why it is exact
---------------
Every mode reported by exhaustive enumeration satisfies the LP of each of its ancestors (its own
``z`` is a feasible point, with ``v_in > tol * scale >= -eps`` on breaking contacts), so it is
never pruned; and every candidate that is not pruned is decided by exactly the same arithmetic
as in :func:`planner.feasibility.feasible_modes` (same row order, same equilibration).  Hence
the feasible set, the certificates and the ``boundary_modes`` are identical.  The only
difference: ``degenerate`` counts the singular candidates *among those tested*.  An LP that
HiGHS does not report as infeasible (including numerical trouble) never prunes.

Cost
----
One small LP (``k`` unknowns, ``n_c`` rows) per expanded node; the number of nodes grows with
the number of kinematically admissible partial assignments, not with eq. (49).  The force stage
(friction) only sees the kinematically admissible modes.  See ``docs/scaling.md`` for measured
times and counts.

References
----------
Trinkle & Zeng (1994), eqs. (5), (9)-(11), (23)-(25), (29), (49); Secs. 4.7 and 6.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.errors import DegenerateError, InputError
from planner.feasibility import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    INDETERMINATE_AUTO_MAX_CONTACTS,
    FeasibleMode,
    Prediction,
    Status,
    _velocity_input,
    force_rhs,
    force_stage,
    kinematic_stage,
)
from planner.model import System
from planner.modes import BREAK, ROLL, SLIDE, CandidateSet, Mode, candidate_count, enumerate_modes
from planner.validation import as_friction

#: Default largest subtree (in candidates) that is tested in one batch instead of branched.
DEFAULT_BATCH_SIZE = 2048
#: Subtrees with fewer candidates than this are tested without a pruning LP first.
DEFAULT_LP_MIN_SIZE = 16
#: Relative slack on ``v_in >= 0`` in the pruning LPs (well above ``DEFAULT_TOL``).
DEFAULT_PRUNE_EPS = 1e-7


@dataclass(frozen=True)
class SearchStats:
    """What the search did.

    Attributes
    ----------
    candidates : int
        Eq. (49) count ``candidate_count(n_c, 3 + |tau_I|)``.
    tested : int
        Candidates that went through the batched kinematic stage (eqs. 23-25).
    force_tested : int
        Candidates that passed it and went through the force stage (eqs. 26-28).
    lp_solves : int
        Pruning LPs solved.
    """

    candidates: int
    tested: int
    force_tested: int
    lp_solves: int

    def to_dict(self) -> dict[str, int]:
        return {
            "candidates": self.candidates,
            "tested": self.tested,
            "force_tested": self.force_tested,
            "lp_solves": self.lp_solves,
        }


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Result of :func:`search_modes`: the prediction and the search statistics."""

    prediction: Prediction
    stats: SearchStats


def _completion_count(n_free: int, rows_needed: int) -> int:
    """Number of assignments of ``n_free`` contacts giving exactly ``rows_needed`` rows (eq. 49)."""
    if rows_needed < 0 or rows_needed > 2 * n_free:
        return 0
    return sum(
        comb(n_free, n_r) * comb(n_free - n_r, rows_needed - 2 * n_r)
        for n_r in range(rows_needed // 2 + 1)
        if rows_needed - 2 * n_r <= n_free - n_r
    )


def candidates_from_codes(codes: np.ndarray, n_rows: int) -> CandidateSet:
    """Build a :class:`CandidateSet` from mode codes ``(M, n_c)`` (each with ``n_rows`` rows).

    Rows follow :func:`planner.modes.enumerate_modes`: ``[n_R normals; t_R tangents; n_S
    normals]`` (eq. 14), each block in contact order, so the arithmetic per candidate is the
    same as on the exhaustive path.
    """
    codes = np.asarray(codes, dtype=np.int8)
    M, n_c = codes.shape
    idx = np.arange(n_c)
    big = 4 * n_c
    key_n = np.where(codes == ROLL, idx, np.where(codes == SLIDE, 2 * n_c + idx, big))
    key_t = np.where(codes == ROLL, n_c + idx, big)
    keys = np.concatenate([key_n, key_t], axis=1)  # (M, 2 n_c)
    row_id = np.concatenate([np.broadcast_to(2 * idx, (M, n_c)),
                             np.broadcast_to(2 * idx + 1, (M, n_c))], axis=1)
    order = np.argsort(keys, axis=1, kind="stable")[:, :n_rows]
    rows = np.take_along_axis(row_id, order, axis=1).astype(np.int64)
    sel = np.take_along_axis(keys, order, axis=1)
    if M and np.any(sel >= big):
        raise InputError(f"codes: expected every mode to have {n_rows} constraint rows")
    sliding = sel >= 2 * n_c
    contact = rows // 2
    return CandidateSet(n_c, n_rows, codes, rows, sliding, contact)


class _Pruner:
    """LP relaxation of a partial assignment (module docstring), kinematics and forces.

    Variables ``x = [z (k); c (2 n_c)]``.  Rows are normalised (unit rows after a global column
    scaling, as in the batched stages) so that HiGHS's absolute tolerances are relative ones.
    """

    def __init__(self, system: System, eps: float, mu: np.ndarray) -> None:
        n_c = system.n_contacts
        E = system.effort_joints
        K = np.concatenate([system.W.T, -system.J[:, E]], axis=1)
        b = _velocity_input(system)
        scale = float(np.max(np.abs(b))) if b.size else 0.0
        col = np.max(np.abs(K), axis=0)
        col[col == 0] = 1.0
        Kc = K / col
        row = np.linalg.norm(Kc, axis=1)
        row[row == 0] = 1.0
        self.K = Kc / row[:, None]
        self.b = b / row
        self.slack = eps * (scale if scale > 0 else 1.0) / row
        self.k = K.shape[1]
        # Equilibrium (eq. 26 summed over all contacts): W c = -g_obj, J_E^T c = tau_E - g_man_E.
        G = np.concatenate([system.W, system.J[:, E].T], axis=0)  # (k, 2 n_c)
        h = force_rhs(system)
        gn = np.linalg.norm(G, axis=1)
        gn[gn == 0] = 1.0
        self.G = G / gn[:, None]
        self.h = h / gn
        self.n_c = n_c
        self.mu = np.asarray(mu, dtype=float)
        # Coulomb slack relative to the total normal force N = sum c_n (see module docstring).
        self.force_eps = eps * max(1.0, float(np.max(self.mu, initial=0.0))) * 10.0
        self.solves = 0

    def feasible(self, codes: np.ndarray, xi: np.ndarray, n_assigned: int) -> bool:
        """False only when HiGHS proves the relaxation of the first ``n_assigned`` contacts
        infeasible."""
        n_c, k = self.n_c, self.k
        nv = k + 2 * n_c
        status = np.full(n_c, -1)
        status[:n_assigned] = codes[:n_assigned]
        a_ub: list[np.ndarray] = []
        b_ub: list[float] = []
        a_eq: list[np.ndarray] = []
        b_eq: list[float] = []
        n_sum = np.zeros(nv)
        n_sum[k::2] = self.force_eps
        bounds: list[tuple[float | None, float | None]] = [(None, None)] * nv
        for i in range(n_c):
            s = status[i]
            kn, kt = self.K[2 * i], self.K[2 * i + 1]
            zrow_n = np.zeros(nv)
            zrow_n[:k] = kn
            zrow_t = np.zeros(nv)
            zrow_t[:k] = kt
            cn, ct = k + 2 * i, k + 2 * i + 1
            if s == BREAK or s == -1:  # v_n >= -slack
                a_ub.append(-zrow_n)
                b_ub.append(-self.b[2 * i] + self.slack[2 * i])
            else:  # v_n = 0
                a_eq.append(zrow_n)
                b_eq.append(self.b[2 * i])
            if s == ROLL:
                a_eq.append(zrow_t)
                b_eq.append(self.b[2 * i + 1])
            if s == SLIDE:  # xi v_t >= -slack (eq. 16), c_t = -mu xi c_n (eq. 17)
                x = float(xi[i])
                a_ub.append(-x * zrow_t)
                b_ub.append(-x * self.b[2 * i + 1] + self.slack[2 * i + 1])
                r = np.zeros(nv)
                r[ct] = 1.0
                r[cn] = self.mu[i] * x
                a_eq.append(r)
                b_eq.append(0.0)
            if s == BREAK:
                bounds[cn] = (0.0, 0.0)
                bounds[ct] = (0.0, 0.0)
            else:  # c_n >= -eps N
                r = -n_sum.copy()
                r[cn] -= 1.0
                a_ub.append(r)
                b_ub.append(0.0)
            if s == ROLL or s == -1:  # |c_t| <= mu c_n + eps N (eqs. 21-22)
                for sign in (1.0, -1.0):
                    r = -n_sum.copy()
                    r[cn] -= self.mu[i]
                    r[ct] += sign
                    a_ub.append(r)
                    b_ub.append(0.0)
        eq_force = np.zeros((k, nv))
        eq_force[:, k:] = self.G
        A_eq = np.vstack([np.array(a_eq).reshape(-1, nv), eq_force])
        B_eq = np.concatenate([np.array(b_eq, dtype=float), self.h])
        self.solves += 1
        res = linprog(
            np.zeros(nv),
            A_ub=np.array(a_ub) if a_ub else None,
            b_ub=np.array(b_ub) if b_ub else None,
            A_eq=A_eq,
            b_eq=B_eq,
            bounds=bounds,
            method="highs",
        )
        return res.status != 2


def _completions(prefix: np.ndarray, n_assigned: int, n_rows: int) -> np.ndarray:
    """All codes that extend ``prefix[:n_assigned]`` to ``n_rows`` rows, (m, n_c) int8."""
    n_c = len(prefix)
    used = 2 * int(np.sum(prefix[:n_assigned] == ROLL)) + int(
        np.sum(prefix[:n_assigned] == SLIDE)
    )
    n_free = n_c - n_assigned
    need = n_rows - used
    if n_free == 0:
        return prefix[None].copy() if need == 0 else np.zeros((0, n_c), dtype=np.int8)
    if _completion_count(n_free, need) == 0:
        return np.zeros((0, n_c), dtype=np.int8)
    if need == 0:
        tail = np.zeros((1, n_free), dtype=np.int8)
    else:
        tail = enumerate_modes(n_free, need).codes
    out = np.empty((tail.shape[0], n_c), dtype=np.int8)
    out[:, :n_assigned] = prefix[:n_assigned]
    out[:, n_assigned:] = tail
    return out


def search_modes(
    system: System,
    mu: Any = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    indeterminate: bool | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
    prune_eps: float = DEFAULT_PRUNE_EPS,
    lp_min_size: int = DEFAULT_LP_MIN_SIZE,
) -> SearchResult:
    """Every feasible mode of ``system`` (same set as exhaustive eq. 49 enumeration), pruned.

    Parameters
    ----------
    system : System
    mu : float or (n_c,), optional
        Friction coefficients; defaults to ``system.mu``.
    tol, singular_tol, indeterminate
        As in :func:`planner.feasibility.feasible_modes`.
    batch_size : int
        Subtrees with at most this many candidates are tested in one batch, not branched.
    prune_eps : float
        Relative slack of ``v_in >= 0`` in the pruning LPs (must exceed ``tol``).

    Returns
    -------
    SearchResult
        ``prediction`` equal to ``feasible_modes(system, mu)`` (modes, order, certificates,
        boundary modes; ``degenerate`` counts tested candidates only) and ``stats``.
    """
    if not isinstance(system, System):
        raise InputError(f"system: expected a planner System, got {type(system).__name__}")
    mu_arr = system.mu if mu is None else as_friction(mu, system.n_contacts)
    if not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"tol: expected a finite number >= 0, got {tol}")
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or (
        batch_size < 1
    ):
        raise InputError(f"batch_size: expected an integer >= 1, got {batch_size!r}")
    if not (np.isfinite(prune_eps) and prune_eps > tol):
        raise InputError(f"prune_eps: expected a finite number > tol ({tol}), got {prune_eps}")
    n_c, k = system.n_contacts, system.dof
    n_cand = candidate_count(n_c, k)
    pruner = _Pruner(system, prune_eps, mu_arr)
    kept: list[np.ndarray] = []
    tested = 0
    # Depth-first over contacts; a node is (codes prefix, xi prefix, number assigned, rows used).
    stack: list[tuple[np.ndarray, np.ndarray, int, int]] = [
        (np.zeros(n_c, dtype=np.int8), np.zeros(n_c, dtype=np.int8), 0, 0)
    ]
    while stack:
        prefix, xi, depth, used = stack.pop()
        size = _completion_count(n_c - depth, k - used)
        if size == 0:
            continue
        if size > lp_min_size and not pruner.feasible(prefix, xi, depth):
            continue
        if size <= batch_size or depth == n_c:
            block = _completions(prefix, depth, k)
            tested += len(block)
            kin = kinematic_stage(
                system, candidates_from_codes(block, k), tol=tol, singular_tol=singular_tol
            )
            keep = kin.ok | kin.boundary
            # Each sliding direction of the prefix owns the candidates with that xi (xi = 0,
            # possible only on a boundary, goes to the S+ branch).
            for i in range(depth):
                if prefix[i] == SLIDE:
                    x = np.where(kin.xi[:, i] == 0, 1, kin.xi[:, i])
                    keep &= x == xi[i]
            kept.append(block[keep])
            continue
        for code, x, rows in ((BREAK, 0, 0), (SLIDE, 1, 1), (SLIDE, -1, 1), (ROLL, 0, 2)):
            if _completion_count(n_c - depth - 1, k - used - rows) == 0:
                continue
            child, child_xi = prefix.copy(), xi.copy()
            child[depth], child_xi[depth] = code, x
            stack.append((child, child_xi, depth + 1, used + rows))
    codes = np.concatenate(kept) if kept else np.zeros((0, n_c), dtype=np.int8)
    codes = _canonical_order(np.unique(codes, axis=0))
    cand = candidates_from_codes(codes, k)
    prediction, force_tested = _predict(
        system, cand, mu_arr, n_cand, tol=tol, singular_tol=singular_tol,
        indeterminate=indeterminate,
    )
    stats = SearchStats(
        candidates=n_cand,
        tested=tested,
        force_tested=force_tested,
        lp_solves=pruner.solves,
    )
    return SearchResult(prediction, stats)


def _canonical_order(codes: np.ndarray) -> np.ndarray:
    """Sort codes as :func:`planner.modes.enumerate_modes`: by ``n_R``, rolling, sliding set."""
    if len(codes) == 0:
        return codes
    n_c = codes.shape[1]
    n_r = (codes == ROLL).sum(axis=1)
    # Lexicographic on sorted index tuples == lexicographic on the membership vectors reversed
    # (a set containing a smaller index first sorts first), i.e. on -membership.
    keys = [-(codes[:, i] == SLIDE).astype(int) for i in reversed(range(n_c))]
    keys += [-(codes[:, i] == ROLL).astype(int) for i in reversed(range(n_c))]
    keys.append(n_r)
    return codes[np.lexsort(keys)]


def _predict(
    system: System,
    cand: CandidateSet,
    mu_arr: np.ndarray,
    n_cand: int,
    *,
    tol: float,
    singular_tol: float,
    indeterminate: bool | None,
) -> tuple[Prediction, int]:
    """Kinematic then force stage on ``cand``; assemble a Prediction as ``feasible_modes`` does."""
    kin = kinematic_stage(system, cand, tol=tol, singular_tol=singular_tol)
    idx = np.flatnonzero(kin.ok)
    fs = force_stage(system, cand, idx, kin.xi[idx], mu_arr, singular_tol=singular_tol)
    margin = np.minimum(fs.margin[0], kin.margin[idx])
    feasible = fs.nonsingular[0] & (margin >= -tol)
    finite = np.isfinite(kin.qdot[idx]).all(axis=1) & np.isfinite(fs.c_A[0]).all(axis=1)
    if np.any(fs.nonsingular[0] & ~finite):
        raise DegenerateError(
            "numerical overflow while solving eqs. (24)/(26): expected inputs whose magnitudes "
            "fit in double precision products (rescale lengths, forces or speeds)"
        )
    modes = []
    for j in np.flatnonzero(feasible):
        i = idx[j]
        modes.append(
            FeasibleMode(
                mode=Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i])),
                qdot=kin.qdot[i].copy(),
                joint_velocities=kin.joint_velocities[i].copy(),
                contact_velocities=kin.v[i].reshape(-1, 2).copy(),
                contact_forces=fs.contact_forces[0, j].copy(),
                joint_efforts=fs.joint_efforts[0, j].copy(),
                margin=float(margin[j]),
                on_boundary=bool(abs(margin[j]) <= tol),
            )
        )
    boundary = tuple(
        Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i]))
        for i in np.flatnonzero(kin.boundary)
    )
    degenerate = int(np.count_nonzero(~kin.nonsingular)) + int(
        np.count_nonzero(~fs.nonsingular[0])
    )
    if indeterminate is None:
        indeterminate = system.n_contacts <= INDETERMINATE_AUTO_MAX_CONTACTS
    extra: tuple[FeasibleMode, ...] = ()
    if indeterminate:
        from planner.indeterminate import indeterminate_modes

        extra = tuple(indeterminate_modes(system, mu_arr, tol=tol, singular_tol=singular_tol))
    n_feasible = len(modes) + len(extra)
    if n_cand == 0:
        status = Status.NO_CANDIDATES
        reason = (
            f"the utility conditions (29)-(32) admit no mode: {system.n_contacts} contact(s) "
            f"cannot supply 2 n_R + n_S = {system.dof} kinematic constraints"
        )
    elif kin.velocity_scale == 0.0:
        status = Status.AT_REST
        reason = (
            "every commanded joint velocity is zero: nothing slides or breaks; "
            + (f"{n_feasible} static equilibrium mode(s) hold" if n_feasible else
               "no static equilibrium holds")
        )
    elif n_feasible == 0:
        status = Status.JAMMED
        reason = "no candidate mode is feasible" + (
            f" ({degenerate} candidate(s) violate the rank conditions (30)-(32))"
            if degenerate else ""
        )
    else:
        status = Status.UNIQUE if n_feasible == 1 else Status.AMBIGUOUS
        reason = f"{n_feasible} feasible mode(s)"
    if boundary or any(m.on_boundary for m in modes + list(extra)):
        reason += "; some decisions are within tolerance of a boundary"
    pred = Prediction(
        status=status,
        candidates=n_cand,
        modes=tuple(modes),
        indeterminate_modes=extra,
        boundary_modes=boundary,
        degenerate=degenerate,
        tol=tol,
        mu=np.array(mu_arr, dtype=float),
        reason=reason,
    )
    return pred, len(idx)
