"""Torque regions for several effort-controlled joints: a polytope per waypoint (eq. 28).

With the effort-controlled joints ``I`` (``p = |tau_I|``) the force stage of a determinate mode is
affine in ``tau_I``: eq. (26) gives ``c_A = Q_AI^{-1} [-g_obj; tau_I - g_man_I]``, so every
Coulomb row of eq. (28) (eqs. 21-22: ``c_n >= 0`` sliding, ``mu c_n -+ c_t >= 0`` and ``c_n >= 0``
rolling) reads ``s0(mu) + s1(mu) . tau_I >= 0``.  At one friction vector a mode's torque set is a
polytope; with ``p = 1`` it is the interval of :mod:`planner.plan.bounds`.

Friction box (one interval per contact).  ``Q_AI`` has one column per sliding contact that is
affine in that contact's ``mu_i`` (eqs. 18-19), so ``det Q_AI`` and, by Cramer's rule, every
``det Q_AI * (s0 + s1 . tau)`` are *multilinear* in ``mu`` (a rolling row's ``mu_i`` multiplies a
numerator free of ``mu_i``).  A multilinear function takes its extremes over a box at the box's
corners.  Hence, when ``det Q_AI`` has the same strict sign at every corner (it then keeps it on
the whole box):

* the claimed mode holds for every ``mu`` in the box iff its rows hold at the ``2^n_c`` corners:
  the *guaranteed polytope* ``G`` is the H-representation of the corner rows -- exact;
* a rival's row ``rho`` fails for every ``mu`` in the box iff it fails at every corner: the
  half-space set ``{s0_rho(k) + s1_rho(k) . tau <= 0 at every corner k}`` is exact.

A torque excludes a rival over the box when, for each ``mu``, *some* row of the rival fails; the
region keeps, per rival, *one* row failing everywhere (an inner approximation of the exclusion set,
which is not convex in general).  The row is chosen greedily, rival by rival, to keep the largest
Chebyshev ball (its centre is the commanded torque, its radius the margin).  Force-indeterminate
rivals (relaxed utility) are excluded by a separating half-space whose offset is the minimum of a
linear program over the corners and a grid: *sampled* (``exact`` False).  When the claimed mode's
or a rival's ``det`` changes sign over the corners, those rows are taken at corners and grid
points as well (``exact`` False).

The common-friction model (one coefficient shared by all contacts) is a subset of the box: the
box region is a sound inner approximation of it.  With ``p = 1``
:func:`planner.plan.guarantee.guarantee` (exact critical points of the common model) is used,
so the region is the one-joint guaranteed band.  With ``p = 0`` (every joint
velocity-controlled) the region is a point: the mode is guaranteed or not, and the margin is
the smallest normalised Coulomb slack.

Units: ``tau_I`` in the joints' units (N m revolute, N prismatic); ``margin`` in the same units
(the radius of the ball of commands that keep the guarantee).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linprog

from planner.errors import DegenerateError, InputError
from planner.model.system import System
from planner.model.validation import friction_interval
from planner.plan.bounds import AffineRows, admissible_modes, affine_rows, box_points
from planner.plan.guarantee import Guarantee, guarantee, resolve_claim
from planner.plan.intervals import Interval
from planner.plan.load_bounds import check_loads, concat_rows, indeterminate_cut_over, with_load
from planner.predict.indeterminate import (
    IndeterminateKinematics,
    coulomb_rows,
    indeterminate_kinematics,
)
from planner.predict.stages import DEFAULT_TOL, force_matrices


def chebyshev_centre(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre ``(p,)`` and radius of the largest ball in ``{x : A x <= b}`` (one LP, HiGHS).

    Radius ``-inf`` when the polytope is empty; ``p = 0``: ``(empty, min(b))`` (the point set is
    non-empty iff every ``b >= 0``).  The caller bounds the polytope (a box of commands).
    """
    p = A.shape[1]
    if p == 0:
        return np.zeros(0), float(np.min(b)) if len(b) else np.inf
    norms = np.linalg.norm(A, axis=1)
    keep = norms > 0
    if np.any(~keep & (b < 0)):
        return np.full(p, np.nan), -np.inf
    An, bn = A[keep] / norms[keep, None], b[keep] / norms[keep]  # unit rows: better conditioned
    res = linprog(np.r_[np.zeros(p), -1.0], A_ub=np.hstack([An, np.ones((len(An), 1))]),
                  b_ub=bn, bounds=[(None, None)] * p + [(0.0, None)], method="highs")
    if res.status == 2:
        return np.full(p, np.nan), -np.inf
    if res.status != 0:
        raise DegenerateError(f"Chebyshev centre LP failed: {res.message}")
    return np.asarray(res.x[:p]), float(res.x[p])


