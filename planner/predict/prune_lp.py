"""The pruning LP of the exact search (:mod:`planner.predict.search`): the relaxation of a
partial mode assignment (forces only, or coupled with the velocities through the power row)
kept in HiGHS so that each node re-solves from the previous basis.  Full description,
exactness argument and measurements: ``docs/scaling.md``.

References
----------
Trinkle & Zeng (1994), eqs. (5), (9)-(11), (16)-(17), (21)-(26).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE
from planner.model.system import System
from planner.predict.stages import equilibrated_kinematics, force_rhs

#: Node states of a contact besides BREAK/SLIDE/ROLL: not yet decided, and "in contact"
#: (rolling or sliding, not yet decided which).
FREE, CONTACT = 3, 4



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
            power[:k] = np.concatenate([h[:system.n_q], -h[system.n_q:]]) / kin.col
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
        #: the constraint matrix and the row bounds of the root (every contact FREE is set by
        #: :meth:`contact_bounds`); the native search (:mod:`planner.predict.native_search`)
        #: solves the same LP
        self.A, self.row_lower, self.row_upper = A, lower, upper
        self._lp: Any = None
        self.cn, self.ct = cn, ct
        self._bounds_cache: dict[tuple[int, int, int], tuple[tuple, tuple[float, float]]] = {}
        self._row_bounds = [(float(lo), float(hi)) for lo, hi in zip(lower, upper)]
        self._col_bounds = [(-inf, inf)] * n_c
        self.state = np.full(n_c, -99)  # state key last set per contact (none yet)
        self.solves = 0

    @property
    def lp(self) -> Any:
        """The HiGHS model (built on first use: the native search does not need it)."""
        if self._lp is None:
            self._lp = make_lp(self.A, self.row_lower, self.row_upper)
        return self._lp

    def contact_bounds(self, i: int, state: int, xi: int) -> tuple[tuple, tuple[float, float]]:
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
        rows, cols = self.contact_bounds(i, state, xi)
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


#: HiGHS options of the pruning LPs (docs/scaling.md, "Cost").  The LP has no objective, so the
#: dual simplex's random cost perturbation only moves it off the vertex it starts from:
#: without it 9 % less CPU time (n_c = 20, seeds 0, 2, 8, 9, two rounds, every pair faster).
_HIGHS_OPTIONS: dict[str, Any] = {
    "simplex_update_limit": 50,
    "dual_simplex_cost_perturbation_multiplier": 0.0,
}


def set_rowwise_matrix(lp: Any, A: np.ndarray, core: Any) -> None:
    """Store the dense constraint matrix ``A (rows, cols)`` in the HiGHS model ``lp`` in
    row-wise sparse form (only the nonzeros; HiGHS's time per solve grows with them)."""
    nz = A != 0
    mat = lp.a_matrix_
    mat.format_ = core.MatrixFormat.kRowwise
    mat.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
    mat.index_ = np.nonzero(nz)[1].astype(np.int32)
    mat.value_ = A[nz]
    mat.num_col_, mat.num_row_ = A.shape[1], A.shape[0]
    lp.a_matrix_ = mat


class HighsLp:
    """One LP ``row_lower <= A x <= row_upper``, ``col bounds``, zero objective, kept in HiGHS
    (SciPy's bundled binding) so that bound changes re-solve from the previous basis."""

    def __init__(self, A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        from scipy.optimize._highspy import _core

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
        set_rowwise_matrix(lp, A, _core)
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
        from scipy.optimize import linprog

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


def make_lp(A: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> Any:
    try:
        return HighsLp(A, lower, upper)
    except (ImportError, AttributeError):  # private SciPy API moved: public linprog instead
        return LinprogLp(A, lower, upper)
