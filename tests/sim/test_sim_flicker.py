"""The classifier and the verdict on RECORDED simulator traces from both engines
(tests/data/sim_trace_*.npz, written by tests/data/record_sim_traces.py), including negative
controls where the simulator check disagrees with the planner.

The predictions are recomputed by the planner for each trace's system and friction; nothing
predicted is stored with the traces.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sim_traces import load_trace

from sim.classify import (
    flicker_fraction,
    jam_steps,
    judged_mask,
    mode_of,
    raw_tokens,
    window_tokens,
)
from sim.judge import judge_modes
from sim.verdict import JAM, TWIST_TOLERANCE, Outcome

FLICKER = ["mujoco_ex41_3s_flicker", "mujoco_ex41_3s_flicker_b", "pymunk_ex41_jam_flicker"]


@pytest.mark.parametrize("name", FLICKER)
def test_recorded_flicker_is_real(name):
    """The per-step labels of these runs do flicker: on a large share of the judged steps the
    raw label differs from the window label."""
    t = load_trace(name)
    th = t.thresholds()
    assert flicker_fraction(t.rec, th, judged_mask(t.rec, th)) > 0.3


@pytest.mark.parametrize("name", ["mujoco_ex41_3s_flicker", "mujoco_ex41_3s_flicker_b"])
def test_window_classifier_sees_the_predicted_mode_through_mujoco_flicker(name):
    """Example 4.1 inside the 3S region at mu_2 >= 0.6 in MuJoCo: contact 3's raw labels cycle
    through S, R and B every few milliseconds. The per-step labels are in the predicted mode on
    under a third of the steps; the window means on >= 95 %, the workpiece twist follows the
    predicted qdot within the tolerance, and the mean forces are within the tolerance of the
    certificate's total normal force (7 % and 4 %, MuJoCo's soft contacts about 10 % low)."""
    t = load_trace(name)
    th = t.thresholds()
    pred = t.prediction()
    assert [m.mode.label for m in pred.all_modes] == ["S+1 S-2 S-3"]
    mask = judged_mask(t.rec, th)
    raw = [mode_of(tuple(r)) for r in raw_tokens(t.rec, th)[mask]]
    assert np.mean([m == pred.all_modes[0].mode for m in raw]) < 0.35
    v, observed = judge_modes(t.rec, t.expectation(pred.all_modes), th)
    assert v.agreement >= 0.95 and v.judged_steps == int(mask.sum())
    assert v.motion is not None and v.motion.twist_error is not None
    assert v.motion.twist_error <= TWIST_TOLERANCE
    assert v.outcome is Outcome.AGREED and v.motion.force_error < 0.1
    assert JAM not in observed  # forces build up while the body moves as predicted: no jam


@pytest.mark.parametrize(("name", "outcome"), [("mujoco_ex41_3s_flicker", Outcome.INCONCLUSIVE),
                                               ("pymunk_ex41_3s", Outcome.DISAGREED)])
def test_a_force_miss_under_flicker_is_inconclusive(name, outcome):
    """The same runs judged against a system whose load is 1.3 x (every certificate's forces
    30 % higher; modes and twist unchanged): the flickering MuJoCo run cannot judge forces --
    ``inconclusive``, saying why -- while the clean pymunk run disagrees."""
    t = load_trace(name)
    system = t.system()
    heavier = dataclasses.replace(system, g_obj=1.3 * np.asarray(system.g_obj))
    v, _ = judge_modes(t.rec, t.expectation(t.prediction().all_modes, system=heavier),
                       t.thresholds())
    assert v.agreement >= 0.95 and v.outcome is outcome, v.reason
    assert ("flicker" in v.reason) == (outcome is Outcome.INCONCLUSIVE)


def test_jam_needs_a_workpiece_that_stops_following():
    """The penetration-growth rule alone fires on the MuJoCo 3S flicker (forces build up and
    level off); gated by the predicted twist, which the workpiece follows, it does not."""
    t = load_trace("mujoco_ex41_3s_flicker_b")
    th = t.thresholds()
    twists = [m.qdot for m in t.prediction().all_modes]
    assert jam_steps(t.rec, th).sum() > 0
    assert jam_steps(t.rec, th, twists).sum() == 0


@pytest.mark.parametrize("name", ["pymunk_ex41_jam_flicker", "mujoco_ex41_jam"])
def test_recorded_jams_agree_with_a_predicted_jam(name):
    """Example 4.1 where no mode is feasible: pymunk's force blows up (its labels flicker),
    MuJoCo's penetration grows. Both are observed jams."""
    t = load_trace(name)
    th = t.thresholds()
    pred = t.prediction()
    assert pred.all_modes == ()
    v, _ = judge_modes(t.rec, t.expectation(pred.all_modes), th)
    assert v.outcome is Outcome.AGREED and v.observed_counts == ((JAM, v.judged_steps),)


