"""Several workpieces: a brute-force LP per candidate mode against feasible_modes,
independent certificate checks, and property tests (rigid motion, relabelling of bodies and
contacts, load scaling) on seeded random multi-body systems with n_c <= 6."""

from __future__ import annotations

import itertools
from functools import cache

import numpy as np
import pytest
from scipy.optimize import linprog

from planner.model.modes import BREAK, ROLL, SLIDE, Mode
from planner.model.system import System
from planner.predict.feasibility import feasible_modes
from planner.sweeps.random_systems import random_multibody_system

CASES = [(seed, n_b, n_c, n_e) for seed in range(6) for (n_b, n_c, n_e) in
         [(2, 4, 0), (2, 5, 0), (2, 6, 1), (3, 6, 0)]]
MARGIN = 1e-6  # LP optima closer than this to a strict/closed boundary are not compared


def brute_force_mode(system: System, codes: tuple[int, ...], xi: tuple[int, ...]
                     ) -> bool | None:
    """Is the mode (codes, xi) feasible? Two LPs written from the model, not from the stages.

    Kinematics (eq. 5, 9-11, 16): unknowns z = (qdot (3 n_b), thetadot_E) and s;
    v = W^T qdot - J_E thetadot_E - J_V thetadot_V; R: v = 0; S: v_n = 0, xi v_t >= s;
    B: v_n >= s; maximise s <= 1 (s scaled by the commanded speed). The equality rows must
    fix z (rank = len(z), conditions 30-32), else None (degenerate). Forces (eqs. 2-3, 17,
    21-22, 26-28): unknowns c (2 n_c) and s; W c = -g_obj, J_E^T c = tau_E - g_man_E;
    B: c = 0; S: c_t = -mu xi c_n, c_n >= s; R: mu c_n -+ c_t >= s, c_n >= s; maximise s <= 1.
    Returns True / False, or None when an optimum is within MARGIN of zero."""
    W, J, mu = system.W, system.J, system.mu
    E, V = system.effort_joints, system.velocity_joints
    n_c, n_q = system.n_contacts, system.n_q
    nz = n_q + len(E)
    K = np.concatenate([W.T, -J[:, E]], axis=1)  # v = K z - b
    b = J[:, V] @ system.joint_inputs[V]
    scale = float(np.abs(b).max()) or 1.0
    eq_rows = [2 * i for i in range(n_c) if codes[i] != BREAK] + \
              [2 * i + 1 for i in range(n_c) if codes[i] == ROLL]
    if np.linalg.matrix_rank(K[eq_rows], tol=1e-9) < nz:
        return None
    A_ub, b_ub = [], []
    for i in range(n_c):  # -(strict quantity) + s <= 0
        if codes[i] == BREAK:
            A_ub.append(np.r_[-K[2 * i], scale])
            b_ub.append(-b[2 * i])
        elif codes[i] == SLIDE:
            A_ub.append(np.r_[-xi[i] * K[2 * i + 1], scale])
            b_ub.append(-xi[i] * b[2 * i + 1])
    kin = linprog(np.r_[np.zeros(nz), -1.0], A_ub=np.array(A_ub) if A_ub else None,
                  b_ub=b_ub or None, A_eq=np.c_[K[eq_rows], np.zeros(len(eq_rows))],
                  b_eq=b[eq_rows], bounds=[(None, None)] * nz + [(None, 1.0)],
                  method="highs")
    if kin.status == 2:
        return False
    s_kin = -kin.fun if A_ub else 1.0
    if abs(s_kin) < MARGIN:
        return None
    if s_kin < 0:
        return False
    G = np.concatenate([W, J[:, E].T], axis=0)
    h = np.r_[-system.g_obj, system.joint_inputs[E] - system.g_man[E]]
    A_eq = [np.r_[G[r], 0.0] for r in range(G.shape[0])]
    b_eq = list(h)
    A_ub, b_ub = [], []
    for i in range(n_c):
        n, t = 2 * i, 2 * i + 1
        row = np.zeros(2 * n_c + 1)
        if codes[i] == BREAK:
            for k in (n, t):
                r = row.copy()
                r[k] = 1.0
                A_eq.append(r)
                b_eq.append(0.0)
            continue
        if codes[i] == SLIDE:
            r = row.copy()
            r[t], r[n] = 1.0, mu[i] * xi[i]
            A_eq.append(r)
            b_eq.append(0.0)
        else:
            for sign in (1.0, -1.0):
                r = row.copy()
                r[n], r[t], r[-1] = -mu[i], sign, 1.0
                A_ub.append(r)
                b_ub.append(0.0)
        r = row.copy()
        r[n], r[-1] = -1.0, 1.0
        A_ub.append(r)
        b_ub.append(0.0)
    frc = linprog(np.r_[np.zeros(2 * n_c), -1.0], A_ub=np.array(A_ub), b_ub=b_ub,
                  A_eq=np.array(A_eq), b_eq=b_eq,
                  bounds=[(None, None)] * (2 * n_c) + [(None, 1.0)], method="highs")
    if frc.status == 2:
        return False
    s_f = -frc.fun
    c_scale = max(1.0, float(np.abs(frc.x[:-1]).max()))
    if abs(s_f) < MARGIN * c_scale:
        return None
    return bool(s_f > 0)


