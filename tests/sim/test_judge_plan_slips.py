"""Claimed slides slower than the classifier's slip threshold (sim.judge_plan.unresolved_slides,
sim.schedule.predicted_slips): the classifier reads the predicted motion itself as ``R`` there,
so ``R`` shows the claim at such a contact -- and nothing else is excused."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.hand_file import load_hand
from planner.model.modes import Mode
from scenarios.registry import DATA_DIR
from sim.expectation import SegmentExpectation
from sim.judge_plan import compare_plan, shows_claim, unresolved_slides
from sim.schedule import predicted_slips
from sim.verdict import Outcome

CLAIM = Mode.parse("S-1 S-2 R3")
WALL_HELD = Mode.parse("S-1 R2 R3")


def _poses(n, dx=0.001):
    return np.column_stack([dx * np.arange(n), np.zeros(n), np.zeros(n)])


def _segment(slips, times, claim=CLAIM):
    n = len(times)
    return SegmentExpectation(claim=claim, start=0.0, times=np.asarray(times, dtype=float),
                              predicted=(frozenset({claim}),) * n, poses=_poses(n),
                              planned_start=np.zeros(3), pairs=(0, 1, 2), gained=(),
                              travel=0.001 * (n - 1), slips=np.asarray(slips, dtype=float))


def test_predicted_slips_are_the_flip_kinematics():
    """A block of thickness h = 0.02 m turning at omega about its corners on the table (vertex 0,
    x = h sin(theta)) and the wall (vertex 3, y = h cos(theta)): eq. 5's tangential rows give
    ``v_t = -h cos(theta) omega`` on the table (t = rot90((0, 1)) = (-1, 0)) and ``-h
    sin(theta) omega`` on the wall (t = rot90((1, 0)) = (0, 1)), by hand."""
    hand, q, _ = load_hand(DATA_DIR / "flip_against_wall.json")
    h, omega = 0.02, 0.05
    theta = np.radians(np.linspace(5.0, 60.0, 23))
    t = (theta - theta[0]) / omega
    poses = np.column_stack([h * np.sin(theta), np.zeros_like(theta), theta])
    angles = np.tile(q[3:], (len(t), 1))
    v = predicted_slips(hand, t, poses, angles)
    assert v.shape == (len(t), 3)
    np.testing.assert_allclose(v[:, 0], -h * np.cos(theta) * omega, rtol=2e-3, atol=1e-7)
    np.testing.assert_allclose(v[:, 1], -h * np.sin(theta) * omega, rtol=2e-3, atol=1e-7)
    # at 5 degrees the wall corner slips at 1.7e-4 of omega h / h: below 5 % of 0.01 m/s
    assert abs(v[0, 1]) < 0.05 * 0.01 < abs(v[0, 0])


def test_unresolved_slides_flag_only_claimed_slides_below_the_threshold():
    times = [0.0, 1.0, 2.0]
    slips = [[-1e-3, -1e-4, 1e-6], [-1e-3, -4e-4, 1e-6], [-1e-3, -8e-4, 1e-6]]
    seg = _segment(slips, times)
    m = unresolved_slides(seg, np.array([0.0, 0.5, 1.0, 1.5, 2.0]), 5e-4)
    # contact 1 always above; contact 3 is claimed rolling (never flagged, however slow)
    assert not m[:, 0].any() and not m[:, 2].any()
    # contact 2: |v| = 1e-4, 2.5e-4, 4e-4, 6e-4, 8e-4 by linear interpolation
    assert m[:, 1].tolist() == [True, True, True, False, False]
    # without predicted slips nothing is flagged
    empty = _segment(np.zeros((0, 0)), times)
    assert not unresolved_slides(empty, np.array([0.0, 1.0]), 5e-4).any()


def test_a_slow_claimed_slide_read_as_rolling_shows_the_claim():
    m = 40
    observed = [WALL_HELD] * 10 + [CLAIM] * 30
    slow = np.zeros((m, 3), dtype=bool)
    slow[:10, 1] = True
    v = compare_plan(CLAIM, observed, [frozenset({CLAIM})] * m, _poses(5), _poses(5),
                     unresolved=slow)
    assert v.outcome is Outcome.AGREED and v.agreement == 1.0
    assert any("slower than the slip threshold (contact 2)" in r for r in v.reasons)
    # the same observation judged on the claim's tokens alone misses 25 %
    strict = compare_plan(CLAIM, observed, [frozenset({CLAIM})] * m, _poses(5), _poses(5))
    assert strict.outcome is Outcome.DISAGREED and strict.agreement == 0.75


def test_nothing_else_is_excused():
    slow = np.array([False, True, False])
    assert shows_claim(WALL_HELD, CLAIM, slow)
    assert not shows_claim(WALL_HELD, CLAIM, np.array([True, False, True]))
    assert not shows_claim(Mode.parse("S-1 S+2 R3"), CLAIM, slow)  # the opposite slide
    assert not shows_claim(Mode.parse("S-1 B2 R3"), CLAIM, slow)  # the wall lost
    assert not shows_claim(Mode.parse("S-1 R2 S+3"), CLAIM, np.ones(3, dtype=bool))  # R3 slips
    assert not shows_claim("JAM", CLAIM, slow)
    # a claimed slide that is fast enough must be read as sliding
    observed = [WALL_HELD] * 40
    v = compare_plan(CLAIM, observed, [frozenset({CLAIM})] * 40, _poses(5), _poses(5),
                     unresolved=np.zeros((40, 3), dtype=bool))
    assert v.outcome is Outcome.DISAGREED and v.agreement == 0.0


def test_unresolved_shape_is_checked():
    with pytest.raises(InputError, match=r"unresolved: expected shape \(2, 3\), got \(2, 2\)"):
        compare_plan(CLAIM, [CLAIM] * 2, [frozenset({CLAIM})] * 2, _poses(3), _poses(3),
                     unresolved=np.zeros((2, 2), dtype=bool))


# ---- recorded runs of the shipped flip's plan in both engines ----------------------------------
def _flip_run(name):
    from sim_traces import TRACE_DIR, load_plan_trace

    from planner.plan.plan_file import load_plan
    from sim.jobs import job_for_plan

    rec, meta = load_plan_trace(name)
    job = job_for_plan(load_plan(TRACE_DIR / "plan_flip_against_wall.json"), meta["engine"],
                       meta["mu"])
    return rec, job.expectation, job.thresholds


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
def test_recorded_flip_shows_its_claim_where_the_wall_slip_is_resolved(engine):
    """The flip at the box's lower corner (wall and table frictionless, finger 0.7), its first
    16 (pymunk) or 22 (MuJoCo) degrees: the wall corner's predicted slip stays below the slip
    threshold for about a third of the recorded stretch and it reads ``R`` there; on the
    claim's tokens alone the run misses a third, with the slow slides read as either it
    shows the claim on at least 95 % -- in both engines."""
    from dataclasses import replace

    from sim.judge import judge

    rec, exp, th = _flip_run(f"{engine}_flip_lower")
    seg = exp.segments[0]
    assert seg.slips.shape == (len(seg.times), 3)
    verdict = judge(rec, exp, th).verdict
    assert verdict.outcome is Outcome.AGREED and verdict.agreement >= 0.95
    assert any("slower than the slip threshold (contact 2)" in r for r in verdict.reasons)
    blind = replace(exp, segments=(replace(seg, slips=np.zeros((0, 0))),))
    strict = judge(rec, blind, th).verdict
    assert strict.outcome is Outcome.DISAGREED and strict.agreement < 0.8
    assert "'S-1 R2 R3'" in strict.reasons[0]


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
@pytest.mark.parametrize("claim", ["R1 R2 S+3", "S-1 S+2 R3"])
def test_recorded_flip_judged_against_another_claim_disagrees(engine, claim):
    """The same recordings judged against the plan's rival (the finger slipping up,
    ``R1 R2 S+3``) or the wall sliding the other way (``S-1 S+2 R3``, slow at first like the
    claim): the rule excuses nothing the run did not show."""
    from dataclasses import replace

    from sim.judge import judge

    rec, exp, th = _flip_run(f"{engine}_flip_lower")
    seg = exp.segments[0]
    other = Mode.parse(claim)
    wrong = replace(exp, segments=(replace(seg, claim=other, predicted=(frozenset({other}),)
                                           * len(seg.times)),))
    verdict = judge(rec, wrong, th).verdict
    assert verdict.outcome is Outcome.DISAGREED and verdict.agreement < 0.7