@pytest.mark.parametrize("name", ["pymunk_ex41_jam_flicker", "mujoco_ex41_jam"])
def test_negative_control_jam_judged_by_a_feasible_prediction(name):
    """The same jam runs judged against the 3S prediction of mu = (0.2, 0.3, 0.1): the check
    disagrees with the planner."""
    t = load_trace(name)
    pred = t.prediction((0.2, 0.3, 0.1))
    assert [m.mode.label for m in pred.all_modes] == ["S+1 S-2 S-3"]
    v, _ = judge_modes(t.rec, t.expectation(pred.all_modes, (0.2, 0.3, 0.1)), t.thresholds())
    assert v.outcome is Outcome.DISAGREED and v.agreement < 0.5


@pytest.mark.parametrize("name", ["pymunk_ex41_3s", "mujoco_ex41_3s_flicker"])
def test_negative_control_wrong_region(name):
    """3S runs judged by the RS region's prediction (mu = 0.75, 0.45, 0.55) disagree: the
    labels, and the twist (its rotation has the other sign)."""
    t = load_trace(name)
    pred = t.prediction((0.75, 0.45, 0.55))
    assert [m.mode.label for m in pred.all_modes] == ["R1 S-2 B3"]
    v, _ = judge_modes(t.rec, t.expectation(pred.all_modes, (0.75, 0.45, 0.55)),
                       t.thresholds())
    assert v.outcome is Outcome.DISAGREED and v.agreement == 0.0
    assert v.motion is not None and v.motion.twist_cosine is not None
    assert v.motion.twist_error > TWIST_TOLERANCE and v.motion.twist_cosine < 0.5


def test_clean_pymunk_run_agrees_in_modes_twist_and_forces():
    t = load_trace("pymunk_ex41_3s")
    v, _ = judge_modes(t.rec, t.expectation(t.prediction().all_modes), t.thresholds())
    assert v.outcome is Outcome.AGREED and v.agreement == 1.0
    assert v.motion is not None and v.motion.force_error is not None
    assert v.motion.force_error <= 0.1 and v.motion.twist_error <= TWIST_TOLERANCE
    assert 0.9 < v.motion.twist_size_ratio < 1.1 and v.motion.twist_cosine > 0.99


def test_negative_control_twist_alone():
    """Modes right, twist wrong: the prediction's qdot scaled by 1.5 (same direction, wrong
    size) turns an agreeing pymunk run into a disagreement."""
    t = load_trace("pymunk_ex41_3s")
    fm = t.prediction().all_modes[0]
    wrong = dataclasses.replace(fm, qdot=1.5 * np.asarray(fm.qdot))
    v, _ = judge_modes(t.rec, t.expectation([wrong]), t.thresholds())
    assert v.agreement == 1.0 and v.outcome is Outcome.DISAGREED
    assert v.motion is not None and v.motion.twist_size_ratio == pytest.approx(2 / 3, rel=0.05)


def test_negative_control_forces_alone():
    """Modes and twist right, the load doubled in the judged system (so every member of the
    certificate family carries twice the forces): disagreed (a clean run, no flicker to
    blame)."""
    t = load_trace("pymunk_ex41_3s")
    system = t.system()
    heavy = dataclasses.replace(system, g_obj=2.0 * np.asarray(system.g_obj))
    fm = t.prediction().all_modes[0]
    v, _ = judge_modes(t.rec, t.expectation([fm], system=heavy), t.thresholds())
    assert v.agreement == 1.0 and v.outcome is Outcome.DISAGREED
    assert "contact forces off the certificate" in v.reason


def test_window_classifier_leaves_a_wedge():
    """pymunk wedges Example 4.3 at mu = 3 (B1 R2 S-3 under 30-110 x the load) and then slides
    off into S-1 R2 B3 with the load alone; the window labels follow the raw labels into the
    new mode within one window (a label frozen by flicker never would)."""
    t = load_trace("pymunk_ex43_mu3_wedge")
    th = t.thresholds()
    raw = raw_tokens(t.rec, th)
    win = window_tokens(t.rec, th)
    last = tuple(raw[-1])
    assert last == ("S-", "R", "B")
    first_raw = int(np.flatnonzero([tuple(r) == last for r in raw])[0])
    first_win = int(np.flatnonzero([tuple(r) == last for r in win])[0])
    step = float(t.rec.times[1] - t.rec.times[0])
    assert abs(first_win - first_raw) * step <= th.window
    assert all(tuple(r) == last for r in win[first_win + int(th.window / step):])
