"""Torque bounds that guarantee a contact mode and exclude its rivals (eq. 28, Section 5.2).

With one effort-controlled joint (``|tau_I| = 1``) the force stage is affine in its torque
``tau``: eq. (26) gives ``c_A(tau) = Q_AI^{-1} [-g_obj; tau - g_man_I]``, so every Coulomb row of
eq. (28) -- ``c_in >= 0`` for a sliding contact, ``mu_i c_in -+ c_it >= 0`` for a rolling one
(eqs. 21-22) -- reads ``s0 + s1 tau >= 0``.  A mode's torque set at one friction vector is
therefore an interval ``[lower, upper]`` (Figures 10-12).  The kinematic stage does not depend on
``tau`` or ``mu``, so the modes that can compete are fixed by the velocity input.

Uncertain friction (Figure 13).  For ``mu`` in an interval the guaranteed set of a mode is the
intersection of its intervals over the interval, and a rival is excluded when ``tau`` lies
outside the union of its intervals.  Both are computed from the exact ``mu``-dependence, not by
sampling:

* ``common`` model (the paper's: one coefficient shared by all contacts, ``mu in [a, b]``):
  ``det(Q_AI)`` and ``det(Q_AI) * (s0, s1)`` are polynomials in ``mu`` (each sliding contact's
  column of ``W_Amu`` is affine in ``mu``, eqs. 18-19).  Between consecutive *critical points* --
  the interval ends, roots of ``s1`` (where a row changes from a lower to an upper bound), of
  ``d/dmu (s0/s1)`` (extrema of a bound), of ``s0_j s1_k - s0_k s1_j`` (where two bounds cross,
  so the active bound or the emptiness of the interval changes) and of ``det`` -- every bound is
  monotone, so the extremes of ``lower(mu)`` and ``upper(mu)`` over the interval are attained at
  critical points.  The intervals are evaluated there with the same linear algebra as the
  feasibility test.
* ``independent`` model (one interval per contact, a box): ``det``, ``det*s0`` and ``det*s1`` are
  multilinear in the coefficients and each bound is linear-fractional in every coordinate, so the
  guaranteed set is attained at the box's corners when ``det`` and ``s1`` keep their signs there
  (checked; otherwise ``exact`` is False and a grid is added).  Rival unions over a box are taken
  over the corners plus a grid (``exact`` False).

Units follow the joint: N m for a revolute joint.  Torques are in the joint's own sign
convention (counter-clockwise positive, docs/conventions.md).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import polynomial as npoly
from scipy.optimize import linprog

from planner.errors import DegenerateError, InputError
from planner.model.modes import BREAK, ROLL, SLIDE, Mode, enumerate_modes
from planner.model.system import System
from planner.model.validation import friction_interval
from planner.plan.intervals import EMPTY, Interval, hull
from planner.predict.indeterminate import (
    IndeterminateKinematics,
    coulomb_rows,
    indeterminate_kinematics,
)
from planner.predict.stages import DEFAULT_TOL, force_matrices, kinematic_stage

MU_MODELS = ("common", "independent")


@dataclass(frozen=True, eq=False)
class ModeRows:
    """Affine Coulomb rows of the kinematically admissible modes at friction vectors ``mu``.

    ``modes``: the ``m`` modes (with sliding directions from the kinematic stage);
    ``s0, s1``: ``(L, m, 3 n_c)`` slacks at ``tau = 0`` and their slopes (three rows per
    contact: sliding ``c_n`` and two unused rows, rolling ``mu c_n - c_t``, ``mu c_n + c_t`` and
    ``c_n``); ``active``: ``(m, 3 n_c)`` rows that constrain; ``det``: ``(L, m)`` ``det Q_AI``
    (raw, signed); ``scale``: ``(L, m)`` force scale for tolerances.
    """

    modes: tuple[Mode, ...]
    s0: np.ndarray
    s1: np.ndarray
    active: np.ndarray
    det: np.ndarray
    scale: np.ndarray


def _check_one_effort(system: System) -> int:
    E = system.effort_joints
    if len(E) != 1:
        raise InputError(
            "torque bounds: expected exactly one effort-controlled joint (|tau_I| = 1), "
            f"got {len(E)}"
        )
    return int(E[0])


def admissible_modes(system: System, *, tol: float = DEFAULT_TOL):
    """Kinematic stage (eqs. 13-16, 23-25) over every candidate; returns ``(stage, index)`` of
    the admissible ones.  Independent of ``tau`` and ``mu``."""
    cand = enumerate_modes(system.n_contacts, system.dof)
    ks = kinematic_stage(system, cand, tol=tol)
    return ks, np.flatnonzero(ks.ok)


def mode_rows(system: System, mu: Any, *, stage=None, index=None) -> ModeRows:
    """Affine Coulomb rows (eqs. 21-22, 26, 28) of the admissible modes at ``mu`` ``(L, n_c)``:
    :func:`affine_rows` with its one effort-controlled torque."""
    _check_one_effort(system)
    rows = affine_rows(system, mu, stage=stage, index=index)
    return ModeRows(rows.modes, rows.s0, rows.s1[..., 0], rows.active, rows.det, rows.scale)


@dataclass(frozen=True, eq=False)
class AffineRows:
    """Coulomb rows ``s0 + s1 . tau_I >= 0`` of the admissible modes at friction vectors ``mu``.

    ``s0 (L, m, 3 n_c)``, ``s1 (L, m, 3 n_c, p)``; ``active (m, 3 n_c)``; ``det (L, m)``;
    ``scale (L, m)`` force scale (tolerances); ``modes`` the ``m`` modes.  Rows per contact as in
    :class:`ModeRows`.
    """

    modes: tuple[Mode, ...]
    s0: np.ndarray
    s1: np.ndarray
    active: np.ndarray
    det: np.ndarray
    scale: np.ndarray


def affine_rows(system: System, mu: Any, *, stage: Any = None, index: Any = None) -> AffineRows:
    """Eqs. (21-22, 26, 28) of every admissible determinate mode at each row of ``mu (L, n_c)``,
    affine in the ``p`` effort-controlled torques."""
    mu2 = np.atleast_2d(np.asarray(mu, dtype=float))
    n_c = system.n_contacts
    if mu2.shape[1] != n_c:
        raise InputError(f"mu: expected {n_c} coefficients per row, got shape {mu2.shape}")
    if stage is None:
        stage, index = admissible_modes(system)
    E = system.effort_joints
    p = len(E)
    cand = stage.candidates
    L, m = mu2.shape[0], len(index)
    modes = tuple(Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in stage.xi[i]))
                  for i in index)
    if m == 0:
        return AffineRows(modes, np.zeros((L, 0, 3 * n_c)), np.zeros((L, 0, 3 * n_c, p)),
                          np.zeros((0, 3 * n_c), bool), np.zeros((L, 0)), np.ones((L, 0)))
    rows, sliding, contact = cand.rows[index], cand.sliding[index], cand.contact[index]
    codes = cand.codes[index]
    QT = force_matrices(system, rows, sliding, contact, stage.xi[index], mu2)
    Q = np.swapaxes(QT, -1, -2)  # (L, m, k, k), k = 3 + p
    k = Q.shape[-1]
    rhs = np.zeros((k, 1 + p))
    rhs[:, 0] = np.concatenate([-system.g_obj, -system.g_man[E]])
    rhs[3:, 1:] = np.eye(p)
    det = np.linalg.det(Q)
    with np.errstate(all="ignore"):
        sol = np.linalg.solve(np.where(np.abs(det)[..., None, None] > 0, Q, np.eye(k)),
                              np.broadcast_to(rhs, (L, m, k, 1 + p)))
    c = np.zeros((L, m, 2 * n_c, 1 + p))
    np.put_along_axis(c, np.broadcast_to(rows[None, :, :, None], (L, m, k, 1 + p)), sol, axis=2)
    cn, ct = c[:, :, 0::2], c[:, :, 1::2]
    mu_b = mu2[:, None, :, None]
    roll = (codes == ROLL)[None, :, :, None]
    slide = (codes == SLIDE)[None, :, :, None]
    row_a = np.where(roll, mu_b * cn - ct, np.where(slide, cn, 0.0))
    row_b = np.where(roll, mu_b * cn + ct, 0.0)
    row_c = np.where(roll, cn, 0.0)
    slack = np.stack([row_a, row_b, row_c], axis=3).reshape(L, m, 3 * n_c, 1 + p)
    active = np.stack([codes != BREAK, codes == ROLL, codes == ROLL], axis=2).reshape(m, 3 * n_c)
    scale = np.max(np.abs(sol), axis=(2, 3))
    scale = np.where(scale > 0, scale, 1.0)
    return AffineRows(modes, slack[..., 0], slack[..., 1:], active, det, scale)


def box_points(mu_lo: np.ndarray, mu_hi: np.ndarray, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """``(corners (2^n, n), grid points (grid^n, n))`` of the friction box."""
    corners = np.array(list(itertools.product(*zip(mu_lo, mu_hi))), dtype=float)
    axes = [np.linspace(a, b, grid) for a, b in zip(mu_lo, mu_hi)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(mu_lo))
    return corners, g


def intervals(rows: ModeRows, *, tol: float = DEFAULT_TOL) -> tuple[np.ndarray, np.ndarray]:
    """Per friction vector and mode, the torque interval of eq. (28): ``lower, upper (L, m)``.

    A row with ``|s1|`` below ``tol`` times the force scale does not depend on ``tau``: it
    empties the interval when ``s0 < -tol * scale`` (Coulomb rows are closed, tolerance policy).
    Singular ``Q_AI`` (``det == 0``) gives an empty interval.
    """
    s0, s1, act = rows.s0, rows.s1, rows.active[None]
    sc = rows.scale[..., None]
    flat = np.abs(s1) <= tol * sc
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = -s0 / s1
    lo_rows = np.where(act & ~flat & (s1 > 0), ratio, -np.inf)
    hi_rows = np.where(act & ~flat & (s1 < 0), ratio, np.inf)
    lower = np.max(lo_rows, axis=-1) if s0.shape[-1] else np.full(s0.shape[:2], -np.inf)
    upper = np.min(hi_rows, axis=-1) if s0.shape[-1] else np.full(s0.shape[:2], np.inf)
    bad = np.any(act & flat & (s0 < -tol * sc), axis=-1) | (rows.det == 0)
    lower = np.where(bad, np.inf, lower)
    upper = np.where(bad, -np.inf, upper)
    return lower, upper


@dataclass(frozen=True)
class ModeBand:
    """A mode's torque interval at fixed friction (``interval``) or, over uncertain friction,
    the set where it is guaranteed (``guaranteed``: intersection) and the hull of where it can
    occur (``possible``: union hull).  ``exact`` is False when a grid had to be used."""

    mode: Mode
    guaranteed: Interval
    possible: Interval
    exact: bool = True

    @property
    def label(self) -> str:
        return self.mode.label


def _roots_in_u(coef: np.ndarray) -> np.ndarray:
    """Real roots in (-1, 1) of a power series in ``u`` (trailing tiny terms trimmed)."""
    c = np.asarray(coef, dtype=float)
    big = np.max(np.abs(c)) if c.size else 0.0
    if big == 0.0:
        return np.zeros(0)
    keep = np.flatnonzero(np.abs(c) > 1e-11 * big)
    c = c[: keep[-1] + 1]
    if len(c) < 2:
        return np.zeros(0)
    r = npoly.polyroots(c)
    real = r[np.abs(r.imag) <= 1e-9 * (1 + np.abs(r.real))].real
    return real[(real > -1.0) & (real < 1.0)]


def critical_mus(system: System, lo: float, hi: float, *, stage=None, index=None,
                 samples: int | None = None) -> np.ndarray:
    """Critical friction values in ``[lo, hi]`` (common model) for every admissible mode:
    the ends plus roots of ``det``, ``s1``, ``(s0/s1)'`` and ``s0_j s1_k - s0_k s1_j``
    (module docstring).  ``det*s0``, ``det*s1`` and ``det`` are polynomials in ``mu`` (degree at
    most ``n_c + 1``); they are recovered exactly (up to rounding) by least squares on Chebyshev
    nodes in the scaled variable ``u = (mu - mid) / half`` and their roots mapped back."""
    if stage is None:
        stage, index = admissible_modes(system)
    n_c = system.n_contacts
    pts = [np.array([lo, hi])]
    if hi - lo <= 1e-12 * max(1.0, abs(hi)) or len(index) == 0:
        return np.unique(pts[0])
    deg = n_c + 2
    n_s = samples or (2 * deg + 3)
    u = -np.cos(np.pi * (np.arange(n_s) + 0.5) / n_s)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    x = mid + half * u
    rows = mode_rows(system, np.repeat(x[:, None], n_c, axis=1), stage=stage, index=index)
    D = rows.det  # (L, m)
    V = np.vander(u, deg + 1, increasing=True)
    pinv = np.linalg.pinv(V)
    cD = pinv @ D  # (deg+1, m)
    c0 = np.einsum("ij,jmr->imr", pinv, rows.s0 * D[..., None])
    c1 = np.einsum("ij,jmr->imr", pinv, rows.s1 * D[..., None])
    roots = []
    for j in range(len(index)):
        roots.append(_roots_in_u(cD[:, j]))
        act = np.flatnonzero(rows.active[j])
        polys = []
        for r in act:
            a, b = c1[:, j, r], c0[:, j, r]
            polys.append((a, b))
            roots.append(_roots_in_u(a))
            deriv = npoly.polysub(npoly.polymul(npoly.polyder(b), a),
                                  npoly.polymul(b, npoly.polyder(a)))
            roots.append(_roots_in_u(deriv))
        for (a1, b1), (a2, b2) in itertools.combinations(polys, 2):
            roots.append(_roots_in_u(npoly.polysub(npoly.polymul(b1, a2), npoly.polymul(b2, a1))))
    ur = np.concatenate(roots) if roots else np.zeros(0)
    pts_arr = np.unique(np.clip(np.concatenate([pts[0], mid + half * ur]), lo, hi))
    # Points just beside each interior critical point guard the one-sided limits at poles.
    eps = 1e-7 * (hi - lo)
    side = np.concatenate([pts_arr - eps, pts_arr + eps])
    side = side[(side > lo) & (side < hi)]
    return np.unique(np.concatenate([pts_arr, side]))


def mode_bands(
    system: System,
    mu: Any,
    *,
    model: str = "common",
    grid: int = 5,
    tol: float = DEFAULT_TOL,
) -> tuple[ModeBand, ...]:
    """Guaranteed and possible torque sets of every admissible mode for ``mu`` in an interval.

    ``mu``: a number, ``(lo, hi)`` for all contacts, or per-contact ``[(lo, hi), ...]``.
    ``model``: ``"common"`` (one coefficient shared by all contacts; needs equal intervals) or
    ``"independent"`` (each contact's coefficient varies on its own).
    """
    if model not in MU_MODELS:
        raise InputError(f"model: expected one of {MU_MODELS}, got {model!r}")
    n_c = system.n_contacts
    mu_lo, mu_hi = friction_interval(mu, n_c)
    stage, index = admissible_modes(system, tol=tol)
    exact = True
    if model == "common" or np.all(mu_lo == mu_hi):
        if not (np.all(mu_lo == mu_lo[0]) and np.all(mu_hi == mu_hi[0])):
            if np.all(mu_lo == mu_hi):
                pts = mu_lo[None]
            else:
                raise InputError(
                    "model 'common' needs the same interval for every contact, got "
                    f"{np.stack([mu_lo, mu_hi], 1).tolist()}; use model='independent'"
                )
        else:
            xs = critical_mus(system, float(mu_lo[0]), float(mu_hi[0]), stage=stage, index=index)
            pts = np.repeat(xs[:, None], n_c, axis=1)
        inter_pts = union_pts = pts
    else:
        corners, g = box_points(mu_lo, mu_hi, grid)
        inter_pts = corners
        union_pts = np.concatenate([corners, g])
        r = mode_rows(system, corners, stage=stage, index=index)
        sgn_det = np.sign(r.det)
        sgn_s1 = np.sign(np.where(r.active[None], r.s1, 1.0))
        if not (np.all(sgn_det == sgn_det[0]) and np.all(sgn_s1 == sgn_s1[0])):
            exact = False
            inter_pts = union_pts
    if model == "common" or np.all(mu_lo == mu_hi):
        grid_pts = np.repeat(np.linspace(mu_lo[0], mu_hi[0], 21)[:, None], n_c, axis=1) \
            if np.all(mu_lo == mu_lo[0]) and np.all(mu_hi == mu_hi[0]) else inter_pts
    else:
        grid_pts = union_pts
    lo_i, hi_i = intervals(mode_rows(system, inter_pts, stage=stage, index=index), tol=tol)
    rows_u = mode_rows(system, union_pts, stage=stage, index=index)
    lo_u, hi_u = intervals(rows_u, tol=tol)
    out = []
    for j, mode in enumerate(rows_u.modes):
        g_lo, g_hi = float(np.max(lo_i[:, j])), float(np.min(hi_i[:, j]))
        ok = lo_u[:, j] <= hi_u[:, j]
        if np.any(ok):
            p = Interval(float(np.min(lo_u[ok, j])), float(np.max(hi_u[ok, j])))
        else:
            p = EMPTY
        gi = Interval(g_lo, g_hi) if g_lo <= g_hi else EMPTY
        out.append(ModeBand(mode, gi, p, exact=exact or model == "common"))
    # Force-indeterminate modes (relaxed utility, Sec. 3.2): torque range by linear programs.
    for kin in indeterminate_kinematics(system, tol=tol):
        has_slide = bool(np.any(kin.codes == SLIDE))
        pts_g = grid_pts if has_slide else np.stack([mu_lo, mu_hi])
        ivs = [indeterminate_interval(system, kin, m) for m in pts_g]
        p = hull(ivs)
        g_lo = max(iv.lower for iv in ivs)
        g_hi = min(iv.upper for iv in ivs)
        gi = Interval(g_lo, g_hi) if g_lo <= g_hi else EMPTY
        # Rolling-only modes: the cones grow with mu, so the ends are exact (nested sets); at a
        # friction point the two linear programs are the exact range.
        out.append(ModeBand(kin.mode, gi, p, exact=not has_slide or bool(np.all(mu_lo == mu_hi))))
    return tuple(out)


def indeterminate_interval(system: System, kin: IndeterminateKinematics, mu: Any) -> Interval:
    """Torque range of a force-indeterminate mode at friction ``mu`` (n_c,): the projection of
    ``{(c_A, tau): Q_A c_A = [-g_obj; tau - g_man_I], B_A c_A >= 0}`` (eqs. 21-22, 26) on
    ``tau``, by two linear programs (scipy HiGHS)."""
    mu_v = np.asarray(mu, dtype=float)
    QT = force_matrices(system, kin.rows[None], kin.sliding[None], kin.contact[None],
                        kin.xi[None], mu_v[None])[0, 0]
    Q = QT.T
    k, k_rows = Q.shape
    E = system.effort_joints
    r0 = np.concatenate([-system.g_obj, -system.g_man[E]])
    e = np.zeros(k)
    e[3] = 1.0
    A_eq = np.hstack([Q, -e[:, None]])
    rs = np.max(np.abs(A_eq), axis=1)
    rs[rs == 0] = 1.0
    B = coulomb_rows(kin.rows, kin.sliding, kin.contact, kin.codes, mu_v)
    A_ub = np.hstack([-B, np.zeros((B.shape[0], 1))])
    ends = []
    for sign in (1.0, -1.0):
        res = linprog(np.r_[np.zeros(k_rows), sign], A_ub=A_ub, b_ub=np.zeros(B.shape[0]),
                      A_eq=A_eq / rs[:, None], b_eq=r0 / rs,
                      bounds=[(None, None)] * (k_rows + 1), method="highs")
        if res.status == 2:
            return EMPTY
        if res.status == 3:
            ends.append(-np.inf if sign > 0 else np.inf)
        elif res.status == 0:
            ends.append(float(res.x[-1]))
        else:
            raise DegenerateError(f"torque range LP failed for mode {kin.mode.label}: "
                                  f"{res.message}")
    return Interval(ends[0], ends[1])
