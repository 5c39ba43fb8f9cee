"""Torque bands over friction *and* the workpiece's mass and centre of mass (eqs. 2, 26, 28).

The load set is the convex hull of ``K`` vertex wrenches ``g_1 .. g_K``
(:class:`planner.model.load_set.LoadSet`: ``g_obj`` is linear in ``(m, m c)``).  At fixed
friction ``mu`` and torque ``tau`` every Coulomb row of eq. (28) is ``s0(mu, g) + s1(mu) . tau``
with ``s0`` *linear* in ``g`` (eq. 26: ``c_A = Q_AI^{-1} [-g_obj; tau - g_man_I]``; ``Q_AI``
and hence ``s1`` and ``det Q_AI`` do not depend on the load).  Therefore
(proofs: docs/planning.md, "Uncertainty beyond friction"):

* **claimed mode, exact.**  A row holds for every ``g`` in the hull iff it holds at every vertex
  (an affine function's minimum over a polytope is at a vertex), for each ``mu`` and ``tau``.  The
  guaranteed band over friction x loads is the intersection of the friction-only guaranteed bands
  at the ``K`` vertex loads -- exactly as exact as each of those is.
* **rivals, a bound checked for tightness.**  The set of torques at which a rival is possible for
  *some* ``(mu, g)`` is a union; its ends are not in general at vertex loads (at fixed ``mu`` the
  rival's lower end is the maximum of affine functions of ``g`` -- convex -- so its minimum over
  the hull can lie inside it).  The band keeps ``tau`` out of the intersection over the rival's
  rows of each row's *own* union (where that row can hold): a superset of the rival's union
  (``tau`` possible at some point satisfies every row there), and each row's union is computed
  exactly (an affine-in-``g`` ratio ``-s0/s1``: its extremes are at a vertex load and a critical
  friction value of that vertex).  Where every load shares the friction points (one friction
  point, or the independent model's corners and grid, which the friction-only bands use too),
  the rows are kept together at each friction point and taken apart over the loads only: the
  hull over the points of each point's row bound, again a superset of the union there, and
  equal to the friction-only union when the set is one load (decoupling the rows across
  friction points as well left the rival possible wherever one row held at one friction and
  another at a different one).  The rival's union is also bounded from inside by the
  friction-only unions at the vertex loads (points of the set).  When the two agree the band is
  exact (``ModeBand.exact``); otherwise it is sound but conservative and marked inexact.
* **force-indeterminate rivals** (relaxed utility): at each friction point of
  :func:`planner.plan.bounds.mode_bands` the torque range over the whole load hull is one linear
  program with the convex weights ``lambda`` of the vertex loads as unknowns (exact at that
  friction point); the friction points are what the friction-only band uses (exact for
  rolling-only modes, a grid otherwise).

Units: torques in the joint's units (N m revolute, N prismatic); loads ``(K, 3)`` [N, N, N m]
about the world origin.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.errors import DegenerateError, InputError
from planner.model.modes import SLIDE
from planner.model.system import System
from planner.model.validation import friction_interval
from planner.plan.bounds import (
    AffineRows,
    ModeBand,
    admissible_modes,
    box_points,
    critical_mus,
    mode_bands,
    mode_rows,
)
from planner.plan.intervals import EMPTY, Interval, hull
from planner.plan.offset_bounds import (
    OffsetBox,
    candidate_arrays,
    lifted_interval,
    sign_changes,
    uniform_indeterminate,
    uniform_stages,
)
from planner.predict.indeterminate import (
    IndeterminateKinematics,
    coulomb_rows,
    indeterminate_kinematics,
)
from planner.predict.stages import DEFAULT_TOL, force_matrices


def check_loads(system: System, loads: Any) -> np.ndarray:
    """``(K, n_q)`` vertex loads as floats; :class:`InputError` naming the shape otherwise."""
    arr = np.asarray(loads, dtype=float)
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] != system.n_q:
        raise InputError(f"loads: expected (K, {system.n_q}) vertex wrenches, got shape "
                         f"{arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("loads: expected finite wrenches, got a non-finite value")
    return arr


def with_load(system: System, g: np.ndarray) -> System:
    """``system`` with the external wrench ``g (n_q,)`` (eq. 2); nothing else changes."""
    return replace(system, g_obj=np.asarray(g, dtype=float))


def concat_rows(parts: list[AffineRows]) -> AffineRows:
    """Stack affine rows of the same modes along the point axis ``L`` (friction x load)."""
    first = parts[0]
    return AffineRows(first.modes, np.concatenate([r.s0 for r in parts]),
                      np.concatenate([r.s1 for r in parts]), first.active,
                      np.concatenate([r.det for r in parts]),
                      np.concatenate([r.scale for r in parts]))


def friction_points(system: System, mu_lo: np.ndarray, mu_hi: np.ndarray, model: str,
                    grid: int, stage: Any, index: Any) -> np.ndarray:
    """``(L, n_c)`` the friction points at which :func:`mode_bands` takes a rival's union for
    this ``system`` (its load): a point; the critical values of the common model; the box's
    corners and grid (independent model)."""
    n_c = system.n_contacts
    if np.all(mu_lo == mu_hi):
        return mu_lo[None]
    if model == "common":
        xs = critical_mus(system, float(mu_lo[0]), float(mu_hi[0]), stage=stage, index=index)
        return np.repeat(xs[:, None], n_c, axis=1)
    corners, g = box_points(mu_lo, mu_hi, grid)
    return np.concatenate([corners, g])


def row_union(s0: np.ndarray, s1: np.ndarray, det: np.ndarray, scale: np.ndarray,
              active: np.ndarray, tol: float) -> Interval:
    """Outer bound of where a mode is possible: the intersection over its active rows of the
    torques at which *that row* holds at some point (``s0, s1 (L, 3 n_c)``, ``det, scale (L,)``).

    A row with the same strict slope sign at every point holds on a half-line from the extreme
    of ``-s0/s1``; a row free of ``tau`` everywhere that fails everywhere empties the set; any
    other row (slope changing sign, flat somewhere) is not used (the bound stays sound).  Points
    with singular ``Q_AI`` are skipped, as in :func:`planner.plan.bounds.intervals`."""
    ok = det != 0
    if not np.any(ok):
        return EMPTY
    lo, hi = -np.inf, np.inf
    sc = scale[ok]
    for r in np.flatnonzero(active):
        a, b = s1[ok, r], s0[ok, r]
        flat = np.abs(a) <= tol * sc
        if np.all(flat):
            if np.all(b < -tol * sc):
                return EMPTY
            continue
        if np.any(flat):
            continue
        if np.all(a > 0):
            lo = max(lo, float(np.min(-b / a)))
        elif np.all(a < 0):
            hi = min(hi, float(np.max(-b / a)))
    return Interval(lo, hi) if lo <= hi else EMPTY


def same_interval(a: Interval, b: Interval, scale: float) -> bool:
    """Equal ends to ``1e-9`` relative (both empty counts as equal)."""
    if a.empty or b.empty:
        return a.empty and b.empty
    return all(x == y or abs(x - y) <= 1e-9 * (scale + abs(x) + abs(y))
               for x, y in ((a.lower, b.lower), (a.upper, b.upper)))


def load_bands(system: System, mu: Any, loads: Any, *, model: str = "common", grid: int = 5,
               tol: float = DEFAULT_TOL,
               box: OffsetBox | None = None) -> tuple[ModeBand, ...]:
    """Guaranteed and possible torque sets of every admissible mode for every friction in ``mu``
    and every load in the hull of ``loads (K, n_q)`` (module docstring).  Same arguments and
    same band order as :func:`planner.plan.bounds.mode_bands`.

    ``box``: a box of contact offsets (:func:`planner.plan.offset_bounds.offset_box`, its
    systems with ``system``'s joints; their loads are replaced by ``loads``): the bands then
    hold over every contact position in it too -- a determinate mode's guaranteed set by
    intersection at the vertices, its possible set by the same row bound over vertex geometry
    x vertex load x friction point; a force-indeterminate mode's, or one whose ``det Q_AI``
    changes sign inside the box (then guaranteed nowhere), by the lifted program over the whole
    friction box (:func:`planner.plan.offset_bounds.lifted_interval`: exact for a friction box
    or a rolling-only mode, else an outer bound and ``exact`` False); docs/planning.md,
    "Contact positions".  Raises :class:`DegenerateError` when the modes may change inside the
    box (:func:`planner.plan.offset_bounds.uniform_stages`)."""
    G = check_loads(system, loads)
    mu_lo, mu_hi = friction_interval(mu, system.n_contacts)
    geos = [system] if box is None else list(box.systems)
    systems = [with_load(geo, g) for geo in geos for g in G]
    per = [mode_bands(s, mu, model=model, grid=grid, tol=tol) for s in systems]
    labels = [b.label for b in per[0]]
    if any([b.label for b in bands] != labels for bands in per[1:]):
        raise DegenerateError("load set: the admissible modes differ between vertex loads "
                              "or vertex geometries")
    if box is not None:
        stages = uniform_stages(geos, tol=tol)
    else:
        stages = [admissible_modes(system, tol=tol)]
    stage_of = [stages[k // len(G)] for k in range(len(systems))]
    pts = [friction_points(s, mu_lo, mu_hi, model, grid, *stage_of[k])
           for k, s in enumerate(systems)]
    if box is not None:  # every geometry at every friction point: the signs of det Q_AI compared
        pts = [np.unique(np.concatenate(pts), axis=0)] * len(systems)
    rows = [mode_rows(s, pts[k], stage=stage_of[k][0], index=stage_of[k][1])
            for k, s in enumerate(systems)]
    n_det = len(stages[0][1])
    poles = (sign_changes(np.stack([r.det for r in rows])) if box is not None and n_det
             else np.zeros(n_det, bool))
    box_exact = bool(model == "independent" or np.all(mu_lo == mu_hi))
    # one friction point, or the independent model's corners and grid: the same points for
    # every load and geometry, which the friction-only bands also use (module docstring)
    shared = box_exact and all(np.array_equal(p, pts[0]) for p in pts)
    if shared:  # (L, systems, ...): each friction point's rows of every load and geometry
        S0, S1, DET, SC = (np.stack([getattr(r, f) for r in rows], axis=1)
                           for f in ("s0", "s1", "det", "scale"))
    kins = (indeterminate_kinematics(system, tol=tol) if box is None
            else uniform_indeterminate(box, tol=tol))
    out = []
    for j, base in enumerate(per[0]):
        own = [bands[j] for bands in per]
        g_lo = max(b.guaranteed.lower for b in own)
        g_hi = min(b.guaranteed.upper for b in own)
        guaranteed = Interval(g_lo, g_hi) if g_lo <= g_hi else EMPTY
        got = [b.possible for b in own if not b.possible.empty]
        inner = hull(got)
        exact = all(b.exact for b in own)
        if box is not None and j < n_det and poles[j]:
            # det Q_AI crosses zero inside the box: not guaranteed there; the lifted program
            guaranteed = EMPTY
            kin_j = candidate_arrays(stages[0][0], int(stages[0][1][j]))
            possible = lifted_interval(box, kin_j, mu_lo, mu_hi, G)
            exact = box_exact or not np.any(kin_j.codes == SLIDE)
        elif j < n_det:  # determinate: the row bound, exact when it meets the inner hull
            if shared:  # rows coupled at each friction point, decoupled over loads only
                outer = hull([row_union(S0[p, :, j], S1[p, :, j], DET[p, :, j], SC[p, :, j],
                                        rows[0].active[j], tol) for p in range(len(pts[0]))])
            else:
                s0 = np.concatenate([r.s0[:, j] for r in rows])
                s1 = np.concatenate([r.s1[:, j] for r in rows])
                det = np.concatenate([r.det[:, j] for r in rows])
                scale = np.concatenate([r.scale[:, j] for r in rows])
                outer = row_union(s0, s1, det, scale, rows[0].active[j], tol)
            size = max([1.0] + [abs(x) for p in got for x in (p.lower, p.upper)
                                if np.isfinite(x)])
            exact = exact and same_interval(outer, inner, size)
            possible = outer
        else:
            kin = kins[j - n_det]
            has_slide = bool(np.any(kin.codes == SLIDE))
            mpts = (np.repeat(np.linspace(mu_lo[0], mu_hi[0], 21)[:, None], system.n_contacts, 1)
                    if has_slide and model == "common" and np.all(mu_lo == mu_lo[0])
                    and np.all(mu_hi == mu_hi[0]) and not np.all(mu_lo == mu_hi)
                    else np.concatenate(box_points(mu_lo, mu_hi, grid)) if has_slide
                    else np.stack([mu_lo, mu_hi]))
            if box is None:
                possible = hull([indeterminate_interval_over(system, kin, m, G) for m in mpts])
            else:  # the whole friction box at once (exact for a box or rolling only)
                possible = lifted_interval(box, kin, mu_lo, mu_hi, G)
                exact = box_exact or not has_slide
        out.append(ModeBand(base.mode, guaranteed, possible, exact=exact))
    return tuple(out)


def indeterminate_interval_over(system: System, kin: IndeterminateKinematics, mu: Any,
                                loads: np.ndarray) -> Interval:
    """Torque range of a force-indeterminate mode at friction ``mu (n_c,)`` over the hull of
    ``loads (K, n_q)``: the projection on ``tau`` of ``{(c_A, tau, lambda): Q_A c_A - e tau +
    [sum_k lambda_k g_k; 0] = [0; -g_man_I], B_A c_A >= 0, lambda >= 0, sum lambda = 1}``
    (eqs. 21-22, 26; two linear programs, scipy HiGHS) -- exact at this friction point."""
    mu_v = np.asarray(mu, dtype=float)
    QT = force_matrices(system, kin.rows[None], kin.sliding[None], kin.contact[None],
                        kin.xi[None], mu_v[None])[0, 0]
    return _range_lp(system, QT.T, coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes,
                                                mu_v), loads, kin.mode.label)


def _range_lp(system: System, Q: np.ndarray, B: np.ndarray, loads: np.ndarray,
              label: str) -> Interval:
    k, n_rows = Q.shape
    K, n_q = loads.shape
    E = system.effort_joints
    e = np.zeros(k)
    e[n_q] = 1.0
    L = np.zeros((k, K))
    L[:n_q] = loads.T
    A_eq = np.vstack([np.hstack([Q, -e[:, None], L]),
                      np.r_[np.zeros(n_rows + 1), np.ones(K)][None]])
    b_eq = np.r_[np.zeros(n_q), -system.g_man[E], 1.0]
    rs = np.max(np.abs(A_eq), axis=1)
    rs[rs == 0] = 1.0
    A_ub = np.hstack([-B, np.zeros((B.shape[0], 1 + K))])
    ends = []
    for sign in (1.0, -1.0):
        res = linprog(np.r_[np.zeros(n_rows), sign, np.zeros(K)], A_ub=A_ub,
                      b_ub=np.zeros(B.shape[0]), A_eq=A_eq / rs[:, None], b_eq=b_eq / rs,
                      bounds=[(None, None)] * (n_rows + 1) + [(0.0, None)] * K, method="highs")
        if res.status == 2:
            return EMPTY
        if res.status == 3:
            ends.append(-np.inf if sign > 0 else np.inf)
        elif res.status == 0:
            ends.append(float(res.x[n_rows]))
        else:
            raise DegenerateError(f"torque range LP failed for mode {label}: {res.message}")
    return Interval(ends[0], ends[1])


def indeterminate_cut_over(system: System, kin: IndeterminateKinematics, mus: np.ndarray,
                           a: np.ndarray, loads: np.ndarray) -> float:
    """``min`` of ``a . tau_I`` over a force-indeterminate rival's torque sets at the friction
    points ``mus`` and every load in the hull of ``loads (K, n_q)`` (the LP of
    :func:`indeterminate_interval_over` with ``p`` torques); ``-inf`` when unbounded, ``+inf``
    when the rival is infeasible at every point."""
    E = system.effort_joints
    p = len(E)
    K, n_q = loads.shape
    best = np.inf
    for mu_v in mus:
        QT = force_matrices(system, kin.rows[None], kin.sliding[None], kin.contact[None],
                            kin.xi[None], mu_v[None])[0, 0]
        Q = QT.T
        k, n_rows = Q.shape
        sel = np.zeros((k, p))
        sel[n_q:, :] = np.eye(p)
        L = np.zeros((k, K))
        L[:n_q] = loads.T
        A_eq = np.vstack([np.hstack([Q, -sel, L]), np.r_[np.zeros(n_rows + p), np.ones(K)][None]])
        b_eq = np.r_[np.zeros(n_q), -system.g_man[E], 1.0]
        B = coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes, mu_v)
        res = linprog(np.r_[np.zeros(n_rows), a, np.zeros(K)],
                      A_ub=np.hstack([-B, np.zeros((len(B), p + K))]), b_ub=np.zeros(len(B)),
                      A_eq=A_eq, b_eq=b_eq,
                      bounds=[(None, None)] * (n_rows + p) + [(0.0, None)] * K, method="highs")
        if res.status == 3:
            return -np.inf
        if res.status == 0:
            best = min(best, float(res.fun))
    return best
