"""Search-tree bookkeeping of the exact search (:mod:`planner.predict.search`): candidate counts
of partial assignments (eq. 49), their completions, the branching rule and the batched leaf
tests (eqs. 23-25, 16).  Description: ``docs/scaling.md``.
"""

from __future__ import annotations

import itertools
from functools import lru_cache
from math import comb

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE, candidates_from_codes, enumerate_modes
from planner.model.system import System
from planner.predict.prune_lp import CONTACT, FREE
from planner.predict.stages import kinematic_stage


@lru_cache(maxsize=4096)
def completion_count(n_free: int, rows_needed: int) -> int:
    """Number of assignments of ``n_free`` contacts giving exactly ``rows_needed`` rows (eq. 49)."""
    if rows_needed < 0 or rows_needed > 2 * n_free:
        return 0
    return sum(
        comb(n_free, n_r) * comb(n_free - n_r, rows_needed - 2 * n_r)
        for n_r in range(rows_needed // 2 + 1)
        if rows_needed - 2 * n_r <= n_free - n_r
    )



def subtree_size(states: np.ndarray, n_rows: int) -> int:
    """Number of candidate codes (eq. 49) consistent with the node ``states``."""
    counts = np.bincount(states, minlength=5)
    used = 2 * int(counts[ROLL]) + int(counts[SLIDE])
    return subtree_count(int(counts[FREE]), int(counts[CONTACT]), n_rows - used)


@lru_cache(maxsize=4096)
def subtree_count(n_free: int, n_con: int, rows_left: int) -> int:
    """Completions of ``n_free`` undecided and ``n_con`` in-contact contacts to ``rows_left``
    rows (each CONTACT gives one row, two if rolling)."""
    need = rows_left - n_con
    return sum(comb(n_con, r) * completion_count(n_free, need - r) for r in range(n_con + 1))


@lru_cache(maxsize=256)
def rolled_subsets(n_con: int, r: int) -> np.ndarray:
    """All ``r``-subsets of ``n_con`` contacts as a read-only boolean table (C(n_con, r), n_con)."""
    rolled = np.zeros((comb(n_con, r), n_con), dtype=bool)
    for j, subset in enumerate(itertools.combinations(range(n_con), r)):
        rolled[j, list(subset)] = True
    rolled.setflags(write=False)
    return rolled


def completions(states: np.ndarray, n_rows: int) -> np.ndarray:
    """All candidate codes (m, n_c) int8 consistent with the node ``states``."""
    n_c = len(states)
    fixed = (states == BREAK) | (states == SLIDE) | (states == ROLL)
    used = 2 * int(np.sum(states == ROLL)) + int(np.sum(states == SLIDE))
    free = np.flatnonzero(states == FREE)
    con = np.flatnonzero(states == CONTACT)
    base = np.where(fixed, states, 0).astype(np.int8)
    blocks = []
    for r in range(len(con) + 1):
        need = n_rows - used - len(con) - r
        if completion_count(len(free), need) == 0:
            continue
        if len(free) == 0:
            tail = np.zeros((1, 0), dtype=np.int8)
        elif need == 0:
            tail = np.zeros((1, len(free)), dtype=np.int8)
        else:
            tail = enumerate_modes(len(free), need).codes
        rolled = rolled_subsets(len(con), r)
        n_t = tail.shape[0]
        blk = np.empty((rolled.shape[0] * n_t, n_c), dtype=np.int8)
        blk[:] = base
        blk[:, free] = np.tile(tail, (rolled.shape[0], 1))
        blk[:, con] = np.where(np.repeat(rolled, n_t, axis=0), ROLL, SLIDE)
        blocks.append(blk)
    return np.concatenate(blocks) if blocks else np.zeros((0, n_c), dtype=np.int8)


def branch_contact(states: np.ndarray, point: np.ndarray | None, mu: np.ndarray) -> int:
    """Contact to branch on, from the relaxed forces ``c``: the FREE contact with the largest
    normal force (its ``B`` child, ``c_i = 0``, is the most likely to be infeasible); else the
    CONTACT one deepest inside its friction cone (largest ``mu c_n - |c_t|``: its sliding
    children are the most likely to be infeasible).  When no FREE contact carries force in
    ``c``, splitting one cannot prune (its ``B`` child is satisfied by ``c``, its ``CONTACT``
    child inherits ``c``), so a CONTACT one is split first if there is one.  ``point is None``:
    the lowest index."""
    free = np.flatnonzero(states == FREE)
    con = np.flatnonzero(states == CONTACT)
    if point is None:
        return int(free[0]) if len(free) else int(con[0])
    c = point
    free_force = c[2 * free]
    if len(free) and (
        not len(con) or np.max(free_force) > ZERO_FORCE * max(float(np.max(np.abs(c))), 1e-300)
    ):
        return int(free[np.argmax(free_force)])
    fn, ft = c[2 * con], c[2 * con + 1]
    return int(con[np.argmax(mu[con] * fn - np.abs(ft))])


#: Relative size below which a relaxed normal force counts as zero in :func:`branch_contact`
#: (a heuristic: it orders the branching, never decides a mode).
ZERO_FORCE = 1e-9


#: Leaf candidates collected before one batched kinematic test (amortises the batched LU).
LEAF_FLUSH = 4096


class LeafBatches:
    """Leaves of the search, tested in batches of about ``LEAF_FLUSH`` candidates.

    The kinematic test of a candidate does not depend on the other candidates of its batch,
    and the traversal does not depend on leaf outcomes, so leaves are queued and tested
    together by :func:`planner.predict.stages.kinematic_stage` (eqs. 23-25, 16).  A candidate
    is kept when it is kinematically admissible or on a kinematic boundary and, at every contact
    its leaf fixed to ``S+``/``S-``, its computed ``xi`` is that of the leaf (``xi = 0``, only
    possible on a boundary, is owned by ``S+``), so each candidate is owned by one leaf.
    """

    def __init__(self, system: System, n_rows: int, *, tol: float, singular_tol: float) -> None:
        self.system, self.n_rows = system, n_rows
        self.tol, self.singular_tol = tol, singular_tol
        self.pending: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.n_pending = 0
        self.kept: list[np.ndarray] = []
        self.tested = 0

    def add(self, block: np.ndarray, states: np.ndarray, xi: np.ndarray) -> None:
        """Queue candidate codes ``block (m, n_c)`` with their leaf's node ``states``/``xi``:
        ``(n_c,)`` for one leaf's block, or ``(m, n_c)``, one row per candidate (the native
        search hands back candidates of many leaves at once)."""
        if len(block) == 0:
            return
        self.pending.append((block, states, xi))
        self.n_pending += len(block)
        if self.n_pending >= LEAF_FLUSH:
            self.flush()

    def flush(self) -> None:
        """Test every queued candidate in one batch."""
        if not self.pending:
            return
        codes = np.concatenate([b for b, _, _ in self.pending])
        # a leaf's states/xi (n_c,) broadcast over its block; expanded ones are (m, n_c) already
        leaf_states = np.concatenate([np.broadcast_to(st, b.shape) for b, st, _ in self.pending])
        leaf_xi = np.concatenate([np.broadcast_to(x, b.shape) for b, _, x in self.pending])
        self.pending, self.n_pending = [], 0
        self.tested += len(codes)
        kin = kinematic_stage(
            self.system, candidates_from_codes(codes, self.n_rows), tol=self.tol,
            singular_tol=self.singular_tol,
        )
        own_xi = np.where(kin.xi == 0, 1, kin.xi)
        foreign = (leaf_states == SLIDE) & (own_xi != leaf_xi)
        keep = (kin.ok | kin.boundary) & ~foreign.any(axis=1)
        self.kept.append(codes[keep])

    def kept_codes(self) -> np.ndarray:
        """Codes ``(m, n_c)`` kept by every leaf (after a final flush)."""
        self.flush()
        if not self.kept:
            return np.zeros((0, self.system.n_contacts), dtype=np.int8)
        return np.concatenate(self.kept)



def canonical_order(codes: np.ndarray) -> np.ndarray:
    """Sort codes as :func:`planner.model.modes.enumerate_modes`: by ``n_R``, rolling set,
    sliding set."""
    if len(codes) == 0:
        return codes
    n_c = codes.shape[1]
    n_r = (codes == ROLL).sum(axis=1)
    # Lexicographic on sorted index tuples == lexicographic on the membership vectors reversed
    # (a set containing a smaller index first sorts first), i.e. on -membership.
    keys = [-(codes[:, i] == SLIDE).astype(int) for i in reversed(range(n_c))]
    keys += [-(codes[:, i] == ROLL).astype(int) for i in reversed(range(n_c))]
    keys.append(n_r)
    return codes[np.lexsort(keys)]
