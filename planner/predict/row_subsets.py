"""Structurally nonsingular ``k``-row subsets of ``K`` for several workpieces.

With ``n_b`` workpieces, ``K`` (``2 n_c x (3 n_b + |tau_I|)``, eq. 5) is block sparse: the two
rows of a contact touch only the three columns of each body it belongs to (one body for a
contact with the environment or a finger, two for a body-body contact) and the effort-joint
columns.  A square ``K_S`` can be nonsingular only if its rows can be matched to its columns;
Hall's condition on the body column groups is therefore necessary: for every set ``T`` of
bodies, the rows of ``S`` touching a body of ``T`` number at least ``3 |T|``.  (The effort
columns are left out of the test: still necessary, and for ``n_b = 1`` the test is empty.)

Rows with the same touched-body set are interchangeable for this count, so the subsets are
generated per *count vector* (how many rows of each class): a count vector passing every
Hall inequality contributes the product of the per-class combinations; the others are never
generated.  Only exact zeros of ``K`` are structural, so every subset dropped here has
``det K_S = 0`` exactly: the row-subset scan of :mod:`planner.predict.indeterminate` finds the
same modes from the subsets kept (a relaxed-utility mode's rows contain a nonsingular ``k``
-subset, which is kept).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from math import comb, prod

import numpy as np

#: Row subsets solved per batch (bounds the pass's memory at any ``n_c``).
SUBSET_CHUNK = 4096


@dataclass(frozen=True, eq=False)
class RowClasses:
    """The rows of ``K`` grouped by the set of bodies they touch: ``masks (G,)`` (bit ``a``:
    body ``a``), ``members`` (row indices per class), ``counts (V, G)`` the count vectors that
    pass Hall's condition and ``sizes (V,)`` the subsets each gives."""

    masks: tuple[int, ...]
    members: tuple[np.ndarray, ...]
    counts: np.ndarray
    sizes: np.ndarray

    @property
    def total(self) -> int:
        """Number of structurally admissible ``k``-row subsets."""
        return int(self.sizes.sum())


def row_classes(K: np.ndarray, n_bodies: int, k: int) -> RowClasses:
    """Group the rows of ``K (2 n_c, 3 n_b + n_E)`` by the bodies they touch (exact nonzeros
    in a body's three columns) and list the count vectors of ``k`` rows that satisfy Hall's
    condition on every set of bodies."""
    touch = np.abs(K[:, :3 * n_bodies]).reshape(K.shape[0], n_bodies, 3).max(axis=2) > 0
    row_mask = (touch * (1 << np.arange(n_bodies))).sum(axis=1)
    masks = tuple(int(m) for m in np.unique(row_mask))
    members = tuple(np.flatnonzero(row_mask == m) for m in masks)
    avail = [len(m) for m in members]
    # Hall's inequalities: for each nonempty body set T, the classes touching T need 3 |T|.
    sets = range(1, 1 << n_bodies)
    hits = np.array([[bool(m & T) for m in masks] for T in sets], dtype=np.int64)
    need = np.array([3 * bin(T).count("1") for T in sets], dtype=np.int64)
    counts: list[tuple[int, ...]] = []

    def extend(prefix: tuple[int, ...], left: int) -> None:
        g = len(prefix)
        if g == len(masks):
            if left == 0:
                vec = np.array(prefix, dtype=np.int64)
                if np.all(hits @ vec >= need):
                    counts.append(prefix)
            return
        rest = sum(avail[g + 1:])
        for c in range(max(0, left - rest), min(avail[g], left) + 1):
            extend(prefix + (c,), left - c)

    extend((), k)
    cv = np.array(counts, dtype=np.int64).reshape(-1, len(masks))
    sizes = np.array([prod(comb(a, c) for a, c in zip(avail, row)) for row in cv],
                     dtype=np.int64)
    return RowClasses(masks, members, cv, sizes)


def admissible_subsets(classes: RowClasses, chunk: int) -> Iterator[np.ndarray]:
    """The structurally admissible ``k``-row subsets as arrays ``(<= chunk, k)`` of row
    indices (every count vector's product of per-class combinations, by flat index)."""
    for row, size in zip(classes.counts, classes.sizes):
        parts = [combinations_array(m, int(c)) for m, c in zip(classes.members, row) if c]
        shape = tuple(len(p) for p in parts)
        for start in range(0, int(size), chunk):
            flat = np.arange(start, min(start + chunk, int(size)))
            idx = np.unravel_index(flat, shape)
            yield np.concatenate([p[i] for p, i in zip(parts, idx)], axis=1)


def combinations_array(items: np.ndarray, r: int) -> np.ndarray:
    """``(C(len(items), r), r)`` every ``r``-combination of ``items``, lexicographic."""
    from itertools import combinations

    if r == 0:
        return np.zeros((1, 0), dtype=np.int64)
    n = len(items)
    flat = np.fromiter((i for c in combinations(range(n), r) for i in c), dtype=np.int64,
                       count=comb(n, r) * r)
    return items[flat.reshape(-1, r)]


def all_subsets(n_rows: int, k: int) -> Iterator[np.ndarray]:
    """Every ``k``-subset of ``n_rows`` rows, lexicographic, in arrays ``(<= SUBSET_CHUNK, k)``."""
    combos = itertools.combinations(range(n_rows), k)
    while True:
        flat = np.fromiter(itertools.chain.from_iterable(itertools.islice(combos, SUBSET_CHUNK)),
                           dtype=np.int64)
        if flat.size == 0:
            return
        yield flat.reshape(-1, k)


def unique_rows(pattern: np.ndarray) -> np.ndarray:
    """The distinct rows of the boolean ``pattern (M, w)`` (as ``np.unique(pattern, axis=0)``,
    in another order): the rows are packed into 64-bit words first, so that a degenerate
    velocity met by many subsets costs one integer sort, not a sort of boolean records."""
    M, w = pattern.shape
    packed = np.packbits(pattern, axis=1)
    pad = -packed.shape[1] % 8
    words = np.pad(packed, ((0, 0), (0, pad))).view(np.uint64)
    if words.shape[1] == 1:
        _, first = np.unique(words[:, 0], return_index=True)
    else:
        _, first = np.unique(words, axis=0, return_index=True)
    return pattern[np.sort(first)]
