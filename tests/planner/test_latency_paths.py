"""The short cuts of the single-call hot path (latency) against direct computations:
the structural test certified by the kinematic stage's determinants, the Gram matrices read
off ``K K^T``, LAPACK's gufuncs against ``numpy.linalg`` and the LU fallback, and the
kinematic stage's one-product contact velocities."""

from __future__ import annotations

import copy
import itertools

import numpy as np
import pytest

from planner import System
from planner.model.modes import enumerate_modes
from planner.predict.indeterminate import (
    SPAN_TOL,
    certified_by_determinants,
    closed_bases_stacked,
    closed_bases_suffice,
)
from planner.predict.linalg import LU_CHUNK, det_solve, lu_det_solve, transposed_det_solve
from planner.predict.stages import equilibrated_kinematics, kinematic_stage
from planner.sweeps.random_systems import random_system


def gram_test_by_svd(Kn: np.ndarray, k: int) -> bool:
    """Independent structural test: no normal row in the span of p <= (k - 1) / 2 rolling
    pairs of other contacts, by the singular values of the stacked rows (no planner code)."""
    n_c = Kn.shape[0] // 2
    for p in range(1, min((k - 1) // 2, n_c - 1) + 1):
        for j in range(n_c):
            for pairs in itertools.combinations([a for a in range(n_c) if a != j], p):
                rows = [2 * j] + [2 * a for a in pairs] + [2 * a + 1 for a in pairs]
                sv = np.linalg.svd(Kn[rows], compute_uv=False)
                if np.prod(sv ** 2) <= SPAN_TOL ** 2:
                    return False
    return True


def pinched_box(n_supports: int) -> System:
    """A box on supports pinched by two fingers on one horizontal line (opposite normals:
    a normal lies in the span of the other finger's pair; the structural test fails)."""
    xs = np.linspace(-1.0, 1.0, n_supports)
    points = [[x, 0.0] for x in xs] + [[-1.0, 0.5], [1.0, 0.5]]
    normals = [[0.0, 1.0]] * n_supports + [[1.0, 0.0], [-1.0, 0.0]]
    vel = [[0.0, 0.0]] * n_supports + [[0.0, 0.01], [0.0, -0.01]]
    return System.from_contacts(points=points, normals=normals, mu=0.6,
                                external_wrench=[0.0, -1.0, 0.0], contact_velocities=vel)


SYSTEMS = [random_system(seed, n_c) for n_c in (3, 4, 5, 6) for seed in range(12)] + [
    pinched_box(3), pinched_box(4)]


@pytest.mark.parametrize("system", SYSTEMS)
def test_structural_test_routes_agree_with_svd(system):
    n_c, k = system.n_contacts, system.dof
    Kn = equilibrated_kinematics(system).Kn
    want = gram_test_by_svd(Kn, k)
    assert bool(closed_bases_stacked(Kn[None])[0]) == want
    kin = kinematic_stage(system, enumerate_modes(n_c, k))
    certified = bool(certified_by_determinants(kin.det[None], n_c, k)[0])
    assert not certified or want  # a certificate is a proof
    # With and without the determinants (fresh objects: the answer is cached per system).
    assert closed_bases_suffice(copy.copy(system), kin) == want
    assert closed_bases_suffice(copy.copy(system)) == want


def test_certificates_settle_random_systems_and_never_a_pinch():
    certified = []
    for system in SYSTEMS:
        kin = kinematic_stage(system, enumerate_modes(system.n_contacts, system.dof))
        certified.append(bool(certified_by_determinants(
            kin.det[None], system.n_contacts, system.dof)[0]))
    assert sum(certified[:-2]) >= 0.9 * (len(SYSTEMS) - 2)  # the short cut usually applies
    assert certified[-2:] == [False, False]


def test_small_batches_are_numpy_linalg_bit_for_bit():
    rng = np.random.default_rng(5)
    A, b = rng.normal(size=(12, 4)), rng.normal(size=12)
    rows = np.array(list(itertools.combinations(range(12), 4))[:100])
    det, z = det_solve(A, b, rows)
    assert np.array_equal(det, np.linalg.det(A[rows]))
    assert np.array_equal(z, np.linalg.solve(A[rows], b[rows][..., None])[..., 0])
    QT = rng.normal(size=(30, 4, 4))
    det, y = transposed_det_solve(QT, b[:4])
    Q = np.ascontiguousarray(QT.transpose(0, 2, 1))
    assert np.array_equal(det, np.linalg.det(Q))
    assert np.array_equal(y, np.linalg.solve(Q, np.broadcast_to(b[:4], (30, 4))[..., None])[..., 0])


def test_an_exactly_singular_matrix_sends_the_batch_to_the_lu_path():
    rng = np.random.default_rng(6)
    A, b = rng.normal(size=(8, 4)), rng.normal(size=8)
    A[5] = 2.0 * A[1]  # rows 1 and 5 dependent: every system holding both is singular
    rows = np.array(list(itertools.combinations(range(8), 4)))
    assert len(rows) <= LU_CHUNK
    det, z = det_solve(A, b, rows)
    aug = np.ascontiguousarray(np.concatenate([A, b[:, None]], axis=1).T)
    d_lu, z_lu = lu_det_solve(np.take(aug, rows.T, axis=1))
    assert np.array_equal(det, d_lu)
    assert np.array_equal(z, z_lu.T)
    singular = np.array([1 in r and 5 in r for r in rows.tolist()])
    assert np.all(np.abs(det[singular]) < 1e-12) and np.all(np.abs(det[~singular]) > 0)


@pytest.mark.parametrize("seed", range(6))
def test_kinematic_stage_velocities_are_eq_5(seed):
    system = random_system(seed, 5)
    kin = kinematic_stage(system, enumerate_modes(5, system.dof))
    E, V = system.effort_joints, system.velocity_joints
    ok = kin.nonsingular
    thetadot = kin.joint_velocities
    assert np.array_equal(thetadot[:, V], np.broadcast_to(system.joint_inputs[V], (len(ok), len(V))))
    assert np.array_equal(thetadot[:, E], kin.effort_velocities)
    for i in np.flatnonzero(ok)[:10]:
        assert np.array_equal(kin.joint_velocities_of(int(i)), thetadot[i])
    # eq. (5): v = W^T qdot - J thetadot, to rounding.
    v = kin.qdot[ok] @ system.W - thetadot[ok] @ system.J.T
    scale = np.abs(v).max(axis=1, keepdims=True)
    assert np.all(np.abs(kin.v[ok] - v) <= 1e-12 * scale)
    assert np.all(np.isnan(kin.v[~ok]))


def _structured_systems():
    """Random systems plus boxes (exact zeros, singular candidates), pinches and multi-body."""
    from planner.sweeps.random_systems import random_multibody_system

    boxes = []
    for n_s in (2, 3, 4):
        xs = np.linspace(-1.0, 1.0, n_s)
        for push in ((0.01, 0.0), (0.0, 0.0), (-0.01, 0.0)):
            boxes.append(System.from_contacts(
                points=[[x, 0.0] for x in xs] + [[-1.0, 0.1]],
                normals=[[0.0, 1.0]] * n_s + [[1.0, 0.0]], mu=0.5,
                external_wrench=[0.0, -1.0, 0.0],
                contact_velocities=[[0.0, 0.0]] * n_s + [list(push)]))
    return (SYSTEMS + boxes + [random_system(s, n_c, n_effort=0) for s in range(3)
                               for n_c in (4, 6)]
            + [random_multibody_system(s, 2, 5) for s in range(4)])


STRUCTURED = _structured_systems()


@pytest.mark.parametrize("system", STRUCTURED)
def test_setup_is_the_direct_formula_bit_for_bit(system):
    """K, its equilibration, G's rows and eq. (26)'s right side as first written (with
    J[:, E] indexing and one concatenation per matrix)."""
    from planner.predict.setup import system_setup

    eq, fs = system_setup(copy.copy(system))
    E, V = system.effort_joints, system.velocity_joints
    K = np.concatenate([system.W.T, -system.J[:, E]], axis=1)
    rhs = system.J[:, V] @ system.joint_inputs[V]
    col = np.abs(K).max(axis=0)
    col[col == 0] = 1.0
    Kc = K / col
    row = np.linalg.norm(Kc, axis=1)
    row[row == 0] = 1.0
    G = np.concatenate([system.W.T, system.J[:, E]], axis=1)
    f_rhs = np.concatenate([-system.g_obj, system.joint_inputs[E] - system.g_man[E]])
    for got, want in ((eq.Kn, Kc / row[:, None]), (eq.bn, rhs / row), (eq.col, col),
                      (eq.row, row), (eq.rhs, rhs), (eq.KT, K.T), (fs.G, G), (fs.rs, col),
                      (fs.normal_rows, G[0::2]), (fs.tangent_rows, G[1::2]), (fs.rhs, f_rhs),
                      (fs.rhs_scaled, f_rhs / col)):
        assert got.tobytes() == np.ascontiguousarray(want).tobytes()
    assert eq.velocity_scale == np.abs(rhs).max() and eq.b_scale == np.abs(rhs / row).max()


@pytest.mark.parametrize("system", STRUCTURED)
def test_kinematic_slacks_and_xi_are_the_direct_formula_bit_for_bit(system):
    """The masked reduction over CandidateSet.strict_rows and the xi of compared signs against
    the nested where's: v_n of breaking, |v_t| of sliding contacts, inf elsewhere."""
    cand = enumerate_modes(system.n_contacts, system.dof)
    kin = kinematic_stage(copy.copy(system), cand)
    breaking, sliding, _ = cand.masks
    v_n, v_t = kin.v[:, 0::2], kin.v[:, 1::2]
    strict = np.where(breaking, v_n, np.where(sliding, np.abs(v_t), np.inf))
    margin = strict.min(axis=1, initial=np.inf)
    if kin.velocity_scale > 0:
        margin = margin / kin.velocity_scale
    margin[~kin.nonsingular] = -np.inf
    assert np.array_equal(kin.margin, margin)
    xi = ((v_t > 0).astype(np.int8) - (v_t < 0).astype(np.int8)) * (sliding & kin.nonsingular[:, None])
    assert kin.xi.tobytes() == xi.astype(np.int8).tobytes()


@pytest.mark.parametrize("scale", [1e300, 1e307, 1.7e308])
@pytest.mark.parametrize("seed", range(4))
def test_overflow_check_from_margins_matches_the_finite_test(seed, scale):
    """DegenerateError exactly when an admissible, force-nonsingular candidate has a non-finite
    qdot or c_A (the check reads the kinematic margins and the force scales instead)."""
    import dataclasses

    from planner.errors import DegenerateError
    from planner.predict.feasibility import feasible_modes
    from planner.predict.stages import force_stage

    base = random_system(seed, 4)
    with np.errstate(all="ignore"):
        variants = [dataclasses.replace(base, joint_inputs=np.clip(
                        base.joint_inputs * scale, -1.7e308, 1.7e308)),
                    dataclasses.replace(base, g_obj=np.clip(base.g_obj * scale, -1.7e308, 1.7e308),
                                        g_man=np.clip(base.g_man * scale, -1.7e308, 1.7e308))]
    for system in variants:
        cand = enumerate_modes(4, system.dof)
        with np.errstate(all="ignore"):
            kin = kinematic_stage(system, cand)
            idx = np.flatnonzero(kin.ok)
            fs = force_stage(system, cand, idx, kin.xi[idx], system.mu)
        finite = np.isfinite(kin.qdot[idx]).all(axis=1) & np.isfinite(fs.c_A[0]).all(axis=1)
        expect = bool(np.any(fs.nonsingular[0] & ~finite))
        with np.errstate(all="ignore"):
            try:
                feasible_modes(copy.copy(system))
                raised = False
            except DegenerateError:
                raised = True
        assert raised == expect
