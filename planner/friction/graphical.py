"""Graphical tests of 3S and RS feasibility (Section 4.1, Fig. 4; Sec. 4.2), from geometry.

Two independent checks of the algebraic regions of :mod:`planner.friction.closed_form`:

* :func:`corollary1_3s` -- Corollary 1 for 3S modes (triangle ``p12 p23 p31``, moment signs);
* :func:`brost_mason_mode` -- Brost & Mason's moment labelling [4] specialised to the
  quasistatic case as Sec. 4.1 describes it, for 3S and RS modes (eqs. 35-36, 40-41).

Each sliding contact pushes along ``f_i = n_i - mu_i xi_i t_i`` through ``r_i`` (the column of
``W_Amu``, eqs. 18-19).  The lines of action of contacts ``i, j`` meet at ``p_ij``; the triangle
``p12 p23 p31`` exists when ``W_Amu`` is nonsingular.  3S is feasible iff (a) the external force
lies in the negative span of the ``f_i`` and (b) about every ``p_ij`` the external wrench and the
third contact's wrench have moments of opposite sense.  Independent of the determinant route of
:mod:`planner.friction.closed_form`.

Moment labelling (Brost & Mason; Sec. 4.1, Fig. 4): every applicable contact force is a
unisense force along a line of action -- a sliding contact's active friction-cone edge
``n - mu xi t`` (eqs. 17-19), a rolling contact's two edges ``n +- mu t`` (eq. 9; "the two edges
of the friction cone of the rolling contact", Sec. 4.2).  A point ``p`` of the plane is labelled
``+`` when every such force has a non-negative moment about ``p`` and ``-`` when every one has a
non-positive moment; the labelled sets ``E+`` and ``E-`` are convex polygons (intersections of
half-planes).  A wrench is a non-negative combination of the forces iff its moment is ``>= 0``
about every point of ``E+`` and ``<= 0`` about every point of ``E-``; the moment is affine in
``p``, so the vertices and recession rays of ``E+`` / ``E-`` suffice.  The mode is feasible iff
``-g_obj`` passes this test (eq. 26 with ``c_A >= 0`` and eq. 28), i.e. the line of action of
``g_obj`` passes through the unshaded channel of Fig. 4(a).

References
----------
Trinkle & Zeng (1994), Sec. 4.1 (Corollary 1, Fig. 4), Sec. 4.2, eqs. (33)-(41).
[4] R. C. Brost and M. T. Mason, Graphical analysis of planar rigid-body dynamics with multiple
frictional contacts, ISRR 1990.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from planner.errors import InputError
from planner.model.geometry import cross2, rot90
from planner.model.modes import BREAK, ROLL, SLIDE


class GraphicalVerdict(str, Enum):
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"
    DEGENERATE = "degenerate"  # lines of action concurrent or parallel


@dataclass(frozen=True)
class GraphicalResult:
    """Verdict with the triangle vertices ``p (3, 2)`` [m] (rows p12, p23, p31) and the
    moment products ``M_g(p_ij) M_k(p_ij)`` (3,), negative when condition (b) holds."""

    verdict: GraphicalVerdict
    vertices: np.ndarray
    moment_products: np.ndarray


def _intersect(r1, f1, r2, f2):
    den = cross2(f1, f2)
    if abs(den) < 1e-12:
        return None
    s = cross2(r2 - r1, f2) / den
    return r1 + s * f1


def corollary1_3s(points, normals, mu, xi, g_obj) -> GraphicalResult:
    """Corollary 1 for three sliding contacts. ``points, normals (3, 2)``; ``mu, xi (3,)``;
    ``g_obj (3,)`` = (f_x, f_y, m_z about the origin)."""
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    if points.shape != (3, 2) or normals.shape != (3, 2):
        raise InputError(f"corollary1_3s: expected points and normals (3, 2), got "
                         f"{points.shape} and {normals.shape}")
    mu = np.asarray(mu, float)
    xi = np.asarray(xi, float)
    g = np.asarray(g_obj, float)
    f = np.array([normals[i] - mu[i] * xi[i] * rot90(normals[i]) for i in range(3)])
    m = np.array([cross2(points[i], f[i]) for i in range(3)])
    pairs = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
    verts = np.full((3, 2), np.nan)
    prods = np.full(3, np.nan)
    for row, (i, j, k) in enumerate(pairs):
        p = _intersect(points[i], f[i], points[j], f[j])
        if p is None:
            return GraphicalResult(GraphicalVerdict.DEGENERATE, verts, prods)
        verts[row] = p
        mg = g[2] - cross2(p, g[:2])
        mk = m[k] - cross2(p, f[k])
        prods[row] = mg * mk
    # (a) -g_force in the cone of f_1..f_3 (planar: some pair brackets it).
    target = -g[:2]
    in_span = False
    for i in range(3):
        for j in range(i + 1, 3):
            A = np.column_stack([f[i], f[j]])
            if abs(np.linalg.det(A)) > 1e-12:
                a = np.linalg.solve(A, target)
                in_span = in_span or bool(np.all(a >= 0))
    ok = in_span and bool(np.all(prods <= 0))
    return GraphicalResult(GraphicalVerdict.FEASIBLE if ok else GraphicalVerdict.INFEASIBLE,
                           verts, prods)


@dataclass(frozen=True)
class MomentLabels:
    """Brost & Mason moment labels of a set of unisense planar forces.

    Attributes
    ----------
    plus_vertices, minus_vertices : (k, 2) [m]
        Vertices of ``E+`` (all forces have moment ``>= 0`` about the point) and ``E-``.
    plus_rays, minus_rays : (k', 2)
        Unit recession directions of ``E+`` / ``E-`` (non-empty when the set is unbounded).
    plus_empty, minus_empty : bool
        True when the labelled set is empty.
    """

    plus_vertices: np.ndarray
    plus_rays: np.ndarray
    minus_vertices: np.ndarray
    minus_rays: np.ndarray
    plus_empty: bool
    minus_empty: bool

    def moment_signs_ok(self, wrench: np.ndarray, tol: float = 1e-12) -> bool:
        """True when ``wrench (3,) = (f_x, f_y, m_z about the origin)`` is consistent with the
        labels: moment ``>= -tol`` about all of ``E+`` and ``<= tol`` about all of ``E-``."""
        w = np.asarray(wrench, float)
        f, m0 = w[:2], w[2]

        def moment(p: np.ndarray) -> np.ndarray:  # moment of w about points p (k, 2)
            return m0 - cross2(p, f)

        def rate(d: np.ndarray) -> np.ndarray:  # d/ds of the moment about p + s d
            return -cross2(d, f)

        ok = True
        if len(self.plus_vertices):
            ok &= bool(np.all(moment(self.plus_vertices) >= -tol))
        if len(self.plus_rays):
            ok &= bool(np.all(rate(self.plus_rays) >= -tol))
        if len(self.minus_vertices):
            ok &= bool(np.all(moment(self.minus_vertices) <= tol))
        if len(self.minus_rays):
            ok &= bool(np.all(rate(self.minus_rays) <= tol))
        return ok


def _halfplane_polygon(a: np.ndarray, b: np.ndarray, tol: float
                       ) -> tuple[np.ndarray, np.ndarray, bool]:
    """Vertices, recession rays and emptiness of ``{p : a_k . p <= b_k}`` (pairwise
    non-parallel lines). ``a (K, 2)``, ``b (K,)``."""
    scale = 1.0 + np.max(np.abs(b))
    verts = []
    for i in range(len(a)):
        for j in range(i + 1, len(a)):
            A = np.vstack([a[i], a[j]])
            p = np.linalg.solve(A, np.array([b[i], b[j]]))
            if np.all(a @ p <= b + tol * scale * (1.0 + np.linalg.norm(p))):
                verts.append(p)
    rays = []
    for k in range(len(a)):
        d = np.array([-a[k, 1], a[k, 0]]) / np.linalg.norm(a[k])
        for s in (d, -d):
            if np.all(a @ s <= tol):
                rays.append(s)
    verts_arr = np.array(verts).reshape(-1, 2)
    rays_arr = np.array(rays).reshape(-1, 2)
    # With pairwise non-parallel boundary lines a non-empty set has at least one vertex.
    return verts_arr, rays_arr, len(verts_arr) == 0


def moment_labels(points, directions, tol: float = 1e-12) -> MomentLabels:
    """Moment labels ``E+`` / ``E-`` of unisense forces ``directions (K, 2)`` acting along lines
    through ``points (K, 2)`` [m] (Brost & Mason; Sec. 4.1, Fig. 4).

    The moment of force ``f_k`` at ``r_k`` about ``p`` is ``(r_k - p) x f_k``, so ``E+`` is
    ``{p : a_k . p <= r_k x f_k}`` with ``a_k = (f_ky, -f_kx)`` and ``E-`` the reverse.
    Raises :class:`InputError` for bad shapes or when two lines of action are parallel
    (degenerate; see :class:`GraphicalVerdict`)."""
    r = np.asarray(points, float)
    f = np.asarray(directions, float)
    if r.ndim != 2 or r.shape[1] != 2 or f.shape != r.shape or len(r) < 2:
        raise InputError(f"moment_labels: expected points and directions (K, 2) with K >= 2, "
                         f"got {r.shape} and {f.shape}")
    a = np.column_stack([f[:, 1], -f[:, 0]])
    b = cross2(r, f)
    pv, pr, pe = _halfplane_polygon(a, b, tol)
    mv, mr, me = _halfplane_polygon(-a, -b, tol)
    return MomentLabels(pv, pr, mv, mr, pe, me)


@dataclass(frozen=True)
class BrostMasonResult:
    """Verdict of the moment-labelling test with its certificate.

    Attributes
    ----------
    verdict : GraphicalVerdict
    points, forces : (K, 2)
        Lines of action used: a point on each [m] and the unit force direction (friction-cone
        edges: 1 per sliding contact, 2 per rolling contact, in contact order).
    contacts : (K,) int
        0-based contact of each force.
    labels : MomentLabels | None
        ``None`` when degenerate.
    """

    verdict: GraphicalVerdict
    points: np.ndarray
    forces: np.ndarray
    contacts: np.ndarray
    labels: MomentLabels | None


def brost_mason_mode(points, normals, mu, codes, xi, g_obj, tol: float = 1e-12
                     ) -> BrostMasonResult:
    """Feasibility of a 3S or RS mode by moment labelling (Sec. 4.1-4.2; eqs. 35-36, 40-41).

    Parameters
    ----------
    points, normals : (n_c, 2)
        Contact points [m] and inward unit normals (world frame).
    mu : (n_c,)
        Friction coefficients [-].
    codes : (n_c,)
        ``ROLL``/``SLIDE``/``BREAK`` per contact with ``2 n_R + n_S = 3``.
    xi : (n_c,)
        Sliding directions (eq. 16); used for sliding contacts only.
    g_obj : (3,)
        External wrench ``(f_x [N], f_y [N], m_z [N m] about the origin)``.

    Returns DEGENERATE when two lines of action are parallel (e.g. ``mu_R = 0`` at the rolling
    contact) or all three meet in one point (``W_Amu`` singular; Corollary 1 assumes it is not).
    """
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    n_c = len(points)
    if points.ndim != 2 or points.shape[1:] != (2,) or normals.shape != points.shape:
        raise InputError(f"brost_mason_mode: expected points and normals (n_c, 2), got "
                         f"{points.shape} and {normals.shape}")
    mu = np.asarray(mu, float).reshape(-1)
    xi = np.asarray(xi, float).reshape(-1)
    codes = tuple(int(c) for c in codes)
    if mu.shape != (n_c,) or xi.shape != (n_c,) or len(codes) != n_c:
        raise InputError(f"brost_mason_mode: expected mu, xi, codes of length {n_c}, got "
                         f"{mu.shape[0]}, {xi.shape[0]}, {len(codes)}")
    n_r, n_s = codes.count(ROLL), codes.count(SLIDE)
    if 2 * n_r + n_s != 3 or any(c not in (ROLL, SLIDE, BREAK) for c in codes):
        raise InputError(f"brost_mason_mode: expected a 3S or RS mode (2 n_R + n_S = 3), "
                         f"got codes {codes}")
    r, f, who = [], [], []
    for i, c in enumerate(codes):
        t = rot90(normals[i])
        edges = ([normals[i] + mu[i] * t, normals[i] - mu[i] * t] if c == ROLL
                 else [normals[i] - mu[i] * xi[i] * t] if c == SLIDE else [])
        for e in edges:
            r.append(points[i])
            f.append(e / np.linalg.norm(e))
            who.append(i)
    r_arr, f_arr, who_arr = np.array(r), np.array(f), np.array(who)
    for i in range(len(f_arr)):
        for j in range(i + 1, len(f_arr)):
            if abs(cross2(f_arr[i], f_arr[j])) < 1e-9:
                return BrostMasonResult(GraphicalVerdict.DEGENERATE, r_arr, f_arr, who_arr, None)
    wrenches = np.vstack([f_arr.T, cross2(r_arr, f_arr)])  # (3, 3): columns [f; r x f]
    if abs(np.linalg.det(wrenches)) < 1e-9:  # concurrent lines: W_Amu singular (Corollary 1)
        return BrostMasonResult(GraphicalVerdict.DEGENERATE, r_arr, f_arr, who_arr, None)
    labels = moment_labels(r_arr, f_arr, tol)
    ok = labels.moment_signs_ok(-np.asarray(g_obj, float), tol)
    return BrostMasonResult(GraphicalVerdict.FEASIBLE if ok else GraphicalVerdict.INFEASIBLE,
                            r_arr, f_arr, who_arr, labels)
