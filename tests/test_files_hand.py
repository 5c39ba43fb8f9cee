"""Hand files (planner/files/hand_file.py): unknown and missing keys, unsupported fingers, the
segment and mu sections, documented defaults, and the plan's hand parsed once."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.files.hand_file import (
    FINGER_MASS,
    SEGMENT_DEFAULTS,
    WORKPIECE_MASS,
    HandSetup,
    hand_file_from_dict,
    hand_from_dict,
    hand_from_plan,
    load_hand,
    load_hand_file,
)
from scenarios.registry import DATA_DIR

HAND_FILE = DATA_DIR / "two_finger_hand.json"
BASE = json.loads(HAND_FILE.read_text())


def _hand(mutate):
    d = copy.deepcopy(BASE)
    mutate(d)
    return d


def test_shipped_hand_loads_with_every_section():
    hf = load_hand_file(HAND_FILE)
    assert hf.hand.n_fingers == 2 and hf.hand.n_contacts == 4
    assert hf.segment is not None and hf.segment.drive == 1 and hf.segment.mode == "4S"
    assert hf.segment.waypoints == 41 and hf.segment.steps == SEGMENT_DEFAULTS["steps"]
    assert hf.mu_interval == ((0.0, 0.2),) and hf.validate_mu == (0.0, 0.1, 0.2)
    assert np.max(np.abs(hf.hand.gaps(hf.q0))) < 1e-12
    hand, q0, data = load_hand(HAND_FILE)  # the tuple form kept for callers
    np.testing.assert_array_equal(q0, hf.q0)
    assert data == BASE


@pytest.mark.parametrize("finger,match", [
    ({"type": "prismatic"}, r"fingers\[1\]\.type: expected \"revolute\" for a single-link finger "
                            r"\(a prismatic joint goes in \"links\": \[...\]\), got 'prismatic'"),
    ({"type": 1}, r"fingers\[1\]\.type: expected \"revolute\" .* got 1"),
    ({"links": [{"length": 0.05}, {"length": 0.05}]}, r"fingers\[1\]: unknown key"),
    ({"links": {"length": 0.05}}, r"fingers\[1\]: unknown key"),
])
def test_malformed_fingers_are_refused(finger, match):
    d = _hand(lambda d: d["fingers"][1].update(finger))
    with pytest.raises(InputError, match=match):
        hand_from_dict(d)


def test_hand_from_plan_is_the_typed_boundary():
    setup = hand_from_plan(BASE)
    assert isinstance(setup, HandSetup)
    hand, q0 = setup  # a NamedTuple: unpacks like the old (hand, q0)
    assert hand.n_fingers == 2 and q0.shape == (5,)
    with pytest.raises(FileFormatError, match="plan.hand: fingers\\[0\\].type: expected"):
        hand_from_plan(_hand(lambda d: d["fingers"][0].update(type="prismatic")))


@pytest.mark.parametrize("finger,key,value", [(0, "width", 1e308), (1, "pivot", [1e308, 0.0])])
def test_extreme_geometry_is_a_documented_error(finger, key, value, recwarn):
    """Found by benchmarks/robustness_table.py (plan campaign): Newton left the float range and
    math.cos raised a bare ValueError. Now a FileFormatError, and no numpy warning printed."""
    d = _hand(lambda d: d["fingers"][finger].update({key: value}))
    with pytest.raises(FileFormatError, match="initial configuration: close: Newton diverged"):
        hand_from_dict(d)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
