"""Closed-form 3S/RS regions (eqs. 34-36, 39-41) against the general test (force_stage)."""

from pathlib import Path

import numpy as np
import pytest

from planner.closed_form import closed_form_region
from planner.errors import InputError
from planner.feasibility import force_stage, kinematic_stage
from planner.io import load_system
from planner.modes import enumerate_modes

DATA = Path(__file__).resolve().parents[1] / "scenarios" / "data"


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
