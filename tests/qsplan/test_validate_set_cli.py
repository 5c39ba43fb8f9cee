"""``qsplan validate --set``: a plan guaranteed over a mass / centre-of-mass set runs at the set's
corners and centre (by default) and, asked, just outside it; one line per point, one schema-valid
summary per run recording the point and what the planner predicts there; outside points may fail
without failing the plan, but their runs are held against the planner's prediction there; bad
options exit 2 before any simulation (docs/planning.md, "Validating at points of the set")."""

from __future__ import annotations

import json

import jsonschema
import pytest
from set_hands import planned

from planner.files.schema import load_schema
from qsplan.cli import main

#: the mass and the centre of mass's x: 4 corners and the centre (5 short runs).
MASS_AND_X = {"mass": [0.08, 0.12], "com": [[0.015, 0.025], [0.0185, 0.0185]]}
#: the centre of mass's height alone, +-5 mm.
HEIGHT = {"com": [[0.02, 0.02], [0.0135, 0.0235]]}


class Plans:
    """Each plan made when a test first asks for it (module scope)."""

    SECTIONS = {"mass_x": MASS_AND_X, "height": HEIGHT, "none": None}

    def __init__(self, tmp):
        self.tmp, self.made = tmp, {}

    def __getitem__(self, key):
        if key not in self.made:
            self.made[key] = planned(self.tmp, self.SECTIONS[key], key)
        return self.made[key]


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    return Plans(tmp_path_factory.mktemp("setval"))


def _summaries(root):
    return {p.parent.name: json.loads(p.read_text())
            for p in sorted((root / "set").rglob("summary.json"))}


@pytest.mark.long
def test_corners_and_centre_by_default_in_pymunk(plans, tmp_path, capsys):
    out = tmp_path / "val"
    assert main(["validate", str(plans["mass_x"]), "--mu", "0.1", "--no-render",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    lines = [x for x in text.splitlines() if "inside the set)" in x]
    assert len(lines) == 5, text
    assert all("inside the set): AGREED, predicted agree -- as predicted" in x for x in lines)
    assert "pymunk set: 5 of 5 runs inside the set as planned" in text
    got = _summaries(out)
    assert sorted(got) == ["centre", "m+cx+", "m+cx-", "m-cx+", "m-cx-"]
    schema = jsonschema.Draft202012Validator(load_schema("run-summary"))
    for name, s in got.items():
        assert [e.message for e in schema.iter_errors(s)] == []
        point = s["parameters"]["set_point"]
        assert point["name"] == name and point["inside"] and point["expect"] == "agree"
        assert s["passed"] and s["status"] == "agreed"
    # the scene simulated the workpiece at the point, not the nominal one
    assert got["m+cx+"]["parameters"]["load_N"] == pytest.approx(0.08 * 1.2)
    assert got["m-cx-"]["parameters"]["load_N"] == pytest.approx(0.08 * 0.8)


@pytest.mark.long
def test_outside_points_where_the_pentagon_tips_disagree_as_predicted(plans, tmp_path, capsys):
    """3 half-widths (15 mm) above and below the centre-of-mass box the planner predicts the
    claim on too little of the segment (the pentagon tips, or no quasistatic mode): the runs
    must not show the claim.  Allowed to fail: the exit code stays 0."""
    out = tmp_path / "val"
    assert main(["validate", str(plans["height"]), "--mu", "0.1", "--no-render", "--set",
                 "outside", "--outside", "3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "set out-cy+ (m=0.1 kg cx=20 mm cy=38.5 mm; outside the set (allowed to fail)): " \
           "DISAGREED, predicted disagree -- as predicted" in text
    got = _summaries(out)
    assert sorted(got) == ["out-cy+", "out-cy-"]
    for s in got.values():
        assert s["parameters"]["set_point"]["expect"] == "disagree"
        assert s["parameters"]["set_point"]["claim_absent_share"][0] > 0.05
        assert s["status"] == "disagreed" and s["passed"]


@pytest.mark.long
def test_the_centre_in_mujoco(plans, capsys):
    assert main(["validate", str(plans["mass_x"]), "--mu", "0.1", "--no-render", "--engine",
                 "mujoco", "--set", "centre"]) == 0
    assert "mujoco mu=0.1 set centre (m=0.1 kg cx=20 mm cy=18.5 mm; inside the set): AGREED, " \
           "predicted agree -- as predicted" in capsys.readouterr().out


@pytest.mark.parametrize("which, extra, message", [
    ("mass_x", ["--set", "corner"], "--set: expected 'none', 'all' or comma-separated kinds of "
                                    "corners, centre, outside, got 'corner'"),
    ("mass_x", ["--set", "outside", "--outside", "0"], "--outside: expected a number > 0"),
    ("mass_x", ["--set", "outside", "--outside", "x"], "--outside: expected a number, got 'x'"),
    ("mass_x", ["--outside", "0.5"], "--outside: expected with --set including 'outside', got "
                                     "--set default"),
    ("none", ["--set", "corners"], "--set: expected a plan whose hand has an 'uncertainty' "
                                   "section"),
])
def test_bad_set_options_exit_2_before_any_run(plans, tmp_path, capsys, which, extra, message):
    out = tmp_path / "val"
    assert main(["validate", str(plans[which]), "--mu", "0.1", "--out", str(out), *extra]) == 2
    captured = capsys.readouterr()
    assert message in captured.err
    assert "pymunk" not in captured.out and not out.exists()


@pytest.mark.long
def test_a_plan_without_a_set_runs_as_before(plans, capsys):
    """No set, no ``--set``: only the nominal run (the default adds nothing)."""
    assert main(["validate", str(plans["none"]), "--mu", "0.1", "--no-render"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("pymunk mu=0.1: AGREED") and " set " not in text
