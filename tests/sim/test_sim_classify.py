"""Observed-mode classifier: thresholds, window means with hysteresis, jam detection,
comparison (synthetic signals; recorded ones in test_sim_flicker.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from planner.errors import InputError
from planner.model.modes import Mode
from planner.predict.stages import FeasibleMode
from sim.classify import (
    Thresholds,
    correction_steps,
    jam_steps,
    observed_modes,
    raw_tokens,
    window_mean,
    window_tokens,
)
from sim.expectation import ModeSet
from sim.judge import judge_modes
from sim.judge_switches import compare_switches
from sim.run import Fault, FaultKind, Recording
from sim.verdict import JAM, Expect, Outcome, Verdict


def judge_run(rec, th, modes):
    """A run judged against feasible ``modes`` without a system (no certificate family)."""
    return judge_modes(rec, ModeSet(tuple(modes), None, 1.0, ("workpiece",), 1e-3, 1.0, 1.0),
                       th)


def _rec(vt, fn, present=None, depth=None, dt=0.01, fault=None, jammed_at=None, poses=None,
         correction=None):
    vt = np.asarray(vt, dtype=float)
    T, P = vt.shape
    present = np.ones((T, P), bool) if present is None else np.asarray(present, bool)
    depth = np.zeros((T, P)) if depth is None else np.asarray(depth, dtype=float)
    z = np.zeros((T, P))
    return Recording(engine="test", pair_names=tuple(f"c{i + 1}" for i in range(P)),
                     body_names=("workpiece",), times=dt * (1 + np.arange(T)),
                     poses=np.zeros((T, 1, 3)) if poses is None else poses, present=present,
                     points=np.zeros((T, P, 2)), normals=np.zeros((T, P, 2)),
                     normal_force=np.asarray(fn, dtype=float), tangent_force=z,
                     slip_velocity=vt, depth=depth, mu_used=z, fault=fault,
                     jammed_at=jammed_at, correction=correction)


TH = Thresholds(slip_speed=1e-4, force_floor=1e-3, window=0.05, settle=0.0)


def _fm(label, qdot=(0.0, 0.0, 0.0), n=1):
    return FeasibleMode(mode=Mode.parse(label), qdot=np.asarray(qdot, dtype=float),
                        joint_velocities=np.zeros(0), contact_velocities=np.zeros((n, 2)),
                        contact_forces=np.zeros((n, 2)), joint_efforts=np.zeros(0),
                        margin=1.0, on_boundary=False, force_indeterminate=True)


def test_raw_tokens_use_slip_speed_and_force_floor():
    rec = _rec([[2e-4, -2e-4, 5e-5, 2e-4]], [[1.0, 1.0, 1.0, 1e-4]])
    assert list(raw_tokens(rec, TH)[0]) == ["S+", "S-", "R", "B"]
    rec = _rec([[0.0]], [[1.0]], present=[[False]])
    assert list(raw_tokens(rec, TH)[0]) == ["B"]


def test_window_mean_is_centred_and_weighted():
    times = 0.01 * np.arange(10)
    vals = np.arange(10, dtype=float)
    m = window_mean(vals, np.ones(10), times, 0.02)  # +-1 step
    assert m[5] == pytest.approx(5.0) and m[0] == pytest.approx(0.5)
    w = np.ones(10)
    w[4:7] = 0
    assert np.isnan(window_mean(vals, w, times, 0.02)[5])  # no weight in the window


def test_window_ignores_blips_and_dates_real_changes():
    vt = np.array([[0.0]] * 10 + [[2e-4]] * 10)
    fn = np.ones((20, 1))
    fn[5] = 0.0  # one-step loss
    tok = window_tokens(_rec(vt, fn), TH)[:, 0]
    assert list(tok[:8]) == ["R"] * 8  # a one-step loss is not a mode change
    assert list(tok[12:]) == ["S+"] * 8
    assert 8 <= list(tok).index("S+") <= 11  # the change is dated near where it happened


def test_flicker_cannot_freeze_a_label():
    """A contact sliding on 60 % of the steps (reading R or B on the others, in bursts) is
    sliding; a debounce that restarts its timer on every repeat of the current label would
    keep such a contact in its first label for ever."""
    rng = np.random.default_rng(0)
    T = 400
    slide = rng.random(T) < 0.6
    vt = np.where(slide, 3e-4, 0.0)[:, None]
    present = (slide | (rng.random(T) < 0.5))[:, None]
    rec = _rec(vt, np.ones((T, 1)), present=present, dt=0.001)
    tok = window_tokens(rec, TH)[:, 0]
    assert np.mean(tok[50:] == "S+") > 0.95
    assert np.mean(raw_tokens(rec, TH)[50:, 0] == "S+") < 0.7


def test_hysteresis_stops_chatter_at_the_threshold():
    """A mean slip hovering at the threshold (+-10 %) enters S once and stays."""
    T = 300
    vt = (1e-4 * (1.0 + 0.1 * np.sin(np.arange(T) / 3.0)))[:, None]
    tok = window_tokens(_rec(vt, np.ones((T, 1)), dt=0.001), TH)[:, 0]
    first = list(tok).index("S+")
    assert all(t == "S+" for t in tok[first:])


def test_observed_mode_strings():
    rec = _rec([[2e-4, 0.0, 0.0]] * 3, [[1.0, 1.0, 0.0]] * 3)
    modes = observed_modes(rec, TH)
    assert modes == [Mode.parse("S+1 R2 B3")] * 3
    assert all(isinstance(m, Mode) for m in modes)  # the planner's Mode, not a string


def test_jam_from_force_blow_up_and_from_depth_growth():
    fn = np.ones((100, 2))
    fn[60:] = 100.0
    th_f = Thresholds(slip_speed=1e-4, force_floor=1e-3, window=0.01, settle=0.0,
                      jam_force=50.0)
    assert np.flatnonzero(jam_steps(_rec(np.zeros((100, 2)), fn), th_f))[0] == 60
    th = Thresholds(slip_speed=1e-4, force_floor=1e-3, settle=0.0, jam_depth_rate=1e-5,
                    jam_rate_window=0.1)
    depth = np.tile(1e-5 + 2e-5 * 0.01 * np.arange(100)[:, None], (1, 2))  # grows 2e-5 m/s each
    jam = jam_steps(_rec(np.zeros((100, 2)), np.ones((100, 2)), depth=depth), th)
    assert jam[20:].all() and not jam[:10].any()
    # a see-saw between two contacts (sum constant) is not a jam
    seesaw = np.stack([1e-5 + 5e-6 * np.sin(np.arange(100) / 5),
                       1e-5 - 5e-6 * np.sin(np.arange(100) / 5)], axis=1)
    assert not jam_steps(_rec(np.zeros((100, 2)), np.ones((100, 2)), depth=seesaw), th).any()
    # growing force while the body moves as predicted is not a jam; while it stands still, it is
    q = np.array([1e-3, 0.0, 0.0])
    moving = np.zeros((100, 1, 3))
    moving[:, 0, 0] = 1e-3 * 0.01 * (1 + np.arange(100))
    assert not jam_steps(_rec(np.zeros((100, 2)), fn, poses=moving), th_f, [q]).any()
    assert jam_steps(_rec(np.zeros((100, 2)), fn), th_f, [q])[70:].all()


def test_compare_outcomes():
    rec = _rec([[2e-4]] * 100, [[1.0]] * 100)
    S, R, Sm = _fm("S+1"), _fm("R1"), _fm("S-1")
    assert judge_run(rec, TH, [S])[0].outcome == Outcome.AGREED
    v = judge_run(rec, TH, [R, Sm])[0]
    assert v.outcome == Outcome.DISAGREED and v.agreement == 0.0 and v.judged_steps == 100
    assert judge_run(rec, TH, [])[0].agreement == 0.0  # a predicted jam, not observed
    bad = _rec([[2e-4]] * 100, [[1.0]] * 100,
               fault=Fault(FaultKind.PENETRATION, 0.5, "pair 'c1' too deep"))
    cmp = judge_run(bad, TH, [S])[0]
    assert cmp.outcome == Outcome.FAULT and "penetration at t=0.5000" in cmp.reason
    assert cmp.fault is not None and cmp.fault.kind is FaultKind.PENETRATION
    # nothing judged; a predicted jam observed on every judged step
    assert judge_run(_rec([[2e-4]] * 10, [[1.0]] * 10),
                     dataclasses.replace(TH, settle=1.0), [S])[0].outcome == Outcome.INCONCLUSIVE
    grows = _rec(np.zeros((100, 1)), np.ones((100, 1)) * 100.0)
    th_jam = dataclasses.replace(TH, jam_force=10.0)
    v, observed = judge_run(grows, th_jam, [])
    assert observed[-1] == JAM and v.outcome == Outcome.AGREED, v.reason


def test_a_run_stopped_before_settling_is_inconclusive():
    """A run that stopped early has only pre-settling steps: none is judged."""
    rec = _rec([[2e-4]] * 10, [[1.0]] * 10, jammed_at=0.1)
    th = Thresholds(slip_speed=1e-4, force_floor=1e-3, window=0.05, settle=0.2)
    v = judge_run(rec, th, [_fm("S+1")])[0]
    assert v.outcome is Outcome.INCONCLUSIVE and v.judged_steps == 0


def test_switches_matched_along_the_motion_not_by_index():
    """A spurious extra switch (a flicker) does not shift the later comparisons."""
    pred, pred_sl = [0.15, 0.09, 0.054], [0, 1, 0]
    obs, obs_sl = [0.1502, 0.12, 0.0901, 0.0541], [0, 0, 1, 0]
    v, errors = compare_switches(pred, pred_sl, obs, obs_sl, tolerance=0.02, required=3)
    assert v.outcome is Outcome.AGREED and v.agreement == 1.0
    assert max(e for e in errors if e is not None) < 0.01
    v, _ = compare_switches(pred, pred_sl, [0.1502, 0.0901], [0, 1], tolerance=0.02, required=3)
    assert v.outcome is Outcome.DISAGREED and v.agreement == pytest.approx(2 / 3)


def test_verdict_held_and_bounds():
    agreed = Verdict(Outcome.AGREED, ("ok",), agreement=1.0)
    disagreed = Verdict(Outcome.DISAGREED, ("no",))
    assert agreed.held(Expect.AGREE) and not agreed.held(Expect.DISAGREE)
    assert disagreed.held(Expect.DISAGREE) and not disagreed.held(Expect.AGREE)
    for out in (Outcome.FAULT, Outcome.INCONCLUSIVE):
        v = Verdict(out, ("x",))
        assert not v.held(Expect.AGREE) and not v.held(Expect.DISAGREE)
    with pytest.raises(InputError, match=r"agreement: expected a fraction in \[0, 1\], got 1.5"):
        Verdict(Outcome.AGREED, (), agreement=1.5)
    with pytest.raises(InputError, match="expect: expected one of agree, disagree, info"):
        Expect.parse("maybe")


def test_sliding_finger_sees_through_creep_and_dates_the_hand_over():
    """Ruler: finger 1 slides at the drive speed while finger 2 'sticks' but creeps at 20 % of
    it (MuJoCo's soft friction measured 13-27 %); then they swap at t = 1 s. The sliding finger
    is the one that carries the motion, and the hand-over is dated where it happened."""
    from sim.judge_switches import creep, observed_switches, sliding_finger

    T, dt, v = 200, 0.01, 1e-3
    t = dt * (1 + np.arange(T))
    swap = t > 1.0
    vt = np.stack([np.where(swap, 0.2 * v, v), np.where(swap, -v, -0.2 * v)], axis=1)
    poses = np.zeros((T, 3, 3))
    poses[:, 1, 0] = -0.04 + np.cumsum(np.where(swap, 0.2 * v, v)) * dt  # finger 1
    poses[:, 2, 0] = 0.025 - np.cumsum(np.where(swap, v, 0.2 * v)) * dt  # finger 2
    rec = dataclasses.replace(_rec(vt, np.ones((T, 2)), dt=dt), body_names=(
        "workpiece", "finger1", "finger2"), poses=poses)
    slider = sliding_finger(rec, 0.05 * v, 0.1)
    assert (slider[10:90] == 0).all() and (slider[110:190] == 1).all()
    pos, sl, when = observed_switches(rec, slider, rec.body_names, 0.1)
    assert sl[0] == 0 and pos[0] == pytest.approx(abs(poses[99, 1, 0]), abs=2 * v * dt)
    assert when[0] == pytest.approx(1.0, abs=2 * dt)
    assert creep(rec, slider, 0.1) == pytest.approx(0.2 * v, rel=1e-6)


def test_depth_creep_under_steady_forces_is_no_jam():
    """``jam_depth_force``: the depth rule needs the total normal force to rise by that much
    over the rate window (a soft contact creeping deeper under steady forces is no jam; a
    predicted jam makes the twist test vacuous, so this alone separates them)."""
    depth = np.tile(1e-5 + 2e-5 * 0.01 * np.arange(100)[:, None], (1, 2))
    steady = np.full((100, 2), 1.5)
    th = Thresholds(slip_speed=1e-4, force_floor=1e-3, settle=0.0, jam_depth_rate=1e-5,
                    jam_rate_window=0.1, jam_depth_force=3.0, jam_force=60.0)
    assert not jam_steps(_rec(np.zeros((100, 2)), steady, depth=depth), th).any()
    assert not jam_steps(_rec(np.zeros((100, 2)), steady, depth=depth), th, []).any()
    # the same depth growth with the forces rising 20 N/s each (4 N per 0.1 s in total): a jam
    rising = 1.5 + 20.0 * 0.01 * np.arange(100)[:, None] * np.ones((1, 2))
    jam = jam_steps(_rec(np.zeros((100, 2)), rising, depth=depth), th)
    assert jam[20:95].all() and not jam[:10].any()  # (the centred mean is short at the end)
    # without the force condition (jam_depth_force = 0) depth alone decides
    th0 = Thresholds(slip_speed=1e-4, force_floor=1e-3, settle=0.0, jam_depth_rate=1e-5,
                     jam_rate_window=0.1)
    assert jam_steps(_rec(np.zeros((100, 2)), steady, depth=depth), th0)[20:].all()


def test_motion_by_position_correction_is_found():
    """A workpiece pushed along by the engine's overlap removal (its poses move, its velocities
    do not: pymunk's bias velocities in a wedge jam) is found; the same motion carried by its
    velocities, or a correction that is small against the jam depth rate or against the body's
    own speed, is not. Such steps are no jam (the judge calls the run one the engine cannot
    judge)."""
    T, v = 100, 8e-4
    moving = np.zeros((T, 1, 3))
    moving[:, 0, 0] = -v * 0.01 * (1 + np.arange(T))
    th = Thresholds(slip_speed=1e-4, force_floor=1e-3, window=0.05, settle=0.0,
                    jam_depth_rate=1e-5)
    vt, fn = np.zeros((T, 2)), np.ones((T, 2))
    by_correction = moving.copy()  # every metre of it beyond twist * dt
    assert correction_steps(_rec(vt, fn, poses=moving, correction=by_correction), th)[5:-5].all()
    assert not jam_steps(_rec(vt, fn, poses=moving, correction=by_correction), th, []).any()
    # a body that slides by its velocities: no correction
    assert not correction_steps(_rec(vt, fn, poses=moving, correction=np.zeros((T, 1, 3))),
                                th).any()
    # a recording without the field (older engines' traces) never shows it
    assert not correction_steps(_rec(vt, fn, poses=moving), th).any()
    # a correction slower than the jam depth rate, or under half the body's speed, is none
    slow = by_correction * (0.5e-5 / v)
    assert not correction_steps(_rec(vt, fn, poses=moving, correction=slow), th).any()
    part = by_correction * 0.4
    assert not correction_steps(_rec(vt, fn, poses=moving, correction=part), th).any()
