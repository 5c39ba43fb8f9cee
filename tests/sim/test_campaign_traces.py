"""The judge on recorded validation-campaign runs (tests/data/campaign_trace_*.npz, recorded by
tests/data/record_sim_traces.py through ``qsplan simulate``'s path; the prediction is made
again here). No simulator runs.

Tall boxes on many supports tipping about a corner (seed 6, supports 6 and 9): MuJoCo's support
next to the pivot stays sunk in the soft table while the box turns. It touches the box at the
end of its flat top nearer the pivot (``sim.scenes.shapes.ENV_INSET`` of the size from the
model's contact point), where the predicted motion lifts the box slower than at the model's
point; the clearing time uses the predicted twist at that recorded point
(:func:`sim.judge_soft.opening_speeds`, docs/simulation.md "Judging a run"). Each run agrees
in both engines, its negative control (the campaign's: another friction, sliding) disagrees,
and a support kept loaded past its clearing time still disagrees.

Blocks stacked on their corners (seed 5, stacked 2 and 9): the blocks move as predicted while
MuJoCo's sticking finger contact chatters and its window slip reading flickers across the slip
threshold. Over the stretch in which the certificate's configuration holds, a closed contact
is read by its two bodies' relative motion there (:func:`sim.judge_soft.stretch_readings`);
each run agrees in both engines, its control does not, and a sticking contact whose bodies
really slip over the stretch is not excused.

A rhombus with a 31 deg corner slid along the table by a frictionless finger on its slanted
edge (seed 7, acute 10): the one certificate of ``S+1 S+2 S+3`` loads the rear corner (the
lower end of the finger's edge) with 2.2 N of its 108 N, and pymunk leaves that corner unloaded (read ``B``) on 94 % of
the steps while the twist matches to 0.0 % and the forces are 2.0 % off the certificate. A
contact the certificate loads by less than the force check's allowance reads as either
(:func:`sim.judge_soft.unload_allowance`); the run agrees, its control does not, and without the
allowance it disagrees.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from sim_traces import load_campaign_trace

from planner.model.modes import BREAK
from sim.classify import judged_mask
from sim.judge import judge
from sim.judge_soft import clearing_times, opening_speeds
from sim.scenes.shapes import ENV_INSET
from sim.verdict import Outcome

TIPPING = ("mujoco_seed6_supports6_tips", "pymunk_seed6_supports6_tips",
           "mujoco_seed6_supports9_tips", "pymunk_seed6_supports9_tips")
STACKED = ("mujoco_seed5_stacked2_finger_sticks", "pymunk_seed5_stacked2_finger_sticks",
           "mujoco_seed5_stacked9_top_slides", "pymunk_seed5_stacked9_top_slides")
LIGHT = ("pymunk_seed7_acute10_light_corner", "mujoco_seed7_acute10_light_corner")


@pytest.mark.parametrize("name", TIPPING + STACKED + LIGHT)
def test_a_recorded_campaign_run_agrees(name: str) -> None:
    trace = load_campaign_trace(name)
    verdict = judge(trace.rec, trace.expectation(), trace.thresholds()).verdict
    assert verdict.outcome is Outcome.AGREED, verdict.reasons


@pytest.mark.parametrize("name", TIPPING + STACKED + LIGHT)
def test_the_negative_control_does_not_agree(name: str) -> None:
    """The campaign's control (another friction, or the mirror image: no mode in common) is
    never agreed -- disagreed, or inconclusive where the engine moved a block by position
    correction (stacked 9 in MuJoCo, 17 % of the steps)."""
    trace = load_campaign_trace(name)
    verdict = judge(trace.rec, trace.control(), trace.thresholds()).verdict
    assert verdict.outcome is not Outcome.AGREED, verdict.reasons
    if name in TIPPING:
        assert verdict.outcome is Outcome.DISAGREED, verdict.reasons


def _last_support(name: str) -> tuple[object, int, int]:
    """The trace, its judged mode's support next to the pivot (the opened contact with the
    slowest predicted opening at the model's point) and the first judged step."""
    trace = load_campaign_trace(name)
    exp, th = trace.expectation(), trace.thresholds()
    (mode,) = exp.modes
    vn = np.asarray(mode.contact_velocities, dtype=float)[:, 0]
    opened = [i for i, c in enumerate(mode.mode.codes) if c == BREAK and vn[i] > 0]
    i = min(opened, key=lambda j: vn[j])
    k0 = int(np.flatnonzero(judged_mask(trace.rec, th))[0])
    return trace, i, k0


