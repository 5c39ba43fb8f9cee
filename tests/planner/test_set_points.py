"""Points of a plan's uncertainty set and the plan at one of them (planner.plan.set_points;
docs/planning.md, "Validating at points of the set"): corners, centre and outside points as the
set's axes describe them, the hand moved there, and every waypoint's modes predicted there by the
planner -- never copied from the plan."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from set_hands import FULL_SET, planned, short_push

from planner.errors import InputError
from planner.files.hand_file import hand_from_dict
from planner.model.load_set import LoadSet
from planner.plan.load_margins import plan_load_set
from planner.plan.plan_file import load_plan
from planner.plan.set_points import (
    claim_shares,
    hand_data_at,
    parse_kinds,
    plan_at,
    set_axes,
    set_points,
)
from scenarios.set_runs import expectation
from sim.verdict import Expect

SET = LoadSet((0.08, 0.12), ((0.015, 0.025), (0.0135, 0.0235)), 0.1, (0.02, 0.0185))


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    return load_plan(planned(tmp_path_factory.mktemp("set"), FULL_SET))


def test_corners_centre_and_outside_points_of_the_axes():
    axes = set_axes(SET)
    assert [a.key for a in axes] == ["m", "cx", "cy"]
    pts = set_points(axes, ("corners", "centre", "outside"), 0.5)
    corners = [p for p in pts if p.kind == "corner"]
    assert len(corners) == 8 and all(p.inside for p in corners)
    assert {p.values for p in corners} == {tuple(v) for v in SET.points()}  # LoadSet's vertices
    assert corners[0].name == "m-cx-cy-" and corners[-1].name == "m+cx+cy+"
    centre = next(p for p in pts if p.kind == "centre")
    assert centre.values == pytest.approx((0.1, 0.02, 0.0185)) and centre.inside
    out = {p.name: p for p in pts if p.kind == "outside"}
    assert sorted(out) == ["out-cx+", "out-cx-", "out-cy+", "out-cy-", "out-m+", "out-m-"]
    assert out["out-m+"].values == pytest.approx((0.12 + 0.5 * 0.02, 0.02, 0.0185))
    assert out["out-cy-"].values == pytest.approx((0.1, 0.02, 0.0135 - 0.5 * 0.005))
    assert not any(p.inside for p in out.values())


def test_an_axis_of_zero_width_has_one_value_and_no_outside_point():
    ls = LoadSet((0.1, 0.1), ((0.015, 0.025), (0.0185, 0.0185)), 0.1, (0.02, 0.0185))
    pts = set_points(set_axes(ls), ("corners", "outside"), 0.25)
    assert [p.name for p in pts] == ["cx-", "cx+", "out-cx+", "out-cx-"]
    assert all(p.values[0] == 0.1 and p.values[2] == 0.0185 for p in pts)


def test_a_mass_pushed_below_zero_is_left_out():
    ls = LoadSet((0.02, 0.18), ((0.02, 0.02), (0.0185, 0.0185)), 0.1, (0.02, 0.0185))
    assert [p.name for p in set_points(set_axes(ls), ("outside",), 0.5)] == ["out-m+"]


@pytest.mark.parametrize("text, message", [
    ("corner", "--set: expected 'none', 'all' or comma-separated kinds of corners, centre, "
               "outside, got 'corner'"),
    ("corners,,centre", "got 'corners,,centre'"),
    ("none,centre", "got 'none,centre'"),
])
def test_bad_kinds_name_what_came(text, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        parse_kinds(text)


def test_kinds_in_order():
    assert parse_kinds("outside,corners") == ("corners", "outside")
    assert parse_kinds("all") == ("corners", "centre", "outside") and parse_kinds("none") == ()


@pytest.mark.parametrize("step", [0.0, -1.0, float("nan")])
def test_a_bad_outside_step_is_refused(step):
    with pytest.raises(InputError, match="--outside: expected a finite step > 0"):
        set_points(set_axes(SET), ("outside",), step)


def test_the_hand_at_a_point_has_that_mass_centre_of_mass_and_load():
    d = short_push(FULL_SET)
    at = hand_data_at(d, set_axes(SET), (0.12, 0.025, 0.0135))
    hand = hand_from_dict(at)[0]
    assert hand.mass == 0.12 and hand.com.tolist() == [0.025, 0.0135]
    assert hand.load_force == pytest.approx(np.array([0.08 * 1.2, 0.0]))  # load ~ mass
    assert hand.load_set is None and "uncertainty" in d  # the input is not changed
    nominal = hand_from_dict(hand_data_at(d, set_axes(SET), (0.1, 0.02, 0.0185)))[0]
    ref = hand_from_dict(short_push(None))[0]
    assert nominal.mass == ref.mass and np.array_equal(nominal.load_force, ref.load_force)


@pytest.mark.long
def test_the_plan_at_a_point_is_predicted_there_not_copied(plan):
    axes = set_axes(plan_load_set(plan))
    claim = plan.segments[0].claim
    forged = replace(plan, segments=tuple(
        replace(s, waypoints=tuple(replace(w, predicted=("R1 R2 R3 R4",)) for w in s.waypoints))
        for s in plan.segments))
    for p in set_points(axes, ("corners", "centre")):
        moved = plan_at(forged, axes, p, [0.1])
        assert all(w.predicted == (claim,) for w in moved.segments[0].waypoints), p.name
        assert moved.segments[0].hand_model[0].mass == p.values[0]
        assert claim_shares(moved) == ((1.0, 0.0),)
        assert expectation(claim_shares(moved)) is Expect.AGREE


@pytest.mark.long
def test_tipping_outside_the_set_is_predicted(plan):
    """15 mm higher (3 half-widths past the box): the pentagon tips over the left finger's
    push at mu = 0.1; the planner no longer predicts the claim over most of the segment."""
    axes = set_axes(plan_load_set(plan))
    up = next(p for p in set_points(axes, ("outside",), 3.0) if p.name == "out-cy+")
    moved = plan_at(plan, axes, up, [0.1])
    labels = {lab for w in moved.segments[0].waypoints for lab in w.predicted}
    assert "B1 S+2 R3 S-4" in labels
    only, absent = claim_shares(moved)[0]
    assert only < 1.0 and absent > 0.05
    assert expectation(claim_shares(moved)) is Expect.DISAGREE


def test_plan_at_checks_its_arguments(plan):
    axes = set_axes(plan_load_set(plan))
    centre = set_points(axes, ("centre",))[0]
    with pytest.raises(InputError, match=r"mus: expected 1 \(one per segment\), got 2"):
        plan_at(plan, axes, centre, [0.1, 0.2])
    with pytest.raises(InputError, match=r"point: expected 3 values \(one per axis\), got 2"):
        plan_at(plan, axes, replace(centre, values=(0.1, 0.02)), [0.1])


def test_expectation_rule():
    assert expectation([(1.0, 0.0), (1.0, 0.0)]) is Expect.AGREE
    assert expectation([(1.0, 0.0), (0.9, 0.1)]) is Expect.DISAGREE
    assert expectation([(0.9, 0.04)]) is Expect.INFO  # the claim shares the point with a rival