@dataclass(frozen=True, eq=False)
class TorqueRegion:
    """Torques ``tau_I`` (``p`` effort joints) that guarantee ``claim`` and exclude every rival
    for every friction in the box (eq. 28): ``{tau : A tau <= b}``.

    ``centre (p,)`` the commanded point (Chebyshev centre), ``margin`` its radius (``-inf``:
    empty); ``effort_joints`` the joints of ``tau_I``; ``exact`` (see module docstring);
    ``rivals`` labels of the rivals excluded; ``diagnosis`` when empty: the covering rival, the
    friction corner at which it is feasible and the torque examined; ``open_rows`` the rows of
    ``A`` that bound the region only because it is open on that side (the box of commands, or
    a one-sided band's infinite end replaced by the command's ball): no mode boundary there.
    """

    claim: str
    A: np.ndarray
    b: np.ndarray
    centre: np.ndarray
    margin: float
    effort_joints: tuple[int, ...]
    exact: bool
    rivals: tuple[str, ...] = ()
    diagnosis: dict[str, Any] = field(default_factory=dict)
    open_rows: tuple[int, ...] = ()

    @property
    def empty(self) -> bool:
        """True when no command has a positive margin (the region has no interior)."""
        return not self.margin > 0.0

    def contains(self, tau: Any, slack: float = 0.0) -> bool:
        t = np.asarray(tau, dtype=float).reshape(len(self.effort_joints))
        return bool(np.all(self.A @ t <= self.b + slack))


def _halfspaces(s0: np.ndarray, s1: np.ndarray, scale: np.ndarray, tol: float, keep: bool
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """Rows ``s0 + s1 . tau >= 0`` (``keep``) or ``<= 0`` (fail) at every point as ``A tau <= b``;
    None when a row free of ``tau`` contradicts it (flat rows: ``|s1| <= tol * scale``)."""
    if s1.shape[-1] == 0:  # p = 0: the point set; normalised slacks as right-hand sides
        return np.zeros((len(s0), 0)), (s0 if keep else -s0) / scale
    sign = -1.0 if keep else 1.0
    flat = np.linalg.norm(s1, axis=-1) <= tol * scale
    A, b = sign * s1, -sign * s0
    if np.any(flat & (b < -tol * scale)):
        return None
    return A[~flat], b[~flat]


def _with_cap(A: np.ndarray, b: np.ndarray, cap: float) -> tuple[np.ndarray, np.ndarray]:
    p = A.shape[1]
    box = np.vstack([np.eye(p), -np.eye(p)])
    return np.vstack([A, box]), np.concatenate([b, np.full(2 * p, cap)])


def _indeterminate_cut(system: System, kin: IndeterminateKinematics, mus: np.ndarray,
                       a: np.ndarray) -> float:
    """``min`` of ``a . tau`` over the rival's torque sets at the friction points ``mus``
    (relaxed utility: ``Q_A c_A = [-g_obj; tau - g_man_I]``, ``B_A c_A >= 0``; LPs, HiGHS).
    ``-inf`` when unbounded; ``+inf`` when the rival is infeasible at every point."""
    E = system.effort_joints
    p = len(E)
    best = np.inf
    for mu_v in mus:
        QT = force_matrices(system, kin.rows[None], kin.sliding[None], kin.contact[None],
                            kin.xi[None], mu_v[None])[0, 0]
        Q = QT.T
        k, n_rows = Q.shape
        sel = np.zeros((k, p))
        sel[3:, :] = np.eye(p)
        A_eq = np.hstack([Q, -sel])
        r0 = np.concatenate([-system.g_obj, -system.g_man[E]])
        B = coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes, mu_v)
        res = linprog(np.r_[np.zeros(n_rows), a], A_ub=np.hstack([-B, np.zeros((len(B), p))]),
                      b_ub=np.zeros(len(B)), A_eq=A_eq, b_eq=r0,
                      bounds=[(None, None)] * (n_rows + p), method="highs")
        if res.status == 3:
            return -np.inf
        if res.status == 0:
            best = min(best, float(res.fun))
    return best