def test_mujoco_touches_a_support_at_the_end_of_its_surface_nearer_the_pivot() -> None:
    """The mechanism: MuJoCo records the support next to the pivot ``ENV_INSET`` of the size
    from the model's point (the end of the capsule's flat top, within its measured depth),
    where the predicted twist opens it at 0.3-0.7 of the model point's speed (the model's
    support 0.262 m from the pivot, the engine's contact 0.1 m)."""
    trace, i, k0 = _last_support("mujoco_seed6_supports6_tips")
    exp = trace.expectation()
    system = exp.system
    r = np.asarray(system.points[i]) + trace.rec.poses[k0, 0, :2]  # turned by 2 mrad: negligible
    off = float(np.linalg.norm(trace.rec.points[k0, i] - r))
    assert abs(off - ENV_INSET * exp.length) < 0.01 * exp.length
    model = float(exp.modes[0].contact_velocities[i, 0]) * exp.velocity_factor
    engine = float(opening_speeds(trace.rec, exp, k0)[0, i])
    assert 0.3 * model < engine < 0.7 * model


def test_a_support_loaded_past_its_clearing_time_still_disagrees() -> None:
    """The MuJoCo run with its support next to the pivot kept loaded from the moment it
    cleared to the end (its readings at the last loaded step repeated): the clearing time at
    the engine's point excuses it for part of the run only, and the run disagrees."""
    trace, i, k0 = _last_support("mujoco_seed6_supports6_tips")
    exp, th = trace.expectation(), trace.thresholds()
    rec = trace.rec
    clear = clearing_times(rec, exp, th, judged_mask(rec, th))[0, i]
    assert rec.times[k0] < clear < rec.times[-1] - 0.5
    last = int(np.flatnonzero(rec.present[:, i])[-1])
    fields = {f: getattr(rec, f).copy() for f in ("present", "normal_force", "depth", "points")}
    for a in fields.values():
        a[last:, i] = a[last, i]
    verdict = judge(replace(rec, **fields), exp, th).verdict
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons


def test_a_sticking_finger_whose_bodies_slip_over_the_stretch_is_not_excused() -> None:
    """The MuJoCo stacked-blocks run with both blocks moved up by 7 % of the drive speed (above
    the slip threshold of 5 %, below the twist tolerance of 10 %): the finger predicted to stick
    slips along its face over the stretch, its flickering readings are not read as sticking,
    and the run does not agree."""
    trace = load_campaign_trace("mujoco_seed5_stacked2_finger_sticks")
    exp, th = trace.expectation(), trace.thresholds()
    assert judge(trace.rec, exp, th).verdict.outcome is Outcome.AGREED
    poses = trace.rec.poses.copy()
    poses[:, :, 1] += 0.07 * exp.drive * trace.rec.times[:, None]
    verdict = judge(replace(trace.rec, poses=poses), exp, th).verdict
    assert verdict.outcome is not Outcome.AGREED, verdict.reasons
    assert verdict.motion.twist_error < 0.1


def test_a_lightly_loaded_corner_read_unloaded_agrees_only_by_the_force_allowance(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """pymunk's acute 10: the rear corner (the lower end of the finger's edge) reads ``B`` on
    94 % of the steps; the certificate loads it by 2.2 N, within the allowance (10 % of
    108 N) -- without the allowance the same recording disagrees."""
    import sim.judge

    trace = load_campaign_trace("pymunk_seed7_acute10_light_corner")
    exp, th = trace.expectation(), trace.thresholds()
    (mode,) = exp.modes
    assert mode.mode.label == "S+1 S+2 S+3" and not mode.force_indeterminate
    fn = np.asarray(mode.contact_forces, dtype=float)[:, 0]
    allowance = sim.judge.unload_allowance(mode, exp.load)
    assert 0.0 < fn[0] < allowance < fn[1]
    assert judge(trace.rec, exp, th).verdict.outcome is Outcome.AGREED
    monkeypatch.setattr(sim.judge, "unload_allowance", lambda mode, load: 0.0)
    verdict = judge(trace.rec, exp, th).verdict
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons
