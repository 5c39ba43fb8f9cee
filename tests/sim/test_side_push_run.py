"""The side push in both engines (docs/planning.md, "The field's tasks"): the plan of
``scenarios/data/side_push.json`` -- a force-indeterminate ``S-1 S-2 R3 R4`` segment, both hand
contacts on one finger face sticking while both table contacts slide -- agrees in pymunk and
MuJoCo, and its negative control (the finger's vertical effort just past the band where the
hand contacts stick) disagrees; the mirrored push of an own hand file agrees too.
"""

from __future__ import annotations

import functools

import pytest
from side_push_hands import band_by_hand, side_push

from planner.files.hand_file import hand_file_from_dict
from planner.plan.hand_planner import plan_hand
from planner.plan.negative_controls import outside_torques
from scenarios.registry import DATA_DIR
from scenarios.runs import validate_plan
from sim.backends import DEFAULT_ENGINES
from sim.verdict import Outcome


@functools.cache
def _plan(mirrored: bool):
    if mirrored:
        return plan_hand(hand_file_from_dict(side_push(0.0435, 10.0, 0.25, 0.7, mirrored=True)))
    return plan_hand(DATA_DIR / "side_push.json")


@pytest.mark.long
@pytest.mark.parametrize("mirrored", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("engine", [pytest.param("pymunk", marks=pytest.mark.slow), "mujoco"])
def test_the_side_push_agrees(engine, mirrored):
    plan = _plan(mirrored)
    mu = plan.validate_mu[0] if plan.validate_mu else (0.25, 0.25, 0.7, 0.7)
    run = validate_plan(plan, engine, mu, name="side push")
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reasons


@pytest.mark.long
@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_efforts_past_the_grips_band_disagree(engine):
    plan = _plan(False)
    seg = plan.segments[0]
    mu = plan.validate_mu[0]
    tau = outside_torques(seg, seg.hand_model[0], mu, reach=0.3)
    lo, hi = band_by_hand(10.0, 0.25, 0.7)
    assert all(t[0] > hi or t[0] < lo for t in tau)  # outside the band derived by hand
    run = validate_plan(seg, engine, mu, torques=tau, expect="disagree", name="side push negative")
    if run.verdict.outcome is Outcome.FAULT:
        # past the band no quasistatic mode exists: the finger slides down the cube's face and,
        # with nothing to stop it, leaves the scene -- in pymunk within 0.1 s, before a step is
        # judged (the palm and table set back by the vertex circles' radius)
        assert "left_scene" in run.verdict.reasons[0] and "finger" in run.verdict.reasons[0]
    else:
        assert run.verdict.outcome is Outcome.DISAGREED, run.verdict.reasons
        assert run.summary.passed
