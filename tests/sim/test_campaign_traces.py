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


@pytest.mark.parametrize("name", TIPPING)
def test_a_tipping_box_on_many_supports_agrees(name: str) -> None:
    trace = load_campaign_trace(name)
    verdict = judge(trace.rec, trace.expectation(), trace.thresholds()).verdict
    assert verdict.outcome is Outcome.AGREED, verdict.reasons


@pytest.mark.parametrize("name", TIPPING)
def test_the_negative_control_of_a_tipping_box_disagrees(name: str) -> None:
    trace = load_campaign_trace(name)
    verdict = judge(trace.rec, trace.control(), trace.thresholds()).verdict
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
    for f, a in fields.items():
        a[last:, i] = a[last, i]
    verdict = judge(replace(rec, **fields), exp, th).verdict
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons
