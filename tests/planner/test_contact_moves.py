"""Contact-position offsets made physical (planner.plan.contact_moves; docs/planning.md,
"Validating at points of the set"): the moved hand file's system at offset 0 *is* the nominal
hand's system with the offsets (W, J, load, every feasible mode with its forces), for a workpiece
vertex on a table, a vertex on a revolute link's side, a fingertip of a prismatic gantry and of a
revolute finger; the scene's tip sits where the hand's does; geometry that cannot move is refused
with the contacts named; the plan at a point of the set has its hands moved and its modes
predicted there."""

from __future__ import annotations

import itertools
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.files.hand_file import hand_file_from_dict
from planner.model.hand_parts import ContactSpec
from planner.plan.contact_moves import (
    PlacedContact,
    contact_words,
    geometry_moves,
    moved_hand_data,
)
from planner.plan.partition import joint_inputs
from planner.predict.feasibility import feasible_modes

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"


def _data(name: str) -> dict:
    return json.loads((DATA / f"{name}.json").read_text())


def _placed(hand, q, s):
    return [PlacedContact(hand, q, i, i + 1, contact_words(hand, i), float(s[i]))
            for i in range(hand.n_contacts)]


def _moved(data, s):
    """The nominal hand file, and the hand file with the geometry moved to offsets ``s``."""
    hf = hand_file_from_dict(data)
    vert, tips = geometry_moves(_placed(hf.hand, hf.q0, s))
    return hf, hand_file_from_dict(moved_hand_data(data, vert, tips))


def _same_system(a, b):
    assert np.allclose(a.W, b.W, rtol=0, atol=1e-12)
    assert np.allclose(a.J, b.J, rtol=0, atol=1e-12)
    assert np.allclose(a.g_obj, b.g_obj, rtol=0, atol=1e-12)


def _same_modes(a, b, mu):
    pa, pb = feasible_modes(a, mu), feasible_modes(b, mu)
    assert pa.labels == pb.labels and pa.labels
    for ma, mb in zip(pa.all_modes, pb.all_modes):
        assert np.allclose(ma.contact_forces, mb.contact_forces, rtol=1e-9, atol=1e-9)
        assert np.allclose(ma.qdot, mb.qdot, rtol=1e-9, atol=1e-12)


# ---- the moved geometry is the planner's offset ----------------------------------------------
@pytest.mark.parametrize("s", list(itertools.product((-0.002, 0.002), repeat=3))
                         + [(0.0, 0.0, 0.004), (0.003, -0.001, 0.0)])
def test_tilting_block_table_vertices_and_gantry_tip(s):
    """Block tilting: vertices 0 and 1 on the table (body frame, along the bottom edge) and the
    gantry's tip on the top edge (its tip shifted across its last link): the moved file closes
    at the same configuration and its system is the nominal one with offsets ``s``."""
    hf, moved = _moved(_data("block_tilting"), np.array(s))
    q0 = hf.q0
    assert np.allclose(moved.q0, q0, rtol=0, atol=1e-12)
    assert np.allclose(moved.hand.gaps(q0), 0.0, atol=1e-12)
    joints = joint_inputs(hf.hand, (0,), [0.01])
    a = moved.hand.system(q0, 0.0, joints).with_joint_inputs([0.01, 9.9])
    b = hf.hand.system(q0, 0.0, joints, offsets=np.array(s)).with_joint_inputs([0.01, 9.9])
    _same_system(a, b)
    nominal = hf.hand.system(q0, 0.0, joints)
    assert not np.allclose(a.W, nominal.W, atol=1e-6)      # the move is not a no-op
    _same_modes(a, b, 0.8)


