"""Inputs the command-line fuzz campaign found, each a plain test of what the loaders refuse.

A new finding goes here as a strict ``xfail`` whose reason names the owner and what the code
must do, until it is fixed (docs/robustness.md lists what is refused).  The ``HAND_FILE`` and
``PLAN_LOADER`` reasons are kept for such findings."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"

HAND_FILE = ("planner/files/hand_file.py (formats owner): validate the field at load time and "
             "raise FileFormatError naming it, expected vs got, exit 2")
PLAN_LOADER = ("planner/plan (plan-loader owner): load_plan must check the plan's internal "
               "consistency and refuse it (FileFormatError, exit 2)")


def _hand(tmp_path, base, edit):
    data = json.loads((DATA / base).read_text())
    edit(data)
    path = tmp_path / "hand.json"
    path.write_text(json.dumps(data))
    return path


def _plan_exit(path, capsys):
    from qsplan.cli import main

    code = main(["plan", str(path), "--out", str(path.with_suffix(".plan.json")),
                 "--waypoints", "3"])
    return code, capsys.readouterr().err


def test_hand_mode_label_of_unknown_letters_is_bad_input(tmp_path, capsys):
    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("mode", "XYZ"))
    code, err = _plan_exit(path, capsys)
    assert code == 2 and "segment.mode: expected a mode family of 4 contacts" in err, err
    assert "got 'XYZ'" in err, err


def test_hand_mode_label_of_the_wrong_length_is_bad_input(tmp_path, capsys):
    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("mode", "S+1 S+2 S-3 S-4 S5"))
    code, err = _plan_exit(path, capsys)
    assert code == 2 and "segment.mode: expected" in err and "expected 4 tokens" in err, err


def test_reversed_surface_edge_is_bad_input(tmp_path, capsys):
    def reverse(d):
        d["environment"][0]["edge"] = d["environment"][0]["edge"][::-1]

    code, err = _plan_exit(_hand(tmp_path, "table_push_hand.json", reverse), capsys)
    assert code == 2 and "environment[0].edge: expected the workpiece on the inward side" in err, err


def test_goal_without_contacts_is_bad_input(tmp_path):
    from planner.errors import InputError
    from planner.files.hand_file import load_hand_file

    path = _hand(tmp_path, "figure9_task_hand.json",
                 lambda d: d["goal"].__setitem__("contacts", []))
    with pytest.raises(InputError, match=r"goal.contacts: expected a non-empty list.*got \[\]"):
        load_hand_file(path)


def test_unbounded_segment_steps_are_bad_input(tmp_path):
    from planner.errors import InputError
    from planner.files.hand_file import load_hand_file

    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("steps", 10_000_000))
    with pytest.raises(InputError, match=r"segment.steps: expected at most 10000 .*, got 10000000"):
        load_hand_file(path)


def _saved_plan(root, name, **options):
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan

    hand = root / name
    hand.write_bytes((DATA / name).read_bytes())
    return json.loads(save_plan(plan_hand(hand, waypoints=3, **options),
                                root / "plan.json").read_text())


@pytest.fixture(scope="module")
def task_plan(tmp_path_factory):
    """A plan whose segment has no effort-controlled joint (table push, per-contact friction)."""
    return _saved_plan(tmp_path_factory.mktemp("plan"), "table_push_hand.json",
                       model="independent")


@pytest.fixture(scope="module")
def band_plan(tmp_path_factory):
    """A plan whose segment has one effort-controlled joint: its waypoints carry a band."""
    return _saved_plan(tmp_path_factory.mktemp("band"), "two_finger_hand.json")


def _resigned(data, tmp_path):
    from planner.plan.plan_file import digest

    body = {k: v for k, v in data.items() if k != "digest"}
    body["digest"] = {"algorithm": "sha256", "value": digest(body)}
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(body))
    return path


def _set_waypoint(key, value):
    def edit(d):
        d["segments"][0]["waypoints"][0][key] = value
    return edit


@pytest.mark.parametrize("plan, edit, match", [
    ("band_plan", _set_waypoint("margin", 5.0),
     r"segments\[0\]\.waypoints\[0\]\.margin: expected at most .* inside bands\[0\] .*got 5"),
    ("task_plan", lambda d: d["segments"][0].__setitem__("released", [["x"], 99]),
     r"segments\[0\]\.released: expected a list of contact objects, got"),
    ("task_plan", lambda d: d["segments"][0].__setitem__("released", [{"kind": "palm",
                                                                       "vertex": 99}]),
     r"segments\[0\]\.released\[0\]\.vertex: expected an integer in \[0, 3\], got"),
    ("task_plan", lambda d: d["segments"][0]["event"].__setitem__("kind", "teleport"),
     r"segments\[0\]\.event\.kind: expected one of .*, got 'teleport'"),
], ids=["margin", "released", "released_contact", "event_kind"])
def test_inconsistent_plans_are_refused(request, tmp_path, plan, edit, match):
    from planner.errors import InputError
    from planner.plan.plan_file import load_plan

    data = copy.deepcopy(request.getfixturevalue(plan))
    edit(data)
    with pytest.raises(InputError, match=match):
        load_plan(_resigned(data, tmp_path))


def test_consistent_plans_load(request, tmp_path):
    """The checks above refuse only the edits: the re-signed plans themselves load."""
    from planner.plan.plan_file import load_plan

    for name in ("band_plan", "task_plan"):
        assert load_plan(_resigned(copy.deepcopy(request.getfixturevalue(name)), tmp_path))


def test_system_loader_checks_the_budget_before_allocating(tmp_path):
    import numpy as np

    from planner.errors import InputError
    from planner.files.reader import set_memory_budget
    from planner.files.system_file import load_system

    n = 2000  # J = I(4000): 128 MB
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 2 * np.pi, n)
    path = tmp_path / "big.json"
    path.write_text(json.dumps({
        "contacts": [{"point": p.tolist(), "normal": [float(np.cos(a)), float(np.sin(a))],
                      "mu": 0.3} for p, a in zip(rng.normal(size=(n, 2)).round(3), ang)],
        "external_wrench": [0, -1, 0],
        "manipulator": {"contact_velocities": rng.normal(size=(n, 2)).round(3).tolist()}}))
    set_memory_budget(64 * 2 ** 20)
    try:
        with pytest.raises(InputError, match=r"expected a request within the memory budget "
                                             r"\(0.0625 GiB\), got .*the \(4000, 4000\) "
                                             r"Jacobian of 2000 contacts' velocities"):
            load_system(path)
    finally:
        set_memory_budget(None)


def test_validate_refuses_a_special_entry_before_simulating(tmp_path, monkeypatch, capsys):
    import os

    import scenarios.runs
    from qsplan.cli import main

    ran = []
    monkeypatch.setattr(scenarios.runs, "validate_plan", lambda *a, **k: ran.append(1) or 1 / 0)
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "summary.json")
    code = main(["validate", str(ROOT / "tests" / "data" / "plan_v1_two_finger.json"),
                 "--mu", "0.1", "--out", str(out), "--no-render"])
    err = capsys.readouterr().err
    assert code == 2 and not ran, err
    assert "summary.json" in err and "FIFO" in err, err


def test_simulate_summary_never_names_the_staging_folder(tmp_path):
    from qsplan.cli import main

    out = tmp_path / "sim"
    assert main(["simulate", str(DATA / "example_4_1.json"), "--out", str(out)]) == 0
    assert ".qsplan-staging" not in (out / "summary.json").read_text()


def test_quiet_simulate_prints_nothing(tmp_path, capsys):
    from qsplan.cli import main

    assert main(["simulate", str(DATA / "example_4_1.json"), "--no-render", "-q"]) == 0
    assert capsys.readouterr().out == ""


def test_scene_bounds_cover_every_body(tmp_path):
    from planner.files.system_file import load_system
    from sim.scenes.system import system_scene

    data = json.loads((ROOT / "tests" / "data" / "two_link_finger_box.json").read_text())
    joints = data["manipulator"]["chain"]["joints"]
    joints[0]["origin"], joints[1]["origin"] = [-0.12, 0.61], [0.58, 0.0]
    path = tmp_path / "far_base.json"
    path.write_text(json.dumps(data))
    scene = system_scene(load_system(path))
    xmin, ymin, xmax, ymax = scene.bounds
    for body in scene.bodies:
        if body.kind.value == "dynamic":
            x, y, _ = body.pose
            assert xmin <= x <= xmax and ymin <= y <= ymax, (body.name, body.pose, scene.bounds)
