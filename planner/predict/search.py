"""All feasible modes without testing every candidate: exact pruned search (issue 6).

The paper tests all eq. (49) candidates (Sec. 4.7: 20 min at ``n_c = 12``) and names as future
work finding all solutions without enumerating the modes (Secs. 4.7, 6).  This module does that
with a depth-first branch-and-bound over *partial* mode assignments, pruned by an LP relaxation,
with the kinematics decided by batched tests at the leaves.  Full description, exactness
argument and measurements: ``docs/scaling.md``.

Algorithm
---------
Write ``z = (qdot, thetadot_E)`` (the unknowns of eq. 24), ``K = [W^T  -J_E]`` (2 n_c x k,
``k = 3 + |tau_I|``), ``b = J_V thetadot_V``; the relative velocity is ``v = K z - b`` (eq. 5).
A feasible mode has ``z`` and contact forces ``c (2 n_c)`` with ``W c = -g_obj``,
``J_E^T c = tau_E - g_man_E`` (eq. 26 over all contacts) and per contact: B ``v_n > 0, c = 0``
(eqs. 11, 25); S ``v_n = 0, xi v_t > 0, c_t = -mu xi c_n, c_n >= 0`` (eqs. 10, 16, 17, 22);
R ``v_n = 0, v_t = 0, |c_t| <= mu c_n`` (eqs. 9, 21).  A node gives each contact a state:
``FREE`` (undecided), ``CONTACT`` (R or S, undecided), or B / R / S+ / S-.  Children
``FREE -> B | CONTACT`` and ``CONTACT -> R | S+ | S-`` partition the parent's candidates.

A node is pruned when HiGHS proves its LP relaxation infeasible (one warm-started LP; only
bounds change between nodes).  Two relaxations (``relaxation=``):

* ``"forces"``: the contact forces only -- equilibrium; ``c = 0`` at B; ``c`` in the friction
  cone at FREE / CONTACT / R; ``c_t = -mu xi c_n``, ``c_n >= 0`` at S (inequalities relaxed by
  ``eps N``).  FREE -> CONTACT and CONTACT -> R leave it unchanged, so those children inherit
  their parent's answer.
* ``"coupled"``: the same plus the velocities ``z`` with each contact's velocity conditions
  (``v_n >= 0`` at FREE / B, ``v_n = 0`` in contact, ``v_t = 0`` at R, ``xi v_t >= 0`` at S)
  and one row that ties them to the forces: the power of the contact forces, ``c^T v =
  (K^T c)^T z - b^T c`` with ``K^T c = [-g_obj; -(tau_E - g_man_E)]`` known from eq. (26), is
  ``-sum_S mu_i c_in |v_it| <= 0`` in every feasible mode (eqs. 16-17), a *linear* inequality
  in ``(z, c)``.  Velocities alone prune almost nothing; with the power row the LP prunes far
  more (``n_c = 20`` seed 3: 1.1e6 instead of 7.1e6 candidates tested).
* ``"auto"`` (default): coupled from :data:`COUPLED_MIN_CONTACTS` contacts on (measured
  crossover; below it the forces-only LP's free inheritance wins).

Subtrees with at most ``batch_size`` candidates are generated and queued, and tested in
batches by the same code as the exhaustive path (:func:`planner.predict.stages.kinematic_stage`,
then :func:`planner.predict.stages.force_stage` on the kinematically admissible ones).

Why it is exact
---------------
A mode that exhaustive enumeration reports feasible has a velocity ``z`` and forces ``c`` that
satisfy the relaxation of every ancestor node: equilibrium and the contact rows hold to
rounding, Coulomb to ``tol max|c_A|`` (bounded by ``eps_f sum c_n`` with ``eps_f >> tol``),
the velocity rows to ``tol * velocity_scale`` (kinematic boundary cases included; the LP allows
``100 eps * velocity_scale``), and the power row holds with ``c^T v <= 0``; so it is never
pruned.  The children partition the candidates, and each surviving candidate is decided by
the same arithmetic as :func:`planner.predict.feasibility.feasible_modes` (same row order and
equilibration, one candidate's arithmetic independent of its batch).  Differences by design:
``degenerate`` counts singular candidates among those tested, and ``boundary_modes`` lists only
kinematic boundary cases whose subtree was not proved infeasible (a subset).

Cost
----
One LP (forces: ``2 n_c + 1`` unknowns, ``5 n_c + k + 2`` rows; coupled: ``k`` more unknowns,
``2 n_c`` more rows) per node that cannot inherit, plus the batched kinematic test of the
queued leaves; the number of nodes grows with the partial assignments whose relaxation is
feasible, not with eq. (49).  Exponential in the worst case (the problem contains an LCP).

References
----------
Trinkle & Zeng (1994), eqs. (5), (9)-(11), (16)-(17), (21)-(26), (29), (49); Secs. 4.7, 6.
"""

