"""The Figure 9 task mirrored about the world ``y`` axis (a hand nobody tuned anything on):
the task search must find the mirror image of the shipped plan -- every sliding sign flipped
(the contact tangents ``t = rot90(n)`` turn round under a reflection), the same segment
events -- and the mirrored plan must hold in simulation."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.plan.hand_planner import plan_hand
from planner.sweeps.random_hands import mirror_hand
from scenarios.runs import validate_plan
from sim.verdict import Outcome

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


def flip(label: str) -> str:
    return label.replace("S+", "S#").replace("S-", "S+").replace("S#", "S-")


@pytest.fixture(scope="module")
def plans(tmp_path_factory, figure9_plan):
    original = figure9_plan
    path = tmp_path_factory.mktemp("mirror") / "figure9_mirrored.json"
    path.write_text(json.dumps(mirror_hand(json.loads(
        (DATA / "figure9_task_hand.json").read_text()))))
    return original, plan_hand(path)


@pytest.mark.long
def test_the_mirrored_task_is_the_mirror_image_of_the_plan(plans):
    original, mirrored = plans
    assert mirrored.reached and original.reached
    assert [s.claim for s in mirrored.segments] == [flip(s.claim) for s in original.segments]
    assert [s.event.kind for s in mirrored.segments] == \
        [s.event.kind for s in original.segments]
    end_o = original.segments[-1].waypoints[-1].pose
    end_m = mirrored.segments[-1].waypoints[-1].pose
    assert end_m[0] == pytest.approx(-end_o[0], abs=1e-4)
    assert end_m[1] == pytest.approx(end_o[1], abs=1e-4)
    assert end_m[2] == pytest.approx(-end_o[2], abs=1e-3)


@pytest.mark.long
def test_the_mirrored_task_holds_in_pymunk(plans):
    _, mirrored = plans
    run = validate_plan(mirrored, "pymunk", 0.1)
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reasons
