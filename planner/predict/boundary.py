"""Boundary-tolerance modes (docs/conventions.md, "Tolerance policy"): candidates that miss a
strict kinematic constraint of Trinkle & Zeng (1994) -- eq. (25), a breaking contact separates;
eq. (16), a sliding contact slips -- by at most the tolerance, and whose contact forces satisfy
eqs. (26)-(28).  One definition for exhaustive enumeration
(:func:`planner.predict.feasibility.feasible_modes`) and the pruned search
(:func:`planner.predict.search.search_modes`), which therefore list the same modes.
"""

from __future__ import annotations

import numpy as np

from planner.model.modes import SLIDE, CandidateSet, Mode, candidates_from_codes
from planner.model.system import System
from planner.predict.stages import KinematicStage, force_stage

__all__ = ["CHUNK", "boundary_modes_of", "force_checked"]

CHUNK = 256
"""Candidates force-tested at once: the force stage's arrays grow with the batch, and a large
enumeration can leave thousands of kinematic boundary candidates."""


def boundary_modes_of(system: System, cand: CandidateSet, kin: KinematicStage,
                      mu_arr: np.ndarray, *, tol: float, singular_tol: float) -> tuple[Mode, ...]:
    """The boundary-tolerance modes among ``cand``: candidates that miss a strict kinematic
    constraint (eq. 25: a breaking contact separates; eq. 16: a sliding contact slips) by at
    most ``tol`` (``kin.boundary``) and whose contact forces pass the force stage (eqs. 26-28,
    Coulomb to ``-tol``): the modes that would be feasible if that strict inequality were closed.

    A sliding contact with ``xi = 0`` (its slip speed exactly zero) is force-tested sliding
    towards ``+t`` (``c_t = -mu c_n``), the direction that owns it in the pruned search
    (:class:`planner.predict.search_tree.LeafBatches`), and keeps the unsigned label ``S``.
    Because the set depends on each candidate's own arithmetic only, exhaustive enumeration
    and the pruned search (whose relaxations every such mode satisfies) list the same modes.
    """
    bidx = kin.boundary.nonzero()[0]
    return force_checked(system, cand.codes.take(bidx, axis=0), kin.xi.take(bidx, axis=0),
                         mu_arr, tol=tol, singular_tol=singular_tol)


def force_checked(system: System, codes: np.ndarray, xi: np.ndarray, mu_arr: np.ndarray, *,
                  tol: float, singular_tol: float) -> tuple[Mode, ...]:
    """The candidates ``codes (m, n_c)`` on a kinematic boundary, with their sliding directions
    ``xi (m, n_c)``, whose forces pass the force stage at friction ``mu_arr (n_c,)`` (see
    :func:`boundary_modes_of`; also used by :func:`planner.predict.batch.predict_batch`)."""
    out: list[Mode] = []
    codes, xi = np.asarray(codes, dtype=np.int8), np.asarray(xi)
    for lo in range(0, len(codes), CHUNK):  # bounded memory on large enumerations
        cand = candidates_from_codes(codes[lo:lo + CHUNK], system.dof)
        x = xi[lo:lo + CHUNK]
        own_xi = np.where((cand.codes == SLIDE) & (x == 0), 1, x)
        fs = force_stage(system, cand, np.arange(len(cand.codes)), own_xi, mu_arr, tol=tol,
                         singular_tol=singular_tol)
        ok = fs.nonsingular[0] & (fs.margin[0] >= -tol)
        out.extend(Mode(tuple(cand.codes[j].tolist()), tuple(x[j].tolist()))
                   for j in np.flatnonzero(ok).tolist())
    return tuple(out)
