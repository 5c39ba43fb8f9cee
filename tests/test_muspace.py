"""mu-space grids (general test, eqs. 26-28) against feasible_modes, JSON round trip, bad input."""

from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.feasibility import feasible_modes
from planner.io import load_system
from planner.muspace import MuGrid, mu_grid

DATA = Path(__file__).resolve().parents[1] / "scenarios" / "data"


@pytest.fixture(scope="module")
def ex41():
    return load_system(DATA / "example_4_1.json")


def test_grid_matches_feasible_modes_pointwise(ex41):
    g = mu_grid(ex41, (0, 1), [0.2, 0.3, 0.6], (0.0, 1.0), n=7)
    sets = g.mode_sets()
    for a, m1 in enumerate(g.axes[0]):
        for b, m2 in enumerate(g.axes[1]):
            p = feasible_modes(ex41, mu=[m1, m2, 0.6])
            if any(fm.on_boundary for fm in p.modes) or p.boundary_modes:
                continue
            want = " | ".join(sorted(p.labels)) if p.labels else "jam"
            got = sets[a, b]
            got = " | ".join(sorted(got.split(" | "))) if got != "jam" else "jam"
            assert got == want, (m1, m2)


def test_example_4_1_has_rs_3s_and_jam(ex41):
    g = mu_grid(ex41, (0, 1), [0.2, 0.3, 0.1], (0.0, 1.0), n=40)
    sets = set(g.mode_sets().ravel())
    assert "jam" in sets
    assert "R1 S-2 B3" in g.labels and "S+1 S-2 S-3" in g.labels


def test_json_round_trip(ex41):
    g = mu_grid(ex41, (0, 2), [0.2, 0.3, 0.1], n=9)
    h = MuGrid.from_dict(g.to_dict())
    assert np.array_equal(g.mode_sets(), h.mode_sets())


@pytest.mark.parametrize("kwargs, msg", [
    ({"vary": (0, 1), "mu_range": (0.8, 0.2)}, "expected min <= max"),
    ({"vary": (0, 1), "mu_range": (-0.1, 1.0)}, "expected mu >= 0"),
    ({"vary": (0, 5)}, r"expected contact index in 1..3, got 6"),
    ({"vary": (1, 1)}, "expected 1 or 2 distinct contacts"),
])
def test_bad_input(ex41, kwargs, msg):
    with pytest.raises(InputError, match=msg):
        mu_grid(ex41, base_mu=[0.2, 0.3, 0.1], **kwargs)


def test_cli_writes_map_and_json(tmp_path):
    from planner.cli import main

    rc = main(["muspace", str(DATA / "example_4_1.json"), "--vary", "1,2", "--slice", "3=0,0.6",
               "--n", "20", "--out", str(tmp_path)])
    assert rc == 0
    assert (tmp_path / "muspace.png").stat().st_size > 0
    import json

    d = json.loads((tmp_path / "muspace.json").read_text())
    assert len(d["slices"]) == 2 and d["slices"][1]["base_mu"][2] == 0.6


def test_cli_rejects_sliced_and_varied(tmp_path, capsys):
    from planner.cli import main

    rc = main(["muspace", str(DATA / "example_4_1.json"), "--vary", "1,2", "--slice", "2=0.1",
               "--out", str(tmp_path)])
    assert rc == 2
    assert "expected a contact not in --vary, got 2" in capsys.readouterr().err


def test_rod_line_section_5_1():
    """Sec. 5.1: rod on two approaching supports; contact 1 sticks iff l1 mu2 < l2 mu1."""
    from planner.model import System

    l1, l2 = 0.3, 0.7
    rod = System.from_contacts(points=[[-l1, 0], [l2, 0]], normals=[[0, 1], [0, 1]],
                               mu=[0.3, 0.3], external_wrench=[0, -1, 0],
                               contact_velocities=[[0, -1], [0, 1]])  # (n, t); t = -x
    g = mu_grid(rod, (0, 1), [0.3, 0.3], (0.0, 1.0), n=41)
    m1, m2 = np.meshgrid(*g.axes, indexing="ij")
    sets = g.mode_sets()
    gap = l2 * m1 - l1 * m2
    away = np.abs(gap) > 1e-6
    assert np.all((sets == "R1 S-2")[away & (gap > 0)])
    assert np.all((sets == "S+1 R2")[away & (gap < 0)])
