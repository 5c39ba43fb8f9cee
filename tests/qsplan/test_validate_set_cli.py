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


# ---- contact positions ------------------------------------------------------------------------
def test_contact_positions_that_cannot_move_are_refused_before_any_run(plans, tmp_path, capsys):
    """The short push with every contact +-2 mm: vertex 1 on the palm ends the edge the right
    tip touches, so moving it has no physical geometry -- named, exit 2, nothing run, by
    default too."""
    plans.SECTIONS["contacts"] = {"contacts": 0.002}
    out = tmp_path / "val"
    for extra in (["--set", "corners"], []):
        assert main(["validate", str(plans["contacts"]), "--mu", "0.1", "--out", str(out),
                     *extra]) == 2
        captured = capsys.readouterr()
        assert ("--set: at point s1-s2-s3-s4-: contact positions: moving contact 2 (vertex 1 on "
                "palm) turns workpiece edge 1, on which contact 4 (right tip on edge 1) lies"
                in captured.err)
        assert "(--set none runs the nominal plan only)" in captured.err
        assert "pymunk" not in captured.out and not out.exists()


@pytest.fixture(scope="module")
def tilt_plan(tmp_path_factory):
    """Block tilting planned with every contact +-2 mm (claim ``R1 R2``), to 16 degrees (half
    the shipped file's turn, so each run is half as long): the 75 mm block turned clockwise
    about its vertex 1 at ``(0.075, 0)``, so its origin goes to ``(0.075 (1 - cos 16 deg),
    0.075 sin 16 deg)``."""
    from planner.files.hand_file import hand_file_from_dict
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan
    from scenarios.registry import DATA_DIR

    d = json.loads((DATA_DIR / "block_tilting.json").read_text())
    d["uncertainty"] = {"contacts": 0.002}
    d["goal"]["pose"] = [0.002905, 0.020673, -0.2792527]
    out = tmp_path_factory.mktemp("tilt") / "tilt_plan.json"
    save_plan(plan_hand(hand_file_from_dict(d), waypoints=3, margins=False), out)
    return out


@pytest.mark.long
def test_far_outside_a_contact_axis_the_run_shows_what_the_planner_predicts(tilt_plan, tmp_path,
                                                                            capsys):
    """6 half-widths past the set along each contact axis: with the pivot 14 mm outwards the
    planner predicts no quasistatic mode (the press force no longer tilts the block) and the
    simulated block does not follow the claim's path -- the check disagrees with the plan, as
    the planner says it must there; 14 mm inwards the claim is kept and the run shows it."""
    out = tmp_path / "val"
    code = main(["validate", str(tilt_plan), "--engine", "pymunk", "--set", "outside",
                 "--outside", "6", "--no-render", "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "set: 2 axes (s1 contact 1 position (vertex 1 on table) +-2 mm" in text
    lost = next(x for x in text.splitlines() if " set out-s1- " in x)
    assert "s1=-14 mm" in lost and ": DISAGREED, predicted disagree -- as predicted" in lost
    kept = next(x for x in text.splitlines() if " set out-s1+ " in x)
    assert ": AGREED, predicted agree -- as predicted" in kept
    rec = _summaries(out)["out-s1-"]["parameters"]["set_point"]
    assert rec["values"]["s1"] == pytest.approx(-0.014) and rec["expect"] == "disagree"
    assert rec["claim_absent_share"] == [1.0]


@pytest.mark.long
def test_contact_corners_in_mujoco(tilt_plan, capsys):
    """Every corner of the contact box in MuJoCo: the moved table vertex and fingertip are the
    scene's (one scene for both engines), the claim holds at each, as guaranteed."""
    code = main(["validate", str(tilt_plan), "--engine", "mujoco", "--set", "corners",
                 "--no-render"])
    text = capsys.readouterr().out
    assert code == 0, text
    lines = [x for x in text.splitlines() if " set s1" in x]
    assert len(lines) == 4 and all("AGREED, predicted agree -- as predicted" in x for x in lines)