@pytest.mark.parametrize("s3, s4", list(itertools.product((-0.002, 0.002), repeat=2)))
def test_revolute_finger_side_vertex_and_tip(s3, s4):
    """Two-finger hand: vertex 3 on the left link's side (moved along the link's axis in the
    body frame) and the right finger's tip on edge 1 (moved along the edge in its link's
    frame): ``J`` is the revolute chain's at the moved point, as ``offsets`` models."""
    s = np.array([0.0, 0.0, s3, s4])
    hf, moved = _moved(_data("two_finger_hand"), s)
    q0 = hf.q0
    assert np.allclose(moved.q0, q0, rtol=0, atol=1e-12)
    joints = joint_inputs(hf.hand, (1,), [0.02])
    a = moved.hand.system(q0, 0.0, joints).with_joint_inputs([-0.0029, 0.02])
    b = hf.hand.system(q0, 0.0, joints, offsets=s).with_joint_inputs([-0.0029, 0.02])
    _same_system(a, b)
    assert not np.allclose(a.J, hf.hand.system(q0, 0.0, joints).J, atol=1e-6)
    _same_modes(a, b, 0.1)


def test_the_scene_places_the_moved_tip_where_the_hand_has_it():
    """The simulators' tip circle (both engines build from one scene) at the finger's
    ``tip_offset``: its centre in the world equals ``Hand.tip_centre``."""
    from sim.scene import Circle
    from sim.scenes.hand import finger_body, hand_scene

    d = _data("two_finger_hand")
    d["fingers"][1]["tip_offset"] = [0.0005, -0.0015]
    hf = hand_file_from_dict(d)
    hand, q0 = hf.hand, hf.q0
    scene = hand_scene(hand, q0, 0.3, ["effort", "velocity"], [lambda t, s: 0.0] * 2,
                       overlap=0.0)
    body = next(b for b in scene.bodies if b.name == finger_body(hand, 1, 0))
    circle = next(sh for sh in body.shapes if isinstance(sh, Circle))
    x, y, a = body.pose
    c, sn = np.cos(a), np.sin(a)
    world = np.array([x + c * circle.center[0] - sn * circle.center[1],
                      y + sn * circle.center[0] + c * circle.center[1]])
    assert np.allclose(world, hand.tip_centre(q0, 1), atol=1e-12)
    nominal = hand_file_from_dict(_data("two_finger_hand"))
    assert np.linalg.norm(hand.tip_centre(q0, 1) - nominal.hand.tip_centre(q0, 1)) \
        == pytest.approx(np.hypot(0.0005, 0.0015), rel=1e-9)


def test_a_bad_tip_offset_names_the_field():
    d = _data("two_finger_hand")
    d["fingers"][0]["tip_offset"] = [0.001]
    with pytest.raises(FileFormatError, match=re.escape("fingers[0].tip_offset: expected a "
                                                        "point [x, y], got [0.001]")):
        hand_file_from_dict(d)


# ---- geometry that cannot move ----------------------------------------------------------------
def test_a_vertex_next_to_a_tip_edge_is_refused():
    """Two-finger hand: vertex 1 on the palm ends edge 1, which the right tip touches: moving it
    along the palm would turn that edge (its normal), which no offset of the planner does."""
    hf = hand_file_from_dict(_data("two_finger_hand"))
    with pytest.raises(InputError, match=re.escape(
            "contact positions: moving contact 2 (vertex 1 on palm) turns workpiece edge 1, on "
            "which contact 4 (right tip on edge 1) lies")):
        geometry_moves(_placed(hf.hand, hf.q0, [0.0, 0.002, 0.0, 0.0]))


def test_a_polygon_that_would_turn_concave_is_refused():
    hf = hand_file_from_dict(_data("two_finger_hand"))
    with pytest.raises(InputError, match=re.escape(
            "contact positions: moving contacts 1 (vertex 0 on palm) leaves the workpiece "
            "polygon not convex (a flat or clockwise turn at vertex 4)")):
        geometry_moves(_placed(hf.hand, hf.q0, [0.0025, 0.0, 0.0, 0.0]))


