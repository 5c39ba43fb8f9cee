"""Observed-mode classifier: thresholds, debouncing, jam detection, comparison."""

from __future__ import annotations

import numpy as np

from sim.classify import (
    JAM,
    Outcome,
    Thresholds,
    compare,
    debounce,
    jam_steps,
    observed_modes,
    raw_tokens,
)
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
    assert observed_modes(rec, TH) == ["S+1 R2 B3"] * 3


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
    obs = observed_modes(rec, TH)
    assert compare(rec, obs, ["S+1"], TH).outcome == Outcome.AGREED
    assert compare(rec, obs, ["R1", "S-1"], TH).outcome == Outcome.DISAGREED
    assert compare(rec, obs, [JAM], TH).agreement == 0.0
    bad = _rec([[2e-4]] * 100, [[1.0]] * 100,
               fault=Fault(FaultKind.PENETRATION, 0.5, "pair 'c1' too deep"))
    cmp = compare(bad, obs, ["S+1"], TH)
    assert cmp.outcome == Outcome.FAULT and "penetration at t=0.5000" in cmp.reason
