"""Hands of any shape: multi-link and prismatic fingers, environment surfaces.

The Jacobians are checked against finite differences of the gaps (eq. 5), the link geometry
against :class:`planner.model.kinematics.Chain`, and the shipped two-finger plan against the plan
recorded in ``tests/data/two_finger_plan_main.json`` by the single-effort planner (to a few ulps:
BLAS kernels differ by CPU): the one planner for any number of effort joints reproduces it.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.hand_file import hand_from_dict
from planner.plan.hand_planner import plan_hand

ROOT = Path(__file__).resolve().parents[2]
HAND_FILE = ROOT / "scenarios" / "data" / "two_finger_hand.json"
BASE = json.loads(HAND_FILE.read_text())
GOLDEN = json.loads((Path(__file__).parents[1] / "data" / "two_finger_plan_main.json").read_text())


def _variant(right: dict) -> dict:
    d = copy.deepcopy(BASE)
    d["fingers"][1] = right
    return d


RIGHT = BASE["fingers"][1]
TWO_LINK = _variant({"name": "right", "pivot": RIGHT["pivot"], "links": [
    {"type": "revolute", "length": 0.03, "width": 0.008, "position": RIGHT["angle"]},
    {"type": "revolute", "length": 0.0289, "width": 0.008, "position": 0.0},
]})
PRISMATIC = _variant({"name": "right", "pivot": RIGHT["pivot"], "links": [
    {"type": "prismatic", "length": 0.0589, "width": 0.008, "offset": RIGHT["angle"],
     "position": 0.0},
]})
REV_PRISM = _variant({"name": "right", "pivot": RIGHT["pivot"], "links": [
    {"type": "revolute", "length": 0.02, "width": 0.008, "position": RIGHT["angle"]},
    {"type": "prismatic", "length": 0.0389, "width": 0.008, "position": 0.0},
]})


def _same(value: object, golden: str) -> bool:
    """``value`` equals the golden ``repr`` to rounding: OpenBLAS picks its kernels by CPU
    (DYNAMIC_ARCH), so an AVX-512 machine rounds some sums differently from the AVX2 machine that
    recorded the file, and the planner's bisections carry that on (measured: 1e-15 relative at
    most, e.g. -0.003273973649354264 vs ...26). A real change of the plan moves these values by
    far more than 1e-12 relative. A band end that is zero up to rounding (+-1e-18 N m, against
    torques of 1e-4 to 1e-2 N m) is compared absolutely, to 1e-15 N m."""
    a, b = float(value), float(golden)
    return a == b or abs(a - b) <= 1e-12 * max(abs(a), abs(b)) + 1e-15


@pytest.mark.long
def test_shipped_plan_is_the_recorded_plan():
    plan = plan_hand(HAND_FILE, policy="midband").segments[0]  # the recorded plan's policy
    assert plan.control == ("effort", "velocity")
    assert len(plan.waypoints) == len(GOLDEN["waypoints"])
    for w, g in zip(plan.waypoints, GOLDEN["waypoints"]):
        assert _same(w.t, g["t"])
        (tau,), (rate,), (band,) = w.torque_commands, w.velocity_commands, w.bands
        assert _same(tau, g["torque_command"])
        assert _same(rate, g["velocity_command"])
        assert len(band) == len(g["band"])
        assert all(_same(x, y) for x, y in zip(band, g["band"]))
        assert list(w.predicted) == g["predicted"]
        assert len(w.angles) == len(g["angles"])
        assert all(_same(x, y) for x, y in zip(w.angles, g["angles"]))


def test_same_tells_one_ulp_from_a_real_change():
    assert _same(-0.0043125227106860335, "-0.004312522710686031")
    assert not _same(-0.0043125227106860335, "-0.004312522711")
    assert _same(-1.6182119435079146e-18, "-1.3046309058136773e-18")
    assert not _same(1e-13, "0.0")
    assert _same(float("inf"), "inf")


@pytest.mark.parametrize("data", [TWO_LINK, PRISMATIC, REV_PRISM],
                         ids=["two-link", "prismatic", "revolute-prismatic"])
def test_chain_fingers_close_and_keep_the_tip(data):
    setup = hand_from_dict(data)
    hand, q0 = setup
    assert hand.n_joints == 1 + len(data["fingers"][1]["links"])
    assert np.max(np.abs(hand.gaps(q0))) < 1e-12
    # The tip is where the single-link finger had it (the same contact closes nearby).
    ref_hand, ref_q = hand_from_dict(BASE)
    assert np.linalg.norm(hand.tip_centre(q0, 1) - ref_hand.tip_centre(ref_q, 1)) < 5e-3


@pytest.mark.parametrize("data", [TWO_LINK, PRISMATIC, REV_PRISM],
                         ids=["two-link", "prismatic", "revolute-prismatic"])
def test_gap_jacobian_matches_finite_differences(data):
    hand, q0 = hand_from_dict(data)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = q0 + 1e-3 * rng.standard_normal(q0.shape)
        G = hand.gap_jacobian(q)
        h = 1e-7
        fd = np.column_stack([(hand.gaps(q + h * e) - hand.gaps(q - h * e)) / (2 * h)
                              for e in np.eye(len(q))])
        np.testing.assert_allclose(G, fd, atol=1e-7)


def test_link_geometry_agrees_with_the_chain_kinematics():
    hand, q0 = hand_from_dict(REV_PRISM)
    f = hand.fingers[1]
    chain = f.chain()
    qf = q0[hand.joint_index(1):hand.joint_index(1) + f.n_joints]
    _, bodies = chain.frames(qf)
    for (start, d), body in zip(hand.links_at(q0, 1), bodies):
        np.testing.assert_allclose(start, body[:2, 2], atol=1e-15)
        np.testing.assert_allclose(d, body[:2, 0], atol=1e-15)


def test_side_contact_on_a_second_link_and_a_table_surface():
    d = copy.deepcopy(TWO_LINK)
    d["environment"] = [{"name": "table", "edge": [[-0.2, -0.3], [0.2, -0.3]]}]
    hand, q0 = hand_from_dict(d)
    assert hand.environment[0][0] == "table"
    names = hand.clearances(q0)
    assert names["vertex 0 - table"] == pytest.approx(0.3, abs=1e-12)  # 0.3 m above the table
    assert "vertex 2 - right link 1" in names and "vertex 2 - right link 0" in names


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d["fingers"][1]["links"][0].update(type="helical"),
     r"fingers\[1\]\.links\[0\]\.type: expected one of \('revolute', 'prismatic'\), "
     r"got 'helical'"),
    (lambda d: d["fingers"][1]["links"][1].pop("position"),
     r"fingers\[1\]\.links\[1\]: expected key 'position'"),
    (lambda d: d["fingers"][1].update(links=[]),
     r"fingers\[1\]\.links: expected a non-empty list, got \[\]"),
    (lambda d: d["fingers"][1].update(length=0.1), r"fingers\[1\]: unknown key 'length'"),
    (lambda d: d["contacts"][2].update(link=2), r"contacts\[2\]\.link: expected an integer"),
    (lambda d: d["contacts"].append({"kind": "surface", "vertex": 2, "surface": "floor"}),
     r"contacts\[4\]\.surface: expected an 'environment' list to refer to, got none"),
    (lambda d: d.update(environment=[{"name": "t", "edge": [[0, 0], [0, 0]]}]),
     r"environment\[0\]\.edge: expected two distinct points, got equal points"),
    (lambda d: d["segment"].update(drive=3), r"segment\.drive: expected an integer"),
    (lambda d: d["segment"].update(drive=[1, 2], speed=[0.1]),
     r"segment\.drive/speed: expected a joint index and a rate, or two lists of the same length, "
     r"got \[1, 2\] and \[0\.1\]"),
    (lambda d: d["segment"].update(drive=[1, 1], speed=[0.1, 0.0]),
     r"segment\.drive: expected distinct joints, got \[1, 1\]"),
    (lambda d: d["segment"].update(drive=[1, 2], speed=[0, 0.0]),
     r"segment\.speed: expected a non-zero rate"),
])
def test_chain_hand_errors_name_the_field(mutate, match):
    d = copy.deepcopy(TWO_LINK)
    mutate(d)
    with pytest.raises(InputError, match=match):
        hand_from_dict(d)


def test_segment_with_several_driven_joints():
    d = copy.deepcopy(TWO_LINK)
    d["segment"].update(drive=[1, 2], speed=[0.02, 0.0])
    from planner.files.hand_file import hand_file_from_dict
    hf = hand_file_from_dict(d)
    assert hf.segment.drives == (1, 2) and hf.segment.speeds == (0.02, 0.0)
    assert hf.segment.drive == 1 and hf.segment.speed == 0.02
