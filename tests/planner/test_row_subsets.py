"""The structural pre-filter of the relaxed-utility row-subset scan is exact."""

from __future__ import annotations

import itertools
from math import comb

import numpy as np
import pytest

from planner.predict.indeterminate import scan_indeterminate
from planner.predict.relaxed_modes import indeterminate_kinematics_of
from planner.predict.row_subsets import admissible_subsets, row_classes, unique_rows
from planner.predict.stages import equilibrated_kinematics
from planner.sweeps.random_systems import random_multibody_system


def _labels(kins) -> list[str]:
    return sorted(f"{k.codes.tolist()}{k.xi.tolist()}" for k in kins)


@pytest.mark.parametrize("seed", range(4))
def test_dropped_subsets_are_singular_and_kept_ones_distinct(seed: int) -> None:
    system = random_multibody_system(seed, 2, 5)
    eq = equilibrated_kinematics(system)
    k = system.dof
    classes = row_classes(eq.Kn, system.n_bodies, k)
    kept = {tuple(sorted(s)) for chunk in admissible_subsets(classes, 97) for s in chunk.tolist()}
    assert len(kept) == classes.total  # no subset twice
    dropped = 0
    for S in itertools.combinations(range(2 * system.n_contacts), k):
        if S not in kept:
            dropped += 1
            assert np.linalg.matrix_rank(eq.Kn[list(S)]) < k
    assert dropped + classes.total == comb(2 * system.n_contacts, k)
    assert dropped > 0  # the block structure prunes something here


@pytest.mark.parametrize("seed", range(6))
def test_pruned_scan_equals_brute_force_over_all_modes(seed: int) -> None:
    """Every mode with more than 3 n_b rows, tested exactly (3^n_c modes), against the scan."""
    system = random_multibody_system(seed, 2, 5)
    n_c = system.n_contacts
    codes = np.array(list(itertools.product(range(3), repeat=n_c)), dtype=np.int8)
    brute = indeterminate_kinematics_of(system, codes)
    scan = scan_indeterminate(system, max_subsets=2**63)
    assert scan.limit == ""
    assert _labels(scan.kinematics) == _labels(brute)


def test_unique_rows_matches_numpy() -> None:
    rng = np.random.default_rng(0)
    for width in (5, 48, 70):
        pattern = rng.random((300, width)) < 0.02
        pattern = np.concatenate([pattern, pattern[:50]])
        ours = {r.tobytes() for r in unique_rows(pattern)}
        assert len(ours) == len(unique_rows(pattern))
        assert ours == {r.tobytes() for r in np.unique(pattern, axis=0)}
