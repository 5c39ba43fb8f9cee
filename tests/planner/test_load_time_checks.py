"""Checks made when an input is read or an output set is opened, before any work: hand-file
segments, plan consistency, the system loader's memory budget, the entries every command
declares, and the engines' limits on the scene a job actually runs."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"


def _hand(tmp_path, base, edit):
    data = json.loads((DATA / base).read_text())
    edit(data)
    path = tmp_path / "hand.json"
    path.write_text(json.dumps(data))
    return path


# ---- hand files -------------------------------------------------------------------------------
def test_mode_families_of_n_contacts():
    from planner.model.modes import family_names

    assert family_names(2) == ("B", "S", "2S", "R", "RS", "2R")
    assert "R2S" in family_names(3) and "4S" in family_names(4) and "5S" not in family_names(4)


@pytest.mark.parametrize("mode, stored", [
    ("4S", "4S"), ("S+1  S+2 S-3 S-4", "S+1 S+2 S-3 S-4"), ("R1 B2 S-3 S-4", "R1 B2 S-3 S-4"),
])
def test_segment_mode_family_or_label_is_accepted(tmp_path, mode, stored):
    from planner.files.hand_file import load_hand_file

    hf = load_hand_file(_hand(tmp_path, "two_finger_hand.json",
                              lambda d: d["segment"].__setitem__("mode", mode)))
    assert hf.segment is not None and hf.segment.mode == stored


@pytest.mark.parametrize("mode, match", [
    ("5S", r"segment.mode: expected a mode family of 4 contacts .*got '5S'"),
    ("S+1 S+2 S-3 X4", r"expected R, S\+, S- or B before 4, got 'X'"),
    ("S+1 S+2 S-4 S-3", r"expected token 3 to end with contact index 3"),
])
def test_segment_mode_of_another_hand_is_refused(tmp_path, mode, match):
    from planner.files.hand_file import load_hand_file

    with pytest.raises(InputError, match=match):
        load_hand_file(_hand(tmp_path, "two_finger_hand.json",
                             lambda d: d["segment"].__setitem__("mode", mode)))


def test_segment_waypoints_are_bounded_like_the_command_line(tmp_path):
    from planner.files.hand_file import MAX_WAYPOINTS, load_hand_file
    from qsplan.commands import plan

    assert plan.MAX_WAYPOINTS == MAX_WAYPOINTS  # one bound for the file and --waypoints
    ok = load_hand_file(_hand(tmp_path, "two_finger_hand.json",
                              lambda d: d["segment"].__setitem__("steps", MAX_WAYPOINTS)))
    assert ok.segment is not None and ok.segment.steps == MAX_WAYPOINTS
    with pytest.raises(InputError, match=rf"segment.waypoints: expected at most {MAX_WAYPOINTS}"
                                         rf" .*got {MAX_WAYPOINTS + 1}"):
        load_hand_file(_hand(tmp_path, "two_finger_hand.json",
                             lambda d: d["segment"].__setitem__("waypoints", MAX_WAYPOINTS + 1)))


def test_goal_without_the_contacts_key_still_loads(tmp_path):
    from planner.files.hand_file import load_hand_file

    hf = load_hand_file(_hand(tmp_path, "figure9_task_hand.json",
                              lambda d: d["goal"].pop("contacts", None)))
    assert hf.goal is not None and hf.goal.contacts == () and hf.goal.pose is not None


# ---- plans ------------------------------------------------------------------------------------
def _resigned(data, tmp_path):
    from planner.plan.plan_file import digest

    body = {k: v for k, v in data.items() if k != "digest"}
    body["digest"] = {"algorithm": "sha256", "value": digest(body)}
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(body))
    return path


@pytest.mark.parametrize("key", ["torque_command", "velocity_command"])
def test_version_2_single_and_list_commands_must_agree(tmp_path, key):
    """The simulator reads the lists; a single value that says otherwise is refused."""
    from planner.plan.plan_file import load_plan

    data = json.loads((ROOT / "tests" / "data" / "plan_v2_three_finger.json").read_text())
    assert load_plan(_resigned(data, tmp_path))
    data["segments"][0]["waypoints"][1][key] = 1e308
    with pytest.raises(InputError, match=rf"segments\[0\]\.waypoints\[1\]\.{key}: expected the "
                                         rf"first of {key}s, .*got 1e\+308"):
        load_plan(_resigned(data, tmp_path))


def test_margin_check_follows_the_bands():
    from planner.errors import FileFormatError
    from planner.plan.plan_fields import check_margin

    check_margin(0.1, (0.0, 1.0), ((-0.1, 0.1), (0.5, np.inf)), "w")  # touches both ends
    check_margin(-3.0, (5.0,), ((-1.0, 1.0),), "w")  # outside: not bounded by the band
    check_margin(0.5, (), (), "w")  # no effort joint: a Coulomb slack, no band
    with pytest.raises(FileFormatError, match=r"w.margin: expected at most 0.1, the room "
                                              r"torque_commands\[1\] = 0.9"):
        check_margin(0.2, (0.0, 0.9), ((-1.0, 1.0), (0.0, 1.0)), "w")


# ---- system loader ------------------------------------------------------------------------------
def test_twenty_thousand_contacts_are_refused_by_the_budget(tmp_path, capsys):
    """2 MB of contacts would need a 12 GB Jacobian: exit 2 before any allocation."""
    from qsplan.cli import main

    n = 20_000
    path = tmp_path / "many.json"
    path.write_text(json.dumps({
        "contacts": [{"point": [i * 1e-3, 0], "normal": [0, 1], "mu": 0.3} for i in range(n)],
        "external_wrench": [0, -1, 0],
        "manipulator": {"contact_velocities": [[0.0, 1.0]] * n}}))
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert "expected a request within the memory budget (4 GiB)" in err, err
    assert "the (40000, 40000) Jacobian of 20000 contacts' velocities" in err, err
    assert "which would need 11.9 GiB" in err, err


# ---- commands: output entries declared, checked before any work -------------------------------
@pytest.fixture
def out_with_fifo(tmp_path):
    def make(entry):
        out = tmp_path / "out"
        (out / entry).parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(out / entry)
        return out
    return make


def test_validate_checks_every_mu_folder_first(out_with_fifo, monkeypatch, capsys):
    import scenarios.runs
    from qsplan.cli import main

    ran = []
    monkeypatch.setattr(scenarios.runs, "validate_plan", lambda *a, **k: ran.append(1) or 1 / 0)
    out = out_with_fifo("mu_0.2/deep/pipe")
    code = main(["validate", str(ROOT / "tests" / "data" / "plan_v1_two_finger.json"),
                 "--mu", "0.1,0.2", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not ran, err
    assert "pipe" in err and "FIFO" in err, err
    assert (out / "mu_0.2" / "deep" / "pipe").is_fifo()


def test_validate_entries():
    from qsplan.commands.validate import output_entries

    assert output_entries([0.1], True) == ("summary.json", "timeline.png", "animation.gif",
                                            "problem.png")
    assert output_entries([0.1], False) == ("summary.json",)
    assert output_entries([0.1, (0.1, 0.2, 0.3), 0.1], True) == ("mu_0.1/", "mu_0.1-0.2-0.3/")


def test_scenarios_run_checks_its_declared_outputs_first(out_with_fifo, monkeypatch, capsys):
    import scenarios.runs
    from qsplan.cli import main

    ran = []
    monkeypatch.setattr(scenarios.runs, "run_scenario", lambda *a, **k: ran.append(1) or 1 / 0)
    out = out_with_fifo("rod_muspace.png")
    assert main(["scenarios", "run", "muspace_rod", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert not ran and "rod_muspace.png" in err and "FIFO" in err, err


def test_every_run_function_scenario_declares_its_outputs():
    from scenarios.registry import all_scenarios

    missing = [n for n, sc in all_scenarios().items() if sc.run is not None and not sc.outputs]
    assert not missing


def test_quiet_scenarios_run_writes_and_prints_nothing(tmp_path, capsys):
    from qsplan.cli import main

    out = tmp_path / "rod"
    assert main(["scenarios", "run", "muspace_rod", "--out", str(out), "-q"]) == 0
    assert capsys.readouterr().out == ""
    assert sorted(p.name for p in out.iterdir()) == ["rod_muspace.json", "rod_muspace.png",
                                                     "summary.json"]


def test_demo_checks_its_entries_first(out_with_fifo, monkeypatch, capsys):
    import planner.plan.hand_planner
    from qsplan.cli import main

    ran = []
    monkeypatch.setattr(planner.plan.hand_planner, "plan_hand",
                        lambda *a, **k: ran.append(1) or 1 / 0)
    out = out_with_fifo("checks.json")
    assert main(["demo", "--out", str(out), "--quick"]) == 2
    err = capsys.readouterr().err
    assert not ran and "checks.json" in err and "FIFO" in err, err


# ---- the engines' limits on the scene a job runs ----------------------------------------------
def test_a_scene_beyond_the_engines_is_bad_input_before_the_engine_starts(tmp_path, monkeypatch,
                                                                          capsys):
    import sim.jobs
    from qsplan.cli import main

    started = []
    monkeypatch.setattr(sim.jobs, "run_scene", lambda *a, **k: started.append(1) or 1 / 0)
    data = json.loads((DATA / "box_on_table_high.json").read_text())
    data["workpiece"]["mass"] = 1e-300
    path = tmp_path / "feather.json"
    path.write_text(json.dumps(data))
    assert main(["simulate", str(path), "--no-render"]) == 2
    err = capsys.readouterr().err
    assert not started, err
    assert "body 'workpiece': expected a mass in [1e-15, 1e+274] kg" in err and "got" in err, err