def brute_force_labels(system: System) -> tuple[set[str], set[str]]:
    """(feasible, undecided) labels over every mode with 2 n_R + n_S = 3 n_b + |tau_I|."""
    feasible, undecided = set(), set()
    for codes in itertools.product((BREAK, SLIDE, ROLL), repeat=system.n_contacts):
        if sum(codes) != system.dof:  # ROLL = 2, SLIDE = 1: sum = 2 n_R + n_S
            continue
        slides = [i for i, c in enumerate(codes) if c == SLIDE]
        for signs in itertools.product((1, -1), repeat=len(slides)):
            xi = [0] * system.n_contacts
            for i, s in zip(slides, signs):
                xi[i] = s
            label = Mode(codes, tuple(xi)).label
            verdict = brute_force_mode(system, codes, tuple(xi))
            if verdict is None:
                undecided.add(label)
            elif verdict:
                feasible.add(label)
    return feasible, undecided


def check_certificate(system: System, m) -> None:
    """Re-check a feasible mode from its certificate alone (eqs. 2-3, 5, 9-11, 16-17, 21-22)."""
    qd, th = m.qdot, m.joint_velocities
    V, E = system.velocity_joints, system.effort_joints
    np.testing.assert_allclose(th[V], system.joint_inputs[V], atol=1e-9)
    v = (system.W.T @ qd - system.J @ th).reshape(-1, 2)
    c = m.contact_forces
    scale_v = max(1.0, float(np.abs(v).max()))
    scale_c = max(1.0, float(np.abs(c).max()))
    np.testing.assert_allclose(system.W @ c.reshape(-1) + system.g_obj, 0.0, atol=1e-7 * scale_c)
    tau = system.J.T @ c.reshape(-1) + system.g_man
    np.testing.assert_allclose(tau[E], system.joint_inputs[E], atol=1e-7 * scale_c)
    for i, (code, xi) in enumerate(zip(m.mode.codes, m.mode.xi)):
        if code == BREAK:
            assert v[i, 0] > 0 and np.allclose(c[i], 0.0)
        elif code == SLIDE:
            assert abs(v[i, 0]) <= 1e-7 * scale_v and xi * v[i, 1] > 0
            assert np.isclose(c[i, 1], -system.mu[i] * xi * c[i, 0], atol=1e-7 * scale_c)
            assert c[i, 0] >= -1e-7 * scale_c
        else:
            assert np.allclose(v[i], 0.0, atol=1e-7 * scale_v)
            assert abs(c[i, 1]) <= system.mu[i] * c[i, 0] + 1e-7 * scale_c


@cache
def compared(seed: int, n_b: int, n_c: int, n_e: int):
    """(system, prediction, LP-feasible labels, undecided labels) of one case."""
    system = random_multibody_system(seed, n_b, n_c, n_effort=n_e)
    return (system, feasible_modes(system), *brute_force_labels(system))


@pytest.mark.parametrize("seed, n_b, n_c, n_e", CASES)
@pytest.mark.long
def test_brute_force_lp_agrees_with_feasible_modes(seed, n_b, n_c, n_e) -> None:
    system, pred, lp, undecided = compared(seed, n_b, n_c, n_e)
    assert system.W.shape == (3 * n_b, 2 * n_c)
    planner = {m.label for m in pred.modes}
    assert planner - undecided == lp - undecided
    assert not (planner & undecided)  # nothing the planner calls feasible is degenerate
    for m in pred.all_modes:
        check_certificate(system, m)


@pytest.mark.long
def test_brute_force_cases_are_not_vacuous() -> None:
    """The comparison above decides something: over the cases, at least ten LP-feasible modes
    (and both jammed and moving systems) are compared."""
    found = [len(compared(*c)[2]) for c in CASES]
    assert sum(found) >= 10 and 0 in found


