"""Planning hands of any shape: each guaranteed region checked by dense friction sampling.

The check is independent of the planner's region: at torques drawn inside the region (its centre
and points out to 90 % of the way to its boundary along random directions) and friction vectors at
the box's corners and uniformly inside it, :func:`planner.predict.feasibility.feasible_modes` (the
full mode enumeration, not the region's rows) must find the claimed mode and nothing else.
"""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.files.hand_file import load_hand_file
from planner.plan.bounds import box_points, mode_bands
from planner.plan.guarantee import guarantee
from planner.plan.partition import control_partitions, joint_inputs
from planner.plan.polytope import chebyshev_centre, torque_region
from planner.plan.segment_planner import plan_segment
from planner.predict.feasibility import feasible_modes

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"
HANDS = [pytest.param("three_finger_hand", marks=pytest.mark.long),  # 15-30 s to plan
         "prismatic_finger_hand", "two_link_finger_hand", "table_push_hand"]


def _segment(hf, **kw):
    """``plan_segment`` of a hand file's segment section (``kw`` overrides)."""
    s = hf.segment
    mu = [list(p) for p in hf.mu_interval]
    args = dict(data=hf.data, drive=s.drives, speed=s.speeds, mode=s.mode,
                mu=mu if len(mu) > 1 else mu[0], model="independent" if len(mu) > 1 else "common",
                max_time=s.max_time, steps=s.steps, waypoints=s.waypoints)
    return plan_segment(hf.hand, hf.q0, **{**args, **kw})


def _model(rp, lo, hi):
    """The friction set a segment's regions hold for: one shared coefficient with one effort
    joint and one interval for all (the band of the common model), else the box."""
    one = len(rp.effort_joints) == 1 and np.all(lo == lo[0]) and np.all(hi == hi[0])
    return "common" if one else "box"


@functools.cache
def _plan(name):
    hf = load_hand_file(DATA / f"{name}.json")
    mu = [list(p) for p in hf.mu_interval]
    rp = _segment(hf)
    lo = np.array([p[0] for p in mu] * (hf.hand.n_contacts if len(mu) == 1 else 1))
    hi = np.array([p[1] for p in mu] * (hf.hand.n_contacts if len(mu) == 1 else 1))
    return hf, rp, lo, hi


@pytest.fixture(params=HANDS)
def planned(request):
    return (request.param, *_plan(request.param))


def _torques_inside(region, rng, n):
    """The centre and ``n`` points along random directions, 90 % of the way to the boundary."""
    c = region.centre
    out = [c]
    p = len(c)
    if p == 0:
        return out
    for _ in range(n):
        d = rng.standard_normal(p)
        d /= np.linalg.norm(d)
        Ad = region.A @ d
        slack = region.b - region.A @ c
        t_max = np.min(np.where(Ad > 0, slack / np.where(Ad > 0, Ad, 1.0), np.inf))
        out.append(c + 0.9 * min(t_max, 1e3) * d)
    return out


def _frictions(lo, hi, rng, n, model="box"):
    """Friction vectors the region claims to hold for: the box's corners and uniform samples
    (``box``), or one coefficient shared by every contact (``common``: ends and samples)."""
    if model == "common":
        m = np.concatenate([[lo[0], hi[0]], rng.uniform(lo[0], hi[0], n)])
        return np.repeat(m[:, None], len(lo), axis=1)
    corners, _ = box_points(lo, hi, 2)
    return np.concatenate([corners, rng.uniform(lo, hi, size=(n, len(lo)))])


