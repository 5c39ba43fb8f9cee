"""The one scene of a whole task (sim/schedule.py): the union of the segments' contacts, the
joints' commands over the whole plan and the control switches at segment boundaries."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.plan.hand_planner import plan_hand
from sim.scenes.hand import hand_scene
from sim.schedule import plan_layout as task_layout

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


@pytest.fixture(scope="module")
def task_plan():
    return plan_hand(DATA / "figure9_task_hand.json", waypoints=5)


@pytest.mark.long
def test_the_layout_unites_the_segments_contacts(task_plan):
    lay = task_layout(task_plan)
    assert lay.hand.n_contacts == 6
    assert lay.members == ((0, 1, 2, 3), (1, 2, 3, 4), (1, 3, 4, 5))
    assert lay.open_at_start == ("c5", "c6")
    ends = np.cumsum([s.waypoints[-1].t for s in task_plan.segments])
    assert lay.starts == pytest.approx((0.0, ends[0], ends[1]))
    assert lay.duration == pytest.approx(ends[-1])
    # segment 1 velocity-controls the right finger, segments 2 and 3 their driven joint, the
    # left finger (a tie of the one-sided bands, docs/planning.md): both joints switch once
    assert [s.control for s in task_plan.segments] == [("effort", "velocity"),
                                                       ("velocity", "effort"),
                                                       ("velocity", "effort")]
    assert lay.control_switches() == ((lay.starts[1], "joint:left", "velocity"),
                                      (lay.starts[1], "joint:right", "effort"))
    assert lay.hand.contact_frame(lay.q0, 4)[2] > 1e-4  # vertex 4 apart from the side at first
    assert not 0.0 <= lay.hand.contact_frame(lay.q0, 5)[3] <= 1.0  # the tip off edge 3 at first
    # a gained contact touches at its segment's planned start, where its site is placed
    for i, seg in ((4, 1), (5, 2)):
        assert abs(lay.hand.contact_frame(lay.q_starts[seg], i)[2]) < 1e-9
        assert np.allclose(lay.site_configs[i], lay.q_starts[seg])


def test_joint_commands_follow_the_segments_and_switch_without_a_ramp(task_plan):
    segs = list(task_plan.segments)
    flipped = tuple("velocity" if c == "effort" else "effort" for c in segs[2].control)
    plan = replace(task_plan, segments=(segs[0], segs[1], replace(segs[2], control=flipped)))
    lay = task_layout(plan)
    t1, t2 = lay.starts[1], lay.starts[2]
    names = lay.hand.joint_names()
    assert lay.control_switches() == tuple(
        [(t1, f"joint:{n}", c) for n, c in zip(names, segs[1].control)]
        + [(t2, f"joint:{n}", c) for n, c in zip(names, flipped)])
    ramp = 0.05
    cmds = lay.commands(ramp)
    for j in range(len(names)):
        for k, t0 in enumerate(lay.starts):
            first = lay.schedules[k].commands[0, j]
            # at a switch the new command holds from the boundary on (no ramp across)
            assert cmds[j](t0 + 1e-6, {}) == pytest.approx(first)
        # within a segment: held, ramped from the previous waypoint's value
        s0 = lay.schedules[0]
        c0 = s0.commands[:, j]
        t_mid = s0.times[1] + 0.5 * ramp
        assert cmds[j](t_mid, {}) == pytest.approx(0.5 * (c0[0] + c0[1]))
    # the unchanged plan: a joint keeping its control is ramped across the boundary
    same = task_layout(task_plan)
    c = same.commands(ramp)[0]
    prev = same.schedules[1].commands[-2, 0]
    new = same.schedules[2].commands[0, 0]
    assert c(same.starts[2] + 0.5 * ramp, {}) == pytest.approx(0.5 * (prev + new))


def test_the_task_scene_has_a_pair_per_contact_of_the_task(task_plan):
    lay = task_layout(task_plan)
    scene = hand_scene(lay.hand, lay.q0, 0.1, lay.schedules[0].controls, lay.commands(0.05),
                       site_configs=lay.site_configs, open_sites=[4, 5])
    assert [p.name for p in scene.pairs] == [f"c{i}" for i in range(1, 7)]
