"""``qsplan plan`` + ``qsplan validate`` on hands other than the shipped two-finger task
(random variants of the shipped hands, ``planner.sweeps.random_hands``):

* a hand file with one driven joint written as a list (``"drive": [1]``) is planned;
* per-contact friction intervals are what the file describes, so ``--model independent`` is the
  default there;
* a plan's ``mu.validate`` values lie inside the planned box, also when the plan was made for
  another interval (``--mu``) than the hand file's, and a plan over per-contact intervals that
  share no coefficient is validated at its corners and centre (per-contact values, ``a/b/c`` on
  the command line);
* a task plan's segment with two velocity- (or effort-) controlled joints drives each joint
  with its own command: driven with the first joint's command, the two-link finger (proximal
  0.02 rad/s, distal 0.01) ends 17 % of its travel off the plan in both engines and the
  three-finger hand loses every contact.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.model.validation import validation_frictions
from planner.plan.plan_file import load_plan
from qsplan.cli import main
from scenarios.registry import DATA_DIR
from sim.schedule import SegmentSchedule


def test_validation_frictions_stay_inside_the_planned_box() -> None:
    lo, hi = np.full(4, 0.0), np.full(4, 0.2)
    assert validation_frictions([0.0, 0.1, 0.2, 0.3], lo, hi) == (0.0, 0.1, 0.2)
    assert validation_frictions([0.5], lo + 0.1, hi + 0.1) == pytest.approx((0.1, 0.2, 0.3))
    assert validation_frictions([], lo, hi) == (0.0, 0.1, 0.2)
    lo2, hi2 = np.array([0.0, 0.3]), np.array([0.1, 0.5])  # no common coefficient
    assert validation_frictions([0.1], lo2, hi2) == ((0.0, 0.3), (0.05, 0.4), (0.1, 0.5))
    assert validation_frictions([(0.05, 0.45)], lo2, hi2) == ((0.05, 0.45),)


@pytest.mark.long
def test_a_two_link_finger_task_plan_drives_each_joint_with_its_own_command(tmp_path) -> None:
    plan_path = tmp_path / "plan.json"
    assert main(["-q", "plan", "two_link_finger_hand", "--waypoints", "6",
                 "--out", str(plan_path)]) == 0
    plan = load_plan(plan_path)
    seg = plan.segments[0]
    sched = SegmentSchedule.from_segment(seg, 4)
    rates = sched.commands[:, [c == "velocity" for c in sched.controls]]
    assert np.allclose(rates, [[0.02, 0.01]] * len(seg.waypoints))  # the file's two rates
    out = tmp_path / "val"
    assert main(["-q", "validate", str(plan_path), "--engine", "pymunk", "--mu", "0.1",
                 "--no-render", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "agreed"


@pytest.mark.long
def test_per_contact_intervals_plan_and_validate_per_contact(tmp_path, capsys) -> None:
    plan_path = tmp_path / "plan.json"
    ivs = "0.0:0.05,0.1:0.15,0.1:0.2,0.0:0.2"  # the file's 0, 0.1, 0.2: none in every interval
    assert main(["-q", "plan", "two_finger_hand", "--mu", ivs, "--waypoints", "6",
                 "--out", str(plan_path)]) == 0
    data = json.loads(plan_path.read_text())
    assert data["mu"]["model"] == "independent"  # the default for per-contact intervals
    assert np.allclose(data["mu"]["validate"], [[0.0, 0.1, 0.1, 0.0],
                                                [0.025, 0.125, 0.15, 0.1],
                                                [0.05, 0.15, 0.2, 0.2]])
    assert main(["validate", str(plan_path), "--engine", "pymunk", "--no-render",
                 "--mu", "0.05/0.1/0.15/0.1"]) == 0
    assert "mu=0.05/0.1/0.15/0.1: AGREED" in capsys.readouterr().out
    assert main(["validate", str(plan_path), "--engine", "pymunk", "--mu", "0.05/0.1"]) == 2
    assert "expected 4 coefficients (one per contact)" in capsys.readouterr().err
    for bad, msg in [("0.1/", "joined by '/'"), ("0.1/x/0.1/0.1", "got 'x' in")]:
        assert main(["validate", str(plan_path), "--mu", bad]) == 2
        assert msg in capsys.readouterr().err


def test_one_driven_joint_may_be_written_as_a_list(tmp_path) -> None:
    hand = json.loads((DATA_DIR / "two_finger_hand.json").read_text())
    hand["segment"]["drive"] = [hand["segment"]["drive"]]
    hand["segment"]["speed"] = [hand["segment"]["speed"]]
    path = tmp_path / "hand.json"
    path.write_text(json.dumps(hand))
    assert main(["-q", "plan", str(path), "--waypoints", "5",
                 "--out", str(tmp_path / "p.json")]) == 0
    plan = load_plan(tmp_path / "p.json")
    assert len(plan.segments) == 1 and plan.segments[0].control == ("effort", "velocity")
