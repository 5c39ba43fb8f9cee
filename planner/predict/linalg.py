"""Determinants and solutions of many small linear systems from one factorisation each.

Used for ``P_AI`` (eq. 24) and ``Q_AI`` (eq. 26): the rank test (30)-(32) and the solve share
the factorisation.  Every system is factorised on its own (Gaussian elimination with partial
pivoting), so a candidate's numbers do not depend on the other candidates of its batch -- to
rounding: small batches go to LAPACK (``numpy.linalg``), large ones to a NumPy elimination
vectorised over the batch (:func:`lu_det_solve`), whichever is faster at that size.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

_gufunc_det: Callable[..., np.ndarray]
_gufunc_solve: Callable[..., np.ndarray]
try:  # the gufuncs behind numpy.linalg.det / solve (same LAPACK calls, less wrapper overhead)
    from numpy.linalg import _umath_linalg

    _gufunc_det, _gufunc_solve = _umath_linalg.det, _umath_linalg.solve1
except (ImportError, AttributeError):  # pragma: no cover - a NumPy without them
    _gufunc_det = np.linalg.det

    def _solve_vector(A: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.linalg.solve(A, np.broadcast_to(b, A.shape[:-1])[..., None])[..., 0]

    _gufunc_solve = _solve_vector


#: Batches of at most this many systems go to LAPACK (``numpy.linalg.det`` / ``solve``):
#: measured faster below it (e.g. 19 systems of 4 x 4: 11 us vs 71 us), slower above.
SMALL_BATCH = 128


#: Matrices per chunk of the batched LU factorisation (keeps its working set in cache).
LU_CHUNK = 2048


def lu_det_solve(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Determinants and solutions of ``C`` small systems from ONE LU factorisation each.

    Gaussian elimination with partial pivoting (LAPACK ``getrf``'s rule: the largest
    ``|entry|`` of the column, the first one on ties), vectorised over the systems, which sit
    on the last (contiguous) axis.  Used for ``P_AI`` (eq. 24) and ``Q_AI`` (eq. 26): the rank
    test (30)-(32) and the solve share the factorisation instead of calling
    ``numpy.linalg.det`` and ``numpy.linalg.solve`` (two LAPACK factorisations per matrix).

    Parameters
    ----------
    X : (k + 1, k, C) float, C-contiguous, overwritten
        ``X[c, a, m] = A_m[a, c]`` for ``c < k`` (column ``c`` of matrix ``m``) and
        ``X[k, a, m] = b_m[a]`` (the right side).

    Returns
    -------
    det : (C,)
        ``det A_m`` (0 when a pivot is exactly zero).
    z : (k, C)
        ``A_m^{-1} b_m``; meaningless where ``det`` is (near) zero -- callers mask it.
    """
    kp1, k, C = X.shape
    det = np.ones(C)
    systems = np.arange(C)
    flat = X.reshape(kp1, k * C)
    lower = np.empty((k, C))
    work = np.empty((k, C))
    for j in range(k):
        p = np.argmax(np.abs(X[j, j:, :]), axis=0)  # pivot row, relative to j
        swap = p != 0
        if swap.any():
            src = (p + j) * C + systems
            tail = flat[j:]  # columns j..k (left of j is no longer read)
            pivot_rows = tail[:, src]
            tail[:, src] = X[j:, j, :]
            X[j:, j, :] = pivot_rows
            det[swap] *= -1.0
        piv = X[j, j, :]
        det *= piv
        if j + 1 < k:
            n = k - j - 1
            lj, wj = lower[:n], work[:n]
            np.divide(X[j, j + 1:, :], np.where(piv == 0.0, 1.0, piv), out=lj)
            for c in range(j + 1, kp1):  # rank-1 update, one contiguous column at a time
                np.multiply(lj, X[c, j, :], out=wj)
                X[c, j + 1:, :] -= wj
    z = np.empty((k, C))
    for a in range(k - 1, -1, -1):  # back substitution on U z = (L^-1 P) b
        acc = X[k, a, :].copy()
        if a + 1 < k:
            acc -= np.einsum("cm,cm->m", X[a + 1:k, a, :], z[a + 1:])
        piv = X[a, a, :]
        z[a] = acc / np.where(piv == 0.0, 1.0, piv)
    return det, z


