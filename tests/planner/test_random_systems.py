"""Seeded random systems (planner.sweeps.random_systems)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.sweeps.random_systems import random_system


@pytest.mark.parametrize("n_c", [3, 7, 20])
def test_shapes_and_joint_counts(n_c):
    s = random_system(5, n_c)
    assert s.n_contacts == n_c
    assert len(s.effort_joints) == n_c - 3
    assert len(s.velocity_joints) == 2
    assert s.dof == n_c


def test_seeded_is_reproducible_and_seeds_differ():
    a, b, c = random_system(3, 8), random_system(3, 8), random_system(4, 8)
    np.testing.assert_array_equal(a.W, b.W)
    np.testing.assert_array_equal(a.J, b.J)
    assert not np.array_equal(a.W, c.W)


def test_contacts_on_convex_workpiece_with_inward_normals():
    s = random_system(11, 10)
    centroid = s.points.mean(axis=0)
    # Inward normals of a convex body point towards any interior point.
    assert np.all(np.einsum("ij,ij->i", s.normals, centroid - s.points) > 0)


def test_planted_loads_balance():
    s = random_system(2, 9)
    from scipy.optimize import linprog

    E = s.effort_joints
    G = np.concatenate([s.W, s.J[:, E].T])
    h = np.concatenate([-s.g_obj, s.joint_inputs[E] - s.g_man[E]])
    n = s.n_contacts
    A = []
    for i in range(n):
        for sg in (1, -1):
            r = np.zeros(2 * n)
            r[2 * i], r[2 * i + 1] = -s.mu[i], sg
            A.append(r)
    bounds = [(0, None) if j % 2 == 0 else (None, None) for j in range(2 * n)]
    res = linprog(np.zeros(2 * n), A_ub=np.array(A), b_ub=np.zeros(2 * n), A_eq=G, b_eq=h,
                  bounds=bounds, method="highs")
    assert res.status == 0


def test_bad_inputs():
    with pytest.raises(InputError, match="n_contacts: expected 3..40, got 2"):
        random_system(0, 2)
    with pytest.raises(InputError, match="n_contacts: expected an integer, got float"):
        random_system(0, 4.0)
    with pytest.raises(InputError, match="n_velocity: expected >= 1"):
        random_system(0, 4, n_velocity=0)
    with pytest.raises(InputError, match="loads: expected 'planted' or 'random', got 'x'"):
        random_system(0, 4, loads="x")
