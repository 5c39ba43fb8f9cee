"""Exactness of the pruned search (planner.predict.search) against exhaustive enumeration (eq. 49)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from randsys import random_system as random_system_mixed
from search_nodes import mode_in_subtree

from planner.errors import InputError
from planner.model.modes import SLIDE, enumerate_modes
from planner.model.system import System
from planner.predict.feasibility import feasible_modes
from planner.predict.search import candidates_from_codes, canonical_order, search_modes
from planner.sweeps.random_systems import random_system


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
    assert sorted(m.label for m in pred_a.boundary_modes) == sorted(
        m.label for m in pred_b.boundary_modes
    )


RELAXATIONS = ["forces", "coupled"]
#: Both engines of the search (planner.predict.native_search: the compiled core; HiGHS).
ENGINES = ["native", "python"]


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("relaxation", RELAXATIONS)
@pytest.mark.parametrize("n_c", [4, 6, 8, 10])
@pytest.mark.parametrize("seed", range(6))
def test_search_equals_exhaustive_planted(seed, n_c, relaxation, engine):
    system = random_system(seed, n_c)
    res = search_modes(system, indeterminate=False, batch_size=64, relaxation=relaxation,
                       engine=engine)
    assert_same(res.prediction, feasible_modes(system, indeterminate=False))
    assert res.stats.candidates == res.prediction.candidates
    assert res.stats.engine == engine


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("relaxation", RELAXATIONS)
@pytest.mark.parametrize("seed", range(40))
def test_search_equals_exhaustive_mixed_systems(seed, relaxation, engine):
    """Virtual-joint and few-effort-joint systems (dof != n_c), small batches to force LPs."""
    rng = np.random.default_rng(1000 + seed)
    n_c = int(rng.integers(3, 7))
    system = random_system_mixed(rng, n_c, n_effort=int(rng.integers(0, 3)))
    res = search_modes(system, batch_size=1, lp_min_size=0, relaxation=relaxation,
                       engine=engine)
    assert_same(res.prediction, feasible_modes(system))


def test_search_reports_fewer_tests_than_candidates_when_jammed_at_root():
    system = random_system(0, 12, loads="random")
    res = search_modes(system, indeterminate=False)
    assert res.prediction.labels == feasible_modes(system, indeterminate=False).labels
    assert res.stats.tested < res.stats.candidates


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("relaxation", RELAXATIONS)
def test_paper_examples(example_41, example_43, relaxation, engine):
    for system, mu in ((example_41, [0.2, 0.2, 0.2]), (example_43, [0.5, 0.5, 0.5])):
        res = search_modes(system, mu, batch_size=1, lp_min_size=0, relaxation=relaxation,
                           engine=engine)
        assert_same(res.prediction, feasible_modes(system, mu))


def test_candidates_from_codes_matches_enumeration():
    cand = enumerate_modes(6, 6)
    perm = np.random.default_rng(0).permutation(len(cand))
    codes = canonical_order(cand.codes[perm])
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
    with pytest.raises(InputError, match="relaxation: expected 'auto', 'coupled' or 'forces'"):
        search_modes(system, relaxation="velocity")
    with pytest.raises(InputError, match="expected every mode to have 4 constraint rows"):
        candidates_from_codes(np.zeros((1, 4), dtype=np.int8), 4)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("relaxation", RELAXATIONS)
@pytest.mark.parametrize("n_c", [12, 13, 14])
def test_search_equals_exhaustive_large(n_c, relaxation, engine):
    for seed in range(2):
        system = random_system(seed, n_c)
        res = search_modes(system, indeterminate=False, relaxation=relaxation, engine=engine)
        assert_same(res.prediction, feasible_modes(system, indeterminate=False))


def test_linprog_fallback_gives_the_same_modes(monkeypatch):
    import planner.predict.prune_lp as prune_lp

    monkeypatch.setattr(prune_lp, "make_lp", prune_lp.LinprogLp)
    for seed, relaxation in zip(range(4), RELAXATIONS * 2):
        system = random_system(seed, 7)
        res = search_modes(
            system, indeterminate=False, batch_size=8, lp_min_size=0, relaxation=relaxation,
            engine="python",
        )
        assert res.stats.lp_solves > 1
        assert_same(res.prediction, feasible_modes(system, indeterminate=False))


@pytest.mark.parametrize("k", [3, 7, 12])
def test_one_lu_gives_numpy_det_and_solve(k):
    """The batched LU shared by the rank test (30)-(32) and the solves (24), (26) agrees with
    numpy.linalg.det / solve, including matrices that need row exchanges and singular ones."""
    from planner.predict.linalg import lu_det_solve

    rng = np.random.default_rng(k)
    A = rng.normal(size=(500, k, k))
    A[::5, 0, 0] = 0.0  # first pivot must come from another row
    A[1::5, :, 0] = 0.0  # exactly singular: a zero column
    A[2::5, -1] = A[2::5, 0]  # exactly singular: repeated row
    A[3::5] *= 0.1  # smaller but regular
    b = rng.normal(size=(500, k))
    X = np.empty((k + 1, k, 500))
    X[:k] = A.transpose(2, 1, 0)  # X[c, a, m] = A[m, a, c]
    X[k] = b.T
    det, z = lu_det_solve(X)
    ref = np.linalg.det(A)
    np.testing.assert_allclose(det, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    singular = (np.arange(500) % 5 == 1) | (np.arange(500) % 5 == 2)
    assert np.all(np.abs(det[singular]) <= 1e-12 * np.abs(ref).max())
    np.testing.assert_allclose(
        z.T[~singular], np.linalg.solve(A[~singular], b[~singular][..., None])[..., 0],
        rtol=1e-7, atol=1e-9,
    )


def test_kinematic_decision_does_not_depend_on_the_batch():
    """Leaves are queued and tested together: a candidate's kinematic decision, xi and
    velocities must not depend on which other candidates share its batch."""
    from planner.predict.stages import kinematic_stage

    system = random_system(3, 9)
    cand = enumerate_modes(9, 9)
    full = kinematic_stage(system, cand)
    pick = np.random.default_rng(0).permutation(len(cand))[:333]
    part = kinematic_stage(system, candidates_from_codes(cand.codes[pick], 9))
    np.testing.assert_array_equal(part.ok, full.ok[pick])
    np.testing.assert_array_equal(part.boundary, full.boundary[pick])
    np.testing.assert_array_equal(part.xi, full.xi[pick])
    np.testing.assert_allclose(part.qdot, full.qdot[pick], rtol=1e-12, atol=1e-12)


def test_search_without_candidates_reports_no_candidates():
    """n_c = 2 contacts cannot supply 3 + |tau_I| = 5 rows (eq. 49 count 0)."""
    from planner.model.system import System
    from planner.predict.feasibility import Status

    s = System.from_contacts(
        points=[[-1, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.3, external_wrench=[0, -1, 0],
        jacobian=[[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 0, 0]]],
        joints=[{"velocity": 1.0}, {"effort": 1.0}, {"effort": 2.0}])
    res = search_modes(s)
    assert res.prediction.status is Status.NO_CANDIDATES
    assert res.prediction.status is feasible_modes(s).status
    assert res.stats.tested == res.stats.candidates == 0
    with pytest.raises(InputError, match="n_rows: expected at most 2 n_c = 4 constraint rows"):
        candidates_from_codes(np.zeros((1, 2), dtype=np.int8), 5)


def test_power_of_contact_forces_is_a_linear_function_and_never_positive():
    """The coupling row of the pruning LP: in every feasible mode ``c^T v = [-g_obj; -(tau_E -
    g_man_E)] . [qdot; thetadot_E] - (J_V thetadot_V) . c`` (eqs. 5, 26) and ``c^T v = -sum_S
    mu_i c_in |v_it| <= 0`` (eqs. 16-17), checked on the modes exhaustive enumeration finds."""
    seen_sliding = 0
    for seed in range(12):
        system = random_system(seed, 7)
        E, V = system.effort_joints, system.velocity_joints
        for m in feasible_modes(system, indeterminate=False).modes:
            c = np.asarray(m.contact_forces, dtype=float).reshape(-1)
            v = np.asarray(m.contact_velocities, dtype=float).reshape(-1)
            th = np.asarray(m.joint_velocities, dtype=float)
            linear = (-system.g_obj @ m.qdot
                      - (system.joint_inputs[E] - system.g_man[E]) @ th[E]
                      - (system.J[:, V] @ system.joint_inputs[V]) @ c)
            scale = np.abs(c).max() * np.abs(v).max() + 1e-300
            assert c @ v == pytest.approx(linear, abs=1e-9 * scale)
            assert c @ v <= 1e-9 * scale
            seen_sliding += any(t.startswith("S") for t in m.mode.tokens)
    assert seen_sliding > 0  # the inequality is strict somewhere, not only 0 = 0


@pytest.mark.parametrize("n_c", [5, 7])
def test_coupled_relaxation_is_a_relaxation_and_prunes_more(n_c):
    """On random partial assignments: a node whose coupled LP is infeasible contains no
    feasible mode (what exactness needs); the coupled LP is infeasible wherever the
    forces-only one is (it has all its rows; unless HiGHS ends without a verdict, which keeps
    the node); and it proves some nodes infeasible that the
    forces-only LP cannot (the power row couples velocities and forces)."""
    from planner.model.modes import BREAK, ROLL, SLIDE
    from planner.predict.search import CONTACT, FREE, Pruner

    rng = np.random.default_rng(7)
    only_coupled = both = 0
    for seed in range(8):
        system = random_system(seed, n_c)
        modes = [m.mode for m in feasible_modes(system, indeterminate=False).modes]
        coupled = Pruner(system, 1e-7, system.mu, coupled=True)
        forces = Pruner(system, 1e-7, system.mu, coupled=False)
        for _ in range(60):
            states = rng.choice([FREE, CONTACT, BREAK, ROLL, SLIDE], n_c).astype(np.int8)
            xi = np.where(states == SLIDE, rng.choice([-1, 1], n_c), 0).astype(np.int8)
            c_inf = coupled.solve(states, xi) is None
            f_inf = forces.solve(states, xi) is None
            if c_inf:
                assert not any(mode_in_subtree(states, xi, m) for m in modes)
            if f_inf and coupled.lp.verdict:  # HiGHS may end without a verdict (kept)
                assert c_inf
            both += f_inf
            only_coupled += c_inf and not f_inf
    assert both > 0 and only_coupled > 0


def box_on_supports(n: int, mu: float = 0.5):
    """A box 0.2 m x 0.1 m, 0.1 kg, on ``n`` evenly spaced table contacts (friction group
    ``table``), pushed at height 0.03 m on its left face by a frictionless finger moving right:
    force-indeterminate sliding (every support slides, S-), written by its geometry."""
    from planner import FeatureContact, WorkpieceGeometry, finger, surface

    w = 0.2
    contacts = [FeatureContact("table", point=[w * i / (n - 1), 0.0], surface="table")
                for i in range(n)]
    contacts.append(FeatureContact(0.0, point=[0.0, 0.03], finger="pusher"))
    return System.from_geometry(
        WorkpieceGeometry([[0, 0], [w, 0], [w, 0.1], [0, 0.1]], mass=0.1), contacts,
        surfaces=[surface("table", [[-1, 0], [1, 0]]), finger("pusher", velocity=(0.001, 0))],
        gravity=(0, -9.81), friction={"table": mu})


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n", [6, 12, 20])
def test_boundary_modes_same_from_search_and_enumeration(n, engine):
    """The boundary-tolerance modes (a strict kinematic row missed by at most tol, forces within
    Coulomb) are one list whichever way the candidates are visited.  On the box on n supports
    they are the determinate two-support subsets of the sliding mode: two supports, one on each
    side of where the normal load must pass, sliding (S-), the others breaking at v_n = 0."""
    system = box_on_supports(n)
    exhaustive = feasible_modes(system)
    searched = search_modes(system, engine=engine).prediction
    assert exhaustive.labels == searched.labels == [
        " ".join([f"S-{i + 1}" for i in range(n)] + [f"R{n + 1}"])]
    labels = sorted(m.label for m in exhaustive.boundary_modes)
    assert labels and labels == sorted(m.label for m in searched.boundary_modes)
    for m in exhaustive.boundary_modes:  # each: two sliding supports, the finger S at 0 speed
        assert m.codes.count(SLIDE) == 3 and m.codes[-1] == SLIDE


@pytest.mark.parametrize("name", ["example_4_1.json", "example_4_3.json", "part_tool_wall.json",
                                  "ruler_block.json", "geometry_ladder.json"])
def test_boundary_modes_same_on_the_shipped_examples(name):
    from planner.files.system_file import load_system

    system = load_system(Path(__file__).resolve().parents[2] / "scenarios" / "data" / name)
    a = feasible_modes(system)
    b = search_modes(system).prediction
    assert a.labels == b.labels
    assert [m.label for m in a.boundary_modes] == [m.label for m in b.boundary_modes]
