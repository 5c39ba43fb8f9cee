"""Hands written by a user in the shipped format validate without a start crash, and a plan
whose torque lies outside its band is a disagreement (the rival mode it showed), not a fault.

The mirrored hand is the shipped two-finger hand reflected in the y axis (x -> -x): the palm
edge and the polygon are reversed to stay counter-clockwise, finger angles become pi - angle,
a finger-side contact changes side, the load and the drive speed change sign. Its fingertip
touches an edge that :meth:`planner.model.hand.Hand.close` closes to a computed gap of about
+1e-17 m, which without a pre-load is no contact at all in either engine.
"""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

from planner.files.hand_file import hand_from_dict
from scenarios.registry import DATA_DIR
from sim.run import FaultKind
from sim.verdict import Outcome

HAND_FILE = DATA_DIR / "two_finger_hand.json"


def mirrored(data: dict) -> dict:
    m = json.loads(json.dumps(data))
    m["name"] = "mirrored_hand"
    a, b = data["palm"]["edge"]
    m["palm"]["edge"] = [[-b[0], b[1]], [-a[0], a[1]]]
    for f in m["fingers"]:
        f["pivot"] = [-f["pivot"][0], f["pivot"][1]]
        f["angle"] = math.pi - f["angle"]
    V = data["workpiece"]["vertices"]
    n = len(V)
    m["workpiece"]["vertices"] = [[-x, y] for x, y in reversed(V)]
    m["workpiece"]["com"] = [-data["workpiece"]["com"][0], data["workpiece"]["com"][1]]
    for c in m["contacts"]:
        if "vertex" in c:
            c["vertex"] = n - 1 - c["vertex"]
        if "edge" in c:
            c["edge"] = n - 2 - c["edge"]
        if "side" in c:
            c["side"] = -c["side"]
    m["load"]["force"] = [-data["load"]["force"][0], data["load"]["force"][1]]
    m["segment"]["speed"] = -data["segment"]["speed"]
    return m


@pytest.fixture(scope="module")
def mirrored_plan(tmp_path_factory):
    from planner.plan.hand_planner import plan_hand

    path = tmp_path_factory.mktemp("hand") / "mirrored_hand.json"
    path.write_text(json.dumps(mirrored(json.loads(HAND_FILE.read_text()))))
    return plan_hand(path, mu=(0.0, 0.2), policy="midband", waypoints=6).segments[0]


@pytest.fixture(scope="module")
def shipped_plan():
    from planner.plan.hand_planner import plan_hand

    return plan_hand(HAND_FILE, mu=(0.0, 0.2), policy="midband").segments[0]


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_the_pre_load_is_what_makes_the_mirrored_hand_start(mirrored_plan, engine):
    """Built exactly touching (overlap 0) the mirrored hand's contacts are missing at the
    first step; with the scene-scaled pre-load they all touch."""
    from sim.backends import make_backend
    from sim.run import RunSettings, run_scene
    from sim.scenes.hand import hand_scene
    from sim.settings import SceneKind, settings_for
    from sim.similarity import scaled_masses

    hand, q0 = hand_from_dict(mirrored_plan.hand)
    es = settings_for(SceneKind.HAND, engine)
    settings = RunSettings(duration=0.01, dt=es.dt, slip_speed=1e-4, penetration_tol=1e-3)

    def scene(**kw):
        return scaled_masses(hand_scene(hand, q0, 0.1, ["effort", "velocity"],
                                        [lambda t, s: 0.0, lambda t, s: 0.0], **kw),
                             es.mass_scale)

    bare = run_scene(scene(overlap=0.0), make_backend(engine, es), settings)
    assert bare.fault is not None and bare.fault.kind is FaultKind.CONTACT_LOST_AT_START
    loaded = run_scene(scene(), make_backend(engine, es), settings)
    assert loaded.fault is None and loaded.present[0].all()


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
@pytest.mark.long
def test_mirrored_hand_validates_without_a_start_crash(mirrored_plan, engine):
    from scenarios.runs import validate_plan

    assert mirrored_plan.claim == "S-1 S-2 S+3 S+4"  # the mirror image of the shipped 4S
    v = validate_plan(mirrored_plan, engine, 0.1, waypoints=4).verdict
    assert v.fault is None or v.fault.kind is not FaultKind.CONTACT_LOST_AT_START
    assert v.outcome is Outcome.AGREED, v.reasons


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
@pytest.mark.long
def test_torque_outside_the_band_disagrees(shipped_plan, engine):
    """The effort joint's torque reversed (far outside the 4S band): the fingers lose the
    workpiece, which escapes (pymunk: it leaves the scene; MuJoCo: it is pushed into a
    finger). The run left the plan before that, so the verdict is a disagreement naming what
    was observed, with the fault as the event that ended the run -- not exit 3."""
    from scenarios.runs import validate_plan

    plan = dataclasses.replace(shipped_plan, waypoints=tuple(
        dataclasses.replace(w, torque_commands=tuple(-x for x in w.torque_commands))
        for w in shipped_plan.waypoints))
    v = validate_plan(plan, engine, 0.1, waypoints=8, expect="disagree").verdict
    assert v.outcome is Outcome.DISAGREED, v.reasons
    assert v.fault is not None and v.fault.kind in (FaultKind.LEFT_SCENE,
                                                    FaultKind.PENETRATION)
    assert "left the plan" in v.reason
