"""Force-indeterminate segments: a side push whose two hand contacts on one finger face stick
while both table contacts slide (relaxed utility, end of Sec. 3.2; docs/planning.md, "The
field's tasks").

The mode ``S S R R`` has ``2 n_R + n_S = 6`` kinematic rows for ``3 + n_theta = 5`` coordinates
(a gantry finger); condition (29) by row count refused it, and the task search never listed it.
Its rows have rank 4: one effort-controlled joint (the vertical slide), the push velocity-
controlled.

By hand (weight ``W``, table friction ``mu_t``, hand friction ``mu_h``, ``m = mu_t mu_h``; the
finger's vertical effort ``tau`` pushes the cube down by ``tau``): the table's normal forces sum
to ``W + tau``, so the sliding table resists the push with ``mu_t (W + tau)``, which is the
finger's total normal force; the hand contacts stick iff the vertical force ``|tau|`` they carry
is within ``mu_h`` times it: ``-m W / (1 + m) <= tau <= m W / (1 - m)``, whatever the cube's
size (moments about the leading bottom corner leave the split of the finger's normal force
free: the forces are indeterminate, the band is not).  For the shipped task (``W = 10 N``,
``0.25``, ``0.7``): ``[-1.4894, 2.1212] N``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from side_push_hands import band_by_hand, side_push

from planner.errors import DegenerateError, InputError
from planner.files.hand_file import hand_file_from_dict, load_hand_file
from planner.plan.hand_planner import plan_hand
from planner.plan.partition import control_partitions, joint_inputs, mode_rows
from planner.plan.plan_file import plan_dict, plan_from_dict
from planner.plan.segment_planner import plan_segment
from planner.plan.trajectory import mode_velocity
from planner.predict.feasibility import feasible_modes
from scenarios.registry import DATA_DIR

SIDE_PUSH = DATA_DIR / "side_push.json"


def _check_plan(plan, claim: str, band: tuple[float, float]) -> None:
    assert plan.reached
    assert [s.claim for s in plan.segments] == [claim]
    seg = plan.segments[0]
    assert seg.control == ("velocity", "effort")  # the push driven, the vertical slide free
    assert seg.exact
    for w in seg.waypoints:
        assert w.predicted == (claim,)
        np.testing.assert_allclose(w.bands[0], band, rtol=1e-6)
        assert band[0] < w.torque_commands[0] < band[1]


@pytest.mark.long
def test_the_shipped_side_push_plans_with_the_default_options():
    """``qsplan plan side_push``: one ``S-1 S-2 R3 R4`` segment to the goal (50 mm right), the
    guaranteed band at every waypoint the one derived by hand, exact at the point friction."""
    plan = plan_hand(SIDE_PUSH)
    _check_plan(plan, "S-1 S-2 R3 R4", band_by_hand(10.0, 0.25, 0.7))
    seg = plan.segments[0]
    assert seg.mu_intervals == ((0.25, 0.25), (0.25, 0.25), (0.7, 0.7), (0.7, 0.7))
    assert abs(seg.waypoints[-1].q[0] - 0.05) <= 0.001 + 1e-9  # the goal's tolerance
    # the velocity command is the push itself: the cube and the finger move together
    assert all(w.velocity_commands == pytest.approx((0.01,)) for w in seg.waypoints)
    again = plan_from_dict(json.loads(json.dumps(plan_dict(plan))))
    assert [s.claim for s in again.segments] == ["S-1 S-2 R3 R4"]


@pytest.mark.parametrize(("a", "weight", "mu_table", "mu_hand", "mirrored", "claim"), [
    (0.0435, 10.0, 0.25, 0.7, True, "S+1 S+2 R3 R4"),  # pushed to the left
    pytest.param(0.08, 5.0, 0.3, 0.5, False, "S-1 S-2 R3 R4",  # another cube, weight, friction
                 marks=pytest.mark.long),
])
def test_own_side_pushes_match_the_band_derived_by_hand(a, weight, mu_table, mu_hand,
                                                        mirrored, claim):
    hf = hand_file_from_dict(side_push(a, weight, mu_table, mu_hand, mirrored=mirrored))
    plan = plan_hand(hf)
    _check_plan(plan, claim, band_by_hand(weight, mu_table, mu_hand))
    assert abs(plan.segments[0].waypoints[-1].q[0] - (-0.03 if mirrored else 0.03)) <= 0.001 + 1e-9


@pytest.mark.long
def test_a_frictionless_face_has_no_guaranteed_grip():
    """``mu_h = 0``: by hand the band shrinks to the single effort ``tau = 0`` (``m = 0``), no
    command keeps a margin, so the grip is not planned; the plan stops short with 0 segments
    and says which segment's guarantee failed."""
    assert band_by_hand(10.0, 0.25, 0.0) == (0.0, 0.0)
    data = side_push(0.0435, 10.0, 0.25, 0.7)
    data["mu"]["bodies"]["pusher"] = [0.0, 0.0]
    plan = plan_hand(hand_file_from_dict(data))
    assert not plan.reached
    assert not plan.segments
    assert "S-1 S-2 R3 R4" in json.dumps(plan.diagnosis)


