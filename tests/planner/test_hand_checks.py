"""A hand file's contacts checked against its geometry (planner.files.hand_checks): features
that do not touch at the start, a contact point beyond its feature, a normal out of the
workpiece -- exit 2 naming the contact by its features, the distance or angle, and the fix."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import pytest

from planner.errors import FileFormatError
from planner.files.hand_checks import START_GAP
from planner.files.hand_file import hand_file_from_dict, load_hand_file

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "scenarios" / "data").glob("*hand*.json")) + sorted(
    (ROOT / "tests" / "data").glob("*hand*.json"))


def hand(name: str) -> dict:
    return json.loads((ROOT / "scenarios" / "data" / name).read_text())


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_hand_file_passes(path):
    assert load_hand_file(path).hand.n_contacts >= 3


def test_finger_side_of_the_wrong_sign_is_a_normal_out_of_the_workpiece():
    """two_finger_hand's vertex 3 rests on the left finger's -1 face; on its +1 face the finger's
    normal rot90(axis) points away from the workpiece: the finger would cut into it."""
    d = hand("two_finger_hand.json")
    d["contacts"][2]["side"] = 1
    with pytest.raises(FileFormatError, match=r"contact 3 \(vertex 3 on the left finger\): "
                       r"expected the contact normal to point into the workpiece, got .*, "
                       r"[0-9.]+ deg outside the inward normals at vertex 3 .*the left finger "
                       r"cuts into the workpiece there; use \"side\": -1"):
        hand_file_from_dict(d)


def test_features_apart_at_the_start_name_the_gap():
    """The left finger turned 0.5 rad away: vertex 3 is 46 mm from its face, more than a quarter
    of the workpiece's size (86.8 mm)."""
    d = hand("two_finger_hand.json")
    d["fingers"][0]["angle"] += 0.5
    with pytest.raises(FileFormatError, match=r"contact 3 \(vertex 3 on the left finger\): "
                       r"expected its features to touch at the start configuration .*got a gap "
                       r"of 0.0458 m, more than 0.25 of the workpiece's size 0.0868 m"):
        hand_file_from_dict(d)
    d["fingers"][0]["angle"] -= 1.0  # turned into the workpiece: an overlap
    with pytest.raises(FileFormatError, match=r"contact 3 .*got an overlap of"):
        hand_file_from_dict(d)


def test_rounded_start_angles_are_closed_not_refused():
    """An angle written 0.05 rad off leaves a gap well below the tolerance: re-closed on load
    to the same configuration."""
    d = hand("two_finger_hand.json")
    ref = hand_file_from_dict(copy.deepcopy(d)).q0
    d["fingers"][1]["angle"] += 0.05
    assert abs(hand_file_from_dict(d).q0 - ref).max() < 1e-9
    assert START_GAP == 0.25


def test_reversed_surface_edge_and_vertex_beyond_the_surface():
    d = hand("table_push_hand.json")
    d["environment"][0]["edge"] = d["environment"][0]["edge"][::-1]
    # the surface's own check comes first: the workpiece must lie on its inward side
    with pytest.raises(FileFormatError, match=r"environment\[0\]\.edge: expected the workpiece "
                       r"on the inward side .*, got it on the other side \(the edge given in "
                       r"reverse\?\)"):
        hand_file_from_dict(d)
    d = hand("table_push_hand.json")
    d["environment"][0]["edge"][1] = [0.02, 0.0]  # the table ends before vertex 1 (x = 0.04)
    with pytest.raises(FileFormatError, match=r"contact 2 \(vertex 1 on the table\): expected "
                       r"the contact point on the table's edge \(fraction 0..1 along it\), got "
                       r"1.06, 0.02 m beyond its end"):
        hand_file_from_dict(d)


def test_tip_beyond_its_edge():
    """table_push_hand's tip on edge 3 (the left face, x = 0, from y = 0.04 down to 0) at mid
    height; the block moved up by 0.05 m leaves the tip below the face's lower end."""
    d = hand("table_push_hand.json")
    d["workpiece"]["vertices"] = [[0, 0], [0.04, 0], [0.04, 0.01], [0, 0.01]]
    d["workpiece"]["com"] = [0.02, 0.005]
    with pytest.raises(FileFormatError, match=r"contact 3 \(the pusher finger's tip on edge 3\)"
                       r": expected the contact point on edge 3 \(fraction 0..1 along it\)"):
        hand_file_from_dict(d)


def test_cli_exit_2_with_the_message(tmp_path):
    d = hand("two_finger_hand.json")
    d["contacts"][2]["side"] = 1
    bad = tmp_path / "side.json"
    bad.write_text(json.dumps(d))
    res = subprocess.run([sys.executable, "-m", "qsplan.cli", "draw", str(bad), "--out",
                          str(tmp_path / "x.png")], capture_output=True, text=True)
    assert res.returncode == 2
    assert "contact 3 (vertex 3 on the left finger): expected the contact normal" in res.stderr
    assert "Traceback" not in res.stderr and not (tmp_path / "x.png").exists()
