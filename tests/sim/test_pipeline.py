"""The one simulation pipeline: every entry point -- ``qsplan simulate``, ``qsplan validate``,
``qsplan scenarios run``, the demo's runs and the validation campaign -- builds its scene and
judges its run through :func:`sim.jobs.execute` (the run loop and the judge it calls are
counted), and every run writes the one ``summary.json`` (its schema:
``planner/files/schemas/run-summary.schema.json``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import sim.jobs
from planner.files.schema import load_schema
from qsplan.cli import main
from scenarios.registry import DATA_DIR

jsonschema = pytest.importorskip("jsonschema")
SUMMARY = load_schema("run-summary")


@pytest.fixture()
def counted(monkeypatch):
    """Counts of the pipeline's run loop and judge calls (patched in :mod:`sim.jobs`, where
    :func:`sim.jobs.execute` looks them up)."""
    calls = {"run_scene": 0, "judge": 0}
    run_scene, judge = sim.jobs.run_scene, sim.jobs.judge

    def counting_run(*a, **k):
        calls["run_scene"] += 1
        return run_scene(*a, **k)

    def counting_judge(*a, **k):
        calls["judge"] += 1
        return judge(*a, **k)

    monkeypatch.setattr(sim.jobs, "run_scene", counting_run)
    monkeypatch.setattr(sim.jobs, "judge", counting_judge)
    return calls


def valid(summary_path: Path) -> dict:
    data = json.loads(summary_path.read_text())
    jsonschema.Draft202012Validator(SUMMARY).validate(data)
    return data


def test_simulate_goes_through_the_pipeline(counted, tmp_path):
    out = tmp_path / "box"
    assert main(["-q", "simulate", str(DATA_DIR / "box_on_table_high.json"), "--duration", "0.6",
                 "--no-render", "--out", str(out)]) == 0
    assert counted == {"run_scene": 1, "judge": 1}
    s = valid(out / "summary.json")
    assert s["kind"] == "system" and s["status"] == "agreed" and s["segments"] == []


@pytest.fixture(scope="module")
def short_plan(tmp_path_factory):
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan
    from scenarios.registry import shipped_file

    plan = plan_hand(shipped_file("two_finger_hand"), mu=(0.0, 0.2), policy="midband",
                     waypoints=4)
    return save_plan(plan, tmp_path_factory.mktemp("plan") / "plan.json")


@pytest.mark.long
def test_validate_goes_through_the_pipeline(counted, short_plan, tmp_path):
    out = tmp_path / "val"
    assert main(["-q", "validate", str(short_plan), "--mu", "0.1", "--no-render",
                 "--out", str(out)]) == 0
    assert counted == {"run_scene": 1, "judge": 1}
    s = valid(out / "summary.json")
    assert s["kind"] == "hand" and len(s["segments"]) == 1 and s["claim_fraction"] >= 0.95


def test_scenarios_run_goes_through_the_pipeline(counted, tmp_path):
    assert main(["-q", "scenarios", "run", "neg_ex41_wrong_region", "--engine", "pymunk",
                 "--out", str(tmp_path / "sc"), "--no-render"]) == 0
    assert counted == {"run_scene": 1, "judge": 1}
    s = valid(tmp_path / "sc" / "summary.json")
    assert s["scenario"] == "neg_ex41_wrong_region" and s["status"] == "disagreed"
    assert s["source"] == "example_4_1" and s["parameters"]["scene_scale"] < 0.02


@pytest.mark.long
def test_a_demo_run_goes_through_the_pipeline(counted, short_plan, tmp_path):
    from qsplan.demo_task import DemoRun, run_demo_job

    s = run_demo_job(DemoRun(plan=str(short_plan), engine="pymunk", mu=0.1,
                             out=str(tmp_path / "d"), folder="d", name="demo run",
                             expect="agree", render=False))
    assert counted == {"run_scene": 1, "judge": 1}
    assert s["status"] == "agreed" and valid(tmp_path / "d" / "summary.json")["folder"] == "d"


def test_the_campaign_goes_through_the_pipeline(counted):
    from campaign_module import campaign

    vc = campaign()
    system, mu, ctrl = vc.point("ex43", 0, 7)
    row = vc.run_point("ex43", "pymunk", system, mu, ctrl)
    assert counted["run_scene"] == 1 and counted["judge"] >= 1
    assert row["status"] in ("agreed", "disagreed", "inconclusive", "fault")


def test_a_ruler_summary_has_the_one_layout(tmp_path):
    from dataclasses import replace

    from planner.predict.ruler import theory_switches
    from scenarios.runs import write_run
    from sim.jobs import execute, job_for_ruler

    pos, who = theory_switches(0.04, 0.025, 0.5, 0.5, 1)
    job = job_for_ruler("pymunk", mu_s=0.5, mu_k=0.5, positions=pos, sliders=who, required=1)
    res = execute(replace(job, run=replace(job.run, duration=2.0, dt=8e-3)))
    write_run(res, tmp_path, render=False)
    s = valid(tmp_path / "summary.json")
    assert s["kind"] == "ruler" and "switch_positions_m" in s["observed"]


def test_user_size_is_simulated_inside_the_measured_range():
    """A 37 m file (Example 4.1 as printed) and a 7 cm box: the first is simulated as a similar
    scene of 0.4 m, the second at its own size; both report twists in the file's units."""
    from planner.files.system_file import load_system
    from planner.predict.feasibility import feasible_modes
    from sim.jobs import job_for_system
    from sim.settings import SIZE_RANGE

    big = load_system(DATA_DIR / "example_4_1.json")
    job = job_for_system(big, "pymunk", feasible_modes(big))
    size = job.parameters["size_m"]
    assert size > 30 and job.scale * size == pytest.approx(SIZE_RANGE[1])
    box = load_system(DATA_DIR / "box_on_table_low.json")
    assert job_for_system(box, "pymunk", feasible_modes(box)).scale == 1.0
    assert np.isclose(job.expectation.length, size)
