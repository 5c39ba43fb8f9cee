"""The pure parts of benchmarks/set_field_tasks.py: how far past the set the plan's stated reach
lies (in half-widths), the ``beyond`` outside step computed from it, and which axis an outside
point pushes and how far from the nominal (the benchmarks directory is not a package)."""

from __future__ import annotations

import json

import pytest
from campaign_module import benchmark

sft = benchmark("set_field_tasks")

HALVES = {"mass": 0.04, "com": 0.005, "contacts": 0.002}


def test_reach_in_half_widths_by_hand():
    # mass 0.2 kg +-20 % (half 0.04 kg) tolerated +-0.05 kg: 0.25 half-widths past the set;
    # centre of mass +-5 mm tolerated +-7.5 mm: 0.5; contacts +-2 mm tolerated +-2.5 mm: 0.25
    tol = {"mass_kg": 0.05, "com_m": 0.0075, "contacts_m": 0.0025, "contacts_computed": True}
    r = sft.reach_in_half_widths(tol, HALVES)
    assert r == pytest.approx({"mass": 0.25, "com": 0.5, "contacts": 0.25})
    assert sft.beyond_step(r) == pytest.approx(0.25 + sft.BEYOND_EXTRA)


def test_reach_unbounded_or_not_computed():
    tol = {"mass_kg": None, "com_m": 0.004, "contacts_m": 0.003, "contacts_computed": False}
    r = sft.reach_in_half_widths(tol, HALVES)
    assert r["mass"] is None and r["contacts"] is None
    assert r["com"] == pytest.approx(-0.2)  # a reach inside the set is negative
    assert sft.beyond_step(r) is None
    assert sft.beyond_step({"contacts": -0.2}) == pytest.approx(sft.BEYOND_EXTRA)


def test_axis_distance_of_outside_points():
    nominal = {"m": 0.2, "cx": 0.04, "cy": 0.025, "s1": 0.0, "s2": 0.0}
    vals = dict(nominal)
    assert sft.axis_distance({"point": "out-s2-", "values": {**vals, "s2": -0.0025}},
                             nominal) == ("s2", "contacts", pytest.approx(0.0025))
    assert sft.axis_distance({"point": "out-m+", "values": {**vals, "m": 0.25}},
                             nominal) == ("m", "mass", pytest.approx(0.05))
    assert sft.axis_distance({"point": "out-cy-", "values": {**vals, "cy": 0.019}},
                             nominal) == ("cy", "com", pytest.approx(0.006))


def test_job_folder_names_read_back():
    assert sft.tag_job("pymunk_mu0.6_outside_0.535") == ("pymunk", "0.6", "outside", 0.535)
    assert sft.tag_job("mujoco_mu0.25-0.25-0.7-0.7_corners-centre") == (
        "mujoco", "0.25/0.25/0.7/0.7", "corners,centre", None)


def test_outside_rows_from_summaries(tmp_path):
    # a job folder as `qsplan validate --out` writes it: set/<point>/summary.json
    nominal = {"m": 0.2, "cx": 0.04, "cy": 0.025, "s1": 0.0, "s2": 0.0}
    f = tmp_path / "set" / "out-s1-" / "summary.json"
    f.parent.mkdir(parents=True)
    f.write_text(json.dumps({
        "status": "disagreed", "passed": False, "claim_fraction": 1.0,
        "final_error_of_travel": 0.045, "fault_kind": None, "reason": "final position off",
        "wall_time_s": 37.0,
        "parameters": {"set_point": {"name": "out-s1-", "kind": "outside", "inside": False,
                                     "values": {**nominal, "s1": -0.0025},
                                     "expect": "agree", "claim_only_share": [1.0]}}}))
    task = {"nominal": nominal, "plan": {"tolerated": {
        "mass_kg": 0.05, "com_m": 0.0065, "contacts_m": 0.00207, "contacts_computed": True}}}
    (row,) = sft.job_rows(task, tmp_path, 0.25)
    assert row["point"] == "out-s1-" and row["axis"] == "s1"
    assert row["distance"] == pytest.approx(0.0025) and row["stated_reach"] == 0.00207
    assert row["beyond_reach"] is True and row["status"] == "disagreed"