from __future__ import annotations

import itertools
import threading
from collections import deque
from dataclasses import dataclass
from functools import lru_cache
from math import comb
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.modes import (
    BREAK,
    ROLL,
    SLIDE,
    candidate_count,
    candidates_from_codes,
    enumerate_modes,
)
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.feasibility import Prediction, predict_candidates
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    equilibrated_kinematics,
    force_rhs,
    kinematic_stage,
)

#: Default largest subtree (in candidates) that is tested in one batch instead of branched.
DEFAULT_BATCH_SIZE = 128
#: Subtrees with fewer candidates than this are tested without a pruning LP first.
DEFAULT_LP_MIN_SIZE = 64
#: Relative slack of the pruning LP's Coulomb rows (well above ``DEFAULT_TOL``).
DEFAULT_PRUNE_EPS = 1e-7
#: ``relaxation="auto"`` prunes with the coupled velocity-force LP from this many contacts
#: on, with the forces-only LP below (docs/scaling.md: measured crossover).
COUPLED_MIN_CONTACTS = 17
#: Default number of open nodes handed to an executor by :func:`search_modes`.
DEFAULT_SUBTREES = 512


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
        Pruning LPs solved (force relaxations).
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


@lru_cache(maxsize=4096)
def _completion_count(n_free: int, rows_needed: int) -> int:
    """Number of assignments of ``n_free`` contacts giving exactly ``rows_needed`` rows (eq. 49)."""
    if rows_needed < 0 or rows_needed > 2 * n_free:
        return 0
    return sum(
        comb(n_free, n_r) * comb(n_free - n_r, rows_needed - 2 * n_r)
        for n_r in range(rows_needed // 2 + 1)
        if rows_needed - 2 * n_r <= n_free - n_r
    )


class Pruner:
    """LP relaxation of a partial assignment: velocities, forces and their power (module
    docstring); ``coupled=False`` keeps only the forces (no ``z'``, no ``vel`` rows, the
    ``pow`` row free).

    Variables ``x = (z', c, N)``: the scaled kinematic unknowns ``z' = col * z`` (``k``, see
    :class:`planner.predict.stages.EquilibratedKinematics`), the contact forces ``c (2 n_c)``
    and ``N = sum_j c_jn`` (its own column and row keep the matrix sparse: HiGHS's time per
    solve grows with the nonzeros).
    The constraint matrix is built once; a partial assignment only changes row and column
    bounds, so HiGHS re-solves each node from the previous basis (dual simplex warm start).
    Rows are normalised so that HiGHS's absolute tolerances act as relative ones.  Row blocks,
    each ``n_c`` long unless noted (``s`` is the velocity slack ``100 eps * velocity_scale`` per
    scaled row, ``eps_f`` the force slack):

    ``vel`` (2 n_c rows) ``v = K z - b`` (eq. 5), row ``2i`` the normal, ``2i + 1`` the tangent
        of contact ``i``: ``v_in >= -s`` (FREE, B: eqs. 11, 25), ``|v_in| <= s`` (CONTACT, R,
        S: eq. 9-10), ``|v_it| <= s`` (R), ``xi v_it >= -s`` (S, eq. 16), else free
    ``eq``  (k rows) equilibrium ``W c = -g_obj``, ``J_E^T c = tau_E - g_man_E``  (eq. 26)
    ``nn``  ``c_in + eps_f N >= 0`` for S (eq. 22, relaxed), else free
    ``cp, cm``  ``mu_i c_in -/+ c_it + eps_f N >= 0`` (FREE / CONTACT / R; eqs. 21-22)
    ``sp, sm``  ``mu_i c_in +/- c_it = 0`` for S+ / S- (eq. 17), else free
    ``pow`` (1 row) ``c^T v = [-g_obj; -(tau_E - g_man_E)] . z - b^T c <= eps_f v_s N``
        (``v_s`` the velocity scale)
    B contacts have ``c_i = 0`` (column bounds).

    The ``pow`` row couples the two halves.  Its left side is the power of the contact forces
    on the relative contact velocities, ``c^T v = c^T (K z - b) = (K^T c)^T z - b^T c``, with
    ``K^T c = [W c; -J_E^T c]`` fixed by eq. (26).  In every feasible mode it is ``<= 0``:
    ``c_i = 0`` at B, ``v_i = 0`` at R, and at S ``v_in = 0`` and ``c_it v_it = -mu_i xi_i
    c_in v_it = -mu_i c_in |v_it|`` (eqs. 16-17, 22).  Neither half knows this alone: the
    velocity rows without it prune almost nothing, with it the LP prunes far more than the
    forces alone (docs/scaling.md).
    """

    def __init__(self, system: System, eps: float, mu: np.ndarray, coupled: bool = True) -> None:
        n_c = system.n_contacts
        E = system.effort_joints
        G = np.concatenate([system.W, system.J[:, E].T], axis=0)  # (k, 2 n_c)
        k = G.shape[0]
        self.k, self.n_c, self.coupled = k, n_c, coupled
        nz = k if coupled else 0  # z' columns (none in the forces-only relaxation)
        nvr = 2 * n_c if coupled else 0  # velocity rows
        self.nz = nz
        h = force_rhs(system)
        gn = np.linalg.norm(G, axis=1)
        gn[gn == 0] = 1.0
        mu = np.asarray(mu, dtype=float)
        self.mu = mu
        force_eps = eps * max(1.0, float(np.max(mu, initial=0.0))) * 10.0
        kin = equilibrated_kinematics(system)
        vs = kin.velocity_scale if kin.velocity_scale > 0 else 1.0
        # Velocity slack per (scaled) row: the leaves keep candidates with margin >= -tol
        # (kinematic boundary cases), and eps_v = 100 eps >> tol covers them and rounding.
        self.slack = 100.0 * eps * vs / kin.row
        self.Kn, self.bn = kin.Kn, kin.bn
        inf = np.inf
        self.inf = inf
        ii = np.arange(n_c)
        nv = nz + 2 * n_c + 1  # (z', c, N)
        nN = nv - 1
        A = np.zeros((nvr + k + 5 * n_c + 2, nv))
        cn, ct = nz + 2 * ii, nz + 2 * ii + 1  # columns of c_in, c_it
        if coupled:
            A[:nvr, :nz] = kin.Kn
        self.o_eq = nvr
        A[self.o_eq:self.o_eq + k, nz:nN] = G / gn[:, None]
        o = self.o_eq + k
        for blk, (a_n, a_t, with_n) in enumerate(
            ((1.0, 0.0, True), (None, -1.0, True), (None, 1.0, True),
             (None, 1.0, False), (None, -1.0, False))
        ):
            r = o + blk * n_c + ii
            if with_n:
                A[r, nN] = force_eps
            A[r, cn] += 1.0 if a_n is not None else mu
            A[r, ct] += a_t
        self.o = o
        # N = sum_j c_jn as its own column keeps the matrix sparse (HiGHS's time per solve
        # grows with the nonzeros).
        A[-2, cn] = 1.0 / np.sqrt(n_c + 1.0)
        A[-2, nN] = -1.0 / np.sqrt(n_c + 1.0)
        # Power row: (K^T c) . z - b . c <= eps_f vs N, with K^T c = [h_obj; -h_E] (eq. 26).
        power = np.zeros(nv)
        if coupled:
            power[:k] = np.concatenate([h[:3], -h[3:]]) / kin.col
            power[k:nN] = -kin.rhs
        power[nN] = -force_eps * vs
        pn = float(np.max(np.abs(power)))
        A[-1] = power / (pn if pn > 0 else 1.0)
        lower = np.full(A.shape[0], -inf)
        upper = np.full(A.shape[0], inf)
        lower[self.o_eq:o] = h / gn
        upper[self.o_eq:o] = h / gn
        lower[-2] = upper[-2] = 0.0
        upper[-1] = 0.0 if coupled else inf
        self.lp = _make_lp(A, lower, upper)
        self.cn, self.ct = cn, ct
        self._bounds_cache: dict[tuple[int, int, int], tuple[tuple, tuple[float, float]]] = {}
        self._row_bounds = [(float(lo), float(hi)) for lo, hi in zip(lower, upper)]
        self._col_bounds = [(-inf, inf)] * n_c
        self.state = np.full(n_c, -99)  # state key last set per contact (none yet)
        self.solves = 0

    def _contact_bounds(self, i: int, state: int, xi: int) -> tuple[tuple, tuple[float, float]]:
        """Row bounds ``((row, lower, upper), ...)`` and the column bounds of ``c_i`` that contact
        ``i`` sets in ``state`` (FREE, CONTACT, BREAK, ROLL, SLIDE with ``xi``); cached."""
        key = (i, state, xi)
        hit = self._bounds_cache.get(key)
        if hit is not None:
            return hit
        inf, n_c, o = self.inf, self.n_c, self.o
        rows = []
        if self.coupled:
            rn, rt = 2 * i, 2 * i + 1
            sn, st = float(self.slack[rn]), float(self.slack[rt])
            bn, bt = float(self.bn[rn]), float(self.bn[rt])
            rows.append((rn, bn - sn, inf if state in (FREE, BREAK) else bn + sn))
            if state == ROLL:
                rows.append((rt, bt - st, bt + st))
            elif state == SLIDE:
                rows.append((rt, bt - st if xi > 0 else -inf, inf if xi > 0 else bt + st))
            else:
                rows.append((rt, -inf, inf))
        sp, sm = state == SLIDE and xi > 0, state == SLIDE and xi < 0
        rows.append((o + i, 0.0 if state == SLIDE else -inf, inf))
        cone = 0.0 if state in (FREE, CONTACT, ROLL) else -inf
        rows.append((o + n_c + i, cone, inf))
        rows.append((o + 2 * n_c + i, cone, inf))
        rows.append((o + 3 * n_c + i, 0.0 if sp else -inf, 0.0 if sp else inf))
        rows.append((o + 4 * n_c + i, 0.0 if sm else -inf, 0.0 if sm else inf))
        cols = (0.0, 0.0) if state == BREAK else (-inf, inf)
        hit = self._bounds_cache[key] = (tuple(rows), cols)
        return hit

    def _set(self, i: int, state: int, xi: int) -> None:
        """Give contact ``i`` the bounds of ``state``, passing HiGHS only those that change."""
        rows, cols = self._contact_bounds(i, state, xi)
        cur, change = self._row_bounds, self.lp.changeRowBounds
        for r, lo, hi in rows:
            if cur[r] != (lo, hi):
                change(r, lo, hi)
                cur[r] = (lo, hi)
        if self._col_bounds[i] != cols:
            self.lp.changeColBounds(int(self.cn[i]), *cols)
            self.lp.changeColBounds(int(self.ct[i]), *cols)
            self._col_bounds[i] = cols

    def solve(self, states: np.ndarray, xi: np.ndarray) -> np.ndarray | None:
        """Solve the relaxation; None when HiGHS proves it infeasible, else ``x = (z', c)``
        (zeros when HiGHS gave no verdict: the node is kept)."""
        keys = 3 * states.astype(np.int64) + xi + 1  # one per FREE, CONTACT, B, R, S+, S-
        # Contacts whose state changed; _set passes HiGHS only the bounds that differ.
        for i in np.flatnonzero(keys != self.state):
            self._set(int(i), int(states[i]), int(xi[i]))
        self.state[:] = keys
        self.solves += 1
        x = self.lp.solve()
        if x is _INFEASIBLE:
            return None
        if x is None:
            return np.zeros(self.nz + 2 * self.n_c + 1)
        return x

    def satisfies(self, x: np.ndarray, i: int, state: int, xi: int) -> bool:
        """Whether a child that puts contact ``i`` in ``state`` may take its parent's LP point
        ``x`` instead of solving: only CONTACT and R children, when ``x`` meets their velocity
        bounds (always, in the forces-only relaxation, where they keep the parent's bounds).
        Skipping an LP never loses a mode (``x`` is a feasible point of the child's LP).  B and
        S children are always solved even when ``x`` happens to be feasible for them: a fresh
        vertex steers the branching (inheriting there made the forces-only tree explode, e.g.
        ``n_c = 18`` seed 1: 212 s instead of 3.4 s)."""
        if state not in (CONTACT, ROLL):
            return False
        if not self.coupled:
            return True
        r = 2 * i if state == CONTACT else 2 * i + 1
        return bool(abs(self.Kn[r] @ x[:self.nz] - self.bn[r]) <= 1.001 * self.slack[r])


_INFEASIBLE = object()


#: HiGHS options of the pruning LPs (docs/scaling.md, "Cost").
_HIGHS_OPTIONS: dict[str, Any] = {"simplex_update_limit": 50}


class HighsLp:
    """One LP ``row_lower <= A x <= row_upper``, ``col bounds``, zero objective, kept in HiGHS
    (SciPy's bundled binding) so that bound changes re-solve from the previous basis."""

    def __init__(self, A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        from scipy.optimize._highspy import _core  # type: ignore[import-untyped]

        self._core = _core
        inf = _core.kHighsInf
        nv = A.shape[1]
        lp = _core.HighsLp()
        lp.num_col_, lp.num_row_ = nv, A.shape[0]
        lp.col_cost_ = np.zeros(nv)
        lp.col_lower_ = np.full(nv, -inf)
        lp.col_upper_ = np.full(nv, inf)
        lp.row_lower_ = np.where(np.isfinite(lower), lower, -inf)
        lp.row_upper_ = np.where(np.isfinite(upper), upper, inf)
        nz = A != 0
        mat = lp.a_matrix_
        mat.format_ = _core.MatrixFormat.kRowwise
        mat.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
        mat.index_ = np.nonzero(nz)[1].astype(np.int32)
        mat.value_ = A[nz]
        mat.num_col_, mat.num_row_ = nv, A.shape[0]
        lp.a_matrix_ = mat
        self._h = _core._Highs()
        self._h.setOptionValue("output_flag", False)
        self._h.setOptionValue("presolve", "off")
        for name, value in _HIGHS_OPTIONS.items():
            self._h.setOptionValue(name, value)
        self._h.passModel(lp)
        self._inf = inf
        self.retries = 0
        self.verdict = True  # whether the last solve ended optimal or infeasible
        if inf == np.inf:  # HiGHS's infinity is IEEE inf: call the binding directly
            self.changeRowBounds = self._h.changeRowBounds  # type: ignore[method-assign]
            self.changeColBounds = self._h.changeColBounds  # type: ignore[method-assign]

    def _b(self, x: float) -> float:
        return self._inf if x == np.inf else -self._inf if x == -np.inf else x

    def changeRowBounds(self, i: int, lo: float, hi: float) -> None:  # noqa: N802
        self._h.changeRowBounds(i, self._b(lo), self._b(hi))

    def changeColBounds(self, j: int, lo: float, hi: float) -> None:  # noqa: N802
        self._h.changeColBounds(j, self._b(lo), self._b(hi))

    def reset(self) -> None:
        """Forget the basis (the next solve starts cold, as in a new model)."""
        self._h.clearSolver()

    def solve(self) -> Any:
        """Solution ``x``, ``_INFEASIBLE`` when proved infeasible, None on any other outcome.

        A warm start occasionally ends without a verdict (``kUnknown``: seen on the coupled LP
        after some bound changes); then the LP is solved once more from scratch."""
        self._h.run()
        status = self._h.getModelStatus()
        if status not in (self._core.HighsModelStatus.kOptimal,
                          self._core.HighsModelStatus.kInfeasible):
            self.retries += 1
            self._h.clearSolver()
            self._h.run()
            status = self._h.getModelStatus()
        self.verdict = status in (self._core.HighsModelStatus.kOptimal,
                                  self._core.HighsModelStatus.kInfeasible)
        if status == self._core.HighsModelStatus.kInfeasible:
            return _INFEASIBLE
        if status != self._core.HighsModelStatus.kOptimal:
            return None
        return np.asarray(self._h.getSolution().col_value)


class LinprogLp:
    """Fallback with the same interface through the public ``scipy.optimize.linprog`` (cold
    starts; used only if SciPy's HiGHS binding is unavailable)."""

    def __init__(self, A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        self.A, self.lower, self.upper = A, lower.copy(), upper.copy()
        self.col_lower = np.full(A.shape[1], -np.inf)
        self.col_upper = np.full(A.shape[1], np.inf)
        self.verdict = True

    def reset(self) -> None:
        """Nothing to forget: every solve starts cold."""

    def changeRowBounds(self, i: int, lo: float, hi: float) -> None:  # noqa: N802
        self.lower[i], self.upper[i] = lo, hi

    def changeColBounds(self, j: int, lo: float, hi: float) -> None:  # noqa: N802
        self.col_lower[j], self.col_upper[j] = lo, hi

    def solve(self) -> Any:
        from scipy.optimize import linprog  # type: ignore[import-untyped]

        eq = self.lower == self.upper
        up = ~eq & np.isfinite(self.upper)
        lo = ~eq & np.isfinite(self.lower)
        res = linprog(
            np.zeros(self.A.shape[1]),
            A_ub=np.vstack([self.A[up], -self.A[lo]]),
            b_ub=np.concatenate([self.upper[up], -self.lower[lo]]),
            A_eq=self.A[eq], b_eq=self.lower[eq],
            bounds=[(None if not np.isfinite(a) else a, None if not np.isfinite(b) else b)
                    for a, b in zip(self.col_lower, self.col_upper)],
            method="highs",
        )
        self.verdict = res.status in (0, 2)
        if res.status == 2:
            return _INFEASIBLE
        return res.x if res.status == 0 else None


def _make_lp(A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> Any:
    try:
        return HighsLp(A, lower, upper)
    except (ImportError, AttributeError):  # private SciPy API moved: public linprog instead
        return LinprogLp(A, lower, upper)


#: Node states of a contact besides BREAK/SLIDE/ROLL: not yet decided, and "in contact"
#: (rolling or sliding, not yet decided which).
FREE, CONTACT = 3, 4


def _subtree_size(states: np.ndarray, n_rows: int) -> int:
    """Number of candidate codes (eq. 49) consistent with the node ``states``."""
    counts = np.bincount(states, minlength=5)
    used = 2 * int(counts[ROLL]) + int(counts[SLIDE])
    return _subtree_count(int(counts[FREE]), int(counts[CONTACT]), n_rows - used)


@lru_cache(maxsize=4096)
def _subtree_count(n_free: int, n_con: int, rows_left: int) -> int:
    """Completions of ``n_free`` undecided and ``n_con`` in-contact contacts to ``rows_left``
    rows (each CONTACT gives one row, two if rolling)."""
    need = rows_left - n_con
    return sum(comb(n_con, r) * _completion_count(n_free, need - r) for r in range(n_con + 1))


@lru_cache(maxsize=256)
def _rolled_subsets(n_con: int, r: int) -> np.ndarray:
    """All ``r``-subsets of ``n_con`` contacts as a read-only boolean table (C(n_con, r), n_con)."""
    rolled = np.zeros((comb(n_con, r), n_con), dtype=bool)
    for j, subset in enumerate(itertools.combinations(range(n_con), r)):
        rolled[j, list(subset)] = True
    rolled.setflags(write=False)
    return rolled


def _completions(states: np.ndarray, n_rows: int) -> np.ndarray:
    """All candidate codes (m, n_c) int8 consistent with the node ``states``."""
    n_c = len(states)
    fixed = (states == BREAK) | (states == SLIDE) | (states == ROLL)
    used = 2 * int(np.sum(states == ROLL)) + int(np.sum(states == SLIDE))
    free = np.flatnonzero(states == FREE)
    con = np.flatnonzero(states == CONTACT)
    base = np.where(fixed, states, 0).astype(np.int8)
    blocks = []
    for r in range(len(con) + 1):
        need = n_rows - used - len(con) - r
        if _completion_count(len(free), need) == 0:
            continue
        if len(free) == 0:
            tail = np.zeros((1, 0), dtype=np.int8)
        elif need == 0:
            tail = np.zeros((1, len(free)), dtype=np.int8)
        else:
            tail = enumerate_modes(len(free), need).codes
        rolled = _rolled_subsets(len(con), r)
        n_t = tail.shape[0]
        blk = np.empty((rolled.shape[0] * n_t, n_c), dtype=np.int8)
        blk[:] = base
        blk[:, free] = np.tile(tail, (rolled.shape[0], 1))
        blk[:, con] = np.where(np.repeat(rolled, n_t, axis=0), ROLL, SLIDE)
        blocks.append(blk)
    return np.concatenate(blocks) if blocks else np.zeros((0, n_c), dtype=np.int8)


def _branch_contact(states: np.ndarray, point: np.ndarray | None, mu: np.ndarray) -> int:
    """Contact to branch on, from the relaxed forces ``c``: the FREE contact with the largest
    normal force (its ``B`` child, ``c_i = 0``, is the most likely to be infeasible); else the
    CONTACT one deepest inside its friction cone (largest ``mu c_n - |c_t|``: its sliding
    children are the most likely to be infeasible).  When no FREE contact carries force in
    ``c``, splitting one cannot prune (its ``B`` child is satisfied by ``c``, its ``CONTACT``
    child inherits ``c``), so a CONTACT one is split first if there is one.  ``point is None``:
    the lowest index."""
    free = np.flatnonzero(states == FREE)
    con = np.flatnonzero(states == CONTACT)
    if point is None:
        return int(free[0]) if len(free) else int(con[0])
    c = point
    free_force = c[2 * free]
    if len(free) and (
        not len(con) or np.max(free_force) > _ZERO_FORCE * max(float(np.max(np.abs(c))), 1e-300)
    ):
        return int(free[np.argmax(free_force)])
    fn, ft = c[2 * con], c[2 * con + 1]
    return int(con[np.argmax(mu[con] * fn - np.abs(ft))])


#: Relative size below which a relaxed normal force counts as zero in :func:`_branch_contact`
#: (a heuristic: it orders the branching, never decides a mode).
_ZERO_FORCE = 1e-9


#: Leaf candidates collected before one batched kinematic test (amortises the batched LU).
_LEAF_FLUSH = 4096


class _LeafBatches:
    """Leaves of the search, tested in batches of about ``_LEAF_FLUSH`` candidates.

    The kinematic test of a candidate does not depend on the other candidates of its batch,
    and the traversal does not depend on leaf outcomes, so leaves are queued and tested
    together by :func:`planner.predict.stages.kinematic_stage` (eqs. 23-25, 16).  A candidate
    is kept when it is kinematically admissible or on a kinematic boundary and, at every contact
    its leaf fixed to ``S+``/``S-``, its computed ``xi`` is that of the leaf (``xi = 0``, only
    possible on a boundary, is owned by ``S+``), so each candidate is owned by one leaf.
    """

    def __init__(self, system: System, n_rows: int, *, tol: float, singular_tol: float) -> None:
        self.system, self.n_rows = system, n_rows
        self.tol, self.singular_tol = tol, singular_tol
        self.pending: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.n_pending = 0
        self.kept: list[np.ndarray] = []
        self.tested = 0

    def add(self, block: np.ndarray, states: np.ndarray, xi: np.ndarray) -> None:
        """Queue a leaf's candidate codes ``block (m, n_c)`` with its node ``states``/``xi``."""
        if len(block) == 0:
            return
        self.pending.append((block, states, xi))
        self.n_pending += len(block)
        if self.n_pending >= _LEAF_FLUSH:
            self.flush()

    def flush(self) -> None:
        """Test every queued candidate in one batch."""
        if not self.pending:
            return
        codes = np.concatenate([b for b, _, _ in self.pending])
        reps = [len(b) for b, _, _ in self.pending]
        leaf_states = np.repeat(np.stack([st for _, st, _ in self.pending]), reps, axis=0)
        leaf_xi = np.repeat(np.stack([x for _, _, x in self.pending]), reps, axis=0)
        self.pending, self.n_pending = [], 0
        self.tested += len(codes)
        kin = kinematic_stage(
            self.system, candidates_from_codes(codes, self.n_rows), tol=self.tol,
            singular_tol=self.singular_tol,
        )
        own_xi = np.where(kin.xi == 0, 1, kin.xi)
        foreign = (leaf_states == SLIDE) & (own_xi != leaf_xi)
        keep = (kin.ok | kin.boundary) & ~foreign.any(axis=1)
        self.kept.append(codes[keep])

    def kept_codes(self) -> np.ndarray:
        """Codes ``(m, n_c)`` kept by every leaf (after a final flush)."""
        self.flush()
        if not self.kept:
            return np.zeros((0, self.system.n_contacts), dtype=np.int8)
        return np.concatenate(self.kept)


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
    executor: Any = None,
    subtrees: int = DEFAULT_SUBTREES,
    relaxation: str = "auto",
    progress: bool = False,
) -> SearchResult:
    """Every feasible mode of ``system`` (same set as exhaustive eq. 49 enumeration), pruned.

    Parameters
    ----------
    system : System
    mu : float or (n_c,), optional
        Friction coefficients; defaults to ``system.mu``.
    tol, singular_tol, indeterminate
        As in :func:`planner.predict.feasibility.feasible_modes`.
    batch_size : int
        Subtrees with at most this many candidates are tested in one batch, not branched.
    prune_eps : float
        Relative slack of the force relaxation: its Coulomb rows are relaxed by
        ``eps_f N`` with ``eps_f = 10 prune_eps max(1, mu_max)`` (must exceed ``tol``).
    lp_min_size : int
        Subtrees with at most this many candidates are not pruned by an LP first.
    executor : planner.sweeps.executor.Executor, optional
        Search independent subtrees in parallel (Sec. 6's "test modes in parallel"): the tree
        is expanded breadth-first here until ``subtrees`` nodes are open, and each open node's
        subtree is searched by ``executor.map`` (local processes or Dask).  The modes are the
        same as without it; ``stats`` sums the workers' counts.
    subtrees : int
        Open nodes handed to the executor.
    relaxation : {"auto", "coupled", "forces"}
        Pruning LP: the contact forces only, or coupled with the velocities through the power
        row (module docstring); ``"auto"`` couples from :data:`COUPLED_MIN_CONTACTS` contacts
        on.  The modes are the same; only the work differs.
    progress : bool
        With an executor: a progress bar (tqdm, on stderr) over the subtrees.

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
    for name, value, low in (("batch_size", batch_size, 1), ("lp_min_size", lp_min_size, 0),
                             ("subtrees", subtrees, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise InputError(f"{name}: expected an integer >= {low}, got {value!r}")
    if not (np.isfinite(prune_eps) and prune_eps > tol):
        raise InputError(f"prune_eps: expected a finite number > tol ({tol}), got {prune_eps}")
    n_c, k = system.n_contacts, system.dof
    n_cand = candidate_count(n_c, k)
    if relaxation not in ("auto", "coupled", "forces"):
        raise InputError(
            f"relaxation: expected 'auto', 'coupled' or 'forces', got {relaxation!r}"
        )
    coupled = relaxation == "coupled" or (
        relaxation == "auto" and n_c >= COUPLED_MIN_CONTACTS
    )
    params = _Params(k, tol, singular_tol, batch_size, prune_eps, lp_min_size, coupled)
    pruner = Pruner(system, prune_eps, mu_arr, coupled=params.coupled)
    leaves = _LeafBatches(system, k, tol=tol, singular_tol=singular_tol)
    root: _Node = (np.full(n_c, FREE, dtype=np.int8), np.zeros(n_c, dtype=np.int8), None, True)
    open_nodes: deque[_Node] = deque([root])
    lp_solves = 0
    if executor is None:
        _expand(open_nodes, pruner, leaves, mu_arr, params)
    else:
        _expand(open_nodes, pruner, leaves, mu_arr, params, breadth_until=subtrees)
        jobs = [(system, mu_arr, node, params) for node in open_nodes]
        for kept, tested, solves in executor.map(
            _search_subtree, jobs, progress=progress, desc="subtrees"
        ):
            leaves.kept.append(kept)
            leaves.tested += tested
            lp_solves += solves
    lp_solves += pruner.solves
    codes = canonical_order(np.unique(leaves.kept_codes(), axis=0))
    cand = candidates_from_codes(codes, k)
    prediction, force_tested = predict_candidates(
        system, cand, mu_arr, tol=tol, singular_tol=singular_tol, indeterminate=indeterminate
    )
    stats = SearchStats(
        candidates=n_cand,
        tested=leaves.tested,
        force_tested=force_tested,
        lp_solves=lp_solves,
    )
    return SearchResult(prediction, stats)


#: A search node: state per contact, xi per contact, the parent's LP point (or None) and
#: whether the node must solve its LP (False: the parent's point is feasible for it).
_Node = tuple[np.ndarray, np.ndarray, "np.ndarray | None", bool]


@dataclass(frozen=True)
class _Params:
    n_rows: int
    tol: float
    singular_tol: float
    batch_size: int
    prune_eps: float
    lp_min_size: int
    coupled: bool


def _expand(
    open_nodes: deque[_Node],
    pruner: Pruner,
    leaves: _LeafBatches,
    mu_arr: np.ndarray,
    params: _Params,
    *,
    breadth_until: int | None = None,
) -> None:
    """Branch and bound over ``open_nodes`` (module docstring).

    Depth-first until no node is open; with ``breadth_until``, breadth-first and only until
    that many nodes are open (they are left in ``open_nodes``).  FREE -> BREAK | CONTACT,
    CONTACT -> ROLL | SLIDE xi=+1 | SLIDE xi=-1: the children partition the parent's codes.  A
    CONTACT or R child inherits its parent's LP point when the point meets its bounds
    (:meth:`Pruner.satisfies`): the parent's answer stands.
    """
    k = params.n_rows
    while open_nodes:
        if breadth_until is not None and len(open_nodes) >= breadth_until:
            return
        states, xi, point, changed = (
            open_nodes.pop() if breadth_until is None else open_nodes.popleft()
        )
        size = _subtree_size(states, k)
        if size == 0:
            continue
        if size > params.lp_min_size:
            if changed or point is None:
                point = pruner.solve(states, xi)
                if point is None:
                    continue
        else:
            point = None
        undecided = np.any((states == FREE) | (states == CONTACT))
        if size <= params.batch_size or not undecided:
            leaves.add(_completions(states, k), states, xi)
            continue
        i = _branch_contact(states, None if point is None else point[pruner.nz:-1], mu_arr)
        children: tuple[tuple[int, int], ...]
        if states[i] == FREE:
            children = ((BREAK, 0), (CONTACT, 0))
        else:
            children = ((SLIDE, 1), (SLIDE, -1), (ROLL, 0))
        for code, x in children:
            child, child_xi = states.copy(), xi.copy()
            child[i], child_xi[i] = code, x
            inherit = point is not None and pruner.satisfies(point, i, code, x)
            open_nodes.append((child, child_xi, point, not inherit))


def _search_subtree(job: tuple[System, np.ndarray, _Node, _Params]) -> tuple[np.ndarray, int, int]:
    """Executor task: search one node's subtree; its kept codes, tested count and LP count.

    A worker process keeps the last system's pruner (its HiGHS model) between tasks, so many
    small subtrees cost little more than one big one.  The basis is cleared before each
    subtree, so the LP answers, and with them the branching and the statistics, do not depend
    on which worker searched which subtrees before (same counts locally and through Dask)."""
    system, mu_arr, node, params = job
    key = _pruner_key(system, mu_arr, params.prune_eps, params.coupled)
    cache = _WORKER.__dict__.setdefault("pruners", {})
    cached = cache.get(key)
    if cached is None:
        cache.clear()
        cached = cache[key] = Pruner(
            system, params.prune_eps, mu_arr, coupled=params.coupled
        )
    pruner = cached
    pruner.lp.reset()  # each subtree starts cold: the traversal does not depend on task order
    before = pruner.solves
    leaves = _LeafBatches(system, params.n_rows, tol=params.tol, singular_tol=params.singular_tol)
    _expand(deque([node]), pruner, leaves, mu_arr, params)
    return leaves.kept_codes(), leaves.tested, pruner.solves - before


#: Per worker thread: the pruner of the last system it searched (see :func:`_search_subtree`).
#: Thread-local because a HiGHS model must not be shared by threads (Dask threads workers).
_WORKER = threading.local()


def _pruner_key(system: System, mu: np.ndarray, eps: float, coupled: bool) -> bytes:
    """Digest of everything a :class:`Pruner` is built from."""
    import hashlib

    d = hashlib.sha256()
    for a in (system.W, system.J, system.joint_inputs, system.g_obj, system.g_man, mu,
              np.asarray(system.effort_joints), np.asarray(system.velocity_joints),
              np.asarray([eps, float(coupled)])):
        a = np.ascontiguousarray(a)
        d.update(str(a.dtype).encode() + str(a.shape).encode())
        d.update(a.tobytes())
    return d.digest()


def canonical_order(codes: np.ndarray) -> np.ndarray:
    """Sort codes as :func:`planner.model.modes.enumerate_modes`: by ``n_R``, rolling set,
    sliding set."""
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