def rebuild(system: System, *, points=None, normals=None, order=None, bodies=None,
            g_obj=None, scale=1.0) -> System:
    """The same scene with contacts in ``order``, body indices mapped by ``bodies`` (old ->
    new), other contact geometry or loads (``scale`` multiplies every load and effort)."""
    n_c = system.n_contacts
    order = np.arange(n_c) if order is None else np.asarray(order)
    perm = np.arange(system.n_bodies) if bodies is None else np.asarray(bodies)
    pairs = [(int(perm[a]), int(perm[b]) if b >= 0 else -1)
             for a, b in (system.contact_bodies[i] for i in order)]
    g = system.g_obj.reshape(-1, 3) if g_obj is None else np.asarray(g_obj).reshape(-1, 3)
    g_new = np.empty_like(g)
    g_new[perm] = g
    E = system.effort_joints
    joints = [{"effort" if j in E else "velocity": float(v * (scale if j in E else 1.0))}
              for j, v in enumerate(system.joint_inputs)]
    return System.from_contacts(
        points=(system.points if points is None else points)[order],
        normals=(system.normals if normals is None else normals)[order],
        mu=system.mu[order], bodies=pairs, n_bodies=system.n_bodies,
        external_wrench=scale * g_new.reshape(-1),
        jacobian=system.J.reshape(n_c, 2, -1)[order], joints=joints,
        joint_loads=scale * system.g_man)


PROPERTY_SEEDS = [(s, 2, 5) for s in range(4)] + [(s, 3, 6) for s in range(3)]


def pred_of(system: System):
    return feasible_modes(system)


@pytest.mark.parametrize("seed, n_b, n_c", PROPERTY_SEEDS)
def test_rigid_motion_of_the_whole_scene(seed, n_b, n_c) -> None:
    """Rotating by phi and translating by d moves every point r -> R r + d, normal n -> R n;
    a body's load (f, m) becomes (R f, m + d x R f) about the origin. Contact-frame Jacobians
    and commands are unchanged, so are the modes and contact forces (contact frame)."""
    system = random_multibody_system(seed, n_b, n_c)
    phi, d = 0.7, np.array([1.3, -0.4])
    R = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    g = system.g_obj.reshape(-1, 3)
    f = g[:, :2] @ R.T
    g2 = np.c_[f, g[:, 2] + d[0] * f[:, 1] - d[1] * f[:, 0]]
    moved = rebuild(system, points=system.points @ R.T + d, normals=system.normals @ R.T,
                    g_obj=g2)
    a, b = pred_of(system), pred_of(moved)
    assert a.labels == b.labels
    for ma, mb in zip(a.modes, b.modes):
        np.testing.assert_allclose(ma.contact_forces, mb.contact_forces, atol=1e-7, rtol=1e-6)


@pytest.mark.parametrize("seed, n_b, n_c", PROPERTY_SEEDS)
def test_relabelling_bodies_and_contacts(seed, n_b, n_c) -> None:
    """Renumbering bodies permutes qdot's blocks and nothing else; reordering contacts permutes
    each mode's tokens (their contact indices) and the contact forces."""
    system = random_multibody_system(seed, n_b, n_c)
    rng = np.random.default_rng(seed)
    perm, order = rng.permutation(n_b), rng.permutation(n_c)
    relabelled = rebuild(system, bodies=perm)
    a, b = pred_of(system), pred_of(relabelled)
    assert a.labels == b.labels
    for ma, mb in zip(a.modes, b.modes):
        np.testing.assert_allclose(mb.qdot.reshape(-1, 3)[perm], ma.qdot.reshape(-1, 3),
                                   atol=1e-9)
    reordered = pred_of(rebuild(system, order=order))

    def key(m, idx):
        return tuple((m.mode.codes[j], m.mode.xi[j]) for j in idx)
    assert sorted(key(m, order) for m in a.modes) == \
        sorted(key(m, range(n_c)) for m in reordered.modes)


@pytest.mark.parametrize("seed, n_b, n_c", PROPERTY_SEEDS)
def test_load_scaling(seed, n_b, n_c) -> None:
    """Scaling g_obj, g_man and the commanded efforts by lambda > 0 scales eq. (26)'s right
    side: the same modes, the same velocities, forces times lambda."""
    system = random_multibody_system(seed, n_b, n_c, n_effort=1)
    a, b = pred_of(system), pred_of(rebuild(system, scale=2.5))
    assert a.labels == b.labels
    for ma, mb in zip(a.modes, b.modes):
        np.testing.assert_allclose(mb.qdot, ma.qdot, atol=1e-9)
        np.testing.assert_allclose(mb.contact_forces, 2.5 * ma.contact_forces, atol=1e-7,
                                   rtol=1e-6)


def test_one_body_is_the_paper_model() -> None:
    """n_b = 1 through the multi-body constructor gives the single-body W and the same modes."""
    system = random_multibody_system(3, 1, 5, n_effort=2)
    plain = System.from_contacts(points=system.points, normals=system.normals, mu=system.mu,
                                 external_wrench=system.g_obj,
                                 jacobian=system.J.reshape(5, 2, -1),
                                 joints=[{"effort" if j in system.effort_joints else "velocity":
                                          float(v)} for j, v in enumerate(system.joint_inputs)],
                                 joint_loads=system.g_man)
    np.testing.assert_array_equal(plain.W, system.W)
    assert pred_of(plain).labels == pred_of(system).labels


