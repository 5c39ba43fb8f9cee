"""The friction-space scenarios (Figs. 3, 6, 8) run with fast settings and write what they say.

Every scenario of ``scenarios/muspace_maps.py`` and ``scenarios/ruler_muspace.py`` writes a
PNG, a JSON map that re-loads, and a ``summary.json`` whose checks (the paper's statements about
the figure) all hold.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.friction.muspace import MuSpaceMap
from scenarios.registry import all_scenarios
from scenarios.runs import run_scenario

MAPS = {"muspace_ex41": "example_4_1", "muspace_ex43": "example_4_3", "muspace_rod": "rod"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _png_ok(path):
    from PIL import Image

    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    with Image.open(path) as im:
        w, h = im.size
        small = np.asarray(im.convert("RGB").resize((64, 16))).reshape(-1, 3)
        colours = len({tuple(c) for c in small.tolist()})
    assert w >= 400 and h >= 300 and colours > 4  # a drawn figure, not a blank canvas


@pytest.mark.parametrize("name", sorted(MAPS))
def test_map_scenario_writes_png_json_summary(name, tmp_path):
    summary = run_scenario(all_scenarios()[name], tmp_path, n=31)
    assert summary["passed"], summary["reason"]
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["scenario"] == MAPS[name] and on_disk["status"] == "info"
    assert all(on_disk["checks"].values()) and len(on_disk["checks"]) >= 2
    stem = MAPS[name]
    _png_ok(tmp_path / f"{stem}_muspace.png")
    m = MuSpaceMap.from_dict(json.loads((tmp_path / f"{stem}_muspace.json").read_text()))
    assert m.closed_forms, "noncompliant examples export their closed forms"
    assert all(g.shape == (31, 31) for g in m.grids)
    assert sorted({s for g in m.grids for s in g.mode_sets().ravel()}) == summary["mode_sets"]
    if name == "muspace_ex43":
        assert len(summary["modes"]) == 4 and max(summary["fraction_three_modes"]) > 0.25
    if name == "muspace_ex41":
        assert "jam" in summary["mode_sets"] and summary["area_3s"][-1] < summary["area_3s"][0]


def test_ruler_muspace_bounces_between_corners(tmp_path):
    from scenarios.ruler_muspace import L1, L2, MU_R, MU_S

    summary = run_scenario(all_scenarios()["ruler_muspace"], tmp_path, n=25, switches=4)
    assert summary["passed"], summary["reason"]
    _png_ok(tmp_path / "ruler_muspace.png")
    data = json.loads((tmp_path / "ruler_muspace.json").read_text())
    assert data["parameters"]["rectangle"] == [[MU_S[0], MU_R[0]], [MU_S[1], MU_R[1]]]
    assert summary["modes"] == ["S+1 R2", "S+1 R2", "R1 S-2", "S+1 R2", "R1 S-2"]
    # Sec. 5.1: the line passes the current corner -> l1 = l2 mu_1S / mu_2R, then
    # l2 = l1 mu_2S / mu_1R, ... (ratio 0.6 for mu_S / mu_R = 0.3 / 0.5)
    want = [L2 * 0.6, L2 * 0.6 * 0.6, L2 * 0.6**3, L2 * 0.6**4]
    assert np.allclose(summary["switch_positions_m"], want, rtol=1e-12)
    assert L1 > want[0]
    first = data["states"][0]
    assert MuSpaceMap.from_dict(first["map"]).closed_form_mode_sets([first["mu"]])[0] == "S+1 R2"
    for state in data["states"][1:]:  # at a switch the current corner is on both boundaries
        m = MuSpaceMap.from_dict(state["map"])
        for region in m.closed_forms:
            assert abs(np.min(region.signed_inequalities([state["mu"]]))) < 1e-12


def test_python_m_scenarios_runs_an_info_scenario(tmp_path, capsys):
    from scenarios.__main__ import main

    assert main(["run", "muspace_rod", "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["status"] == "info" and out["passed"] is True