@pytest.mark.long
def test_every_region_holds_under_dense_friction_sampling(planned):
    name, hf, rp, lo, hi = planned
    hand = hf.hand
    rng = np.random.default_rng(16)
    V, E = rp.velocity_joints, rp.effort_joints
    checked = 0
    for w, reg in list(zip(rp.waypoints, rp.regions))[::3]:
        base = hand.system(w.q, 0.0, joint_inputs(hand, V, w.velocity_commands))
        assert reg.contains(reg.centre, 1e-12)
        for tau in _torques_inside(reg, rng, 4):
            inputs = np.array(base.joint_inputs)
            inputs[list(E)] = tau
            system = base.with_joint_inputs(inputs)
            for mu in _frictions(lo, hi, rng, 24, _model(rp, lo, hi)):
                labels = feasible_modes(system, mu).labels
                assert labels == [rp.claim], (name, w.t, tau, mu, labels)
                checked += 1
    assert checked >= 24 * len(rp.waypoints[::3])


def test_commands_and_partition_shape(planned):
    name, hf, rp, lo, hi = planned
    k_eff = {"three_finger_hand": 2, "prismatic_finger_hand": 1, "two_link_finger_hand": 1,
             "table_push_hand": 0}[name]
    assert len(rp.effort_joints) == k_eff
    assert len(rp.velocity_joints) + k_eff == hf.hand.n_joints
    assert all(w.margin > 0 for w in rp.waypoints)
    assert len(rp.regions) == len(rp.waypoints)
    for w, reg in zip(rp.waypoints, rp.regions):
        assert len(w.torque_commands) == len(w.bands) == k_eff
        assert reg.contains(w.torque_commands, 1e-9)
        for j, (lo_j, hi_j) in enumerate(w.bands):  # each effort's range, the others held
            assert lo_j < w.torque_commands[j] < hi_j


def test_a_command_far_outside_the_region_lets_a_rival_in():
    """Negative control for the independent check: with the effort-controlled joints relaxed
    (zero torque) the three-finger hand's claimed mode is not the only possibility."""
    hf, rp, lo, hi = _plan("three_finger_hand")
    hand = hf.hand
    w = rp.waypoints[0]
    system = hand.system(w.q, 0.0, joint_inputs(hand, rp.velocity_joints, w.velocity_commands))
    rng = np.random.default_rng(0)
    seen = [feasible_modes(system, mu).labels for mu in _frictions(lo, hi, rng, 10)]
    assert any(labels != [rp.claim] for labels in seen)
    assert not rp.regions[0].contains(np.zeros(2))


def test_one_effort_joint_region_is_todays_band():
    hf = load_hand_file(DATA / "two_finger_hand.json")
    hand = hf.hand
    system = hand.system(hf.q0, 0.0, [{"effort": 0.0}, {"velocity": 0.02}])
    band = guarantee(system, "4S", (0.0, 0.2)).best()
    reg = torque_region(system, "4S", (0.0, 0.2))
    assert reg.b.tolist() == [band.upper, -band.lower]
    assert reg.centre[0] == 0.5 * (band.lower + band.upper)
    assert reg.margin == 0.5 * (band.upper - band.lower)
    # The corner H-representation (any p) is sound for the common model: inside the guaranteed band.
    poly = torque_region(system, "4S", (0.0, 0.2), method="polytope")
    assert poly.exact and not poly.empty
    a = poly.A[:, 0]
    lo = np.max(poly.b[a < 0] / a[a < 0])
    hi = np.min(poly.b[a > 0] / a[a > 0])
    assert band.lower - 1e-12 <= lo < hi <= band.upper + 1e-12
    # ... and inside the claim's guaranteed set over the box of the independent model
    bands = {b.label: b for b in mode_bands(system, (0.0, 0.2), model="independent")}
    own = bands[reg.claim].guaranteed
    assert own.lower - 1e-12 <= lo and hi <= own.upper + 1e-12


def test_control_partitions_follow_conditions_29_and_32():
    assert control_partitions(3, "S+1 S+2 S-3 S-4") == [((1, 2), (0,)), ((0, 2), (1,)),
                                                        ((0, 1), (2,))]
    assert control_partitions(1, "S-1 S-2 S-3") == [((0,), ())]
    assert control_partitions(3, "S+1 S+2 S-3 S-4 R5") == [((), (0, 1, 2))]  # k = 6
    with pytest.raises(ValueError, match=r"condition \(29\) expected 3 <= 2 n_R \+ n_S <= 3 \+ "
                                         r"n_theta = 4, got 6"):
        control_partitions(1, "R1 R2 R3")


