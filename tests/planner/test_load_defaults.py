"""Defaults reproduce the friction-only plans bit for bit: every shipped hand file planned as it
is and with an ``uncertainty`` section holding only the nominal mass and centre of mass gives the
same segments (claims, control, exact flags, every waypoint's commands, bands and margins), and a
file without the section gets no ``extra.uncertainty`` (docs/planning.md, "Uncertainty beyond
friction")."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.files.hand_file import hand_file_from_dict
from planner.plan.hand_planner import plan_hand
from planner.plan.plan_file import plan_body

ROOT = Path(__file__).resolve().parents[2]
#: Planned in the default run (a few seconds each); every other shipped hand is marked long,
#: those taking 15 s and more on two shared cores (and the flip, about 15 min) slow: by hand.
QUICK = ["scenarios/data/prismatic_finger_hand.json", "scenarios/data/table_push_hand.json"]


def _by_hand(rel: str, why: str = "15-35 s") -> object:
    return pytest.param(rel, marks=pytest.mark.slow, id=f"{Path(rel).stem} ({why}: by hand)")


LONG = [_by_hand("scenarios/data/three_finger_hand.json"), "scenarios/data/two_finger_hand.json",
        _by_hand("scenarios/data/two_link_finger_hand.json"),
        _by_hand("tests/data/triangle_apex_hand.json"),
        _by_hand("scenarios/data/block_tilting.json"), "scenarios/data/box_pivot_down.json",
        _by_hand("scenarios/data/box_pivot_up.json"),
        _by_hand("scenarios/data/figure9_task_hand.json"),
        _by_hand("scenarios/data/flip_against_wall.json", "about 15 min"),
        _by_hand("tests/data/hexagon_hand.json"), "tests/data/hexagon_hand_plain.json"]


def nominal_section(data: dict) -> dict:
    wp = data["workpiece"]
    m = wp.get("mass", 0.1)
    cx, cy = wp.get("com", [0.0, 0.0])
    return {"mass": [m, m], "com": [[cx, cx], [cy, cy]]}


def check_same(rel: str) -> None:
    data = json.loads((ROOT / rel).read_text())
    if "segment" not in data and "goal" not in data:
        pytest.skip(f"{rel}: nothing to plan")
    plain = plan_hand(ROOT / rel)
    with_section = dict(data, uncertainty=nominal_section(data))
    hf = hand_file_from_dict(with_section)
    assert hf.hand.load_set is not None and hf.hand.load_set.trivial
    nominal = plan_hand(hf, margins=False)
    a, b = plan_body(plain), plan_body(nominal)
    assert "uncertainty" not in a["extra"]
    for key in ("segments", "reached", "diagnosis", "mu", "policy"):
        assert a[key] == b[key], key


@pytest.mark.parametrize("rel", QUICK)
def test_nominal_section_reproduces_plans(rel):
    check_same(rel)


@pytest.mark.long
@pytest.mark.parametrize("rel", LONG)
def test_nominal_section_reproduces_every_shipped_plan(rel):
    check_same(rel)
