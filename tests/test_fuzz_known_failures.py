"""Defects the extended fuzz campaign found in areas being rewritten by other engineers, pinned
as strict ``xfail``: each flips to a pass (and must then lose its mark) when its owner fixes it.
The owner and what the code must do are in each reason; docs/robustness.md lists them."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
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


@pytest.mark.xfail(strict=True, reason=f"segment.mode 'XYZ' is answered 'cannot guarantee the "
                                       f"mode' (exit 1): {HAND_FILE}")
def test_hand_mode_label_of_unknown_letters_is_bad_input(tmp_path, capsys):
    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("mode", "XYZ"))
    code, err = _plan_exit(path, capsys)
    assert code == 2 and "mode" in err, err


@pytest.mark.xfail(strict=True, reason=f"a 5-token mode for 4 contacts is answered 'cannot "
                                       f"guarantee the mode' (exit 1): {HAND_FILE}")
def test_hand_mode_label_of_the_wrong_length_is_bad_input(tmp_path, capsys):
    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("mode", "S+1 S+2 S-3 S-4 S5"))
    code, err = _plan_exit(path, capsys)
    assert code == 2 and "mode" in err, err


@pytest.mark.xfail(strict=True, reason=f"a surface edge given in reverse (the workpiece on its "
                                       f"outer side) is answered 'segment cannot start' (exit "
                                       f"1): {HAND_FILE}")
def test_reversed_surface_edge_is_bad_input(tmp_path, capsys):
    def reverse(d):
        d["environment"][0]["edge"] = d["environment"][0]["edge"][::-1]

    code, err = _plan_exit(_hand(tmp_path, "table_push_hand.json", reverse), capsys)
    assert code == 2 and "edge" in err, err


@pytest.mark.xfail(strict=True, reason="'goal': {'contacts': []} loads (a 0-segment plan that "
                                       "validate refuses later): planner/files/hand_goal.py "
                                       "(formats owner) must require at least one goal contact")
def test_goal_without_contacts_is_bad_input(tmp_path):
    from planner.errors import InputError
    from planner.files.hand_file import load_hand_file

    path = _hand(tmp_path, "figure9_task_hand.json",
                 lambda d: d["goal"].__setitem__("contacts", []))
    with pytest.raises(InputError, match="contacts"):
        load_hand_file(path)


@pytest.mark.xfail(strict=True, reason=f"segment.steps 10000000 is accepted and runs unbounded: "
                                       f"{HAND_FILE} (bound it, e.g. like --waypoints)")
def test_unbounded_segment_steps_are_bad_input(tmp_path):
    from planner.errors import InputError
    from planner.files.hand_file import load_hand_file

    path = _hand(tmp_path, "two_finger_hand.json",
                 lambda d: d["segment"].__setitem__("steps", 10_000_000))
    with pytest.raises(InputError, match="steps"):
        load_hand_file(path)


@pytest.fixture(scope="module")
def task_plan(tmp_path_factory):
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan

    root = tmp_path_factory.mktemp("plan")
    hand = root / "hand.json"
    hand.write_bytes((DATA / "table_push_hand.json").read_bytes())
    return json.loads(save_plan(plan_hand(hand, waypoints=3), root / "plan.json").read_text())


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


@pytest.mark.parametrize("edit", [
    pytest.param(_set_waypoint("margin", 5.0),
                 marks=pytest.mark.xfail(strict=True, reason=f"a margin that contradicts the "
                                                             f"band: {PLAN_LOADER}")),
    pytest.param(lambda d: d["segments"][0].__setitem__("released", [["x"], 99]),
                 marks=pytest.mark.xfail(strict=True, reason=f"a garbage 'released': "
                                                             f"{PLAN_LOADER}")),
    pytest.param(lambda d: d["segments"][0]["event"].__setitem__("kind", "teleport"),
                 marks=pytest.mark.xfail(strict=True, reason=f"an unknown event.kind: "
                                                             f"{PLAN_LOADER}")),
], ids=["margin", "released", "event_kind"])
def test_inconsistent_plans_are_refused(task_plan, tmp_path, edit):
    from planner.errors import InputError
    from planner.plan.plan_file import load_plan

    data = copy.deepcopy(task_plan)
    edit(data)
    with pytest.raises(InputError):
        load_plan(_resigned(data, tmp_path))


@pytest.mark.xfail(strict=True, reason="the system loader builds the dense (2 n_c, 2 n_c) "
                                       "Jacobian of contact velocities before any budget check: "
                                       "planner/files/system_file.py (formats owner) must pass "
                                       "cost= to read_json (reader.dense_bytes of what it "
                                       "allocates), so --memory-gib refuses it first")
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
        with pytest.raises(InputError, match="memory budget"):
            load_system(path)
    finally:
        set_memory_budget(None)


@pytest.mark.xfail(strict=True, reason="qsplan/commands/validate.py (lead): the command must "
                                       "declare its entries (output_set(..., entries=('summary."
                                       "json', 'timeline.png', 'animation.gif', 'mu_<v>/' per "
                                       "value))) so a FIFO at OUT/summary.json is refused "
                                       "before any simulation")
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
    assert code == 2 and not ran, capsys.readouterr().err


def test_simulate_summary_never_names_the_staging_folder(tmp_path):
    from qsplan.cli import main

    out = tmp_path / "sim"
    assert main(["simulate", str(DATA / "example_4_1.json"), "--out", str(out)]) == 0
    assert ".qsplan-staging" not in (out / "summary.json").read_text()


@pytest.mark.xfail(strict=True, reason="qsplan/commands/simulate.py (lead): -q is ignored (the "
                                       "result line is printed); the same in validate, "
                                       "scenarios run and demo")
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