def test_chebyshev_centre_of_a_box_and_of_an_empty_set():
    A = np.vstack([np.eye(2), -np.eye(2)])
    c, r = chebyshev_centre(A, np.array([1.0, 3.0, 1.0, 1.0]))
    np.testing.assert_allclose(c[0], 0.0, atol=1e-9)
    assert r == pytest.approx(1.0)
    _, r = chebyshev_centre(A, np.array([-1.0, 1.0, -1.0, 1.0]))
    assert r == -np.inf


@pytest.mark.long
@pytest.mark.slow  # about a minute; by hand (-m slow)
def test_the_one_planner_plans_one_or_several_effort_joints_alike():
    """``plan_hand`` (the hand file entry point) gives the same segment as ``plan_segment``, for
    two effort joints as for one: one planner, one segment type."""
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import plans_equal

    for name in ("three_finger_hand", "two_link_finger_hand"):
        hf, rp, _, _ = _plan(name)
        plan = plan_hand(DATA / f"{name}.json")
        seg = plan.segments[0]
        assert seg.waypoints == rp.waypoints and seg.control == rp.control
        assert plans_equal(plan, replace(plan, segments=(replace(rp, extra=seg.extra),)))


@pytest.mark.long
def test_an_empty_region_says_why():
    """Friction up to 0.3 on every contact: with the left finger velocity-controlled no torque
    pair on the right and top fingers keeps all five contacts sliding."""
    from planner.errors import DegenerateError

    hf = load_hand_file(DATA / "three_finger_hand.json")
    system = hf.hand.system(hf.q0, 0.0, joint_inputs(hf.hand, (0,), [0.02]))
    reg = torque_region(system, "5S", (0.0, 0.3))
    assert reg.empty and "not guaranteed over the friction box" in reg.diagnosis["reason"]
    # independent: at every torque pair of a grid some corner of the friction box admits
    # another mode (or none)
    base = np.array(system.joint_inputs)
    corners, _ = box_points(np.zeros(5), np.full(5, 0.3), 2)
    for t1 in np.linspace(-0.03, 0.03, 7):
        for t2 in np.linspace(-0.03, 0.03, 7):
            inputs = base.copy()
            inputs[[1, 2]] = (t1, t2)
            sys_t = system.with_joint_inputs(inputs)
            assert any(feasible_modes(sys_t, mu).labels != [reg.claim] for mu in corners)
    with pytest.raises(DegenerateError, match=r"no control partition guarantees S\+1 S\+2 S-3 "
                                              r"S-4 S\+5: with the left finger velocity-"
                                              r"controlled: no guaranteed effort at t = 0 s"):
        _segment(hf, mu=(0.0, 0.3), waypoints=5, control=(0,))


@pytest.mark.long
@pytest.mark.slow  # about a minute; by hand (-m slow)
def test_a_partial_plan_stops_where_no_region_exists_and_says_why():
    hf = load_hand_file(DATA / "three_finger_hand.json")
    hand, s = hf.hand, hf.segment
    plan = _segment(hf, mu=(0.0, 0.1), control=(2,), partial=True)
    short = plan.shortfall
    assert short is not None and 0 < short.index == len(plan.waypoints) < s.waypoints
    full = np.linspace(0.0, plan.waypoints[-1].t * (s.waypoints - 1) / (short.index - 1),
                       s.waypoints)
    assert short.t == pytest.approx(full[short.index]) and short.velocity_joints == (2,)
    assert short.rival is not None and short.rival in short.reason
    assert short.widest_mu is not None
    lo, hi = (np.array(x) for x in short.widest_mu)
    assert np.all(lo == 0.0) and 0.0 < hi[0] < 0.1
    # The narrower interval works there: its region's centre, checked by the full enumeration.
    from planner.plan.trajectory import integrate_segment

    traj = integrate_segment(hand, hf.q0, drive=s.drives, speed=s.speeds, mode=s.mode,
                             max_time=s.max_time, steps=s.steps)
    at = traj.at_times(hand, np.array([short.t]))
    system = hand.system(at.q[0], 0.0, joint_inputs(hand, (2,), at.thetadot[0, [2]]))
    reg = torque_region(system, plan.claim, np.stack([lo, hi], 1))
    assert not reg.empty
    inputs = np.array(system.joint_inputs)
    inputs[[0, 1]] = reg.centre
    sys_c = system.with_joint_inputs(inputs)
    rng = np.random.default_rng(5)
    for mu in _frictions(lo, hi, rng, 30):
        assert feasible_modes(sys_c, mu).labels == [plan.claim]
    # Without ``partial`` the same request is refused with every partition's reason.
    from planner.errors import DegenerateError
    with pytest.raises(DegenerateError, match=r"with the top finger velocity-controlled: no "
                                              r"guaranteed effort at t = 1.95 s: rival"):
        _segment(hf, mu=(0.0, 0.1), control=(2,))