def det_solve(A: np.ndarray, b: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``det A[rows_m]`` and ``A[rows_m]^{-1} b[rows_m]`` for every row selection ``rows_m``.

    Parameters
    ----------
    A : (n, k), b : (n,)
        The full matrix and right side; ``rows (M, k)`` selects each system's rows.

    Returns
    -------
    det : (M,) signed determinants; z : (M, k) solutions (meaningless where ``det`` ~ 0).
    """
    M, k = rows.shape
    if M <= SMALL_BATCH:
        hit = _lapack(A.take(rows, axis=0), b.take(rows))
        if hit is not None:
            return hit
    aug = np.ascontiguousarray(np.concatenate([A, b[:, None]], axis=1).T)  # (k+1, n)
    det = np.zeros(M)
    z = np.empty((M, k))
    for s in range(0, M, LU_CHUNK):
        d, zc = lu_det_solve(np.take(aug, rows[s:s + LU_CHUNK].T, axis=1))
        det[s:s + LU_CHUNK] = d
        z[s:s + LU_CHUNK] = zc.T
    return det, z


def transposed_det_solve(AT: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``det A_m`` and ``A_m^{-1} b`` for ``AT (M, k, k)`` holding the transposes ``A_m^T``
    and one right side ``b (k,)``."""
    M, k, _ = AT.shape
    if M <= SMALL_BATCH:
        hit = _lapack(AT.transpose(0, 2, 1), b)
        if hit is not None:
            return hit
    det = np.zeros(M)
    y = np.empty((M, k))
    for s in range(0, M, LU_CHUNK):
        chunk = AT[s:s + LU_CHUNK]
        X = np.empty((k + 1, k, chunk.shape[0]))
        X[:k] = chunk.transpose(1, 2, 0)  # X[c, a, .] = A[a, c] = AT[c, a]
        X[k] = b[:, None]
        d, yc = lu_det_solve(X)
        det[s:s + LU_CHUNK] = d
        y[s:s + LU_CHUNK] = yc.T
    return det, y


@np.errstate(all="ignore")  # (the decorator is cheaper than a with-block per call)
def _lapack(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """LAPACK ``getrf``-based ``(det, solution)`` of ``A (M, k, k)`` and ``b (M, k)`` or one
    right side ``b (k,)`` for all (any strides: the gufuncs copy each matrix into LAPACK's
    layout); None when a matrix is exactly singular (a zero determinant: the whole batch then
    goes to :func:`lu_det_solve`, as when ``numpy.linalg.solve`` refused it).  The gufuncs
    behind ``numpy.linalg.det`` and ``solve`` are called directly: the same arithmetic, bit for
    bit, without the wrappers' per-call overhead."""
    if A.shape[0] == 0:
        return np.zeros(0), np.zeros((0, A.shape[-1]))
    det = _gufunc_det(A)
    if np.count_nonzero(det) < det.shape[0]:
        return None
    return det, _gufunc_solve(A, b)


@np.errstate(all="ignore")
def batch_det(A: np.ndarray) -> np.ndarray:
    """``det A_m`` for ``A (..., k, k)`` (``numpy.linalg.det``'s LAPACK gufunc, bit for bit,
    without its wrapper's per-call overhead)."""
    return _gufunc_det(A)


def batch_det_solve(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``det A_m`` and ``A_m^{-1} b_m`` for ``A (M, k, k)``, ``b (M, k)``."""
    M, k, _ = A.shape
    if M <= SMALL_BATCH:
        hit = _lapack(A, b)
        if hit is not None:
            return hit
    det = np.zeros(M)
    z = np.empty((M, k))
    for s in range(0, M, LU_CHUNK):
        chunk = A[s:s + LU_CHUNK]
        X = np.empty((k + 1, k, chunk.shape[0]))
        X[:k] = chunk.transpose(2, 1, 0)  # X[c, a, m] = A_m[a, c]
        X[k] = b[s:s + LU_CHUNK].T
        d, zc = lu_det_solve(X)
        det[s:s + LU_CHUNK] = d
        z[s:s + LU_CHUNK] = zc.T
    return det, z
