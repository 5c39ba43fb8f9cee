"""Closed-form friction regions of 3S and RS modes by Cramer's rule (eqs. 34-36, 39-41).

For a mode with three force unknowns (3S: ``c_1n, c_2n, c_3n``; RS: ``c_Rn, c_Rt, c_Sn``) and no
effort joints, eq. (26) reads ``W_Amu c_A = -g_obj`` with ``W_Amu`` of eqs. (18)-(19).  Every
determinant is multilinear in the sliding contacts' ``mu`` (each column holds one ``mu``), so
``det(W_Amu) = sum_S a_S prod_{i in S} mu_i`` with ``a_S`` the determinant whose sliding columns
in ``S`` are replaced by ``-xi_i w_it`` (the expansions of App. A eqs. 50-57, App. B 58-60).
Feasibility (eq. 28) is then polynomial: ``D c_in = D_in`` gives ``D D_in >= 0`` per sliding
contact, and for a rolling contact ``D (mu D_Rn) >= |D D_Rt|``.

Differences to the paper: coefficients are computed numerically from ``W`` rather than printed
symbolically; ``xi`` comes from :func:`planner.feasibility.kinematic_stage`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from planner.errors import InputError
from planner.modes import ROLL, SLIDE


@dataclass(frozen=True)
class MultilinearPoly:
    """``sum_S coef[S] prod_{i in S} mu_i`` over subsets ``S`` of sliding contacts (0-based)."""

    terms: tuple[tuple[tuple[int, ...], float], ...]

    def __call__(self, mu: np.ndarray) -> np.ndarray:
        """Evaluate at ``mu (L, n_c)``; returns ``(L,)``."""
        mu = np.atleast_2d(mu)
        out = np.zeros(mu.shape[0])
        for subset, c in self.terms:
            out = out + c * np.prod(mu[:, list(subset)], axis=1) if subset else out + c
        return out


@dataclass(frozen=True)
class ClosedFormRegion:
    """Region of one 3S or RS mode: ``D``, and numerators per unknown (Cramer, eq. 26)."""

    codes: tuple[int, ...]
    xi: tuple[int, ...]
    denominator: MultilinearPoly
    numerators: tuple[MultilinearPoly, ...]  # one per unknown column (row order of the mode)
    unknowns: tuple[tuple[int, str], ...]  # (contact, "n"|"t")

    def margin(self, mu: np.ndarray) -> np.ndarray:
        """Smallest polynomial slack, ``(L,)``; ``>= 0`` inside the region (eq. 28)."""
        mu = np.atleast_2d(np.asarray(mu, float))
        D = self.denominator(mu)
        num = {u: p(mu) * D for u, p in zip(self.unknowns, self.numerators)}
        slacks = []
        for i, code in enumerate(self.codes):
            if code == SLIDE:
                slacks.append(num[(i, "n")])
            elif code == ROLL:
                slacks.append(mu[:, i] * num[(i, "n")] - np.abs(num[(i, "t")]))
        return np.min(np.stack(slacks), axis=0)


def closed_form_region(W: np.ndarray, g_obj: np.ndarray, codes, xi) -> ClosedFormRegion:
    """Coefficients of the 3S / RS region (eqs. 34-36, 39-41; App. A/B) for mode ``codes``."""
    codes = tuple(int(c) for c in codes)
    xi = tuple(int(x) for x in xi)
    n_r = sum(c == ROLL for c in codes)
    n_s = sum(c == SLIDE for c in codes)
    if 2 * n_r + n_s != 3:
        raise InputError(f"closed form: expected a 3S or RS mode (2 n_R + n_S = 3), got {codes}")
    cols, slide_of, unknowns = [], [], []
    for i, c in enumerate(codes):
        if c == ROLL:
            cols += [W[:, 2 * i], W[:, 2 * i + 1]]
            slide_of += [None, None]
            unknowns += [(i, "n"), (i, "t")]
        elif c == SLIDE:
            cols.append(W[:, 2 * i])
            slide_of.append(i)
            unknowns.append((i, "n"))
    sliding = [i for i in slide_of if i is not None]
    rhs = -np.asarray(g_obj, float)

    def poly(replace: int | None) -> MultilinearPoly:
        terms = []
        for r in range(len(sliding) + 1):
            for subset in itertools.combinations(sliding, r):
                M = []
                for j, col in enumerate(cols):
                    if j == replace:
                        M.append(rhs)
                    elif slide_of[j] in subset:
                        M.append(-xi[slide_of[j]] * W[:, 2 * slide_of[j] + 1])
                    else:
                        M.append(col)
                if replace is not None and slide_of[replace] in subset:
                    continue
                terms.append((subset, float(np.linalg.det(np.column_stack(M)))))
        return MultilinearPoly(tuple(terms))

    return ClosedFormRegion(codes, xi, poly(None), tuple(poly(j) for j in range(3)),
                            tuple(unknowns))
