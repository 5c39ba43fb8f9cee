"""The friction model a plan records is the one its guarantee holds for: one interval ->
``common`` (the paper's shared coefficient), one interval per contact -> ``independent`` (equal
or not), and a segment with other than one effort-controlled joint -> ``independent`` (its
region is checked over the box of per-contact intervals, planner.plan.polytope).  Hand files
have no friction groups: a group is refused with the key named, never planned as ``common``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.errors import FileFormatError
from planner.files.hand_file import hand_file_from_dict
from planner.plan.hand_planner import default_mu_model
from planner.plan.plan_file import load_plan
from qsplan.cli import main

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


@pytest.mark.parametrize("mu,model", [
    ((0.0, 0.2), "common"), (0.3, "common"), ([(0.0, 0.2)] * 4, "independent"),
    ([(0.0, 0.2), (0.0, 0.1)], "independent"), ([[0.3, 0.5], [0.3, 0.5]], "independent"),
])
def test_default_model_follows_the_friction_description(mu, model):
    assert default_mu_model(mu) == model


def test_equal_per_contact_intervals_are_planned_and_recorded_independent(tmp_path, capsys):
    """Four intervals, one per contact, all [0, 0.2]: each contact's coefficient on its own."""
    out = tmp_path / "p.json"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2,0:0.2,0:0.2,0:0.2", "--waypoints", "3",
               "--out", str(out)])
    assert rc == 0
    assert json.loads(out.read_text())["mu"]["model"] == "independent"
    assert "mu independent [0, 0.2]" in capsys.readouterr().out
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2", "--waypoints", "3", "--out",
               str(tmp_path / "c.json")])
    assert rc == 0 and load_plan(tmp_path / "c.json").mu_model == "common"


def test_two_effort_joints_record_the_box(tmp_path):
    """three_finger_hand drives one of three joints: two effort-controlled joints, a region
    checked over the box, so the plan says independent although one interval was given."""
    out = tmp_path / "p.json"
    assert main(["plan", "three_finger_hand", "--waypoints", "3", "--out", str(out)]) == 0
    plan = load_plan(out)
    assert len(plan.segments[0].effort_joints) == 2
    assert plan.mu_model == "independent" and plan.mu_intervals == ((0.0, 0.1),)


@pytest.mark.parametrize("change,match", [
    (lambda d: d.update(friction={"table": [0.3, 0.5]}), "hand: unknown key 'friction'"),
    (lambda d: d["contacts"][0].update(mu="table"), r"contacts\[0\]: unknown key 'mu'"),
])
def test_friction_groups_in_a_hand_file_are_refused(change, match):
    d = json.loads((DATA / "table_push_hand.json").read_text())
    change(d)
    with pytest.raises(FileFormatError, match=match):
        hand_file_from_dict(d)
