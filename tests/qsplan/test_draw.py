"""``qsplan draw``: every shipped file gives a picture, and the drawn geometry (contact
positions, normals, friction cones, load) is read back from the figure's data."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from qsplan.cli import main
from qsplan.commands.draw import figure

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios" / "data").glob("*.json"))


@pytest.fixture(autouse=True)
def close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def artists(fig, gid):
    return [a for a in fig.findobj() if a.get_gid() == gid]


def one(fig, gid):
    found = artists(fig, gid)
    assert len(found) == 1, (gid, len(found))
    return found[0]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_file_draws(path, tmp_path):
    out = tmp_path / "pic.png"
    assert main(["draw", str(path), "--out", str(out), "-q"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from planner.files.reader import read_json
    from qsplan.commands.draw import kind_of

    fig = figure(str(path), kind_of(read_json(path, "f")))
    pts = one(fig, "contact-points")
    text = path.read_text()
    assert len(pts.get_xdata()) >= 2
    assert bool(artists(fig, "workpiece-0")) == ("polygon" in text or "vertices" in text)
    for i in range(1, len(pts.get_xdata()) + 1):
        assert artists(fig, f"normal-{i}") and artists(fig, f"cone-{i}")


def test_box_drawing_shows_contacts_normals_and_cones():
    """The geometry-first box (w 0.08, h 0.12, table mu 0.3, frictionless pusher at y 0.06):
    contacts at (0, 0), (0.08, 0), (0, 0.06); normals up, up, right; cone half-angles
    atan(0.3), atan(0.3), 0; the weight 0.981 N straight down at (0.04, 0.06)."""
    fig = figure(str(ROOT / "scenarios/data/geometry_box_low.json"), "system")
    pts = one(fig, "contact-points")
    assert np.allclose(np.c_[pts.get_xdata(), pts.get_ydata()], [[0, 0], [0.08, 0], [0, 0.06]])
    for i, n in enumerate(([0, 1], [0, 1], [1, 0])):
        arrow = one(fig, f"normal-{i + 1}")
        d = np.subtract(arrow.xy, arrow.xyann)
        assert np.allclose(d / np.linalg.norm(d), n)
    for i, mu in enumerate((0.3, 0.3, 0.0)):
        p, a, b = one(fig, f"cone-{i + 1}").get_xy()[:3]
        half = 0.5 * math.acos(np.dot(a - p, b - p) / np.linalg.norm(a - p) / np.linalg.norm(b - p))
        assert half == pytest.approx(math.atan(mu), abs=1e-9)
    load = one(fig, "load-0")
    assert np.allclose(load.xyann, [0.04, 0.06]) and np.allclose(
        np.subtract(load.xy, load.xyann)[0], 0.0) and load.xy[1] < load.xyann[1]
    drive = one(fig, "drive-3")
    assert np.subtract(drive.xy, drive.xyann)[0] > 0 and not artists(fig, "drive-1")


def test_mode_overlay_draws_the_certificate(tmp_path):
    """--mode 'S-1 S-2 R3': forces on the box at each contact along c_n n + c_t t (the
    table's friction points back, -x), and every vertex moves right with the box."""
    fig = figure(str(ROOT / "scenarios/data/geometry_box_low.json"), "system", "S-1 S-2 R3")
    f1 = np.subtract(one(fig, "force-1").xy, one(fig, "force-1").xyann)
    assert f1[0] < 0 < f1[1]
    for k in range(4):
        v = np.subtract(one(fig, f"vertex-velocity-0-{k}").xy,
                        one(fig, f"vertex-velocity-0-{k}").xyann)
        assert v[0] > 0 and abs(v[1]) < 1e-12
    out = tmp_path / "m.svg"
    assert main(["draw", str(ROOT / "scenarios/data/geometry_box_low.json"), "--mode",
                 "S-1 S-2 R3", "--out", str(out), "-q"]) == 0
    assert out.read_text().lstrip().startswith("<?xml")


def test_draw_refuses_bad_requests(tmp_path, capsys):
    box = str(ROOT / "scenarios/data/geometry_box_low.json")
    assert main(["draw", box, "--mode", "R1 R2 R3", "--out", str(tmp_path / "a.png")]) == 2
    assert "--mode: expected one of the feasible modes ['S-1 S-2 R3']" in capsys.readouterr().err
    assert main(["draw", box, "--out", str(tmp_path / "a.jpg")]) == 2
    assert "--out: expected a .png or .svg file" in capsys.readouterr().err


def test_hand_drawing_has_goal_and_contacts():
    fig = figure(str(ROOT / "scenarios/data/figure9_task_hand.json"), "hand")
    assert artists(fig, "goal") and len(one(fig, "contact-points").get_xdata()) == 4
