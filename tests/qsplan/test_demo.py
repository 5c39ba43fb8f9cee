"""`qsplan demo` (the main job): wiring and expectations with stubbed simulator runs (fast),
bad input, and the real quick demo in both engines (slow)."""

from __future__ import annotations

import json

import pytest

from qsplan.cli import main
from scenarios.registry import DATA_DIR

HAND_FILE = DATA_DIR / "two_finger_hand.json"

CLAIM = "S+1 S+2 S-3 S-4"
R2S = "R1 B2 S-3 S-4"


@pytest.fixture(scope="module")
def small_plans():
    from planner.plan.hand_planner import plan_hand

    return {p: plan_hand(HAND_FILE, mu=(0.0, 0.2), policy=p, waypoints=5)
            for p in ("midband", "rival:R2S")}


@pytest.fixture(scope="module")
def task_plan():
    from planner.plan.hand_planner import plan_hand

    return plan_hand(DATA_DIR / "figure9_task_hand.json", waypoints=5)


def _stub(negative_passes: bool, segment_fails: bool):
    """A stand-in for :func:`qsplan.demo_task.run_demo_job`: the summary a run would write."""
    def job(j):
        agree = j.expect == "agree"
        base = {"name": j.name, "engine": j.engine, "expect": j.expect, "task": j.task,
                "parameters": {"mu": [j.mu] * 4}, "wall_time_s": 0.1, "folder": j.folder,
                "fault": None, "observed_counts": {}}
        if j.task:
            ok = (agree and not segment_fails) or (not agree and negative_passes)
            rows = [{"segment": k + 1, "status": "agreed", "claim_fraction": 1.0,
                     "final_error_of_travel": 0.001} for k in range(3)]
            if agree and segment_fails:
                rows[2].update(status="disagreed", claim_fraction=0.7)
            return {**base, "status": "agreed" if ok else "disagreed",
                    "reason": "" if ok else "segment 1: disagreed", "segments": rows,
                    "passed": ok == agree}
        ok = agree or negative_passes
        s = {**base, "status": "agreed" if ok else "disagreed",
             "claim_fraction": 1.0 if ok else 0.3, "predicted_fraction": 1.0,
             "final_error_of_travel": 0.001, "travel_m": 0.015, "final_angle_error_rad": 0.0,
             "observed_counts": {CLAIM if ok else R2S: 10},
             "observed": {"segments": [{"mode": R2S, "start_s": 0.0, "end_s": 1.0}]},
             "passed": ok == agree, "segments": []}
        if not agree:
            s.update({"rival_predicted": [R2S], "rival_stretch_s": [0.0, 6.6],
                      "rival_observed_s": 1.0, "rival_observed_fraction": 0.2,
                      "rival_first_observed_s": 0.2, "rival_first_interval_majority": R2S})
        return s
    return job


@pytest.mark.parametrize("negative_passes, segment_fails, code",
                         [(False, False, 0), (True, False, 1), (False, True, 1)])
@pytest.mark.long
def test_demo_expectations(small_plans, task_plan, monkeypatch, tmp_path, capsys,
                           negative_passes, segment_fails, code):
    """All expectations held -> 0; a negative control that passes validation, or one segment
    of the whole task that disagrees -> 1."""
    import planner.plan.hand_planner as hp
    import qsplan.commands.demo as demo

    def planned(source, mu=None, policy=None):
        return task_plan if policy is None else small_plans[policy]

    monkeypatch.setattr(hp, "plan_hand", planned)
    monkeypatch.setattr(demo, "run_demo_job", _stub(negative_passes, segment_fails))
    out = tmp_path / "report"
    assert main(["demo", "--out", str(out), "--jobs", "1", "--no-render",
                 "--engines", "pymunk,mujoco"]) == code
    checks = json.loads((out / "checks.json").read_text())
    assert checks["held"] is (code == 0)
    names = [c["check"] for c in checks["checks"]]
    assert sum(n.startswith("negative control in") for n in names) == 4  # R2S: 2 engines x 2
    assert sum("negative control (torques reversed)" in n for n in names) == 2
    assert sum(n.startswith("task segment") for n in names) == 18  # 2 engines x 3 mu x 3
    assert sum(n.startswith("whole task in") for n in names) == 6
    held = {c["check"]: c["held"] for c in checks["checks"]}
    assert held["plan.json reloads to the same plan"]
    assert held["a plan with one torque edited by hand is rejected"]
    assert held["whole task planned to its goal (Figure 9, mu in [0, 0.2])"]
    seg3 = [v for k, v in held.items() if k.startswith("task segment 3 in")]
    assert len(seg3) == 6 and all(seg3) is (not segment_fails)
    report = (out / "REPORT.md").read_text()
    assert ("all expectations held" if code == 0 else "SOME EXPECTATIONS FAILED") in report
    assert report.index("## The task") < report.index("Figures 10-13") < report.index(
        "## Checks")  # the story first, then the torque regions, then the tables
    assert (out / "index.html").is_file() and (out / "plan.json").is_file()
    assert (out / "task" / "plan_task.json").is_file()
    assert (out / "negative_control" / "plan_negative.json").is_file()
    assert (out / "negative_control" / "task" / "plan_task_negative.json").is_file()
    assert not (out / "negative_control" / "tampered_copy.json").exists()


def test_demo_bad_input(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--engines", "bullet"]) == 2
    assert "--engines: expected names from pymunk, mujoco, dart, got 'bullet'" in capsys.readouterr().err
    assert main(["demo", "--out", str(tmp_path), "--jobs", "0"]) == 2
    assert "--jobs: expected an integer in 1..64, got 0" in capsys.readouterr().err


@pytest.mark.slow
def test_quick_demo_end_to_end(tmp_path):
    """The real thing: the whole task at mu = 0.1 and both negative controls, both engines."""
    out = tmp_path / "report"
    assert main(["demo", "--out", str(out), "--quick"]) == 0
    checks = json.loads((out / "checks.json").read_text())
    assert checks["held"] and len(checks["runs"]) == 6
    assert (out / "task" / "mujoco" / "mu_0.1" / "summary.json").is_file()
    assert (out / "story" / "task_story.png").is_file()
    assert (out / "figures" / "fig13_guaranteed.png").is_file()
