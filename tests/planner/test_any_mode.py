"""Any contact mode in a segment: the closure of a mode's constraints (eqs. 13-16), starts with
redundant contacts, sticking segments, per-body friction (docs/planning.md, "Any mode in a
segment").

Each test here fails on a planner whose closure asks for one free coordinate per contact: the
sticking-contact closure raised ``expected 3 free coordinates (one per contact)``, the corner
start was refused (``expected at most 4 contacts``), and the task search never tried a mode
with a sticking contact (the shipped field tasks stopped after 0 segments).
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from planner.errors import FileFormatError
from planner.files.hand_file import hand_file_from_dict, load_hand_file
from planner.model.closure import close_configuration, constraint_rank, tangent_jacobian
from planner.plan.hand_planner import plan_hand
from planner.plan.partition import joint_inputs
from planner.plan.plan_file import plan_dict, plan_from_dict
from planner.plan.trajectory import integrate_segment, mode_velocity
from planner.plan.wording import mode_change_words
from scenarios.registry import DATA_DIR

TILT = DATA_DIR / "block_tilting.json"


def _corner_block(phi: float = 0.0, contacts: list | None = None) -> dict:
    """A 0.10 x 0.02 m block on a table (y = 0) against a wall (x = 0, the palm), rotated
    ``phi`` counter-clockwise with vertex 0 on the table and vertex 3 on the wall; a point
    finger on a two-slide gantry touches the middle of its far end (edge 1)."""
    L, H, r = 0.10, 0.02, 0.001
    c, s = math.cos(phi), math.sin(phi)
    x = H * s
    p = np.array([x + c * L - s * H / 2, s * L + c * H / 2])
    n_in = np.array([-c, -s])
    tip = p - r * n_in
    d_b = np.array([math.cos(5 * math.pi / 4), math.sin(5 * math.pi / 4)])
    pivot = tip - 0.05 * d_b - np.array([0.0, 0.02])
    return {
        "palm": {"edge": [[0.0, 0.3], [0.0, -0.01]]},
        "environment": [{"name": "table", "edge": [[-0.01, 0.0], [0.4, 0.0]]}],
        "fingers": [{"name": "finger", "pivot": pivot.tolist(), "links": [
            {"type": "prismatic", "length": 0.02, "width": 2 * r, "offset": math.pi / 2,
             "position": 0.0},
            {"type": "prismatic", "length": 0.05, "width": 2 * r, "offset": 3 * math.pi / 4,
             "position": 0.0}]}],
        "workpiece": {"vertices": [[0, 0], [L, 0], [L, H], [0, H]], "com": [L / 2, H / 2],
                      "mass": 0.12, "pose": [x, 0.0, phi]},
        "contacts": contacts or [
            {"kind": "surface", "vertex": 0, "surface": "table"},
            {"kind": "palm", "vertex": 3},
            {"kind": "tip", "edge": 1, "finger": 0}],
        "load": {"force": [0.0, -1.1772]},
    }


def test_a_start_with_more_contacts_than_coordinates_closes():
    """The block lying in the corner: 5 contacts (two on the table, two on the wall, the
    finger) for 5 coordinates of which the constraints fix only 4 (the rank): it loads, every
    gap closed (refused before: 'expected at most 4 contacts for 2 joints')."""
    data = _corner_block(0.0, [
        {"kind": "surface", "vertex": 0, "surface": "table"},
        {"kind": "surface", "vertex": 1, "surface": "table"},
        {"kind": "palm", "vertex": 0}, {"kind": "palm", "vertex": 3},
        {"kind": "tip", "edge": 1, "finger": 0}])
    data["workpiece"]["pose"] = [0.0004, -0.0003, 0.002]  # rounded: the loader re-closes it
    hf = hand_file_from_dict(data)
    assert np.max(np.abs(hf.hand.gaps(hf.q0))) < 1e-12
    assert constraint_rank(hf.hand.gap_jacobian(hf.q0)) == 4
    np.testing.assert_allclose(hf.q0[:3], 0.0, atol=1e-12)


def test_sticking_closure_has_more_free_coordinates_than_contacts():
    """Three contacts, one sticking, four free coordinates (x, y, phi and the undriven joint):
    closed in the least-squares sense without moving the sticking contact along its edge
    (refused before: 'expected 3 free coordinates (one per contact)')."""
    hf = hand_file_from_dict(_corner_block(math.radians(5)))
    h, q0 = hf.hand, hf.q0
    q = q0.copy()
    q[3] += 1e-3  # the driven joint moved: the contacts open
    assert np.max(np.abs(h.gaps(q))) > 1e-5
    s_before = h.contact_geometry(q)[2][2]
    closed = close_configuration(h, q, [3], sticking=[2])
    assert np.max(np.abs(h.gaps(closed))) < 1e-12
    assert closed[3] == q[3]
    # the tip keeps (to second order) its place on the end face: no slip at the R contact
    assert abs(h.contact_geometry(closed)[2][2] - s_before) < 1e-3


def test_tangent_jacobian_is_the_kinematic_stage_tangential_velocity():
    """``tangent_jacobian @ state rate`` is eq. 5's ``v_t``: zero at the rolling contact of an
    admissible mode, the sliding speed at the sliding ones."""
    hf = hand_file_from_dict(_corner_block(math.radians(5)))
    h, q = hf.hand, hf.q0
    vel = mode_velocity(h, q, 0, 0.01, "S-1 S-2 R3")
    assert vel is not None
    rate = np.concatenate([h.pose_rates_from_twist(q, vel[0]), vel[1]])
    vt = tangent_jacobian(h, q) @ rate
    assert abs(vt[2]) < 1e-12
    assert vt[0] < -1e-4 and vt[1] < -1e-4  # S-: both slide in -t
    system = h.system(q, 0.0, joint_inputs(h, (0,), (0.01,)))
    v = system.W.T @ vel[0] - system.J @ vel[1]
    np.testing.assert_allclose(vt, v.reshape(-1, 2)[:, 1], atol=1e-12)


def test_a_sticking_segment_integrates_to_the_standing_block():
    """The flip against the wall: the finger sticks, the block slides on table and wall and
    stands up; the mode ends at 90 degrees where vertex 0 stops sliding."""
    hf = hand_file_from_dict(_corner_block(math.radians(5)))
    tr = integrate_segment(hf.hand, hf.q0, drive=0, speed=0.01, mode="S-1 S-2 R3",
                           max_time=30.0, steps=300)
    assert tr.event.kind == "mode change"
    assert "contact 1 (vertex 0 on the table) stops sliding" in tr.event.detail
    assert tr.q[-1, 2] == pytest.approx(math.pi / 2, abs=1e-6)
    assert np.max(np.abs(hf.hand.gaps(tr.q[-1]))) < 1e-10


def test_mode_change_words_take_unsigned_sliding_tokens():
    """A mode on the boundary between sliding directions (``S2``, ``xi = 0``) is worded, not
    an error (it raised 'expected R, S+, S- or B before 2')."""
    hf = hand_file_from_dict(_corner_block(math.radians(5)))
    words = mode_change_words(hf.hand, "S-1 S-2 R3", ["R1 S2 S+3"])
    assert "contact 1 (vertex 0 on the table) stops sliding" in words


def test_mu_bodies_errors_name_the_body():
    data = _corner_block(math.radians(5))
    data["mu"] = {"bodies": {"finger": [0.7, 1.0], "floor": [0.0, 0.4]}}
    with pytest.raises(FileFormatError, match=r"mu.bodies: expected body names among "
                       r"\['palm', 'table', 'finger'\].*got 'floor'"):
        hand_file_from_dict(data)
    data["mu"] = {"bodies": {"finger": [1.0, 0.7]}}
    with pytest.raises(FileFormatError, match=r"mu.bodies.finger: expected lo <= hi"):
        hand_file_from_dict(data)
    data["mu"] = {"bodies": {"finger": [0.7, 1.0]}, "validate": [{"wall": 0.1}]}
    with pytest.raises(FileFormatError, match=r"mu.validate\[0\]: expected body names"):
        hand_file_from_dict(data)


def test_per_body_friction_of_a_single_segment():
    """One segment planned with ``mu.bodies``: each contact gets its body's interval and the
    validation values are per contact."""
    data = _corner_block(math.radians(5))
    data["segment"] = {"drive": 0, "speed": 0.01, "mode": "S-1 S-2 R3", "max_time": 2.0,
                       "waypoints": 3}
    data["mu"] = {"bodies": {"finger": [0.7, 1.0], "table": [0.0, 0.4], "palm": [0.0, 0.4]},
                  "validate": [{"finger": 0.8, "table": 0.2, "palm": 0.3}, 0.5]}
    plan = plan_hand(hand_file_from_dict(data))
    assert plan.segments[0].mu_intervals == ((0.0, 0.4), (0.0, 0.4), (0.7, 1.0))
    assert plan.validate_mu == ((0.2, 0.3, 0.8),)  # 0.5 lies outside the table's interval
    # the plan file keeps them: a loaded segment is guaranteed over the bodies' intervals
    loaded = plan_from_dict(plan_dict(plan))
    assert loaded.segments[0].mu_intervals == ((0.0, 0.4), (0.0, 0.4), (0.7, 1.0))


@pytest.mark.long
def test_block_tilting_plans_to_its_goal_with_a_sticking_segment():
    """The shipped block-tilting task plans to its goal with the default options: the bottom
    edge and the finger stick (``R1 R2``), at least 30 degrees (0 segments before)."""
    plan = plan_hand(TILT)
    assert plan.reached
    assert [s.claim for s in plan.segments] == ["R1 R2"]
    assert plan.segments[-1].waypoints[-1].q[2] <= -math.radians(30)
    hf = load_hand_file(TILT)
    assert hf.goal is not None


def test_the_shipped_field_tasks_load():
    for name in ("block_tilting", "box_pivot_up", "box_pivot_down"):
        data = json.loads((DATA_DIR / f"{name}.json").read_text())
        hf = hand_file_from_dict(copy.deepcopy(data))
        assert hf.goal is not None and np.max(np.abs(hf.hand.gaps(hf.q0))) < 1e-12


def test_remedy_names_the_friction_a_sticking_finger_needs():
    """The box pivot with its finger 0.02 m from the pivot corner on a 0.05 m tall box: the
    finger must drag the top face, 0.05 mu N > 0.02 N (moments about the pivot, gravity's
    extra term vanishing as the squeeze grows), so no effort guarantees ``R1 R2`` over
    [0.3, 0.9] and the remedy asks for friction of at least 0.4 (hand-derived).  The table's
    corner must hold the same horizontal force, mu_t (N + m g) >= 0.4 N, so raising one
    contact's lower end alone never works: with model ``independent`` no contact is named."""
    from planner.plan.segment_planner import remedies
    from planner.plan.task_contacts import with_contacts

    hf = load_hand_file(DATA_DIR / "box_pivot_up.json")
    h = with_contacts(hf.hand, hf.hand.contacts[1:])  # vertex 1 on the table, the tip
    lo, hi = np.array([0.3, 0.3]), np.array([0.9, 0.9])
    out = remedies(h, hf.q0, (0,), np.array([0.01]), "R1 R2", lo, hi, "common")
    assert len(out) == 1
    need = float(out[0].split("at least ")[1].split(" ")[0])
    assert 0.4 <= need <= 0.41
    out = remedies(h, hf.q0, (0,), np.array([0.01]), "R1 R2", lo, hi, "independent")
    assert len(out) == 1 and out[0].startswith("friction at least 0.4")
