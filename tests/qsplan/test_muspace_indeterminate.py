"""Force-indeterminate modes (relaxed utility, Sec. 3.2) on friction-space maps: the map labels
agree with feasible_modes at every grid point (they were 'jam' before)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.friction.muspace import mu_grid
from planner.model.system import System
from planner.predict.feasibility import feasible_modes


def _box(mu, pusher, load=(0.0, -1.0, 0.0)):
    """A unit box on a table (contacts 1, 2 at its bottom corners) and a pusher on its left side
    (contact 3), given as contact-point velocities."""
    return System.from_contacts(
        points=[[-0.5, 0.0], [0.5, 0.0], [-0.5, 0.5]], normals=[[0, 1], [0, 1], [1, 0]],
        mu=mu, external_wrench=load, contact_velocities=[[0, 0], [0, 0], pusher])


def _agree(make, base, n=11):
    grid = mu_grid(make(base), (0, 1), base, (0.0, 1.0), n=n)
    bad = 0
    for i, a in enumerate(grid.axes[0]):
        for j, b in enumerate(grid.axes[1]):
            mu = np.array(base, float)
            mu[0], mu[1] = a, b
            want = sorted(feasible_modes(make(mu)).labels)
            got = sorted(lab for lab, f in zip(grid.labels, grid.feasible[i * n + j]) if f)
            bad += want != got
    return grid, bad


@pytest.mark.parametrize("case", ["pushed (S-1 S-2 R3, sliding: every point)",
                                  "resting under a side load (R1 R2 B3, rolling: bisection)"])
def test_indeterminate_modes_on_the_map_agree_with_feasible_modes(case):
    if case.startswith("pushed"):
        def make(mu):
            return _box(mu, [0.01, 0.0])
        expect = "S-1 S-2 R3"
    else:
        def make(mu):
            return _box(mu, [-0.01, 0.0], load=(0.3, -1.0, 0.0))
        expect = "R1 R2 B3"
    grid, bad = _agree(make, [0.3, 0.3, 0.2])
    assert bad == 0
    assert expect in grid.labels
    assert any(np.any(grid.feasible[:, k]) for k in range(len(grid.labels)))
    if expect == "R1 R2 B3":  # needs friction: jam near the origin, the mode further out
        sets = grid.mode_sets()
        assert sets.flat[0] == "jam" and expect in sets.flat[-1]


def test_without_indeterminate_modes_the_map_is_unchanged():
    def make(mu):
        return _box(mu, [0.01, 0.0])

    off = mu_grid(make([0.3, 0.3, 0.2]), (0, 1), [0.3, 0.3, 0.2], n=9, indeterminate=False)
    assert off.labels == ()  # without the relaxed modes: everything "jam"
    on = mu_grid(make([0.3, 0.3, 0.2]), (0, 1), [0.3, 0.3, 0.2], n=9)
    assert on.labels == ("S-1 S-2 R3",)


def test_cli_muspace_quiet_and_verbose(tmp_path, capsys):
    from pathlib import Path

    from qsplan.cli import main

    data = Path(__file__).resolve().parents[2] / "scenarios" / "data" / "example_4_1.json"
    args = ["muspace", str(data), "--vary", "1,2", "--slice", "3=0", "--n", "20",
            "--out", str(tmp_path)]
    assert main([*args, "-q"]) == 0
    assert capsys.readouterr().out == ""
    assert main([*args, "-v"]) == 0
    out = capsys.readouterr().out
    assert "wrote" in out and "S+1 S-2 S-3" in out and "%" in out


def _pushed_box(mu, h, load):
    return System.from_contacts(
        points=[[-0.5, 0.0], [0.5, 0.0], [-0.5, h]], normals=[[0, 1], [0, 1], [1, 0]], mu=mu,
        external_wrench=load, contact_velocities=[[0, 0], [0, 0], [0.01, 0.0]])


@pytest.mark.parametrize("h, load, base, vary", [
    (0.515, (0.261, -1.0, -0.339), [0.291, 0.541, 0.388], (0, 1)),  # sliding j: an interval
    (0.397, (0.3, -1.0, 0.712), [0.471, 0.274, 0.158], (0, 1)),
    (0.336, (0.235, -1.0, 0.617), [0.432, 0.109, 0.107], (2, 0)),  # rolling j: an up-set
    (0.489, (0.061, -1.0, -0.336), [0.308, 0.245, 0.155], (0, 1)),  # two modes, ambiguity
    (0.359, (-0.385, -1.0, -0.522), [0.081, 0.31, 0.518], (1, 2)),
])
@pytest.mark.long
def test_sliding_and_rolling_lines_agree_pointwise(h, load, base, vary):
    """Two LPs per grid line (relaxed_map) give the per-point verdicts of feasible_modes on maps
    where the force-indeterminate mode S-1 S-2 R3 holds on part of the grid only."""
    n = 15
    grid = mu_grid(_pushed_box(base, h, load), vary, base, (0.0, 1.0), n=n)
    frac = grid.feasible[:, grid.labels.index("S-1 S-2 R3")].mean()
    assert 0.05 < frac < 0.95
    for i, a in enumerate(grid.axes[0]):
        for j, b in enumerate(grid.axes[1]):
            mu = np.array(base, float)
            mu[vary[0]], mu[vary[1]] = a, b
            want = sorted(feasible_modes(_pushed_box(mu, h, load)).labels)
            got = sorted(lab for lab, f in zip(grid.labels, grid.feasible[i * n + j]) if f)
            assert got == want, (a, b)
