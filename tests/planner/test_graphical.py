"""Corollary 1 graphical test vs the closed-form (algebraic) 3S test on random configurations."""

import numpy as np
import pytest

from planner.errors import InputError
from planner.friction.closed_form import closed_form_region
from planner.friction.graphical import GraphicalVerdict, corollary1_3s
from planner.model.geometry import wrench_matrix
from planner.model.modes import SLIDE


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


def _random_mode_case(rng, kind):
    from planner.model.modes import BREAK, ROLL

    pts = rng.uniform(-1, 1, (3, 2))
    ang = rng.uniform(0, 2 * np.pi, 3)
    nrm = np.column_stack([np.cos(ang), np.sin(ang)])
    mu = rng.uniform(0, 1, 3)
    xi = rng.choice([-1, 1], 3)
    g = rng.normal(size=3)
    base = (ROLL, SLIDE, BREAK) if kind == "RS" else (SLIDE, SLIDE, SLIDE)
    codes = tuple(int(c) for c in np.array(base)[rng.permutation(3)])
    return pts, nrm, mu, xi, g, codes


@pytest.mark.parametrize("kind", ["RS", "3S"])
@pytest.mark.long
def test_brost_mason_matches_algebraic_on_random_configurations(kind):
    """Moment labelling (Sec. 4.1-4.2) == eqs. (35)-(36) / (40)-(41) away from boundaries."""
    from planner.friction.graphical import brost_mason_mode

    rng = np.random.default_rng(11 if kind == "RS" else 12)
    compared = feasible = 0
    for _ in range(2000):
        pts, nrm, mu, xi, g, codes = _random_mode_case(rng, kind)
        reg = closed_form_region(wrench_matrix(pts, nrm), g, codes, xi)
        D = reg.denominator(mu[None])[0]
        alg = reg.margin(mu[None])[0]
        if abs(D) < 1e-6 or abs(alg) < 1e-6 * D**2:
            continue
        res = brost_mason_mode(pts, nrm, mu, codes, xi, g)
        if res.verdict is GraphicalVerdict.DEGENERATE:
            continue
        compared += 1
        feasible += alg >= 0
        assert (res.verdict is GraphicalVerdict.FEASIBLE) == (alg >= 0), (pts, nrm, mu, codes)
    assert compared > 1500 and 50 < feasible < compared - 50


def test_brost_mason_agrees_with_corollary1_for_3s():
    from planner.friction.graphical import brost_mason_mode

    rng = np.random.default_rng(13)
    compared = 0
    for _ in range(1000):
        pts, nrm, mu, xi, g, codes = _random_mode_case(rng, "3S")
        c1 = corollary1_3s(pts, nrm, mu, xi, g)
        bm = brost_mason_mode(pts, nrm, mu, codes, xi, g)
        if GraphicalVerdict.DEGENERATE in (c1.verdict, bm.verdict):
            continue
        if np.min(np.abs(c1.moment_products)) < 1e-9:
            continue
        compared += 1
        assert c1.verdict is bm.verdict
    assert compared > 800


def test_brost_mason_example_4_1_rs_golden():
    """Example 4.1 (eq. 37): R1 S-2 B3 holds at mu = (0.75, 0.45, .) and not at (0.2, 0.3, .)
    (Fig. 3: the RS region lies below the positive-slope curve)."""
    from pathlib import Path

    from planner.files.system_file import load_system
    from planner.friction.graphical import brost_mason_mode
    from planner.model.modes import Mode

    s = load_system(Path(__file__).resolve().parents[2] / "scenarios/data/example_4_1.json")
    m = Mode.parse("R1 S-2 B3")
    yes = brost_mason_mode(s.points, s.normals, [0.75, 0.45, 0.1], m.codes, m.xi, s.g_obj)
    no = brost_mason_mode(s.points, s.normals, [0.2, 0.3, 0.1], m.codes, m.xi, s.g_obj)
    assert yes.verdict is GraphicalVerdict.FEASIBLE
    assert no.verdict is GraphicalVerdict.INFEASIBLE
    assert yes.forces.shape == (3, 2) and yes.contacts.tolist() == [0, 0, 1]


def test_brost_mason_degenerate_and_bad_input():
    from planner.friction.graphical import brost_mason_mode
    from planner.model.modes import BREAK, ROLL

    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]])
    nrm = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, -1.0]])
    res = brost_mason_mode(pts, nrm, [0.0, 0.3, 0.3], (ROLL, SLIDE, BREAK), (0, 1, 0), [0, -1, 0])
    assert res.verdict is GraphicalVerdict.DEGENERATE  # mu_R = 0: the two cone edges coincide
    with pytest.raises(InputError, match=r"expected a 3S or RS mode .* got codes \(2, 2, 0\)"):
        brost_mason_mode(pts, nrm, [0.3] * 3, (ROLL, ROLL, BREAK), (0, 0, 0), [0, -1, 0])
    with pytest.raises(InputError, match="expected mu, xi, codes of length 3, got 2, 3, 3"):
        brost_mason_mode(pts, nrm, [0.3] * 2, (ROLL, SLIDE, BREAK), (0, 1, 0), [0, -1, 0])
    with pytest.raises(InputError, match=r"expected points and normals \(n_c, 2\)"):
        brost_mason_mode(pts[:, :1], nrm, [0.3] * 3, (ROLL, SLIDE, BREAK), (0, 1, 0), [0, -1, 0])


def test_brost_mason_concurrent_lines_are_degenerate():
    """Three sliding forces whose lines meet in one point: W_Amu singular -> DEGENERATE."""
    from planner.friction.graphical import brost_mason_mode

    ang = np.array([0.3, 2.2, 4.1])
    nrm = np.column_stack([np.cos(ang), np.sin(ang)])
    pts = 0.7 * nrm  # mu = 0: every force acts along its normal, all through the origin
    res = brost_mason_mode(pts, nrm, [0.0] * 3, (SLIDE,) * 3, (1, 1, 1), [0, -1, 0])
    assert res.verdict is GraphicalVerdict.DEGENERATE and res.labels is None
