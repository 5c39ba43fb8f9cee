"""Relaxed utility (end of Section 3.2): statically indeterminate, force-indeterminate modes.

When a mode has more kinematic constraints than ``3 + |tau_I|`` (e.g. two rolling contacts on
one rigid link, mode ``2R``), ``Q_A`` has a null space and the contact forces are not unique.
The paper keeps condition (29)'s lower bound, drops ``Q_AI`` from (32) and asks only that the
left null space of ``Q_A`` be trivial (full row rank).  Here:

* kinematics: ``P_A`` (``(2 n_R + n_S) x (3 + |tau_I|)``) must have full column rank
  (unique ``qdot``, eq. 24 in the generalised-inverse sense) and the over-determined system
  ``P_A zdot_I = J_AV thetadot_V`` must be consistent (residual within ``tol``); breaking contacts
  separate and sliding contacts slip as in the determinate case (eqs. 16, 25);
* forces: ``c_A = Q_A^+ rhs + N y`` (generalised inverse plus null space); feasibility of
  ``B_A c_A >= 0`` is a linear program (scipy HiGHS) maximising the smallest normalised slack.

The candidates are not enumerated (``3^n_c`` modes): :func:`scan_indeterminate` solves every
``k``-row subset of ``K`` (polynomial in ``n_c``), keeps the velocities at which more than ``k``
rows vanish, and reads the modes off them; the exact kinematic test and the LP run only for
those few modes.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from functools import lru_cache
from math import comb

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE, enumerate_modes
from planner.model.system import System
from planner.predict.linalg import batch_det, lu_det_solve
from planner.predict.relaxed_modes import (
    IndeterminateKinematics,
    coulomb_rows,
    feasible_relaxed_modes,
    force_lp,
    indeterminate_kinematics_of,
)
from planner.predict.row_subsets import (
    SUBSET_CHUNK,
    admissible_subsets,
    all_subsets,
    row_classes,
    unique_rows,
)
from planner.predict.stages import (
    DEFAULT_SINGULAR_TOL,
    DEFAULT_TOL,
    FeasibleMode,
    KinematicStage,
    equilibrated_kinematics,
)

__all__ = [
    "IndeterminateKinematics", "IndeterminateScan", "coulomb_rows", "force_lp",
    "indeterminate_kinematics", "indeterminate_kinematics_of", "indeterminate_modes",
    "row_subset_count", "scan_indeterminate",
]


#: Largest number of ``k``-row subsets of ``K`` (``C(2 n_c, 3 + |tau_I|)``) the row-subset scan
#: examines by default (about 1-2 s; e.g. ``n_c <= 57`` without effort joints, ``n_c <= 10`` for
#: random systems with ``3 + |tau_I| = n_c``); above it the scan is skipped and the result says
#: so.  (Deciding whether any ``k + 1`` rows of ``[K | b]`` are dependent is NP-hard in general:
#: Khachiyan 1995, so no budget-free exact test is fast for large ``k``.)
DEFAULT_MAX_ROW_SUBSETS = 250_000
#: Generation tolerance, relative to the largest equilibrated right side: a row with
#: ``|v| <= GEN_TOL max|bn|`` at a subset's solution may vanish in the mode (it covers the
#: difference between the subset's exact solution and the mode's generalised-inverse one,
#: ``cond(K_S) * tol``); every generated mode is then decided by the exact test.
GEN_TOL = 1e-6
#: Largest number of modes one subset's velocity may generate (contacts within ``GEN_TOL`` of
#: two states multiply); above it the pass reports a limit.
MAX_MODES_PER_VELOCITY = 4096


@dataclass(frozen=True, eq=False)
class IndeterminateScan:
    """Result of :func:`scan_indeterminate`.

    ``kinematics``: the kinematically admissible force-indeterminate candidates; ``subsets``:
    ``k``-row subsets of ``K`` examined; ``generated``: distinct candidate modes given to the
    exact test; ``limit``: empty when the scan is complete, else why it is not."""

    kinematics: tuple[IndeterminateKinematics, ...]
    subsets: int
    generated: int
    limit: str = ""


def row_subset_count(system: System) -> int:
    """``C(2 n_c, 3 + |tau_I|)``: the ``k``-row subsets :func:`scan_indeterminate` solves."""
    return comb(2 * system.n_contacts, system.dof)


def scan_indeterminate(
    system: System,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    max_subsets: int = DEFAULT_MAX_ROW_SUBSETS,
) -> IndeterminateScan:
    """Every kinematically admissible force-indeterminate candidate (relaxed utility, end of
    Sec. 3.2), at any ``n_c``, without enumerating the ``3^n_c`` modes.

    A relaxed-utility mode has rows ``A`` with ``|A| > k = 3 + |tau_I|`` and ``P_A`` of full
    column rank, so its velocity ``z = (qdot, thetadot_E)`` is unique (eq. 24) and already
    fixed by some ``k`` linearly independent rows of ``A``.  Conversely ``z`` fixes the mode:
    ``v = K z - b`` (eq. 5) vanishes on exactly the rows of ``A``; contacts with ``v_n > 0``
    break (eq. 25), with ``v_n = 0, v_t != 0`` slide with ``xi = sgn(v_t)`` (eq. 16), with
    ``v = 0`` roll.  Hence:

    1. solve ``K_S z = b_S`` for every ``k``-subset ``S`` of the ``2 n_c`` rows of ``K``
       (``C(2 n_c, k)`` small systems, batched, in chunks of :data:`SUBSET_CHUNK`): the rank
       test (30)-(32) on ``K_S`` drops singular subsets;
    2. keep the ``z`` at which more than ``k`` rows vanish (within :data:`GEN_TOL`: the cheap
       test; at generic ``z`` exactly ``k`` rows vanish and the subset is dropped) and read
       the mode(s) off ``v`` (a contact within ``GEN_TOL`` of two states yields both);
    3. decide every generated mode by the exact test of :func:`indeterminate_kinematics_of`
       (full column rank of ``P_A``, generalised-inverse velocities, consistency within
       ``tol``, strict margins), the same as testing it among all ``3^n_c`` modes.

    The work is polynomial in ``n_c`` for a fixed number of effort joints.  When
    ``C(2 n_c, k) > max_subsets`` nothing is scanned and ``limit`` says so.
    """
    n_c, k = system.n_contacts, system.dof
    if 2 * n_c <= k:  # no mode can have more than k rows
        return IndeterminateScan((), 0, 0)
    eq = equilibrated_kinematics(system)
    classes = row_classes(eq.Kn, system.n_bodies, k) if system.n_bodies > 1 else None
    count = row_subset_count(system) if classes is None else classes.total
    if count > max_subsets:
        return IndeterminateScan((), 0, 0, (
            f"force-indeterminate (relaxed-utility) modes not searched: C(2 n_c, 3 n_b + |tau_I|) "
            f"= C({2 * n_c}, {k}) = {count} row subsets exceed max_subsets = {max_subsets}"
        ))
    Kn, bn = eq.Kn, eq.bn
    subsets = all_subsets(2 * n_c, k) if classes is None else admissible_subsets(
        classes, SUBSET_CHUNK)
    strict, gen = generation_thresholds(system, tol)
    aug = np.ascontiguousarray(np.concatenate([Kn, bn[:, None]], axis=1).T)  # (k+1, 2 n_c)
    found: set[bytes] = set()
    codes_out: list[np.ndarray] = []
    limit = ""
    for S in subsets:
        det, z = lu_det_solve(np.take(aug, S.T, axis=1))
        good = np.abs(det) > singular_tol * 1e-3  # loose: the exact test decides the rank
        if not np.any(good):
            continue
        z = np.ascontiguousarray(z[:, good])
        # (2 n_c, C) equilibrated velocities, eq. (5).  einsum, not BLAS: a (2 n_c x k) times
        # (k x 4096) product is too small for threads, which spin for 10-50 ms on a busy machine.
        v = np.einsum("rk,kc->rc", Kn, z) - bn[:, None]
        limit = codes_from_velocities(v.T, k, strict, gen, found, codes_out) or limit
    kins = indeterminate_kinematics_of(system, codes_out, tol=tol, singular_tol=singular_tol)
    return IndeterminateScan(tuple(kins), count, len(codes_out), limit)


def generation_thresholds(system: System, tol: float) -> tuple[np.ndarray, float]:
    """``(strict (2 n_c,), gen)``: the equilibrated velocity a breaking contact's normal or a
    sliding contact's tangent must exceed (eqs. 16, 25: ``tol`` times the velocity scale), and
    the size below which a row counts as vanishing (:data:`GEN_TOL`)."""
    eq = equilibrated_kinematics(system)
    scale = eq.velocity_scale if eq.velocity_scale > 0 else 1.0
    return tol * scale / eq.row, GEN_TOL * eq.b_scale


def codes_from_velocities(
    v: np.ndarray, k: int, strict: np.ndarray, gen: float,
    found: set[bytes], codes_out: list[np.ndarray],
) -> str:
    """Append to ``codes_out`` the modes (not yet in ``found``) read off the equilibrated
    velocities ``v (C, 2 n_c)`` at which more than ``k`` rows vanish; a limit message if a
    velocity near too many mode boundaries was skipped, else ``""``."""
    zero = np.abs(v) <= gen
    many = np.flatnonzero(zero.sum(axis=1) > k)
    if many.size == 0:
        return ""
    n_c = v.shape[1] // 2
    # What each contact may be at each kept velocity (break; normal vanishes; tangent
    # vanishes; slip): many subsets of one mode give the same pattern, expanded once.
    vm, zm = v[many], zero[many]
    pattern = np.concatenate([
        vm[:, 0::2] > strict[0::2], zm[:, 0::2], zm[:, 1::2], np.abs(vm[:, 1::2]) > strict[1::2],
    ], axis=1)
    limit = ""
    for row in unique_rows(pattern):
        for code in modes_of_pattern(row.reshape(4, n_c)):
            if code is None:
                limit = (f"a velocity near {MAX_MODES_PER_VELOCITY}+ mode boundaries: "
                         "some force-indeterminate candidates were not generated")
                continue
            key = code.tobytes()
            if key not in found:
                found.add(key)
                codes_out.append(code)
    return limit


#: Rows (unit length) whose Gram determinant is at most ``SPAN_TOL**2`` count as dependent in
#: :func:`closed_bases_suffice` (conservative: then the full row-subset scan runs).
SPAN_TOL = 1e-6
#: Largest number of rank tests :func:`closed_bases_suffice` makes before answering False.
MAX_STRUCTURE_TESTS = 50_000


def closed_bases_suffice(system: System, kinematics: KinematicStage | None = None) -> bool:
    """Cheap structural test: True when every relaxed-utility mode contains an eq. (49)
    candidate (``n_R`` rolling pairs and ``n_S`` sliding normals, ``k`` rows) that is
    nonsingular, so that the velocities of the determinate candidates already reveal every
    force-indeterminate mode.

    Let ``B`` be a maximal independent set of a mode's rows that is *closed* (a tangent only
    with its normal).  Every normal of the mode lies in ``span B``; if ``rank B < k`` some
    rolling contact ``j`` has ``t_j`` outside it and ``n_j`` inside.  Were ``n_j``'s expansion
    to use a normal ``n_s`` whose tangent is not in ``B``, exchanging ``n_s`` for ``(n_j, t_j)``
    would give a larger closed independent set; so ``n_j`` lies in the span of at most
    ``(k - 1) / 2`` rolling pairs ``(n_a, t_a)`` of other contacts.  This function checks that
    no normal does (Gram determinant of ``[n_j; n_a; t_a; ...]`` above ``SPAN_TOL^2``); e.g.
    a pinch grasp (opposite normals on one line) fails it.  Answers False
    (scan everything) when that takes more than :data:`MAX_STRUCTURE_TESTS` tests."""
    eq = equilibrated_kinematics(system)
    hit = eq.derived.get("closed_bases")
    if hit is None:
        n_c, k = system.n_contacts, system.dof
        if not structure_tests_fit(n_c, k):
            hit = False
        elif kinematics is not None and kinematics.candidates is enumerate_modes(n_c, k) and (
                np.minimum.reduce(np.abs(kinematics.det), initial=np.inf) > DET_CERTIFICATE
                and every_structure_test_covered(n_c, k)
                or bool(certified_by_determinants(kinematics.det[None], n_c, k)[0])):
            hit = True  # (every candidate a witness: certified_by_determinants' common case)
        else:
            hit = bool(closed_bases_stacked(eq.Kn[None])[0])
        eq.derived["closed_bases"] = hit
    return hit


#: An eq. (49) candidate with equilibrated ``|det P_AI|`` above this certifies every structural
#: test whose rows it contains (:func:`certified_by_determinants`; 2x for rounding).
DET_CERTIFICATE = 2 * SPAN_TOL


def certified_by_determinants(det: np.ndarray, n_c: int, k: int) -> np.ndarray:
    """``(B,)`` bool: True where the equilibrated determinants ``det (B, M)`` of the eq. (49)
    candidates (:func:`planner.model.modes.enumerate_modes` order) prove every test of
    :func:`closed_bases_suffice`; False means "not proved" (run the Gram tests).

    A test's rows ``S`` (``n_j`` and ``p`` rolling pairs, all unit rows of ``Kn``) are a
    subset of a candidate's rows ``A``; by Fischer's inequality ``det P_A^2 = det(P_A P_A^T) <=
    det(Kn_S Kn_S^T) prod |other rows|^2 = det(Kn_S Kn_S^T)``, so ``|det P_A| > SPAN_TOL``
    implies the Gram determinant exceeds ``SPAN_TOL^2``: the test passes."""
    cover = structure_test_cover(n_c, k)
    B, M = det.shape
    if cover is None or not cover.shape[0]:
        return np.zeros(B, bool) if cover is None else np.ones(B, bool)
    abs_det = np.abs(det)
    if np.minimum.reduce(abs_det, axis=None, initial=np.inf) > DET_CERTIFICATE:  # all witnesses
        return np.full(B, every_structure_test_covered(n_c, k))
    # good[:, M] is False: the padding of cover's rows points there.  (Boolean gathers, not a
    # matrix product: no BLAS threads for this.)
    good = np.zeros((B, M + 1), bool)
    np.greater(abs_det, DET_CERTIFICATE, out=good[:, :M])
    witnessed = np.logical_or.reduce(good.take(cover, axis=1), axis=2)  # (B, T)
    return np.logical_and.reduce(witnessed, axis=1)


@lru_cache(maxsize=64)
def every_structure_test_covered(n_c: int, k: int) -> bool:
    """True when every test of :func:`closed_bases_suffice` has at least one eq. (49)
    candidate containing its rows (:func:`structure_test_cover`), so that all candidates
    having ``|det P_A| > DET_CERTIFICATE`` prove the structural test."""
    cover = structure_test_cover(n_c, k)
    return cover is not None and bool(np.all(cover[:, 0] < len(enumerate_modes(n_c, k))))


@lru_cache(maxsize=64)
def structure_test_cover(n_c: int, k: int) -> np.ndarray | None:
    """``(T, C)`` indices of the eq. (49) candidates (:func:`planner.model.modes.enumerate_modes`
    order) that contain the rows of each test of :func:`closed_bases_suffice` (all ``p``,
    :func:`pair_span_rows` order), padded with ``M`` (no candidate); None when the table
    would be large (more than 2e7 entries x rows to build)."""
    cand = enumerate_modes(n_c, k)
    p_max = min((k - 1) // 2, n_c - 1)
    tests = [pair_span_rows(n_c, p) for p in range(1, p_max + 1)]
    T, M = sum(len(t) for t in tests), len(cand)
    if T * M * 2 * n_c > 20_000_000:
        return None
    has_c = np.zeros((M, 2 * n_c), bool)
    np.put_along_axis(has_c, cand.rows, True, axis=1)
    has_t = np.zeros((T, 2 * n_c), bool)
    start = 0
    for t in tests:  # one block of tests per p
        np.put_along_axis(has_t[start:start + len(t)], t, True, axis=1)
        start += len(t)
    contains = ~np.any(has_t[:, None, :] & ~has_c[None], axis=2)  # (T, M)
    width = max(int(contains.sum(axis=1).max()) if T else 0, 1)
    cover = np.full((T, width), M, dtype=np.int64)
    for i, row in enumerate(contains):
        idx = np.flatnonzero(row)
        cover[i, :len(idx)] = idx
    cover.setflags(write=False)
    return cover


def closed_bases_stacked(Kn: np.ndarray) -> np.ndarray:
    """:func:`closed_bases_suffice`'s rank tests for every configuration of the stacked
    equilibrated ``Kn (B, 2 n_c, k)`` (unit rows): ``(B,)`` bool, True where no normal row
    ``Kn[2 j]`` lies (nearly) in the span of ``p <= (k - 1) / 2`` rolling pairs of other
    contacts.  Each test's Gram matrix is read off the Gram matrix ``Kn Kn^T`` of all rows."""
    B, two_n, k = Kn.shape
    n_c = two_n // 2
    ok = np.ones(B, bool)
    p_max = min((k - 1) // 2, n_c - 1)
    if p_max < 1:
        return ok
    gram = (Kn @ np.swapaxes(Kn, 1, 2)).reshape(B, two_n * two_n)
    for p in range(1, p_max + 1):
        g = gram.take(pair_span_gram_index(n_c, p), axis=1)  # (B, T, 2 p + 1, 2 p + 1)
        # det(X X^T) is the product of the squared singular values: 0 for dependent rows.
        ok &= ~np.logical_or.reduce(batch_det(g) <= SPAN_TOL ** 2, axis=1)
    return ok


@lru_cache(maxsize=256)
def structure_tests_fit(n_c: int, k: int) -> bool:
    """True when :func:`closed_bases_suffice`'s rank tests at ``n_c`` contacts and ``k = 3 +
    |tau_I|`` number at most :data:`MAX_STRUCTURE_TESTS`."""
    tests = sum(n_c * comb(n_c - 1, p) for p in range(1, (k - 1) // 2 + 1))
    return tests <= MAX_STRUCTURE_TESTS


@lru_cache(maxsize=64)
def pair_span_gram_index(n_c: int, p: int) -> np.ndarray:
    """Flat indices ``(T, 2 p + 1, 2 p + 1)`` into the ``(2 n_c)^2`` Gram matrix of ``K``'s
    rows: the Gram matrix of each row set of :func:`pair_span_rows` ``(n_c, p)``."""
    rows = pair_span_rows(n_c, p)
    idx = rows[:, :, None] * (2 * n_c) + rows[:, None, :]
    idx.setflags(write=False)
    return idx


@lru_cache(maxsize=64)
def pair_span_rows(n_c: int, p: int) -> np.ndarray:
    """Row indices ``(T, 2 p + 1)``: ``[n_j, n_a, ..., t_a, ...]`` for every contact ``j`` and
    every ``p``-set of other contacts (the tests of :func:`closed_bases_suffice`)."""
    sets = np.array(list(itertools.combinations(range(n_c), p)), dtype=np.int64)
    j = np.repeat(np.arange(n_c), len(sets))
    P = np.tile(sets, (n_c, 1))
    keep = ~np.any(P == j[:, None], axis=1)
    j, P = j[keep], P[keep]
    rows = np.concatenate([2 * j[:, None], 2 * P, 2 * P + 1], axis=1)
    rows.setflags(write=False)
    return rows


def modes_of_pattern(pattern: np.ndarray) -> Iterator[np.ndarray | None]:
    """Mode codes ``(n_c,) int8`` allowed by ``pattern (4, n_c)`` (rows: may break; normal
    vanishes; tangent vanishes; may slip) -- a superset of the modes whose rows all vanish;
    one None instead once more than :data:`MAX_MODES_PER_VELOCITY` would be generated."""
    can_b, zn, zt, can_s = pattern
    options: list[list[int]] = []
    size = 1
    for i in range(pattern.shape[1]):
        opts = [BREAK] if can_b[i] else []
        if zn[i]:
            if zt[i]:
                opts.append(ROLL)
            if can_s[i]:
                opts.append(SLIDE)
        if not opts:  # penetrating (v_n < 0): no mode
            return
        options.append(opts)
        size *= len(opts)
    if size > MAX_MODES_PER_VELOCITY:
        yield None
        return
    for combo in itertools.product(*options):
        yield np.array(combo, dtype=np.int8)


def indeterminate_kinematics(
    system: System,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
) -> list[IndeterminateKinematics]:
    """Candidates with ``2 n_R + n_S > 3 + |tau_I|`` that pass the kinematic tests (unique,
    consistent velocities; eqs. 16, 24-25 in the generalised-inverse sense).  Friction- and
    effort-independent.  Found by :func:`scan_indeterminate` (with no subset budget)."""
    scan = scan_indeterminate(system, tol=tol, singular_tol=singular_tol,
                              max_subsets=row_subset_count(system))
    return list(scan.kinematics)




def indeterminate_modes(
    system: System,
    mu: np.ndarray,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    kinematics: tuple[IndeterminateKinematics, ...] | list[IndeterminateKinematics] | None = None,
) -> list[FeasibleMode]:
    """Feasible modes with ``2 n_R + n_S > 3 + |tau_I|`` (force-indeterminate) at friction
    ``mu (n_c,)``: the force LP on every kinematically admissible one (``kinematics``, default
    :func:`indeterminate_kinematics`)."""
    if kinematics is None:
        kinematics = indeterminate_kinematics(system, tol=tol, singular_tol=singular_tol)
    return feasible_relaxed_modes(system, mu, kinematics, tol=tol, singular_tol=singular_tol)
