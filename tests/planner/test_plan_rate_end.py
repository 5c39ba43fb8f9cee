"""A segment ends before its rates diverge (docs/planning.md, "Waypoint spacing", "Rates").

Two random three-finger hands (``tests/data/three_finger_fold_left.json`` and
``three_finger_fold_right.json``) slide their workpiece in 5S until the contact constraints
become singular: at that fold the top finger's rate grows as ``1/sqrt(t_end - t)`` (14666 and
24858 rad/s at the last state the integration reaches, against 0.24 and 0.17 rad/s one
waypoint earlier).  A plan must not keep a waypoint there: its commands and the motion it
describes could not be held between waypoints, and the validation's slow motion follows its
fastest command.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np
import pytest

from planner.files.hand_file import load_hand_file
from planner.model.hand import Hand
from planner.plan.hand_planner import plan_hand
from planner.plan.model import Event, Plan
from planner.plan.spacing import POSE_TOLERANCE_OF_TRAVEL, STILL, joint_travel, rate_lags
from planner.plan.trajectory import Trajectory

DATA = Path(__file__).parents[1] / "data"
HANDS = ("three_finger_fold_left.json", "three_finger_fold_right.json")


@functools.cache
def _plan(name: str) -> Plan:
    return plan_hand(DATA / name)


@functools.cache
def _hand() -> Hand:
    return load_hand_file(DATA / HANDS[0]).hand  # three revolute joints, size about 5 cm


def _lines(t: np.ndarray, theta: np.ndarray, rate: np.ndarray,
           still: np.ndarray | None = None) -> Trajectory:
    """A trajectory of the hand's first joint with the given coordinates and rates; the
    second joint's rates ``still`` (default 0), the third at rest, the workpiece at rest."""
    n = len(t)
    q = np.zeros((n, 6))
    q[:, 3] = theta
    rates = np.zeros((n, 3))
    rates[:, 0] = rate
    if still is not None:
        rates[:, 1] = still
    return Trajectory(t, q, np.zeros((n, 3)), rates, "1S", 0, 1.0,
                      Event("time limit", "", float(t[-1])))


def test_lag_of_a_linear_rate_is_a_quarter_step_times_its_change() -> None:
    # theta = t^2 / 2 on [0, 1]: rate t; 4 intervals of 0.25 s, each rate change 0.25 rad/s
    t = np.linspace(0.0, 1.0, 5)
    tr = _lines(t, 0.5 * t**2, t)
    travel = joint_travel(_hand(), tr)
    assert travel[0] == pytest.approx(0.5)
    # a joint that does not move is held to STILL of the size: 1e-6 rad within 2 %
    assert travel[1:] == pytest.approx([STILL / POSE_TOLERANCE_OF_TRAVEL] * 2)
    lags = rate_lags(tr, travel)
    # dt |dr| / 4 = 0.25 * 0.25 / 4 over a travel of 0.5
    assert lags[:, 0] == pytest.approx([0.25 * 0.25 / 4 / 0.5] * 4)
    assert np.all(lags[:, 1:] == 0.0)
    # the straight line between waypoints is off the parabola by half of that at mid-interval
    mid = 0.5 * (t[:-1] + t[1:])
    chord = 0.5 * (0.5 * t[:-1] ** 2 + 0.5 * t[1:] ** 2)
    assert np.abs(chord - 0.5 * mid**2) == pytest.approx(0.5 * lags[:, 0] * travel[0])


