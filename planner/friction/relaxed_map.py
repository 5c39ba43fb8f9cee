"""Force-indeterminate (relaxed-utility, end of Sec. 3.2) modes on friction-space grids,
without one linear program per grid point.

Along a grid line only the first varied coefficient ``mu_j`` changes.  For a relaxed mode the
feasible ``mu_j`` of that line form one interval, found by two linear programs:

* ``j`` slides (eqs. 10, 17): the forces enter eq. (26) through ``c_nj`` and ``g = mu_j c_nj``
  linearly, so the feasible ``(c_nj, g)`` are a convex set ``S`` (a projection of the force
  polyhedron) and ``mu_j`` is feasible iff the ray ``g = mu_j c_nj`` meets ``S``.  If
  ``c_nj = 0`` is feasible every ``mu_j`` is; otherwise the slopes ``g / c_nj`` of a convex
  set in ``c_nj > 0`` form an interval, whose ends are linear-fractional programs, solved as
  LPs by the Charnes-Cooper substitution ``y = c / c_nj``, ``t = 1 / c_nj``:
  ``min / max mu'`` s.t. ``sum_r Q_r y_r + q_nj - xi_j mu' q_tj = rhs t``, the other
  contacts' Coulomb rows on ``y``, ``t >= 0``.
* ``j`` rolls (eqs. 9, 21): ``|c_tj| <= mu_j c_nj`` only loosens with ``mu_j``: an up-set,
  ``mu_j >= min |y_tj|`` by one LP of the same kind.
* ``j`` breaks or is not in the mode: the line is all feasible or all not (one test).

Every grid point's verdict is then read off the interval.  Near an end (within
:data:`EDGE` relative) a point is decided by the per-point test of
:func:`planner.predict.feasibility.feasible_modes` (:func:`planner.predict.indeterminate.force_lp`),
so the labels agree with it at every grid point, boundaries included.

References: Trinkle & Zeng (1994), eqs. (9)-(10), (17), (21)-(22), (26); Sec. 3.2;
Charnes & Cooper (1962), linear-fractional programming.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from planner.model.modes import BREAK, ROLL, SLIDE
from planner.model.system import System
from planner.predict.indeterminate import IndeterminateKinematics, force_lp
from planner.predict.prune_lp import set_rowwise_matrix
from planner.predict.stages import DEFAULT_SINGULAR_TOL, force_rhs

#: Grid points within this relative distance of an interval end are tested one by one.
EDGE = 1e-6


class _Lp:
    """Small dense LPs ``min c x`` s.t. ``A_ub x <= 0``, ``A_eq x = 0``, bounds: HiGHS through
    SciPy's bundled binding (one solver object reused: ~3x less overhead than ``linprog``),
    or ``scipy.optimize.linprog`` if that binding is unavailable."""

    def __init__(self) -> None:
        try:
            from scipy.optimize._highspy import _core

            self._core = _core
            self._h = _core._Highs()
            self._h.setOptionValue("output_flag", False)
        except (ImportError, AttributeError):  # private SciPy API moved
            self._core = None

    def solve(self, c: np.ndarray, A_ub: np.ndarray, A_eq: np.ndarray,
              bounds: list[tuple[float | None, float | None]]) -> np.ndarray | None:
        """The optimal ``x``, or None when infeasible (or no verdict)."""
        if self._core is None:
            res = linprog(c, A_ub=A_ub, b_ub=np.zeros(A_ub.shape[0]), A_eq=A_eq,
                          b_eq=np.zeros(A_eq.shape[0]), bounds=bounds, method="highs")
            return res.x if res.status == 0 else None
        core = self._core
        inf = core.kHighsInf
        A = np.vstack([A_ub, A_eq])
        lp = core.HighsLp()
        lp.num_col_, lp.num_row_ = A.shape[1], A.shape[0]
        lp.col_cost_ = np.asarray(c, dtype=float)
        lp.col_lower_ = np.array([-inf if lo is None else lo for lo, _ in bounds], dtype=float)
        lp.col_upper_ = np.array([inf if hi is None else hi for _, hi in bounds], dtype=float)
        lp.row_lower_ = np.r_[np.full(A_ub.shape[0], -inf), np.zeros(A_eq.shape[0])]
        lp.row_upper_ = np.zeros(A.shape[0])
        set_rowwise_matrix(lp, A, core)
        self._h.clearModel()
        self._h.passModel(lp)
        self._h.run()
        if self._h.getModelStatus() != core.HighsModelStatus.kOptimal:
            return None
        return np.asarray(self._h.getSolution().col_value)


def relaxed_mode_on_lines(
    system: System, kin: IndeterminateKinematics, axis0: np.ndarray, others: np.ndarray,
    j: int, tol: float,
) -> np.ndarray:
    """Feasibility ``(n_lines, len(axis0))`` of one relaxed mode on grid lines.

    ``others (n_lines, n_c)`` holds each line's friction vector (entry ``j`` ignored),
    ``axis0`` the values of ``mu_j`` along every line (ascending).
    """
    out = np.zeros((others.shape[0], len(axis0)), bool)
    code = int(kin.codes[j])
    lp = _Lp()
    for li, mu_line in enumerate(others):
        if code == BREAK:  # mu_j does not enter: one test for the line
            m = mu_line.copy()
            m[j] = axis0[0]
            out[li] = _point(system, kin, m, tol)
            continue
        lo, hi = _interval(system, kin, mu_line, j, code, lp)
        row = np.zeros(len(axis0), bool)
        if lo is not None:
            span = max(1.0, abs(lo), abs(hi) if np.isfinite(hi) else 1.0)
            row = (axis0 >= lo - EDGE * span) & (axis0 <= hi + EDGE * span)
            near = (np.abs(axis0 - lo) <= 2 * EDGE * span) | (
                np.isfinite(hi) & (np.abs(axis0 - hi) <= 2 * EDGE * span))
        else:
            near = np.zeros(len(axis0), bool)
        for i in np.flatnonzero(near):
            m = mu_line.copy()
            m[j] = axis0[i]
            row[i] = _point(system, kin, m, tol)
        out[li] = row
    return out


def relaxed_mode_at_points(system: System, kin: IndeterminateKinematics, mu: np.ndarray,
                           tol: float) -> np.ndarray:
    """Feasibility ``(L,)`` of one relaxed mode at friction vectors ``mu (L, n_c)``, one linear
    program each (:func:`planner.predict.indeterminate.force_lp`)."""
    return np.array([_point(system, kin, m, tol) for m in mu], dtype=bool)


def _point(system: System, kin: IndeterminateKinematics, mu: np.ndarray, tol: float) -> bool:
    res = force_lp(system, kin.rows, kin.sliding, kin.contact, kin.codes, kin.xi, mu,
                   DEFAULT_SINGULAR_TOL)
    return res is not None and min(kin.margin, res[2]) >= -tol


def _interval(system: System, kin: IndeterminateKinematics, mu: np.ndarray, j: int,
              code: int, lp: _Lp) -> tuple[float | None, float]:
    """Feasible ``mu_j`` of the mode on one line: ``(lo, hi)`` (``hi`` may be inf), or
    ``(None, nan)`` when none."""
    E = system.effort_joints
    G = np.concatenate([system.W.T, system.J[:, E]], axis=1)  # (2 n_c, q): rows of Q^T
    rhs = force_rhs(system)
    rs = np.max(np.abs(G), axis=0)
    rs[rs == 0] = 1.0
    G, rhs = G / rs, rhs / rs
    rows, contact = kin.rows, kin.contact
    n_r = rows.size
    # Columns of Q for the mode's force components at this line's friction (eqs. 17-19).
    Q = np.empty((G.shape[1], n_r))
    for r in range(n_r):
        i = int(contact[r])
        col = G[rows[r]].copy()
        if kin.sliding[r]:
            col -= mu[i] * kin.xi[i] * G[2 * i + 1]
        Q[:, r] = col
    ub: list[np.ndarray] = []  # rows "a . x <= 0" on x = (y, mu', t)
    n_var = n_r + 2
    for r in range(n_r):
        i = int(contact[r])
        if rows[r] % 2 == 0 and i != j:
            if kin.codes[i] == ROLL:
                jt = int(np.flatnonzero(rows == rows[r] + 1)[0])
                for sign in (1.0, -1.0):
                    a = np.zeros(n_var)
                    a[r], a[jt] = -mu[i], -sign
                    ub.append(a)
            a = np.zeros(n_var)
            a[r] = -1.0
            ub.append(a)
    rn = int(np.flatnonzero(rows == 2 * j)[0])
    # Equality: Q y (with y_nj = 1 and, if j slides, its column's mu part moved to mu') = rhs t.
    A_eq = np.zeros((Q.shape[0], n_var))
    A_eq[:, :n_r] = Q
    A_eq[:, n_r + 1] = -rhs
    bounds: list[tuple[float | None, float | None]] = [(None, None)] * n_r
    bounds += [(0.0, None), (0.0, None)]  # mu' >= 0, t >= 0
    if code == SLIDE:
        A_eq[:, rn] = G[2 * j]
        A_eq[:, n_r] = -kin.xi[j] * G[2 * j + 1]
    else:  # rolling: mu' >= |y_tj|
        rt = int(np.flatnonzero(rows == 2 * j + 1)[0])
        for sign in (1.0, -1.0):
            a = np.zeros(n_var)
            a[rt], a[n_r] = sign, -1.0
            ub.append(a)
    # c_nj = 0 feasible?  Then every mu_j is (the original problem with that force zero).
    A_ub = np.array(ub) if ub else np.zeros((0, n_var))
    # c_j = 0 feasible (t = 1: the original scale)?  Then every mu_j is.
    zero_bounds = list(bounds)
    zero_bounds[rn] = (0.0, 0.0)
    if code == ROLL:
        zero_bounds[int(np.flatnonzero(rows == 2 * j + 1)[0])] = (0.0, 0.0)
    zero_bounds[n_r], zero_bounds[n_r + 1] = (0.0, 0.0), (1.0, 1.0)
    A_zero = A_eq.copy()
    A_zero[:, rn] = Q[:, rn]
    if lp.solve(np.zeros(n_var), A_ub, A_zero, zero_bounds) is not None:
        return 0.0, np.inf
    bounds[rn] = (1.0, 1.0)
    c = np.zeros(n_var)
    c[n_r] = 1.0
    lo = lp.solve(c, A_ub, A_eq, bounds)
    if lo is None:
        return None, float("nan")
    if code == ROLL:
        return float(lo[n_r]), np.inf
    hi = lp.solve(-c, A_ub, A_eq, bounds)
    return float(lo[n_r]), (float(hi[n_r]) if hi is not None else np.inf)