@pytest.mark.parametrize("seed, n_b, n_c", [(0, 2, 6), (1, 2, 8), (2, 3, 8), (3, 3, 9)])
def test_pruned_search_finds_the_same_modes(seed, n_b, n_c) -> None:
    """The pruned search (Secs. 4.7, 6) on several workpieces: the determinate modes of the
    exhaustive test, no more, no fewer."""
    from planner.predict.search import search_modes

    system = random_multibody_system(seed, n_b, n_c)
    exhaustive = feasible_modes(system, indeterminate=False)
    found = search_modes(system).prediction
    assert sorted(m.label for m in found.modes) == sorted(m.label for m in exhaustive.modes)


def test_batched_prediction_matches_single_calls() -> None:
    """Many configurations at once (planner.predict.batch) on multi-body systems with the same
    contacts and joints: equal to one call each."""
    from planner.predict.batch import feasible_modes_batch

    base = random_multibody_system(4, 2, 6, n_effort=1)
    systems = [rebuild(base, scale=s) for s in (0.5, 1.0, 2.0)]
    systems.append(random_multibody_system(4, 2, 6, n_effort=1, mu_range=(0.3, 0.4)))
    batched = feasible_modes_batch(systems)
    for system, pred in zip(systems, batched):
        single = feasible_modes(system)
        assert pred.labels == single.labels and pred.status is single.status
        for a, b in zip(pred.all_modes, single.all_modes):
            np.testing.assert_allclose(a.qdot, b.qdot, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_relative_velocity_is_the_difference_of_point_velocities(seed) -> None:
    """Eq. (5) with the block W: ``v_i = W_i^T qdot - J_i thetadot`` equals, in contact i's
    frame (n_i, t_i), the velocity of body a_i's material point at r_i minus that of body b_i
    (or of the manipulator point, ``J_i thetadot``), each from ``v + omega z x r``."""
    from planner.model.bodies import body_velocity_at

    system = random_multibody_system(seed, 3, 6, body_contact_share=0.8)
    rng = np.random.default_rng(seed)
    qdot, thetadot = rng.normal(size=system.n_q), rng.normal(size=system.n_joints)
    v = (system.W.T @ qdot - system.J @ thetadot).reshape(-1, 2)
    manip = (system.J @ thetadot).reshape(-1, 2)
    for i, (a, b) in enumerate(system.contact_bodies):
        n, t = system.normals[i], system.tangents[i]
        rel = body_velocity_at(qdot, a, system.points[i])
        if b >= 0:
            rel = rel - body_velocity_at(qdot, b, system.points[i])
            expected = np.array([rel @ n, rel @ t])
        else:
            expected = np.array([rel @ n, rel @ t]) - manip[i]
        np.testing.assert_allclose(v[i], expected, atol=1e-12)
    assert any(b >= 0 for _, b in system.contact_bodies)


def brute_force_relaxed(system: System) -> tuple[set[str], set[str]]:
    """(feasible, undecided) labels over every mode with 2 n_R + n_S > 3 n_b + |tau_I| (the
    relaxed utility conditions, end of Sec. 3.2), by the same two LPs."""
    feasible, undecided = set(), set()
    for codes in itertools.product((BREAK, SLIDE, ROLL), repeat=system.n_contacts):
        if sum(codes) <= system.dof:
            continue
        slides = [i for i, c in enumerate(codes) if c == SLIDE]
        for signs in itertools.product((1, -1), repeat=len(slides)):
            xi = [0] * system.n_contacts
            for i, s in zip(slides, signs):
                xi[i] = s
            verdict = brute_force_mode(system, codes, tuple(xi))
            label = Mode(codes, tuple(xi)).label
            if verdict is None:
                undecided.add(label)
            elif verdict:
                feasible.add(label)
    return feasible, undecided


@pytest.mark.parametrize("seed, n_b, n_c", [(1, 2, 4), (1, 2, 5), (5, 2, 5), (0, 2, 5)])
def test_brute_force_lp_agrees_on_relaxed_utility_modes(seed, n_b, n_c) -> None:
    """The force-indeterminate modes (more than 3 n_b + |tau_I| constraints, a unique
    velocity) against the LP over every such mode."""
    system = random_multibody_system(seed, n_b, n_c)
    pred = feasible_modes(system, indeterminate=True)
    planner = {m.label for m in pred.indeterminate_modes}
    lp, undecided = brute_force_relaxed(system)
    assert planner - undecided == lp - undecided
