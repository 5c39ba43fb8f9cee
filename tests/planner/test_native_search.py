"""The native core of the exact search (planner.predict.native_search, native/search_core.c):
that it builds where a C compiler exists, that its LP verdicts are sound (an infeasible node
holds no feasible mode, and HiGHS agrees), that its feasible points meet the bounds, and that
the search falls back to Python, saying so, when the core is unavailable.  The search's modes
against exhaustive enumeration, with both engines: tests/planner/test_search.py."""

from __future__ import annotations

import numpy as np
import pytest
from search_nodes import mode_in_subtree

from planner.errors import InputError
from planner.model.modes import BREAK, ROLL, SLIDE
from planner.predict import native_search
from planner.predict.feasibility import feasible_modes
from planner.predict.search import CONTACT, FREE, Pruner, search_modes
from planner.sweeps.random_systems import random_system


def test_the_native_core_builds_where_a_compiler_exists():
    """CI has a C compiler: the native core must be what the search uses there."""
    if not native_search._compilers():
        pytest.skip("no C compiler on this machine")
    status = native_search.native_status()
    assert status.available, status.reason
    assert search_modes(random_system(0, 6)).stats.engine == "native"


@pytest.mark.parametrize("coupled", [False, True])
@pytest.mark.parametrize("n_c", [5, 8])
def test_native_lp_verdicts_are_sound_and_match_highs(n_c, coupled):
    """On random partial assignments the native dual simplex proves a node infeasible only
    when it holds no feasible mode (what exactness needs) and HiGHS finds it infeasible too;
    its feasible points meet every row and column bound; and it is not vacuous: it proves
    (nearly) every node infeasible that HiGHS does (an LP without a verdict keeps the node)."""
    if not native_search.native_status().available:
        pytest.skip("native core unavailable")
    rng = np.random.default_rng(11)
    native_inf = highs_inf = unknown = 0
    for seed in range(8):
        system = random_system(seed, n_c)
        modes = [m.mode for m in feasible_modes(system, indeterminate=False).modes]
        pruner = Pruner(system, 1e-7, system.mu, coupled=coupled)
        tree = native_search.NativeTree(pruner, system.dof, 8, 4)
        for _ in range(50):
            states = rng.choice([FREE, CONTACT, BREAK, ROLL, SLIDE], n_c).astype(np.int8)
            xi = np.where(states == SLIDE, rng.choice([-1, 1], n_c), 0).astype(np.int8)
            verdict, x = tree.solve_node(states, xi)
            h_inf = pruner.solve(states, xi) is None
            if verdict == "infeasible":
                assert not any(mode_in_subtree(states, xi, m) for m in modes)
                if pruner.lp.verdict:
                    assert h_inf
                native_inf += 1
            elif verdict == "feasible":
                lo, hi = _bounds(pruner, states, xi)
                act = pruner.A @ x
                scale = 1.0 + np.abs(x).max()
                assert np.all(act >= lo - 1e-8 * scale) and np.all(act <= hi + 1e-8 * scale)
                broken = states == BREAK
                assert np.all(np.abs(x[pruner.cn[broken]]) <= 1e-8 * scale)
                assert np.all(np.abs(x[pruner.ct[broken]]) <= 1e-8 * scale)
            else:
                unknown += 1
            highs_inf += h_inf
        tree.close()
    assert highs_inf > 20
    assert native_inf >= 0.95 * highs_inf
    assert unknown <= 0.02 * 400


def _bounds(pruner, states, xi):
    lo, hi = pruner.row_lower.copy(), pruner.row_upper.copy()
    for i, (st, x) in enumerate(zip(states, xi)):
        rows, _ = pruner.contact_bounds(i, int(st), int(x))
        for r, a, b in rows:
            lo[r], hi[r] = a, b
    return lo, hi


