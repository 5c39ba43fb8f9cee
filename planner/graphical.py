"""Graphical test of Corollary 1 (Section 4.1, Fig. 4) for 3S modes, from geometry.

Each sliding contact pushes along ``f_i = n_i - mu_i xi_i t_i`` through ``r_i`` (the column of
``W_Amu``, eqs. 18-19).  The lines of action of contacts ``i, j`` meet at ``p_ij``; the triangle
``p12 p23 p31`` exists when ``W_Amu`` is nonsingular.  3S is feasible iff (a) the external force
lies in the negative span of the ``f_i`` and (b) about every ``p_ij`` the external wrench and the
third contact's wrench have moments of opposite sense.  Independent of the determinant route of
:mod:`planner.closed_form`.  Brost & Mason labelling for RS: not implemented yet.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from planner.errors import InputError
from planner.model import cross2, rot90


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
