"""Closed-form friction regions of 3S and RS modes by Cramer's rule (eqs. 34-36, 39-41).

For a mode with three force unknowns (3S: ``c_1n, c_2n, c_3n``; RS: ``c_Rn, c_Rt, c_Sn``) and no
effort joints, eq. (26) reads ``W_Amu c_A = -g_obj`` with ``W_Amu`` of eqs. (18)-(19).  Every
determinant is multilinear in the sliding contacts' ``mu`` (each column holds one ``mu``), so
``det(W_Amu) = sum_S a_S prod_{i in S} mu_i`` with ``a_S`` the determinant whose sliding columns
in ``S`` are replaced by ``-xi_i w_it`` (the expansions of App. A eqs. 50-57, App. B 58-60).
Feasibility (eq. 28) is then polynomial: ``D c_in = D_in`` gives ``D D_in >= 0`` per sliding
contact, and for a rolling contact ``D (mu D_Rn) >= |D D_Rt|``.

Correspondence with the paper's coefficients (0-based subsets printed 1-based): for a 3S mode
the denominator's coefficient of ``mu_1 mu_2 mu_3`` is App. A's ``A`` (eq. 50), of ``mu_j mu_k``
is ``B_i`` (eq. 51), of ``mu_i`` is ``C_i`` (eq. 52), the constant is ``D`` (eq. 50); the
numerator of ``c_in`` has ``E_i`` (``prod_{j != i} mu_j``, eq. 53), ``F_ij`` (``mu_j``, eqs.
54-56) and ``G_i`` (constant, eq. 57).  For an RS mode the denominator is ``A mu_S + B`` (eq. 58),
the numerators are ``C_1 mu_S + D_1`` (``c_Rn``), ``C_2 mu_S + D_2`` (``c_Rt``) and ``D_3``
(``c_Sn``) (eqs. 59-60).  :meth:`ClosedFormRegion.inequalities` returns the polynomials of eqs.
(35)-(36) / (40)-(41), all multilinear in the mu's:

    region = { mu : D(mu) != 0  and  sign(D(mu)) * P_k(mu) >= 0 for every k }.

Differences to the paper: coefficients are computed numerically from ``W`` rather than printed
symbolically; ``xi`` comes from :func:`planner.predict.feasibility.kinematic_stage`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.modes import ROLL, SLIDE, Mode


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

    def times(self, i: int) -> MultilinearPoly:
        """``mu_i * self`` (``i`` 0-based, not already in any term)."""
        if any(i in subset for subset, _ in self.terms):
            raise InputError(f"times: expected mu_{i + 1} absent from the polynomial, got it")
        return MultilinearPoly(tuple((tuple(sorted(subset + (i,))), c)
                                     for subset, c in self.terms))

    def __add__(self, other: MultilinearPoly) -> MultilinearPoly:
        acc: dict[tuple[int, ...], float] = {}
        for subset, c in self.terms + other.terms:
            acc[subset] = acc.get(subset, 0.0) + c
        return MultilinearPoly(tuple(sorted(acc.items(), key=lambda t: (len(t[0]), t[0]))))

    def __neg__(self) -> MultilinearPoly:
        return MultilinearPoly(tuple((subset, -c) for subset, c in self.terms))

    def to_list(self) -> list[dict[str, Any]]:
        """JSON form: ``[{"mu": [1-based contacts], "coef": float}, ...]``; the term is
        ``coef * prod(mu_i for i in "mu")`` (an empty list is the constant)."""
        return [{"mu": [i + 1 for i in subset], "coef": c} for subset, c in self.terms]

    @staticmethod
    def from_list(data: Any) -> MultilinearPoly:
        try:
            return MultilinearPoly(tuple((tuple(int(i) - 1 for i in t["mu"]), float(t["coef"]))
                                         for t in data))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"polynomial: expected a list of {{'mu': [...], 'coef': x}}, "
                             f"got {data!r:.80}") from exc


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

    @property
    def label(self) -> str:
        """Mode string, e.g. ``"R1 S-2 B3"`` (docs/conventions.md)."""
        return Mode(self.codes, self.xi).label

    def inequalities(self) -> tuple[tuple[str, MultilinearPoly], ...]:
        """``(name, P_k)`` with the region ``sign(D) P_k >= 0`` (eqs. 35-36, 40-41).

        Sliding contact ``i``: ``P = N_in`` (numerator of ``c_in``, eq. 34 / 39).  Rolling
        contact ``i``: ``mu_i N_in - N_it`` and ``mu_i N_in + N_it`` (eq. 40's two Coulomb
        rows).  Names: ``"c_2n>=0"``, ``"mu_1 c_1n - c_1t>=0"``, ``"mu_1 c_1n + c_1t>=0"``."""
        num = dict(zip(self.unknowns, self.numerators))
        out: list[tuple[str, MultilinearPoly]] = []
        for i, code in enumerate(self.codes):
            k = i + 1
            if code == SLIDE:
                out.append((f"c_{k}n>=0", num[(i, "n")]))
            elif code == ROLL:
                scaled = num[(i, "n")].times(i)
                out.append((f"mu_{k} c_{k}n - c_{k}t>=0", scaled + -num[(i, "t")]))
                out.append((f"mu_{k} c_{k}n + c_{k}t>=0", scaled + num[(i, "t")]))
        return tuple(out)

    def signed_inequalities(self, mu: np.ndarray) -> np.ndarray:
        """``sign(D(mu)) P_k(mu)``, shape ``(L, K)``; the region is where all are ``>= 0``
        and ``D != 0`` (eqs. 35-36, 40-41).  ``mu (L, n_c)``."""
        mu = np.atleast_2d(np.asarray(mu, float))
        sign = np.sign(self.denominator(mu))
        return np.stack([sign * p(mu) for _, p in self.inequalities()], axis=1)

    def contains(self, mu: np.ndarray) -> np.ndarray:
        """Boolean ``(L,)``: ``mu (L, n_c)`` lies in the region (eqs. 35-36, 40-41)."""
        mu = np.atleast_2d(np.asarray(mu, float))
        nonzero = self.denominator(mu) != 0
        return nonzero & np.all(self.signed_inequalities(mu) >= 0, axis=1)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (see the module docstring and docs/muspace.md)."""
        return {
            "mode": self.label,
            "family": Mode(self.codes, self.xi).family,
            "region": "D(mu) != 0 and sign(D(mu)) * P_k(mu) >= 0 for every k "
                      "(Trinkle & Zeng 1994 eqs. 35-36, 40-41)",
            "denominator": self.denominator.to_list(),
            "unknowns": [f"c_{i + 1}{part}" for i, part in self.unknowns],
            "numerators": [p.to_list() for p in self.numerators],
            "inequalities": [{"name": name, "terms": p.to_list()}
                             for name, p in self.inequalities()],
        }

    @staticmethod
    def from_dict(data: Any) -> ClosedFormRegion:
        """Inverse of :meth:`to_dict` (the inequalities are rebuilt from the numerators)."""
        try:
            mode = Mode.parse(str(data["mode"]))
            unknowns = tuple((int(u[2:-1]) - 1, u[-1]) for u in data["unknowns"])
            den = MultilinearPoly.from_list(data["denominator"])
            nums = tuple(MultilinearPoly.from_list(p) for p in data["numerators"])
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"closed-form region: expected keys mode, unknowns, denominator, "
                             f"numerators; got {exc}") from exc
        if len(nums) != 3 or len(unknowns) != 3:
            raise InputError(f"closed-form region: expected 3 numerators and unknowns, got "
                             f"{len(nums)} and {len(unknowns)}")
        return ClosedFormRegion(mode.codes, mode.xi, den, nums, unknowns)