def test_without_the_native_core_the_search_runs_in_python_and_says_so(monkeypatch):
    unavailable = native_search.NativeStatus(False, "no C compiler found ($CC, cc, gcc, clang)")
    monkeypatch.setattr(native_search, "native_status", lambda: unavailable)
    system = random_system(2, 8)
    res = search_modes(system, indeterminate=False)
    assert res.stats.engine == "python"
    assert res.prediction.labels == feasible_modes(system, indeterminate=False).labels
    with pytest.raises(InputError, match=r"engine: 'native' needs the compiled search core, "
                       r"which is not available here \(no C compiler found"):
        search_modes(system, engine="native")


def test_build_says_why_it_cannot_build(monkeypatch, tmp_path):
    monkeypatch.setenv("QSPLAN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(native_search, "_compilers", lambda: [])
    status = native_search._build()
    assert not status.available and status.reason == "no C compiler found ($CC, cc, gcc, clang)"
    monkeypatch.setattr(native_search, "_compilers", lambda: ["/bin/false"])
    status = native_search._build()
    assert not status.available and status.reason.startswith("compile failed: false")
    assert not list(tmp_path.glob("*.so"))  # nothing half-written is left behind


def test_engine_and_batch_limits_are_checked():
    system = random_system(0, 5)
    with pytest.raises(InputError, match="engine: expected 'auto', 'native' or 'python', "
                       "got 'gpu'"):
        search_modes(system, engine="gpu")
    if native_search.native_status().available:
        big = native_search.MAX_BATCH + 1
        with pytest.raises(InputError, match=f"batch_size: expected <= "
                           f"{native_search.MAX_BATCH} with engine='native', got {big}"):
            search_modes(system, batch_size=big, engine="native")
        assert search_modes(system, batch_size=big).stats.engine == "python"


def test_native_search_reports_its_work():
    if not native_search.native_status().available:
        pytest.skip("native core unavailable")
    system = random_system(4, 12)
    res = search_modes(system, indeterminate=False, engine="native")
    assert res.stats.engine == "native" and res.stats.lp_solves > 0
    assert 0 < res.stats.tested < res.stats.candidates
    assert res.stats.to_dict()["engine"] == "native"


@pytest.mark.parametrize(("n_c", "batch"), [(9, 1), (12, 8), (14, 40)])
def test_native_leaves_hand_back_exactly_their_candidates(n_c, batch):
    """The C completion generator gives every leaf exactly its eq. (49) candidates: what Python
    tests equals the leaves' sizes summed, and no candidate comes twice from leaves with the
    same sliding directions (the S+ and S- children of a contact share their codes -- a
    candidate's xi is computed, eq. 16 -- and each keeps the candidates whose xi is its own)."""
    from planner.predict.search_tree import LeafBatches

    if not native_search.native_status().available:
        pytest.skip("native core unavailable")
    system = random_system(n_c, n_c)
    pruner = Pruner(system, 1e-7, system.mu, coupled=n_c >= 12)
    tree = native_search.NativeTree(pruner, system.dof, batch, batch // 2)
    seen = []

    class Recorder(LeafBatches):
        def add(self, block, states, xi):
            signs = np.where(states == SLIDE, xi, 0)
            seen.append(np.concatenate([block, signs], axis=1))
            super().add(block, states, xi)

    leaves = Recorder(system, system.dof, tol=1e-9, singular_tol=1e-10)
    root = np.full(n_c, FREE, dtype=np.int8)
    stats = tree.search(root, np.zeros(n_c, dtype=np.int8), leaves)
    leaves.kept_codes()
    tagged = np.concatenate(seen)
    assert leaves.tested == stats.leaf_candidates == len(tagged) > 0
    assert len(np.unique(tagged, axis=0)) == len(tagged)
    codes = tagged[:, :n_c]
    rows = 2 * (codes == ROLL).sum(axis=1) + (codes == SLIDE).sum(axis=1)
    assert np.all(rows == system.dof)