def test_two_contacts_on_one_vertex_are_refused():
    """A vertex on the table and on a second feature: moving it along one moves it across the
    other."""
    hf = hand_file_from_dict(_data("block_tilting"))
    hand = replace(hf.hand, contacts=hf.hand.contacts + (ContactSpec("palm", vertex=1),))
    placed = _placed(hand, hf.q0, [0.0, 0.002, 0.0, 0.0])
    with pytest.raises(InputError, match=re.escape(
            "contact positions: contacts 2 (vertex 1 on table) and 4 (vertex 1 on palm) share "
            "workpiece vertex 1")):
        geometry_moves(placed)
    assert geometry_moves(_placed(hand, hf.q0, [0.0, 0.0, 0.001, 0.0]))[1]   # others may move


# ---- the plan at a point of the set -------------------------------------------------------------
@pytest.fixture(scope="module")
def tilt_plan():
    """Block tilting planned with every contact +-2 mm (the task keeps vertex 1 on the table
    and the tip on the top edge: claim ``R1 R2``)."""
    from planner.plan.hand_planner import plan_hand

    d = _data("block_tilting")
    d["uncertainty"] = {"contacts": 0.002}
    return plan_hand(hand_file_from_dict(d), waypoints=3, margins=False)


def test_the_set_has_one_axis_per_moving_contact(tilt_plan):
    from planner.plan.set_points import corner_count, plan_axes, set_points
    from qsplan.commands.validate_set import axes_line

    axes = plan_axes(tilt_plan)
    assert [a.key for a in axes] == ["m", "cx", "cy", "s1", "s2"]
    assert [a.name for a in axes[3:]] == ["contact 1 position (vertex 1 on table)",
                                          "contact 2 position (finger tip on edge 2)"]
    assert all((a.lo, a.hi, a.nominal) == (-0.002, 0.002, 0.0) for a in axes[3:])
    pts = set_points(axes, ("corners", "centre", "outside"), 0.25)
    assert corner_count(axes) == 4
    assert [p.name for p in pts] == ["s1-s2-", "s1-s2+", "s1+s2-", "s1+s2+", "centre",
                                     "out-s1+", "out-s1-", "out-s2+", "out-s2-"]
    assert pts[-1].words(axes).endswith("s1=0 mm s2=-2.5 mm")
    assert axes_line(axes, pts) == (
        "set: 2 axes (s1 contact 1 position (vertex 1 on table) +-2 mm, s2 contact 2 position "
        "(finger tip on edge 2) +-2 mm); 4 corners (the product of the axes' ends); 9 points "
        "per engine and friction value")


def test_the_plan_at_a_corner_is_the_moved_geometry_predicted_there(tilt_plan):
    """At each corner the segment's hand IS the moved geometry: at its start its system is the
    nominal one with the corner's offsets; the path is the moved body's; every waypoint's modes
    are the planner's there (a forged ``predicted`` does not survive)."""
    from planner.plan.set_points import plan_at, plan_axes, set_points

    axes = plan_axes(tilt_plan)
    seg = tilt_plan.segments[0]
    forged = replace(tilt_plan, segments=(replace(seg, waypoints=tuple(
        replace(w, predicted=("B1 B2",)) for w in seg.waypoints)),))
    hand, q0 = seg.hand_model
    joints = joint_inputs(hand, seg.velocity_joints, list(seg.waypoints[0].velocity_commands))
    for point in set_points(axes, ("corners",)):
        moved = plan_at(forged, axes, point, [0.8]).segments[0]
        mhand, mq0 = moved.hand_model
        assert mhand.load_set is None and mhand.contact_offsets() is None
        assert np.allclose(mq0, q0, atol=1e-12)
        assert np.allclose(moved.waypoints[0].q, q0, atol=1e-12)
        _same_system(mhand.system(q0, 0.0, joints),
                     hand.system(q0, 0.0, joints, offsets=np.array(point.values[3:])))
        assert all(w.predicted == ("R1 R2",) for w in moved.waypoints)
        assert not np.allclose(moved.waypoints[-1].q, seg.waypoints[-1].q, atol=1e-5)
        assert np.allclose(mhand.gaps(moved.waypoints[-1].q), 0.0, atol=1e-9)


