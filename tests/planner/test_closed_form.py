"""Closed-form 3S/RS regions (eqs. 34-36, 39-41) against the general test (force_stage)."""

from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.system_file import load_system
from planner.friction.closed_form import closed_form_region
from planner.model.modes import enumerate_modes
from planner.predict.stages import force_stage, kinematic_stage

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


def _disagreements(name: str, n_points: int, seed: int = 0) -> tuple[int, int]:
    s = load_system(DATA / f"{name}.json")
    cand = enumerate_modes(s.n_contacts, s.dof)
    kin = kinematic_stage(s, cand)
    idx = np.flatnonzero(kin.ok)
    mu = np.random.default_rng(seed).uniform(0, 1, (n_points, s.n_contacts))
    fs = force_stage(s, cand, idx, kin.xi[idx], mu)
    bad = checked = 0
    for j, i in enumerate(idx):
        reg = closed_form_region(s.W, s.g_obj, cand.codes[i], kin.xi[i])
        cf = reg.margin(mu)
        general = fs.margin[:, j]
        clear = (np.abs(general) > 1e-9) & (np.abs(cf) > 1e-9)
        checked += int(clear.sum())
        bad += int(np.sum((cf[clear] >= 0) != (general[clear] >= 0)))
    return bad, checked


@pytest.mark.parametrize("name", ["example_4_1", "example_4_3"])
def test_closed_form_agrees_1e4(name):
    bad, checked = _disagreements(name, 10_000)
    assert checked > 10_000 and bad == 0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["example_4_1", "example_4_3"])
def test_closed_form_agrees_1e5(name):
    bad, checked = _disagreements(name, 100_000, seed=1)
    assert checked > 100_000 and bad == 0


def test_rejects_non_3s_rs_mode():
    s = load_system(DATA / "example_4_1.json")
    with pytest.raises(InputError, match="expected a 3S or RS mode"):
        closed_form_region(s.W, s.g_obj, (2, 2, 1), (0, 0, 1))


def test_coefficients_match_appendix_a_and_b():
    """Spot-check the exported coefficients against App. A (eqs. 50, 52, 57) and B (58-60)."""
    from planner.model.modes import Mode

    s = load_system(DATA / "example_4_1.json")
    W, g = s.W, s.g_obj
    n = [W[:, 2 * i] for i in range(3)]
    t = [W[:, 2 * i + 1] for i in range(3)]
    det = lambda *cols: np.linalg.det(np.column_stack(cols))  # noqa: E731
    m = Mode.parse("S+1 S-2 S-3")
    x1, x2, x3 = m.xi
    reg = closed_form_region(W, g, m.codes, m.xi)
    den = dict(reg.denominator.terms)
    assert np.isclose(den[(0, 1, 2)], -x1 * x2 * x3 * det(*t))  # A, eq. 50
    assert np.isclose(den[()], det(*n))  # D, eq. 50
    assert np.isclose(den[(0,)], -x1 * det(t[0], n[1], n[2]))  # C_1, eq. 52
    num1 = dict(reg.numerators[0].terms)
    assert np.isclose(num1[()], -det(g, n[1], n[2]))  # G_1, eq. 57
    assert np.isclose(num1[(1, 2)], -x2 * x3 * det(g, t[1], t[2]))  # E_1, eq. 53
    assert np.isclose(num1[(1,)], x2 * det(g, t[1], n[2]))  # F_12, eq. 54
    rs = Mode.parse("R1 S-2 B3")
    reg = closed_form_region(W, g, rs.codes, rs.xi)
    xs = rs.xi[1]
    den = dict(reg.denominator.terms)
    assert np.isclose(den[(1,)], -xs * det(n[0], t[0], t[1]))  # A, eq. 58
    assert np.isclose(den[()], det(n[0], t[0], n[1]))  # B, eq. 58
    c_rn, c_rt, c_sn = (dict(p.terms) for p in reg.numerators)
    assert np.isclose(c_rn[(1,)], xs * det(g, t[0], t[1]))  # C_1, eq. 59
    assert np.isclose(c_rt[()], -det(n[0], g, n[1]))  # D_2, eq. 60
    assert np.isclose(c_sn[()], -det(n[0], t[0], g))  # D_3, eq. 60


def test_region_dict_round_trip_and_inequalities():
    from planner.friction.closed_form import ClosedFormRegion
    from planner.model.modes import Mode

    s = load_system(DATA / "example_4_3.json")
    mu = np.random.default_rng(4).uniform(0, 1, (500, 3))
    for label in ("S-1 S+2 S-3", "R1 B2 S-3"):
        m = Mode.parse(label)
        reg = closed_form_region(s.W, s.g_obj, m.codes, m.xi)
        back = ClosedFormRegion.from_dict(reg.to_dict())
        assert back.label == label
        assert np.array_equal(back.contains(mu), reg.contains(mu))
        # sign(D) P_k >= 0 for all k  <=>  the Cramer margin of eq. 28 is >= 0
        assert np.array_equal(reg.contains(mu), reg.margin(mu) >= 0)
    names = [n for n, _ in closed_form_region(s.W, s.g_obj, (2, 0, 1), (0, 0, -1)).inequalities()]
    assert names == ["mu_1 c_1n - c_1t>=0", "mu_1 c_1n + c_1t>=0", "c_3n>=0"]
    with pytest.raises(InputError, match="expected keys mode, unknowns, denominator"):
        ClosedFormRegion.from_dict({"mode": "R1 B2 S-3"})


def test_closed_form_agrees_on_random_noncompliant_systems():
    """Random contact configurations (3-5 contacts, velocity joints only): every admissible
    3S / RS mode's closed form agrees with force_stage away from boundaries."""
    import sys

    sys.path.insert(0, str(Path(__file__).parents[1]))
    from randsys import random_system

    from planner.friction.muspace import closed_form_regions

    rng = np.random.default_rng(21)
    bad = checked = 0
    for _ in range(20):
        s = random_system(rng, int(rng.integers(3, 6)), n_effort=0)
        cand = enumerate_modes(s.n_contacts, s.dof)
        kin = kinematic_stage(s, cand)
        idx = np.flatnonzero(kin.ok)
        regions = closed_form_regions(s)
        assert [r.label for r in regions] == [
            closed_form_region(s.W, s.g_obj, cand.codes[i], kin.xi[i]).label for i in idx]
        mu = rng.uniform(0, 1, (500, s.n_contacts))
        fs = force_stage(s, cand, idx, kin.xi[idx], mu)
        for j, reg in enumerate(regions):
            cf = reg.margin(mu)
            general = fs.margin[:, j]
            clear = (np.abs(general) > 1e-9) & (np.abs(cf) > 1e-9) & fs.nonsingular[:, j]
            checked += int(clear.sum())
            bad += int(np.sum((cf[clear] >= 0) != (general[clear] >= 0)))
    assert checked > 5_000 and bad == 0