def test_a_fold_fails_at_any_spacing_a_smooth_rate_passes_when_fine() -> None:
    # theta = -2 sqrt(1 - t): rate 1 / sqrt(1 - t), unbounded at t = 1 (a fold of the closure)
    for n in (11, 101, 1001):
        t = np.linspace(0.0, 1.0, n)
        rate = 1.0 / np.sqrt(np.maximum(1.0 - t, 1e-16))
        tr = _lines(t, -2.0 * np.sqrt(1.0 - t), rate)
        lags = rate_lags(tr, joint_travel(_hand(), tr))[:, 0]
        assert lags[-1] > POSE_TOLERANCE_OF_TRAVEL
        assert np.all(lags[: n // 2] <= POSE_TOLERANCE_OF_TRAVEL)
    t = np.linspace(0.0, 1.0, 11)
    # round-off rates of a joint that does not move do not count
    noise = 1e-9 * np.random.default_rng(7).standard_normal(len(t))
    tr = _lines(t, 0.5 * t**2, t, still=noise)
    assert np.all(rate_lags(tr, joint_travel(_hand(), tr)) <= POSE_TOLERANCE_OF_TRAVEL)
    assert np.any(rate_lags(tr, np.array([0.5, 1e-12, 1.0]))[:, 1] > POSE_TOLERANCE_OF_TRAVEL)


@pytest.mark.parametrize("name", HANDS)
def test_fold_hand_commands_do_not_jump(name: str) -> None:
    seg = _plan(name).segments[0]
    V = [j for j, c in enumerate(seg.control) if c == "velocity"]
    t = np.array([w.t for w in seg.waypoints])
    angles = np.array([w.angles for w in seg.waypoints])
    cmd = np.array([w.velocity_commands for w in seg.waypoints])
    travel = np.sum(np.abs(np.diff(angles, axis=0)), axis=0)
    assert np.all(np.isfinite(cmd))
    # a held command is the mean rate over its interval, between the rates at its two ends;
    # two neighbouring commands then differ by at most the rate change over both intervals,
    # each bounded by 4 * POSE_TOLERANCE_OF_TRAVEL * travel / dt (docs/planning.md)
    dt = np.diff(t)
    for i, j in enumerate(V):
        jump = 0.25 * dt * np.abs(np.diff(cmd[:, i]))
        assert np.all(jump <= 2 * POSE_TOLERANCE_OF_TRAVEL * travel[j]), (j, cmd[:, i])
    # every joint, from the plan's own angles (even spacing): a step theta_k+1 - theta_k lies in
    # dt [r_k, r_k+1], so two neighbouring steps differ by at most dt (|dr_k| + |dr_k+1|) <=
    # 2 * 4 * POSE_TOLERANCE_OF_TRAVEL * travel (before: the top finger 1.15 times that)
    assert np.allclose(dt, dt[0])
    second = np.abs(np.diff(angles, 2, axis=0))
    assert np.all(second <= 8 * POSE_TOLERANCE_OF_TRAVEL * travel + 1e-12), second.max(axis=0)


@pytest.mark.parametrize("name", HANDS)
def test_fold_hand_ends_before_the_singular_configuration_and_says_so(name: str) -> None:
    plan = _plan(name)
    seg = plan.segments[0]
    ended = seg.extra["spacing"]["ended"]
    assert seg.event.kind == "mode change"
    assert re.match(r"near a singular configuration: the top finger would need \d+ rad/s at "
                    r"t = [\d.]+ s, against 0\.\d+ rad/s at the last waypoint kept", seg.event.detail)
    assert "no waypoint spacing holds it, so the segment ends here" in seg.event.detail
    assert "become singular or ill-conditioned" in seg.event.detail
    assert ended["joint"] == 2 and abs(ended["needed"]) > 1e3
    assert seg.waypoints[-1].t == pytest.approx(ended["t_s"]) == pytest.approx(seg.event.t)
    assert ended["t_next_s"] > seg.waypoints[-1].t
    assert all(w.margin > 0 for w in seg.waypoints)


@pytest.mark.long
@pytest.mark.parametrize("name", [pytest.param(HANDS[0], marks=pytest.mark.slow), HANDS[1]])
def test_fold_hand_plan_validates_in_pymunk(name: str) -> None:
    """Each plan, ended before the fold, agrees in pymunk at its validation frictions (before:
    the left hand's last command of 14666 rad/s set a slow motion of 8.5e5 s, over the 300 s a
    run may last; the right hand's contact 5 lost its load over the last 5 % of the segment,
    the claim seen on 94.5-94.7 % of it).  The left hand runs by hand (``-m slow``): its command
    no longer jumps, which the planner-level tests above check for both hands."""
    from scenarios.runs import validate_plan
    from sim.verdict import Outcome

    plan = _plan(name)
    for mu in plan.validate_mu:
        run = validate_plan(plan, "pymunk", mu)
        assert run.verdict.outcome is Outcome.AGREED, (mu, run.verdict.reasons)