def torque_region(system: System, claim: str, mu: Any, *, model: str = "common",
                  grid: int = 3, tol: float = DEFAULT_TOL, cap: float | None = None,
                  method: str = "auto", loads: Any = None) -> TorqueRegion:
    """The torques of the effort-controlled joints that make ``claim`` the only possible mode
    for every friction in ``mu`` (module docstring; eqs. 21-22, 26, 28).

    ``mu``: ``(lo, hi)`` or per-contact pairs; ``model``: ``"common"`` or ``"independent"``
    (used with ``p = 1``; with ``p != 1`` the box is used, sound for both); ``grid``: points per
    axis of the sampled checks; ``cap``: half-width of the box of commands (default: twice the
    largest distance from zero torque to one of the claim's Coulomb hyperplanes, the problem's
    torque scale -- a region open towards harder squeezing is cut there); ``method``:
    ``"auto"`` (the guaranteed band when ``p = 1``) or ``"polytope"`` (the corner
    H-representation for any ``p``); ``loads``: ``(K, n_q)`` vertex wrenches of the workpiece's
    uncertain mass and centre of mass (None: ``system.g_obj`` only).  A row is affine in the load
    and multilinear in ``mu``, so its extremes over box x load hull are at corner x vertex pairs:
    the rows are taken there (docs/planning.md, "Uncertainty beyond friction").
    """
    if method not in ("auto", "polytope"):
        raise InputError(f"method: expected 'auto' or 'polytope', got {method!r}")
    E = tuple(int(j) for j in system.effort_joints)
    p = len(E)
    n_c = system.n_contacts
    mu_lo, mu_hi = friction_interval(mu, n_c)
    if p == 1 and method == "auto":
        return _from_band(system, claim, mu, model, tol, E, loads)
    stage, index = admissible_modes(system, tol=tol)
    corners, g = box_points(mu_lo, mu_hi, grid)
    G = None if loads is None else check_loads(system, loads)

    def rows_at(pts: np.ndarray) -> tuple[AffineRows, np.ndarray]:
        """Rows at friction points ``pts`` (x every vertex load when ``loads`` is given)."""
        if G is None:
            return affine_rows(system, pts, stage=stage, index=index), pts
        return (concat_rows([affine_rows(with_load(system, w), pts, stage=stage, index=index)
                             for w in G]), np.tile(pts, (len(G), 1)))

    rows_c, corners_l = rows_at(corners)
    labels = [m.label for m in rows_c.modes]
    kins = indeterminate_kinematics(system, tol=tol)
    label = resolve_claim(claim, labels + [k.mode.label for k in kins],
                          [m.family for m in rows_c.modes] + [k.mode.family for k in kins])
    if label not in labels:
        why = ("force-indeterminate (relaxed utility): torque regions need a determinate mode"
               if label in [k.mode.label for k in kins] else "not kinematically admissible")
        return empty_region(label, p, E, {"reason": f"{label}: {why}"})
    exact = True
    rows_g: tuple[AffineRows, np.ndarray] | None = None

    def rows_for(j: int) -> tuple[AffineRows, np.ndarray]:
        """Rows of mode ``j`` at the corners, or at corners + grid when ``det`` changes sign."""
        nonlocal exact, rows_g
        d = rows_c.det[:, j]
        if np.all(d > 0) or np.all(d < 0):
            return rows_c, corners_l
        exact = False
        if rows_g is None:
            rows_g = rows_at(np.concatenate([corners, g]))
        return rows_g

    jc = labels.index(label)
    rc, _ = rows_for(jc)
    act = rc.active[jc]
    ok = np.abs(rc.det[:, jc]) > 0
    n_rows = int(ok.sum()) * int(act.sum())
    hs = _halfspaces(rc.s0[ok, jc][:, act].reshape(n_rows),
                     rc.s1[ok, jc][:, act].reshape(n_rows, p),
                     np.repeat(rc.scale[ok, jc], int(act.sum())), tol, keep=True)
    if hs is None:
        return empty_region(label, p, E, {"reason": f"{label}: a Coulomb row free of the torques "
                                              "fails in the friction box"})
    A, b = hs
    if cap is None:
        with np.errstate(divide="ignore", invalid="ignore"):
            bounds = np.abs(b) / np.linalg.norm(A, axis=1) if len(b) else np.zeros(0)
        fin = bounds[np.isfinite(bounds)]
        cap = 2.0 * float(np.max(fin)) if fin.size and np.max(fin) > 0 else 1.0
    open_rows: tuple[int, ...] = ()
    if p:
        A, b = _with_cap(A, b, cap)
        open_rows = tuple(range(len(b) - 2 * p, len(b)))  # later rows are appended after these
    centre, radius = chebyshev_centre(A, b)
    if not radius > 0:
        return empty_region(label, p, E, {
            "reason": f"{label} is not guaranteed over the friction box for any torque (its own "
                      "Coulomb rows conflict)"})
    excluded: list[str] = []
    for j, lab in enumerate(labels):
        if j == jc:
            continue
        rr, pts = rows_for(j)
        okr = np.abs(rr.det[:, j]) > 0
        options = []
        for r in np.flatnonzero(rr.active[j]):
            hs_r = _halfspaces(rr.s0[okr, j, r], rr.s1[okr, j, r], rr.scale[okr, j], tol,
                               keep=False)
            if hs_r is not None:
                options.append(hs_r)
        found = _best_option(A, b, options)
        if found is None:
            return empty_region(label, p, E, _covering(rr, j, pts, lab, centre, p), exact=exact)
        A, b, centre, radius = found
        excluded.append(lab)
    for kin in kins:
        if kin.mode.label == label:
            continue
        exact = False
        pts = corners  # sampled at the corners (exact False)
        dirs = list(np.eye(p))
        options = []
        if p == 0:
            cut = (_indeterminate_cut(system, kin, pts, np.zeros(0)) if G is None
                   else indeterminate_cut_over(system, kin, pts, np.zeros(0), G))
            options = [(np.zeros((0, 0)), np.zeros(0))] if cut == np.inf else []
        else:
            for a in dirs + [-d for d in dirs]:
                cut = (_indeterminate_cut(system, kin, pts, a) if G is None
                       else indeterminate_cut_over(system, kin, pts, a, G))
                if np.isfinite(cut) or cut == np.inf:
                    options.append((a[None], np.array([min(cut, 1e300)])))
        found = _best_option(A, b, options)
        if found is None:
            return empty_region(label, p, E, {"rival": kin.mode.label, "torque": centre.tolist(),
                                        "reason": f"force-indeterminate rival {kin.mode.label} "
                                                  "is possible at every command"}, exact=False)
        A, b, centre, radius = found
        excluded.append(kin.mode.label)
    return TorqueRegion(label, A, b, centre, radius, E, exact, tuple(excluded),
                        open_rows=open_rows)


