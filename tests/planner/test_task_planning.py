"""Whole tasks: goals in hand files, the task search, plan files of several segments."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from planner.errors import FileFormatError
from planner.files.hand_file import hand_file_from_dict, load_hand_file
from planner.files.schema import load_schema
from planner.model.modes import Mode
from planner.plan.hand_planner import plan_hand
from planner.plan.partition import joint_inputs
from planner.plan.plan_file import load_plan, plan_from_dict, save_plan
from planner.predict.feasibility import feasible_modes

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"
TASK = DATA / "figure9_task_hand.json"


@pytest.fixture(scope="module")
def task_plan(figure9_plan):
    return figure9_plan


@pytest.fixture(scope="module")
def small_plan():
    """The same task at 5 waypoints a segment: the file-format checks need its shape, not the
    default spacing (planned in a third of the time)."""
    return plan_hand(TASK, waypoints=5)


@pytest.fixture(scope="module")
def task_json(small_plan, tmp_path_factory):
    path = save_plan(small_plan, tmp_path_factory.mktemp("task") / "plan.json")
    return path


@pytest.mark.long
def test_the_figure_9_task_reaches_its_goal_in_three_4s_segments(task_plan):
    hf = load_hand_file(TASK)
    assert task_plan.reached and task_plan.diagnosis is None
    assert len(task_plan.segments) == 3
    assert all(Mode.parse(s.claim).family == "4S" for s in task_plan.segments)
    assert [s.event.kind for s in task_plan.segments] == ["new contact", "lost contact", "goal"]
    assert task_plan.segments[0].event.detail == "vertex 4 meets the left finger"
    assert task_plan.segments[1].event.detail == ("vertex 3 runs off the left finger at its tip "
                                                  "end")
    # segment 1 ends edge-to-edge: vertex 4 joins vertex 3 on the left finger's side
    assert {"kind": "side", "vertex": 4, "finger": 0, "side": -1} in task_plan.contacts[1]
    assert task_plan.released[1] == ({"kind": "palm", "vertex": 0},)  # segment 2 lifts it
    last = task_plan.segments[-1].waypoints[-1]
    assert hf.goal is not None
    assert hf.goal.pose_reached(np.array([*last.pose, *last.angles]))
    hand = task_plan.segments[-1].hand_model.hand
    assert not hf.goal.missing_contacts(hand.contacts)
    # the chain is continuous: each segment starts where the previous one ended
    for a, b in zip(task_plan.segments, task_plan.segments[1:]):
        end = np.array([*a.waypoints[-1].pose, *a.waypoints[-1].angles])
        start = np.array([*b.waypoints[0].pose, *b.waypoints[0].angles])
        assert np.allclose(end, start, atol=1e-6)


@pytest.mark.long
@pytest.mark.parametrize("k", [0, 1, 2])
def test_the_commanded_torques_guarantee_the_claim_on_a_friction_grid(task_plan, k):
    """Independent check: at waypoints of segment k, the commanded torque with mu anywhere in
    [0, 0.2] (common) leaves the claimed mode the only feasible one (eqs. 13-32)."""
    seg = task_plan.segments[k]
    hand = seg.hand_model.hand
    V = tuple(j for j, c in enumerate(seg.control) if c == "velocity")
    for w in seg.waypoints[::5]:
        q = np.array([*w.pose, *w.angles])
        joints = joint_inputs(hand, V, w.velocity_commands)
        for j, tau in zip([j for j, c in enumerate(seg.control) if c == "effort"],
                          w.torque_commands):
            joints[j] = {"effort": tau}
        for mu in np.linspace(0.0, 0.2, 5):
            pred = feasible_modes(hand.system(q, mu, joints))
            labels = {m.mode.label for m in pred.modes}
            assert labels == {seg.claim}, (w.t, mu, labels)


def test_a_task_plan_round_trips_and_validates(small_plan, task_json):
    back = load_plan(task_json)
    assert len(back.segments) == 3
    assert [s.claim for s in back.segments] == [s.claim for s in small_plan.segments]
    assert np.allclose(back.start_times(), small_plan.start_times())
    assert back.contacts == small_plan.contacts and back.released == small_plan.released
    doc = json.loads(task_json.read_text())
    assert doc["version"] == 3
    schema = load_schema("plan")
    registry = None
    try:
        from referencing import Registry, Resource
        registry = Registry().with_resource(
            "https://qsplan.example/schemas/hand.schema.json",
            Resource.from_contents(load_schema("hand")))
    except ImportError:  # pragma: no cover
        pass
    validator = jsonschema.Draft202012Validator(schema, registry=registry)
    assert [e.message for e in validator.iter_errors(doc)] == []


def test_a_tampered_task_plan_is_refused(task_json):
    doc = json.loads(task_json.read_text())
    doc["segments"][1]["waypoints"][3]["torque_commands"][0] += 1.0
    with pytest.raises(FileFormatError, match="digest mismatch"):
        plan_from_dict(doc)


def test_old_plan_files_still_load():
    old = ROOT / "tests" / "data" / "plan_v1_two_finger.json"  # written by version 1
    raw = json.loads(old.read_text())
    task = load_plan(old)
    assert len(task.segments) == 1 and task.reached
    assert task.segments[0].claim == raw["claim"]
    assert task.segments[0].torques()[:, 0].tolist() == [w["torque_command"]
                                                         for w in raw["waypoints"]]


@pytest.mark.parametrize("goal,message", [
    ({}, "goal: expected 'pose', 'contacts' or both, got neither"),
    ({"pose": [0, 0]}, r"goal.pose: expected \[x, y, phi\]"),
    ({"pose": [0, 0, 0], "tolerance": {"angle": 0}}, "goal.tolerance.angle: expected a positive"),
    ({"contacts": [{"kind": "palm", "vertex": 9}]}, r"goal.contacts\[0\].vertex"),
    ({"pose": [0, 0, 0], "max_segments": 0}, "goal.max_segments: expected an integer in"),
    ({"pose": [0, 0, 0], "speed": 1}, "goal: unknown key 'speed'"),
])
def test_goal_errors_name_the_field(goal, message):
    data = json.loads(TASK.read_text())
    data["goal"] = goal
    with pytest.raises(FileFormatError, match=message):
        hand_file_from_dict(copy.deepcopy(data), "t")


@pytest.mark.long
def test_qsplan_plan_writes_the_one_plan_model_for_any_hand(tmp_path):
    out = tmp_path / "p.json"
    r = subprocess.run([sys.executable, "-m", "qsplan.cli", "plan", "three_finger_hand",
                        "--out", str(out)], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    plan = load_plan(out)
    assert plan.segments[0].control.count("effort") == 2  # 5S: |tau_I| = 2
    # the file asks for 11; the segment ends one waypoint before its top finger's fold
    # (docs/planning.md, "Segment ends before the rates diverge")
    assert len(plan.segments[0].waypoints) == 10
    assert "(1 segment(s), 10 waypoints" in r.stdout
    assert "near a singular configuration: the top finger would need" in r.stdout


@pytest.mark.long
def test_qsplan_plan_writes_a_partial_plan_and_exits_1(tmp_path):
    out = tmp_path / "partial.json"
    r = subprocess.run([sys.executable, "-m", "qsplan.cli", "plan", "figure9_task_hand",
                        "--mu", "0:1", "--max-expansions", "1", "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "goal reached: False" in r.stdout and "stops short of the goal" in r.stdout
    assert "widest friction interval that would work there: [0, 0." in r.stdout
    assert ": :" not in r.stdout and "furthest try: " in r.stdout
    plan = load_plan(out)  # the partial plan says where and why, and keeps it through its file
    assert not plan.reached
    d = plan.diagnosis
    assert d is not None and d["failed"] is not None
    assert "no guaranteed effort" in d["failed"]["why"]
    assert "the workpiece moves" in d["failed"]["what"]  # which way, in plain words
    lo, hi = d["failed"]["widest_mu"]
    assert all(x == 0.0 for x in lo) and 0.2 < hi[0] < 1.0  # narrower than asked, wider than 0.2
    assert load_plan(save_plan(plan, tmp_path / "again.json")).diagnosis == json.loads(
        json.dumps(d))


def _mutations(doc):
    """(name, mutated copy) pairs: every top-level and segment key deleted or of a wrong type."""
    from planner.plan.plan_file import digest

    def signed(d):
        d["digest"] = {"algorithm": "sha256",
                       "value": digest({k: v for k, v in d.items() if k != "digest"})}
        return d

    out = []
    for key in doc:
        if key == "digest":
            continue
        for bad in (None, 7, "x", [], {}):
            d = copy.deepcopy(doc)
            d[key] = bad
            out.append((f"{key}={bad!r}", signed(d)))
        d = copy.deepcopy(doc)
        del d[key]
        out.append((f"no {key}", signed(d)))
    for key in doc["segments"][0]:
        for bad in (None, 7, "x", [], {}):
            d = copy.deepcopy(doc)
            d["segments"][0][key] = bad
            out.append((f"segments[0].{key}={bad!r}", signed(d)))
    d = copy.deepcopy(doc)
    d["segments"][1]["waypoints"][0]["torque_commands"] = [1.0, 2.0]
    out.append(("two torques for one effort joint", signed(d)))
    d = copy.deepcopy(doc)
    d["segments"][1]["waypoints"][0]["bands"] = []
    out.append(("no band for the effort joint", signed(d)))
    return out


def test_every_broken_version_2_plan_is_refused_with_a_file_format_error(task_json):
    doc = json.loads(task_json.read_text())
    cases = _mutations(doc)
    assert len(cases) > 80
    for name, d in cases:
        try:
            plan_from_dict(d)
        except FileFormatError:
            continue
        # only harmless edits may load: free content, or an equivalent value
        assert name.startswith(("extra={}", "notes='x'", "policy='x'", "diagnosis=None",
                                "segments[0].released=[]", "segments[0].notes='x'",
                                "segments[0].extra={}")), name


def test_a_segment_stops_at_the_goal_and_events_change_the_contact_set():
    from planner.plan.task_contacts import after_event, with_contacts
    from planner.plan.trajectory import integrate_segment
    from planner.plan.wording import contact_words

    hf = load_hand_file(DATA / "two_finger_hand.json")
    full = integrate_segment(hf.hand, hf.q0, drive=1, speed=0.02, mode="4S", max_time=60.0,
                             steps=120)
    assert full.event.kind == "new contact"
    x_goal = 0.5 * (full.q[0, 0] + full.q[-1, 0])
    cut = integrate_segment(hf.hand, hf.q0, drive=1, speed=0.02, mode="4S", max_time=60.0,
                            steps=120, stop=lambda q: q[0] <= x_goal)
    assert cut.event.kind == "goal" and abs(cut.q[-1, 0] - x_goal) < 1e-6
    assert cut.duration < full.duration
    after = after_event(hf.hand, full.q[-1], full.event.kind)
    names = [contact_words(hf.hand, c) for c in after]
    assert names == ["vertex 0 on the palm", "vertex 1 on the palm", "vertex 3 on the left finger",
                     "the right finger's tip on edge 1",
                     "vertex 4 on the left finger"]  # edge-to-edge: a 2nd vertex
    assert np.allclose(with_contacts(hf.hand, after).gaps(full.q[-1]), 0.0, atol=1e-8)
