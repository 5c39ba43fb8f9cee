"""Planar contact geometry of Trinkle & Zeng (1994), eqs. (1)-(2): the wrench matrix ``W``.

Column pair ``i`` of ``W`` (3, 2 n_c) maps the contact force ``c_i = (c_in, c_it)`` (contact
frame) to the wrench it exerts on the workpiece about the world origin: ``[n_i; r_i x n_i]`` and
``[t_i; r_i x t_i]`` with ``t_i = rot90(n_i)`` (docs/conventions.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.validation import WRENCH_COLUMN_TOL, as_array, is_numeric


def cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The paper's planar cross product ``a (x) b = a_1 b_2 - a_2 b_1`` (eq. 1), broadcasting."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot90(n: np.ndarray) -> np.ndarray:
    """Rotate 2-vectors by +90 degrees: ``(x, y) -> (-y, x)``; gives ``t`` from ``n``."""
    n = np.asarray(n, dtype=float)
    if n.ndim == 1:  # one vector: the hot path of the planner's contact frames
        return np.array([-n[1], n[0]])
    return np.stack([-n[..., 1], n[..., 0]], axis=-1)


def wrench_matrix(points: Any, normals: Any) -> np.ndarray:
    """Global wrench matrix ``W = [w_1n w_1t ... w_nn w_nt]`` of eq. (1)-(2).

    Parameters
    ----------
    points : (n_c, 2) [m]
        Contact points ``r_i``, world frame.
    normals : (n_c, 2)
        Unit inward normals ``n_i``, world frame.

    Returns
    -------
    W : (3, 2 n_c)
        Column ``2i`` is ``[n_i; r_i (x) n_i]``, column ``2i+1`` is ``[t_i; r_i (x) t_i]``.
    """
    r = as_array(points, (None, 2), "points")
    n = as_array(normals, (r.shape[0], 2), "normals")
    t = rot90(n)
    W = np.empty((3, 2 * r.shape[0]))
    W[0:2, 0::2] = n.T
    W[0:2, 1::2] = t.T
    W[2, 0::2] = cross2(r, n)
    W[2, 1::2] = cross2(r, t)
    return W


def check_wrench_matrix(W: Any, tol: float = WRENCH_COLUMN_TOL) -> np.ndarray:
    """Validate a wrench matrix given as data (eq. 1); returns it as a float array.

    Each column pair must be a unit normal ``n`` and the tangent ``t = rot90(n)`` to ``tol``
    (default 2e-3, because the paper prints eqs. 37 and 42 rounded to three digits).  The matrix
    is used exactly as given; it is not re-normalised.
    """
    arr = np.asarray(W, dtype=float) if is_numeric(W) else None
    if arr is None or arr.ndim != 2 or arr.shape[0] != 3 or arr.shape[1] % 2 or arr.shape[1] == 0:
        shape = None if arr is None else arr.shape
        raise InputError(
            f"wrench_matrix: expected shape (3, 2*n_c) with columns [w_1n w_1t ...], got {shape}"
        )
    W = as_array(arr, (3, None), "wrench_matrix")
    for i in range(W.shape[1] // 2):
        n = W[0:2, 2 * i]
        t = W[0:2, 2 * i + 1]
        norm = float(np.hypot(*n))
        if abs(norm - 1.0) > tol:
            raise InputError(
                f"wrench_matrix: contact {i + 1}: expected a unit normal in column {2 * i + 1} "
                f"(|n| = 1 within {tol:g}), got |n| = {norm:.6g}"
            )
        if float(np.max(np.abs(t - rot90(n)))) > tol:
            raise InputError(
                f"wrench_matrix: contact {i + 1}: expected tangent t = n rotated by +90 deg "
                f"= {rot90(n).round(4).tolist()} in column {2 * i + 2}, got {t.round(4).tolist()}"
            )
    return W


def contact_points_from_wrench(W: np.ndarray) -> np.ndarray:
    """Contact points implied by a wrench matrix: ``r_i = m_it n_i - m_in t_i``.

    With ``t = rot90(n)``: ``r x n = m_in`` and ``r x t = r . n = m_it``, hence the formula.

    Returns
    -------
    points : (n_c, 2) [m], world frame.
    """
    n = W[0:2, 0::2].T
    t = W[0:2, 1::2].T
    m_n = W[2, 0::2]
    m_t = W[2, 1::2]
    return m_t[:, None] * n - m_n[:, None] * t