def _best_option(A: np.ndarray, b: np.ndarray, options: list[tuple[np.ndarray, np.ndarray]]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
    """The option (half-spaces) that keeps the largest Chebyshev ball, or None if all empty."""
    best = None
    for A_r, b_r in options:
        A2 = np.vstack([A, A_r]) if A_r.size else A
        b2 = np.concatenate([b, b_r]) if A_r.size else b
        c, r = chebyshev_centre(A2, b2)
        if r > 0 and (best is None or r > best[3]):  # an interior is needed: rivals are closed
            best = (A2, b2, c, r)
    return best


def _covering(rows: AffineRows, j: int, pts: np.ndarray, label: str, centre: np.ndarray,
              p: int) -> dict[str, Any]:
    """Where rival ``j`` covers the region: the friction points at which it is feasible at the
    current centre (all its active rows hold there)."""
    act = rows.active[j]
    sl = rows.s0[:, j, act] + (rows.s1[:, j, act] @ centre if p else 0.0)
    feas = (np.all(sl >= -DEFAULT_TOL * rows.scale[:, j, None], axis=1)
            & (np.abs(rows.det[:, j]) > 0))
    at = pts[feas].tolist()
    where = (f"at torque {np.round(centre, 6).tolist()} it is feasible for mu = {at[:3]}" if at
             else f"at torque {np.round(centre, 6).tolist()} different rows exclude it at "
                  "different friction points (the one-row inner approximation cannot keep it out)")
    return {"rival": label, "torque": centre.tolist(), "mu": at,
            "reason": f"rival {label} cannot be excluded by any one of its Coulomb rows over the "
                      f"friction box; {where}"}


def empty_region(label: str, p: int, E: tuple[int, ...], diagnosis: dict[str, Any],
                 exact: bool = True) -> TorqueRegion:
    """The empty region of ``label`` (``p`` effort joints ``E``) with its ``diagnosis``."""
    return TorqueRegion(label, np.zeros((0, p)), np.zeros(0), np.full(p, np.nan), -np.inf, E,
                        exact, (), diagnosis)


def torque_scale(system: System, E: tuple[int, ...]) -> float:
    """The size of the effort-controlled joints' commands at which the contacts carry forces of
    the load's size: ``|f| * l`` (``|f|`` the largest external force on a workpiece, ``l`` the
    largest ``|J_i e_j|`` over contacts ``i`` and joints ``j`` in ``E`` -- the lever arm of a
    revolute joint [m], 1 for a prismatic one) plus the largest ``|g_man_j|`` (eq. 3); units of
    the joints (N m or N).  1 when both are zero: with no load the modes are homogeneous in
    ``tau_I`` (eqs. 26, 28) and any positive command is as good as another."""
    if not E:
        return 1.0
    f = np.linalg.norm(np.asarray(system.g_obj, dtype=float).reshape(-1, 3)[:, :2], axis=1)
    J = np.asarray(system.J, dtype=float)[:, list(E)].reshape(-1, 2, len(E))
    lever = float(np.max(np.linalg.norm(J, axis=1))) if J.size else 0.0
    man = float(np.max(np.abs(np.asarray(system.g_man, dtype=float)[list(E)])))
    s = float(np.max(f)) * lever + man
    return s if s > 0 and np.isfinite(s) else 1.0


def _from_band(system: System, claim: str, mu: Any, model: str, tol: float,
               E: tuple[int, ...], loads: Any = None) -> TorqueRegion:
    """``p = 1``: the widest piece of the guaranteed band
    (:func:`planner.plan.guarantee.guarantee`)."""
    g = guarantee(system, claim, mu, model=model, tol=tol, loads=loads)
    return band_region(system, g, g.best(), tol=tol)


def band_region(system: System, g: Guarantee, piece: Interval, *, tol: float = DEFAULT_TOL
                ) -> TorqueRegion:
    """``p = 1``: the region of one ``piece`` of the guaranteed band ``g`` (Figure 13).

    A finite piece ``[lo, hi]`` is ``A = [[1], [-1]]``, ``b = [hi, -lo]``, centred in its
    middle.  A one-sided piece steps in from its finite end by the end's size or, when that end
    is zero torque (to rounding), by :func:`torque_scale`; its infinite end is replaced by the
    command's ball (an inner approximation, marked in ``open_rows``).  An empty piece gives an
    empty region whose diagnosis names the rivals that cover the claim's guaranteed band."""
    E = tuple(int(j) for j in system.effort_joints)
    if piece.empty:
        return empty_region(g.claim, 1, E, _band_diagnosis(g), exact=g.exact)
    lo, hi = piece.lower, piece.upper
    if np.isfinite(lo) and np.isfinite(hi):
        centre, radius = 0.5 * (lo + hi), 0.5 * (hi - lo)
    elif np.isfinite(lo) or np.isfinite(hi):  # one-sided: step in by the bound's size, or by
        end = lo if np.isfinite(lo) else hi    # the load's torque scale when the bound is 0
        scale = torque_scale(system, E)
        step = abs(end) if abs(end) > tol * scale else scale
        centre, radius = (end + step if np.isfinite(lo) else end - step), step
    else:
        centre, radius = 0.0, 1.0
    # An infinite end is replaced by the command's ball (an inner approximation there).
    A = np.array([[1.0], [-1.0]])
    b = np.array([hi if np.isfinite(hi) else centre + radius,
                  -lo if np.isfinite(lo) else -(centre - radius)])
    open_rows = tuple(k for k, end in enumerate((hi, -lo)) if not np.isfinite(end))
    return TorqueRegion(g.claim, A, b, np.array([centre]), float(radius), E, g.exact,
                        tuple(g.rivals), open_rows=open_rows)


def _band_diagnosis(g: Guarantee) -> dict[str, Any]:
    """Why a one-effort band has no piece: the claim's own rows conflict over the friction
    interval, or rivals that are possible over its guaranteed band (the widest first)."""
    own = g.claim_band
    if own is None:
        return {"reason": f"{g.claim} is not kinematically admissible"}
    if own.guaranteed.empty:
        return {"reason": f"{g.claim} is not guaranteed for any effort over the friction "
                          "interval (its own Coulomb rows conflict)"}
    band = own.guaranteed
    cover = [b for b in g.bands if b.label != g.claim and not b.possible.empty
             and b.possible.lower <= band.upper and b.possible.upper >= band.lower]
    cover.sort(key=lambda b: min(b.possible.upper, band.upper) - max(b.possible.lower,
                                                                      band.lower), reverse=True)
    if not cover:  # pragma: no cover - subtract() leaves a piece when nothing overlaps
        return {"reason": f"no guaranteed effort for {g.claim}"}
    words = "; ".join(f"rival {b.label} is possible for efforts in {_iv(b.possible)}"
                      for b in cover)
    return {"reason": f"{words}, covering the efforts {_iv(band)} that guarantee {g.claim}",
            "rival": cover[0].label}


def _iv(iv: Interval) -> str:
    lo = f"{iv.lower:.3g}" if np.isfinite(iv.lower) else "-inf"
    hi = f"{iv.upper:.3g}" if np.isfinite(iv.upper) else "inf"
    return f"[{lo}, {hi}]"
