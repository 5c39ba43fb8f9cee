"""Observed-mode classifier: thresholds, debouncing, jam detection, comparison."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.model.modes import Mode
from sim.classify import (
    Thresholds,
    debounce,
    jam_steps,
    judge_run,
    observed_modes,
    raw_tokens,
)
from sim.compare import JAM, Expect, Outcome, Verdict, compare_modes
from sim.run import Fault, FaultKind, Recording


def _rec(vt, fn, present=None, depth=None, dt=0.01, fault=None, jammed_at=None):
    vt = np.asarray(vt, dtype=float)
    T, P = vt.shape
    present = np.ones((T, P), bool) if present is None else np.asarray(present, bool)
    depth = np.zeros((T, P)) if depth is None else np.asarray(depth, dtype=float)
    z = np.zeros((T, P))
    return Recording(engine="test", pair_names=tuple(f"c{i + 1}" for i in range(P)),
                     body_names=("workpiece",), times=dt * (1 + np.arange(T)),
                     poses=np.zeros((T, 1, 3)), present=present,
                     points=np.zeros((T, P, 2)), normals=np.zeros((T, P, 2)),
                     normal_force=np.asarray(fn, dtype=float), tangent_force=z,
                     slip_velocity=vt, depth=depth, mu_used=z, fault=fault,
                     jammed_at=jammed_at)


TH = Thresholds(slip_speed=1e-4, force_floor=1e-3, debounce=0.05, settle=0.0)


def test_raw_tokens_use_slip_speed_and_force_floor():
    rec = _rec([[2e-4, -2e-4, 5e-5, 2e-4]], [[1.0, 1.0, 1.0, 1e-4]])
    assert list(raw_tokens(rec, TH)[0]) == ["S+", "S-", "R", "B"]
    rec = _rec([[0.0]], [[1.0]], present=[[False]])
    assert list(raw_tokens(rec, TH)[0]) == ["B"]


def test_debounce_ignores_blips_and_backfills_real_changes():
    tok = np.array([["R"]] * 5 + [["B"]] + [["R"]] * 4 + [["S+"]] * 10, dtype=object)
    times = 0.01 * np.arange(len(tok))
    out = debounce(tok, times, 0.05)
    assert list(out[:10, 0]) == ["R"] * 10  # one-step loss is not a mode change
    assert list(out[10:, 0]) == ["S+"] * 10  # a persistent change starts where it started


def test_observed_mode_strings():
    rec = _rec([[2e-4, 0.0, 0.0]] * 3, [[1.0, 1.0, 0.0]] * 3)
    modes = observed_modes(rec, TH)
    assert modes == [Mode.parse("S+1 R2 B3")] * 3
    assert all(isinstance(m, Mode) for m in modes)  # the planner's Mode, not a string


def test_jam_from_force_blow_up_and_from_depth_growth():
    fn = np.ones((100, 2))
    fn[60:] = 100.0
    assert np.flatnonzero(jam_steps(_rec(np.zeros((100, 2)), fn), TH, 50.0))[0] == 60
    th = Thresholds(slip_speed=1e-4, force_floor=1e-3, settle=0.0, jam_depth_rate=1e-5,
                    jam_rate_window=0.1)
    depth = np.tile(1e-5 + 2e-5 * 0.01 * np.arange(100)[:, None], (1, 2))  # grows 2e-5 m/s each
    jam = jam_steps(_rec(np.zeros((100, 2)), np.ones((100, 2)), depth=depth), th, None)
    assert jam[20:].all() and not jam[:10].any()
    # a see-saw between two contacts (sum constant) is not a jam
    seesaw = np.stack([1e-5 + 5e-6 * np.sin(np.arange(100) / 5),
                       1e-5 - 5e-6 * np.sin(np.arange(100) / 5)], axis=1)
    assert not jam_steps(_rec(np.zeros((100, 2)), np.ones((100, 2)), depth=seesaw), th,
                         None).any()


def test_compare_outcomes():
    rec = _rec([[2e-4]] * 100, [[1.0]] * 100)
    S, R, Sm = Mode.parse("S+1"), Mode.parse("R1"), Mode.parse("S-1")
    assert judge_run(rec, TH, [S])[0].outcome == Outcome.AGREED
    v = judge_run(rec, TH, [R, Sm])[0]
    assert v.outcome == Outcome.DISAGREED and v.agreement == 0.0 and v.judged_steps == 100
    assert judge_run(rec, TH, [JAM])[0].agreement == 0.0
    bad = _rec([[2e-4]] * 100, [[1.0]] * 100,
               fault=Fault(FaultKind.PENETRATION, 0.5, "pair 'c1' too deep"))
    cmp = judge_run(bad, TH, [S])[0]
    assert cmp.outcome == Outcome.FAULT and "penetration at t=0.5000" in cmp.reason
    assert cmp.fault is not None and cmp.fault.kind is FaultKind.PENETRATION
    assert compare_modes([], [S]).outcome == Outcome.INCONCLUSIVE


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