@pytest.mark.parametrize("name", ["three_finger_hand", "table_push_hand"])
def test_region_figures_are_written(tmp_path, name):
    from planner.plots.bounds import plot_regions, slice_polygon

    hf, rp, lo, hi = _plan(name)
    paths = plot_regions(rp, tmp_path, hf.hand.joint_names())
    assert paths[0].stat().st_size > 1000
    if len(rp.effort_joints) == 2:
        w, reg = rp.waypoints[0], rp.regions[0]
        poly = slice_polygon(reg.A, reg.b, np.array(w.torque_commands), (0, 1))
        assert len(poly) >= 3
        # every vertex lies on the region (within rounding), the command inside the polygon
        assert np.all(reg.A @ poly.T <= reg.b[:, None] + 1e-9)


def test_slice_of_a_square():
    from planner.plots.bounds import slice_polygon

    A = np.vstack([np.eye(3), -np.eye(3)])
    poly = slice_polygon(A, np.ones(6), np.zeros(3), (0, 2))
    np.testing.assert_allclose(sorted(map(tuple, np.round(poly, 12))),
                               [(-1, -1), (-1, 1), (1, -1), (1, 1)])


@pytest.mark.long
def test_open_rows_mark_the_sides_where_no_mode_boundary_is():
    """``TorqueRegion.open_rows``: the prismatic finger at a shared friction in [0.5, 0.6] has a
    one-sided band (pulling harder never lets a rival in); its infinite end is replaced by the
    command's ball and marked open, while the finite end is a real boundary -- a torque just
    past it admits a rival or loses the mode.  The three-finger hand's open rows are its box of
    commands (``+-e_k``)."""
    hf = load_hand_file(DATA / "prismatic_finger_hand.json")
    rp = _segment(hf, mu=[0.5, 0.6], waypoints=2)
    w = rp.waypoints[0]
    reg = rp.regions[0]
    assert len(reg.open_rows) == 1
    real = 1 - reg.open_rows[0]
    end = reg.b[real] / reg.A[real, 0]
    past = end + 0.02 * reg.margin * reg.A[real, 0]
    base = hf.hand.system(w.q, 0.0, joint_inputs(hf.hand, rp.velocity_joints,
                                                 w.velocity_commands))
    inputs = np.array(base.joint_inputs)
    inputs[list(rp.effort_joints)] = past
    system = base.with_joint_inputs(inputs)
    seen = [feasible_modes(system, m).labels for m in np.linspace(0.5, 0.6, 21)]
    assert any(labels != [rp.claim] for labels in seen)

    _, rp3, _, _ = _plan("three_finger_hand")
    reg3 = rp3.regions[0]
    p = len(rp3.effort_joints)
    box = reg3.A[list(reg3.open_rows)]
    assert len(reg3.open_rows) == 2 * p
    assert np.allclose(np.abs(box).sum(axis=1), 1.0) and np.allclose(np.abs(box).max(axis=1), 1.0)
