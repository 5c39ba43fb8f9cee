"""Corollary 1 graphical test vs the closed-form (algebraic) 3S test on random configurations."""

import numpy as np
import pytest

from planner.closed_form import closed_form_region
from planner.errors import InputError
from planner.graphical import GraphicalVerdict, corollary1_3s
from planner.model import wrench_matrix
from planner.modes import SLIDE


def test_graphical_matches_algebraic_on_random_configurations():
    rng = np.random.default_rng(3)
    compared = feasible = 0
    for _ in range(2000):
        pts = rng.uniform(-1, 1, (3, 2))
        ang = rng.uniform(0, 2 * np.pi, 3)
        nrm = np.column_stack([np.cos(ang), np.sin(ang)])
        mu = rng.uniform(0, 1, 3)
        xi = rng.choice([-1, 1], 3)
        g = np.concatenate([rng.normal(size=2), rng.normal(size=1)])
        W = wrench_matrix(pts, nrm)
        reg = closed_form_region(W, g, (SLIDE,) * 3, xi)
        alg = reg.margin(mu[None])[0]
        D = reg.denominator(mu[None])[0]
        if abs(D) < 1e-6 or abs(alg) < 1e-6:
            continue
        res = corollary1_3s(pts, nrm, mu, xi, g)
        if res.verdict is GraphicalVerdict.DEGENERATE or np.min(np.abs(res.moment_products)) < 1e-9:
            continue
        compared += 1
        feasible += alg >= 0
        assert (res.verdict is GraphicalVerdict.FEASIBLE) == (alg >= 0)
    assert compared > 1000 and 50 < feasible < compared - 50


def test_bad_shape():
    with pytest.raises(InputError, match=r"expected points and normals \(3, 2\)"):
        corollary1_3s(np.zeros((2, 2)), np.zeros((3, 2)), [0, 0, 0], [1, 1, 1], [0, -1, 0])
