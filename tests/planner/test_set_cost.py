"""What each uncertainty costs (planner.plan.set_cost, planner.plots.set_cost): the numbers the
figure shows are the planner's exact bands at those sizes (re-computed here with
:func:`planner.plan.load_bounds.load_bands`), they shrink as the set grows, and the figure is
written."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from set_hands import FULL_SET, planned

from planner.errors import InputError
from planner.model.load_set import point_set
from planner.plan.intervals import subtract
from planner.plan.load_bounds import load_bands
from planner.plan.partition import joint_inputs
from planner.plan.plan_file import load_plan
from planner.plan.set_cost import MULTIPLES, reference_sizes, set_cost, widened_friction


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    return load_plan(planned(tmp_path_factory.mktemp("cost"), FULL_SET))


@pytest.fixture(scope="module")
def cost(plan):
    return set_cost(plan)


def _by_hand(plan, cost, load_set, mu):
    """The claim's guaranteed band and pieces from load_bands at the binding waypoint."""
    seg = plan.segments[cost.segment]
    w = seg.waypoints[cost.waypoint]
    hand = replace(seg.hand_model[0], load_set=load_set)
    system = hand.system(w.q, 0.0, joint_inputs(hand, seg.velocity_joints, w.velocity_commands))
    loads = hand.load_vertices(w.q)
    loads = np.asarray(system.g_obj)[None] if loads is None else loads
    bands = load_bands(system, mu, loads, model=plan.mu_model)
    own = next(b for b in bands if b.label == seg.claim)
    return own.guaranteed, subtract(own.guaranteed, [b.possible for b in bands
                                                      if b.label != seg.claim])


@pytest.mark.long
def test_the_numbers_are_load_bands_at_those_sizes(plan, cost):
    ref = reference_sizes(plan)
    assert ref["mass"] == pytest.approx(0.02) and ref["com"] == pytest.approx(0.005)
    hand = plan.segments[0].hand_model[0]
    mus = list(plan.segments[0].mu_intervals)
    for axis in ("mass", "com", "friction"):
        assert len(cost.curves[axis]) == len(MULTIPLES)
        for x, pt in zip(MULTIPLES, cost.curves[axis]):
            if axis == "friction":
                ls, mu = hand.load_set, widened_friction(mus, x)
            else:
                ls, mu = hand.load_set.widened(axis, x * ref[axis]), mus
            band, pieces = _by_hand(plan, cost, ls, mu)
            assert (pt.band.lower, pt.band.upper) == pytest.approx((band.lower, band.upper),
                                                                   rel=1e-12), (axis, x)
            assert [x for p in pt.pieces for x in (p.lower, p.upper)] == pytest.approx(
                [x for p in pieces for x in (p.lower, p.upper)], rel=1e-12)


@pytest.mark.long
def test_the_guaranteed_band_shrinks_as_each_set_grows(cost):
    for axis, pts in cost.curves.items():
        for a, b in zip(pts, pts[1:]):
            assert a.band.lower <= b.band.lower + 1e-12 and b.band.upper <= a.band.upper + 1e-12
        assert pts[-1].band.upper - pts[-1].band.lower < pts[0].band.upper - pts[0].band.lower \
            or axis == "friction"


@pytest.mark.long
def test_the_friction_axis_at_zero_width_is_the_box_centre(plan, cost):
    lo, hi = plan.segments[0].mu_intervals[0]
    assert widened_friction([(lo, hi)], 0.0) == [(0.5 * (lo + hi), 0.5 * (lo + hi))]
    assert widened_friction([(0.0, 0.2)], 2.0) == [(0.0, 0.30000000000000004)]
    assert widened_friction([(0.8, 0.8)], 1.0, 0.1) == [(0.75, 0.8500000000000001)]
    assert cost.curves["friction"][0].size == 0.0
    assert cost.curves["friction"][2].size == pytest.approx(hi - lo)


@pytest.mark.long
def test_a_plan_at_a_point_uses_default_references(plan):
    hand = plan.segments[0].hand_model[0]
    bare = replace(plan, segments=tuple(
        replace(s, hand={k: v for k, v in s.hand.items() if k != "uncertainty"})
        for s in plan.segments))
    assert bare.segments[0].hand_model[0].load_set is None
    ref = reference_sizes(bare)
    assert ref["mass"] == pytest.approx(0.1 * hand.mass)
    assert ref["com"] == pytest.approx(0.05 * hand.length_scale)
    assert point_set(hand.mass, hand.com).trivial


@pytest.mark.long
def test_bad_multiples_are_refused(plan):
    with pytest.raises(InputError, match="multiples: expected finite sizes >= 0"):
        set_cost(plan, (0.0, -1.0))
    with pytest.raises(InputError, match="multiples: expected finite sizes >= 0"):
        set_cost(plan, (math.inf,))


@pytest.mark.long
def test_the_figure_is_written(tmp_path, plan):
    from planner.plots.set_cost import COST_FIGURE, draw_plan_cost
    from qsplan.commands.plan import COST_FIGURE as LISTED

    assert LISTED == COST_FIGURE
    out = draw_plan_cost(plan, tmp_path / COST_FIGURE)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.long
def test_a_size_where_a_stage_fails_shows_nothing_guaranteed(plan, monkeypatch):
    from planner.errors import DegenerateError
    from planner.plan import set_cost as module

    def fails(*args, **kwargs):
        raise DegenerateError("load set: the admissible modes differ between vertex loads")

    monkeypatch.setattr(module, "guarantee", fails)
    got = module.set_cost(plan, (0.0, 1.0))
    for pts in got.curves.values():
        assert all(p.band.empty and not p.pieces and not p.exact and p.radius == -math.inf
                   for p in pts)
