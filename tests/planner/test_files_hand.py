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


def test_an_explicit_revolute_type_is_fine():
    d = _hand(lambda d: d["fingers"][0].update(type="revolute"))
    assert hand_from_dict(d).hand.n_fingers == 2


@pytest.mark.parametrize("mutate,match", [
    (lambda d: d.update(palms={}), "hand: unknown key 'palms'"),
    (lambda d: d["palm"].update(normal=[0, 1]), "palm: unknown key 'normal'"),
    (lambda d: d["fingers"][0].update(lenght=0.1), r"fingers\[0\]: unknown key 'lenght'"),
    (lambda d: d["workpiece"].update(velocity=[0, 0]), "workpiece: unknown key 'velocity'"),
    (lambda d: d["contacts"][3].update(vertex=1), r"contacts\[3\] \(tip\): unknown key 'vertex'"),
    (lambda d: d["contacts"][0].update(sides=1), r"contacts\[0\]: unknown key 'sides'"),
    (lambda d: d["load"].update(torque=0.1), "load: unknown key 'torque'"),
    (lambda d: d["segment"].update(sped=1), "segment: unknown key 'sped'"),
    (lambda d: d["mu"].update(intervals=[0, 1]), "mu: unknown key 'intervals'"),
    (lambda d: d.pop("contacts"), "hand: expected key 'contacts'"),
    (lambda d: d["fingers"][0].pop("angle"), r"fingers\[0\]: expected key 'angle'"),
    (lambda d: d["workpiece"].pop("pose"), "workpiece: expected key 'pose'"),
    (lambda d: d["contacts"][2].pop("finger"), r"contacts\[2\] \(side\): expected key 'finger'"),
    (lambda d: d["load"].pop("force"), "load: expected key 'force'"),
    (lambda d: d["segment"].pop("drive"), "segment: expected key 'drive'"),
    (lambda d: d["segment"].update(drive=2), r"segment.drive: expected an integer in \[0, 1\]"),
    (lambda d: d["segment"].update(speed=0), "segment.speed: expected a non-zero rate"),
    (lambda d: d["segment"].update(speed="fast"), "segment.speed: expected a finite number, "
                                                  "got the string 'fast'"),
    (lambda d: d["segment"].update(mode=4), "segment.mode: expected a string, got the number 4"),
    (lambda d: d["segment"].update(waypoints=1), r"segment.waypoints: expected an integer >= 2"),
    (lambda d: d["segment"].update(max_time=-1), "segment.max_time: expected a positive number"),
    (lambda d: d["mu"].update(interval=[0.3, 0.1]), "mu.interval: expected lo <= hi"),
    (lambda d: d["mu"].update(interval=[[0, 0.1]] * 3),
     r"mu.interval: expected \[lo, hi\] or 4 such pairs"),
    (lambda d: d["mu"].update(interval=[-0.1, 0.1]), "mu.interval: expected friction coefficients >= 0"),
    (lambda d: d["mu"].update(validate=0.1), "mu.validate: expected a list of numbers"),
    (lambda d: d["mu"].update(validate=[-1]), r"mu.validate\[0\]: expected a number >= 0"),
    (lambda d: d["workpiece"].update(pose={"x": 0}), "workpiece.pose: expected \\[x, y, phi\\]"),
    (lambda d: d["workpiece"].update(pose=[0, 0, None]), r"workpiece.pose\[2\]: expected a finite"),
    (lambda d: d["fingers"][0].update(name=7), r"fingers\[0\].name: expected a string"),
    (lambda d: d["contacts"][2].update(side=True), r"contacts\[2\].side: expected \+1 or -1"),
    (lambda d: d.update(version=True), "expected format 'qsplan-hand' version 1"),
    (lambda d: d["workpiece"].update(vertices=[[0, 0], [1, 0], [0, 1], [1, 1]]),
     "workpiece.vertices: expected a convex polygon"),
])
def test_hand_file_errors_name_the_key(mutate, match):
    with pytest.raises(FileFormatError, match=match) as info:
        hand_from_dict(_hand(mutate), source="hand file 'h.json'")
    assert str(info.value).startswith("hand file 'h.json': ")


def test_documented_defaults():
    d = _hand(lambda d: [d["fingers"][0].pop("mass"), d["workpiece"].pop("mass"),
                         d.pop("load"), d["segment"].pop("max_time"),
                         d["segment"].pop("waypoints"), d.pop("mu"), d["fingers"][1].pop("name")])
    hf = hand_file_from_dict(d)
    assert hf.hand.fingers[0].mass == FINGER_MASS and hf.hand.mass == WORKPIECE_MASS
    assert hf.hand.fingers[1].name == "finger2"
    np.testing.assert_array_equal(hf.hand.load_force, [0.0, 0.0])
    assert hf.segment is not None
    assert (hf.segment.max_time, hf.segment.waypoints) == (60.0, 41)
    assert hf.mu_interval is None and hf.validate_mu == ()
    no_segment = _hand(lambda d: d.pop("segment"))
    assert hand_file_from_dict(no_segment).segment is None


def test_side_defaults_to_plus_one():
    d = _hand(lambda d: d["contacts"][2].pop("side"))
    # +1 by default: the left finger's +1 face turns away from vertex 3, and the check says so
    with pytest.raises(FileFormatError, match='use "side": -1'):
        hand_file_from_dict(d)
    assert hand_file_from_dict(BASE).hand.contacts[2].side == -1


def test_free_keys_are_allowed():
    d = _hand(lambda d: [d["fingers"][0].update(note="x"), d["workpiece"].update(comment="y"),
                         d["contacts"][0].update(name="heel"), d["palm"].update(notes="z"),
                         d.update(reference="Trinkle & Zeng 1994")])
    assert hand_from_dict(d).hand.n_contacts == 4


def test_hand_from_plan_is_the_typed_boundary():
    setup = hand_from_plan(BASE)
    assert isinstance(setup, HandSetup)
    hand, q0 = setup  # a NamedTuple: unpacks as (hand, q0)
    assert hand.n_fingers == 2 and q0.shape == (5,)
    with pytest.raises(FileFormatError, match="plan.hand: fingers\\[0\\].type: expected"):
        hand_from_plan(_hand(lambda d: d["fingers"][0].update(type="prismatic")))


@pytest.mark.parametrize("finger,key,value", [(0, "width", 1e308), (1, "pivot", [1e308, 0.0])])
def test_extreme_geometry_is_a_documented_error(finger, key, value, recwarn):
    """Found by benchmarks/robustness_table.py (plan campaign): Newton left the float range and
    math.cos raised a bare ValueError. Now a FileFormatError, and no numpy warning printed: the
    contact whose features are astronomically apart at the start is named before closing."""
    d = _hand(lambda d: d["fingers"][finger].update({key: value}))
    with pytest.raises(FileFormatError, match=r"contact [34] \(.*\): expected its features to "
                       "touch at the start configuration"):
        hand_from_dict(d)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
