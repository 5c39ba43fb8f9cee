"""mu-space grids (general test, eqs. 26-28) against feasible_modes, JSON round trip, bad input."""

from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.system_file import load_system
from planner.friction.muspace import MuGrid, mu_grid
from planner.predict.feasibility import feasible_modes

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


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
    ({"vary": (1, 1)}, "expected 1 to 3 distinct contacts"),
])
def test_bad_input(ex41, kwargs, msg):
    with pytest.raises(InputError, match=msg):
        mu_grid(ex41, base_mu=[0.2, 0.3, 0.1], **kwargs)


def test_cli_writes_map_and_json(tmp_path):
    from qsplan.cli import main

    rc = main(["muspace", str(DATA / "example_4_1.json"), "--vary", "1,2", "--slice", "3=0,0.6",
               "--n", "20", "--out", str(tmp_path)])
    assert rc == 0
    assert (tmp_path / "muspace.png").stat().st_size > 0
    import json

    d = json.loads((tmp_path / "muspace.json").read_text())
    assert len(d["slices"]) == 2 and d["slices"][1]["base_mu"][2] == 0.6


def test_cli_rejects_sliced_and_varied(tmp_path, capsys):
    from qsplan.cli import main

    rc = main(["muspace", str(DATA / "example_4_1.json"), "--vary", "1,2", "--slice", "2=0.1",
               "--out", str(tmp_path)])
    assert rc == 2
    assert "expected a contact not in --vary, got 2" in capsys.readouterr().err


def test_rod_line_section_5_1():
    """Sec. 5.1: rod on two approaching supports; contact 1 sticks iff l1 mu2 < l2 mu1."""
    from planner.model.system import System

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


def _near_closed_form_boundary(m, mu, eps=1e-9):
    near = np.zeros(len(mu), bool)
    for r in m.closed_forms:
        D = r.denominator(mu)
        P = r.signed_inequalities(mu)
        near |= (np.abs(D) < eps) | np.any(np.abs(P) < eps * (1 + np.abs(D)[:, None]), axis=1)
    return near


@pytest.mark.parametrize("name", ["example_4_1", "example_4_3"])
def test_json_closed_forms_reproduce_labels(name, tmp_path):
    """Export -> file -> re-load: the per-mode inequalities alone re-label every grid point."""
    import json

    from planner.files.atomic import atomic_write_json
    from planner.friction.muspace import MuSpaceMap, muspace_map

    s = load_system(DATA / f"{name}.json")
    m = muspace_map(s, (0, 1), [0.2, 0.3, 0.1], n=41, sliced=2, slice_values=(0.0, 0.4))
    atomic_write_json(tmp_path / "m.json", m.to_dict())
    d = json.loads((tmp_path / "m.json").read_text())
    assert d["closed_forms"][0]["inequalities"][0]["terms"][0].keys() == {"mu", "coef"}
    back = MuSpaceMap.from_dict(d)
    assert [r.label for r in back.closed_forms] == [r.label for r in m.closed_forms]
    compared = 0
    for g in back.grids:
        mu = g.points()
        keep = ~_near_closed_form_boundary(back, mu)
        got = back.closed_form_mode_sets(mu)[keep]
        want = g.mode_sets().ravel()[keep]
        norm = [" | ".join(sorted(x.split(" | "))) for x in (*got, *want)]
        assert norm[: len(got)] == norm[len(got):]
        compared += int(keep.sum())
    assert compared > 0.9 * 2 * 41 * 41


def test_three_coefficients_grid_and_slices(ex41):
    """3-D box decomposition: its slices equal 2-D grids computed directly."""
    from planner.friction.muspace import MuSpaceMap, muspace_map

    m = muspace_map(ex41, (0, 1, 2), [0.2, 0.3, 0.1], n=9)
    g3 = m.grids[0]
    assert g3.shape == (9, 9, 9) and g3.feasible.shape[0] == 729
    panels, titles = m.panels(3)
    assert titles == ["mu_3=0", "mu_3=0.5", "mu_3=1"]
    for p in panels:
        direct = mu_grid(ex41, (0, 1), p.base_mu, n=9)
        assert np.array_equal(p.mode_sets(), direct.mode_sets())
    frac = g3.region_fractions()
    assert abs(sum(frac.values()) - 1) < 1e-12 and "jam" in frac
    back = MuSpaceMap.from_dict(m.to_dict())
    assert np.array_equal(back.grids[0].mode_sets(), g3.mode_sets())


def test_muspace_map_bad_input(ex41):
    from planner.friction.muspace import MuSpaceMap, muspace_map

    with pytest.raises(InputError, match="expected a contact not in vary, got 2"):
        muspace_map(ex41, (0, 1), sliced=1, slice_values=(0.1,))
    with pytest.raises(InputError, match=r"expected finite mu >= 0, got \[0.1, -0.2\]"):
        muspace_map(ex41, (0, 1), sliced=2, slice_values=(0.1, -0.2))
    with pytest.raises(InputError, match=r"expected contact index in 1..3, got 4"):
        muspace_map(ex41, (0, 1), sliced=3, slice_values=(0.1,))
    with pytest.raises(InputError, match="expected format 'qsplan-muspace', got None"):
        MuSpaceMap.from_dict({"slices": []})


def test_cli_three_varied(tmp_path, capsys):
    import json

    from qsplan.cli import main

    assert main(["muspace", str(DATA / "example_4_3.json"), "--vary", "1,2,3", "--n", "8",
                 "--panels", "2", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "muspace.json").read_text())
    cells = d["slices"][0]["cells"]
    assert d["slices"][0]["vary"] == [1, 2, 3] and len(cells) == 64
    assert all(len(row.split()) == 8 for row in cells)
    assert len(d["closed_forms"]) >= 4
    rc = main(["muspace", str(DATA / "example_4_3.json"), "--vary", "1,2,3", "--slice", "3=0.1",
               "--out", str(tmp_path)])
    assert rc == 2
    assert "expected no --slice with three varied coefficients" in capsys.readouterr().err
