"""Exactness of the pruned search (planner.search) against exhaustive enumeration (eq. 49)."""

from __future__ import annotations

import numpy as np
import pytest
from randsys import random_system as random_system_mixed

from planner.errors import InputError
from planner.feasibility import feasible_modes
from planner.modes import enumerate_modes
from planner.random_systems import random_system
from planner.search import _canonical_order, candidates_from_codes, search_modes


def assert_same(pred_a, pred_b):
    """Same feasible modes, same order, same certificates (to rounding: batched matrix
    products may take different BLAS paths for different batch sizes)."""
    assert pred_a.status == pred_b.status
    assert pred_a.labels == pred_b.labels
    for a, b in zip(pred_a.all_modes, pred_b.all_modes):
        for name in ("qdot", "joint_velocities", "contact_forces", "joint_efforts"):
            np.testing.assert_allclose(
                getattr(a, name), getattr(b, name), rtol=1e-12, atol=1e-12, err_msg=name
            )
        assert a.margin == pytest.approx(b.margin, rel=1e-9, abs=1e-12)
    assert set(m.label for m in pred_a.boundary_modes) <= set(
        m.label for m in pred_b.boundary_modes
    )


@pytest.mark.parametrize("n_c", [4, 6, 8, 10])
@pytest.mark.parametrize("seed", range(6))
def test_search_equals_exhaustive_planted(seed, n_c):
    system = random_system(seed, n_c)
    res = search_modes(system, indeterminate=False, batch_size=64)
    assert_same(res.prediction, feasible_modes(system, indeterminate=False))
    assert res.stats.candidates == res.prediction.candidates


@pytest.mark.parametrize("seed", range(40))
def test_search_equals_exhaustive_mixed_systems(seed):
    """Virtual-joint and few-effort-joint systems (dof != n_c), small batches to force LPs."""
    rng = np.random.default_rng(1000 + seed)
    n_c = int(rng.integers(3, 7))
    system = random_system_mixed(rng, n_c, n_effort=int(rng.integers(0, 3)))
    res = search_modes(system, batch_size=1, lp_min_size=0)
    assert_same(res.prediction, feasible_modes(system))


def test_search_reports_fewer_tests_than_candidates_when_jammed_at_root():
    system = random_system(0, 12, loads="random")
    res = search_modes(system, indeterminate=False)
    assert res.prediction.labels == feasible_modes(system, indeterminate=False).labels
    assert res.stats.tested < res.stats.candidates


def test_paper_examples(example_41, example_43):
    for system, mu in ((example_41, [0.2, 0.2, 0.2]), (example_43, [0.5, 0.5, 0.5])):
        res = search_modes(system, mu, batch_size=1, lp_min_size=0)
        assert_same(res.prediction, feasible_modes(system, mu))


def test_candidates_from_codes_matches_enumeration():
    cand = enumerate_modes(6, 6)
    perm = np.random.default_rng(0).permutation(len(cand))
    codes = _canonical_order(cand.codes[perm])
    rebuilt = candidates_from_codes(codes, 6)
    np.testing.assert_array_equal(rebuilt.codes, cand.codes)
    np.testing.assert_array_equal(rebuilt.rows, cand.rows)
    np.testing.assert_array_equal(rebuilt.sliding, cand.sliding)


def test_bad_inputs():
    system = random_system(0, 4)
    with pytest.raises(InputError, match="expected a planner System"):
        search_modes("nope")
    with pytest.raises(InputError, match="batch_size: expected an integer >= 1, got 0"):
        search_modes(system, batch_size=0)
    with pytest.raises(InputError, match="prune_eps: expected a finite number > tol"):
        search_modes(system, prune_eps=0.0)
    with pytest.raises(InputError, match="expected every mode to have 4 constraint rows"):
        candidates_from_codes(np.zeros((1, 4), dtype=np.int8), 4)


@pytest.mark.slow
@pytest.mark.parametrize("n_c", [12, 13, 14])
def test_search_equals_exhaustive_large(n_c):
    for seed in range(2):
        system = random_system(seed, n_c)
        res = search_modes(system, indeterminate=False)
        assert_same(res.prediction, feasible_modes(system, indeterminate=False))


def test_linprog_fallback_gives_the_same_modes(monkeypatch):
    import planner.search as search

    monkeypatch.setattr(search, "_make_lp", search._LinprogLp)
    for seed in range(3):
        system = random_system(seed, 7)
        res = search_modes(system, indeterminate=False, batch_size=8, lp_min_size=0)
        assert res.stats.lp_solves > 1
        assert_same(res.prediction, feasible_modes(system, indeterminate=False))