def test_far_outside_along_the_pivot_the_planner_loses_the_claim(tilt_plan):
    """The pivot moved 14 mm outwards (6 half-widths past the set): the press force no longer
    tilts the block -- the planner predicts no quasistatic mode at any waypoint, so the run is
    expected to disagree; along the other side it keeps the claim."""
    from planner.plan.set_points import claim_shares, plan_at, plan_axes, set_points
    from scenarios.set_runs import expectation
    from sim.verdict import Expect

    axes = plan_axes(tilt_plan)
    pts = {p.name: p for p in set_points(axes, ("outside",), 6.0)}
    lost = plan_at(tilt_plan, axes, pts["out-s1-"], [0.8])
    assert claim_shares(lost) == ((0.0, 1.0),) and expectation(claim_shares(lost)) is Expect.DISAGREE
    kept = plan_at(tilt_plan, axes, pts["out-s1+"], [0.8])
    assert expectation(claim_shares(kept)) is Expect.AGREE


# ---- a motion that ends early at a point ------------------------------------------------------
@pytest.mark.long
def test_a_box_that_meets_the_table_early_ends_its_segment_there_and_agrees():
    """Box pivot down planned over the whole set (mass +-20 %, centre of mass +-5 mm, contacts
    +-2 mm; tests/data/plan_box_pivot_down_full_set.json): the 80 x 50 mm box pivots about its
    vertex 1 on the table until its vertex 0 meets the table at t = 4.49 s. With that vertex
    2 mm back along the table (``s1 = -2 mm``; in the body frame it moves down by
    ``2 sin 48.9 deg = 1.5 mm``) the box lies flat earlier, tilted by ``-1.5 / 80`` rad: vertex 0
    meets the table before the planned end. The moved path ends there, with the event -- before,
    it stood still at the last state reached for the rest of the segment while the run went on
    turning the box (final position 5.3 % of travel off in pymunk) -- and the run there agrees."""
    from planner.plan.plan_file import load_plan
    from planner.plan.set_points import plan_at, plan_axes, set_points
    from scenarios.set_runs import run_at_point

    plan = load_plan(ROOT / "tests" / "data" / "plan_box_pivot_down_full_set.json")
    axes = plan_axes(plan)
    points = {p.name: p for p in set_points(axes, ["corners", "centre"])}
    end = plan.segments[0].waypoints[-1].t
    centre = plan_at(plan, axes, points["centre"], [0.6]).segments[0]
    assert centre.waypoints[-1].t == end and centre.event == plan.segments[0].event
    early = plan_at(plan, axes, points["m+cx+cy+s1-s2+"], [0.6]).segments[0]
    t = np.array([w.t for w in early.waypoints])
    assert np.all(np.diff(t) > 0) and t[-1] < end - 0.1
    assert early.event.kind == "new contact" and early.event.t == pytest.approx(t[-1])
    assert "vertex 0 meets the table" in early.event.detail
    V = np.array(early.hand["workpiece"]["vertices"])

    def lowest(w):
        x, y, phi = w.pose
        c, s = np.cos(phi), np.sin(phi)
        return (y + V[:, 0] * s + V[:, 1] * c)

    assert lowest(early.waypoints[-1])[0] == pytest.approx(0.0, abs=1e-6)  # vertex 0 lands
    assert lowest(early.waypoints[-2])[0] > 1e-4                            # not before
    assert early.waypoints[-1].pose[2] == pytest.approx(np.arctan2(-1.5e-3, 0.08), abs=2e-3)
    run = run_at_point(plan, axes, points["m+cx+cy+s1-s2+"], "pymunk", 0.6, name="early")
    assert run.matched and not run.failed, run.result.verdict.reasons
    assert run.early and "not 4.49 s: vertex 0 meets the table" in run.early[0]
