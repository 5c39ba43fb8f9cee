"""A short two-finger push planned over a mass / centre-of-mass set, shared by the tests of
validation at the set's points and of what each uncertainty costs.

The shipped ``two_finger_hand`` (the fingers push the pentagon left on the palm, claim
``S+1 S+2 S-3 S-4``) cut to 2 s and 9 waypoints, with an ``uncertainty`` section: by hand, the
planner's prediction at the commands stays the claim alone for the centre of mass 5 mm and the
mass 20 % either way, and the pentagon tips (``B1 S+2 R3 S-4``, or no quasistatic mode at all)
once its centre of mass is 15 mm higher or lower (``tests/planner/test_set_points.py`` checks
both at every waypoint)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from scenarios.registry import DATA_DIR

#: mass +-20 %, centre of mass +-5 mm in x and y.
FULL_SET = {"mass": [0.08, 0.12], "com": [[0.015, 0.025], [0.0135, 0.0235]]}


def short_push(section: dict[str, Any] | None) -> dict[str, Any]:
    """The hand file's content with ``section`` as its ``uncertainty`` (None: none)."""
    d = json.loads((DATA_DIR / "two_finger_hand.json").read_text())
    if section is not None:
        d["uncertainty"] = section
    d["segment"]["max_time"] = 2.0
    d["segment"]["waypoints"] = 9
    return d


def planned(tmp: Path, section: dict[str, Any] | None, name: str = "push") -> Path:
    """Plan :func:`short_push` (friction-only margins skipped: no bisection) into
    ``tmp/<name>_plan.json``; returns its path."""
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan

    hand = tmp / f"{name}.json"
    hand.write_text(json.dumps(short_push(section)))
    out = tmp / f"{name}_plan.json"
    save_plan(plan_hand(hand, margins=False), out)
    return out