def closed_form_region(W: np.ndarray, g_obj: np.ndarray, codes, xi) -> ClosedFormRegion:
    """Coefficients of the 3S / RS region (eqs. 34-36, 39-41; App. A/B) for mode ``codes``."""
    codes = tuple(int(c) for c in codes)
    xi = tuple(int(x) for x in xi)
    n_r = sum(c == ROLL for c in codes)
    n_s = sum(c == SLIDE for c in codes)
    if 2 * n_r + n_s != 3:
        raise InputError(f"closed form: expected a 3S or RS mode (2 n_R + n_S = 3), got {codes}")
    cols: list[np.ndarray] = []
    slide_of: list[int | None] = []
    unknowns: list[tuple[int, str]] = []
    for i, c in enumerate(codes):
        if c == ROLL:
            cols += [W[:, 2 * i], W[:, 2 * i + 1]]
            slide_of += [None, None]
            unknowns += [(i, "n"), (i, "t")]
        elif c == SLIDE:
            cols.append(W[:, 2 * i])
            slide_of.append(i)
            unknowns.append((i, "n"))
    sliding: list[int] = [i for i in slide_of if i is not None]
    rhs = -np.asarray(g_obj, float)

    def poly(replace: int | None) -> MultilinearPoly:
        terms: list[tuple[tuple[int, ...], float]] = []
        for r in range(len(sliding) + 1):
            for subset in itertools.combinations(sliding, r):
                M = []
                for j, col in enumerate(cols):
                    if j == replace:
                        M.append(rhs)
                    elif (k := slide_of[j]) is not None and k in subset:
                        M.append(-xi[k] * W[:, 2 * k + 1])
                    else:
                        M.append(col)
                if replace is not None and slide_of[replace] in subset:
                    continue
                terms.append((subset, float(np.linalg.det(np.column_stack(M)))))
        return MultilinearPoly(tuple(terms))

    return ClosedFormRegion(codes, xi, poly(None), tuple(poly(j) for j in range(3)),
                            tuple(unknowns))