def test_the_partition_of_a_force_indeterminate_mode_comes_from_its_rank():
    """Six rows, rank four: one effort joint, and only the vertical slide can be it (with the
    push effort-controlled the rows leave the push speed free)."""
    hf = load_hand_file(SIDE_PUSH)
    rows = mode_rows(hf.hand, hf.q0, "S-1 S-2 R3 R4")
    assert rows.shape == (6, 5)
    assert control_partitions(2, "S-1 S-2 R3 R4", rows) == [((0,), (1,))]
    with pytest.raises(InputError, match=r"condition \(29\) expected 3 <= 2 n_R \+ n_S <= 3 "
                                         r"\+ n_theta = 5, got 6"):
        control_partitions(2, "S-1 S-2 R3 R4")
    with pytest.raises(InputError, match=r"expected its 6 kinematic rows to have rank between "
                                         r"3 and 3 \+ n_theta = 5 .*got rank 0"):
        control_partitions(2, "S-1 S-2 R3 R4", np.zeros((6, 5)))
    with pytest.raises(InputError, match=r"expected its rows of shape \(6, 5\), got \(4, 5\)"):
        control_partitions(2, "S-1 S-2 R3 R4", rows[:4])
    # the paper's determinate modes keep the row count whatever rows are given
    assert control_partitions(2, "S-1 S-2 S3 S4", rows[:4]) == [((1,), (0,)), ((0,), (1,))]


def test_a_velocity_controlled_slide_is_refused_naming_the_partition():
    hf = load_hand_file(SIDE_PUSH)
    with pytest.raises(InputError, match=r"control: expected velocity-controlled joints forming "
                                         r"a partition of S-1 S-2 R3 R4 \(\|tau_I\| = 1\), got "
                                         r"\(1,\)"):
        plan_segment(hf.hand, hf.q0, data=hf.data, drive=0, speed=0.01, mode="S-1 S-2 R3 R4",
                     mu=[(0.25, 0.25)] * 2 + [(0.7, 0.7)] * 2, model="independent",
                     control=(1,), max_time=1.0, steps=10)


def test_the_mode_velocity_of_the_grip_moves_cube_and_finger_together():
    hf = load_hand_file(SIDE_PUSH)
    vel = mode_velocity(hf.hand, hf.q0, 0, 0.01, "S-1 S-2 R3 R4")
    assert vel is not None
    qdot, thetadot = vel
    np.testing.assert_allclose(qdot, [0.01, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(thetadot, [0.01, 0.0], atol=1e-12)
    # pushed the other way the table contacts would slide the other way: not this label
    assert mode_velocity(hf.hand, hf.q0, 0, -0.01, "S-1 S-2 R3 R4") is None
    system = hf.hand.system(hf.q0, 0.0, joint_inputs(hf.hand, (0,), (0.01,)))
    assert system.dof == 4  # 3 + |tau_I|: six rows are more than the determinate count


def test_the_shipped_file_is_the_documented_task():
    data = json.loads(SIDE_PUSH.read_text())
    assert data["load"]["force"] == [0.0, -10.0]
    assert data["workpiece"]["vertices"][1] == [0.0435, 0]
    assert data["mu"]["bodies"] == {"table": [0.25, 0.25], "finger": [0.7, 0.7]}
    hf = load_hand_file(SIDE_PUSH)
    assert np.max(np.abs(hf.hand.gaps(hf.q0))) < 1e-12


@pytest.mark.long
def test_the_band_is_rechecked_by_the_feasibility_test_with_certificates():
    """Independently of the band code: at the plan's waypoints the feasibility test
    (:func:`planner.predict.feasibility.feasible_modes`, its own LP with a certificate) finds
    the claim, and nothing else, at the command and just inside both ends of the band derived by
    hand, and not just outside them (there no quasistatic mode exists: the finger would slide
    along the face)."""
    plan = plan_hand(SIDE_PUSH)
    seg = plan.segments[0]
    hand = seg.hand_model[0]
    mu = plan.validate_mu[0]
    lo, hi = band_by_hand(10.0, 0.25, 0.7)
    for w in seg.waypoints[::7]:
        system = hand.system(w.q, mu, joint_inputs(hand, (0,), w.velocity_commands))
        for tau, inside in ((w.torque_commands[0], True), (0.98 * lo, True), (0.98 * hi, True),
                            (1.02 * lo, False), (1.02 * hi, False)):
            pred = feasible_modes(system.with_joint_inputs([w.velocity_commands[0], tau]))
            assert pred.labels == (["S-1 S-2 R3 R4"] if inside else []), (w.t, tau)
            if inside:
                fm = pred.find("S-1 S-2 R3 R4")
                assert fm is not None and fm.force_indeterminate
                f = np.asarray(fm.contact_forces).reshape(4, 2)  # (normal, tangential) [N]
                assert np.all(f[:, 0] >= -1e-9)
                # the certificate keeps Coulomb's law: sliding on the table, sticking at the hand
                np.testing.assert_allclose(np.abs(f[:2, 1]), 0.25 * f[:2, 0], atol=1e-9)
                assert np.all(np.abs(f[2:, 1]) <= 0.7 * f[2:, 0] + 1e-9)


def test_a_single_segment_takes_the_family_and_refuses_the_wrong_direction():
    """The file's ``segment`` without a goal: the family ``2R2S`` names the one admissible
    force-indeterminate mode; ``S+1 S+2 R3 R4`` (sliding left while pushed right) is refused
    naming the admissible one."""
    data = json.loads(SIDE_PUSH.read_text())
    data.pop("goal")
    data["segment"].update({"mode": "2R2S", "max_time": 1.0, "steps": 10})
    plan = plan_hand(hand_file_from_dict(data))
    assert [s.claim for s in plan.segments] == ["S-1 S-2 R3 R4"]
    data["segment"]["mode"] = "S+1 S+2 R3 R4"
    with pytest.raises(DegenerateError, match=r"mode 'S\+1 S\+2 R3 R4': expected it kinematically "
                                              r"admissible at the start .* got \['S-1 S-2 R3 R4'\]"):
        plan_hand(hand_file_from_dict(data))
