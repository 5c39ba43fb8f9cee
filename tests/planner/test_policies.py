"""Command policies (planner.plan.policies) and joint limits (planner.files.hand_limits).

The triangle hand (tests/data/triangle_apex_hand.json: the left finger's side over the apex,
friction in [0, 0.3]) has a guaranteed band that is one-sided, ``(-inf, 0]`` N m, until a rival
appears about 2 s in and sets a lower end hundreds of N m away: the maximum-margin command jumps
from the one-sided band's step (the load's torque scale, 0.06 N m) to that band's middle.  The
default policy must not, and every policy's commands are re-checked with the full mode
enumeration (``feasible_modes``, not the region) at both ends of each hold interval over a dense
friction grid; a command pushed just past a face must be caught by the same check.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from planner.errors import DegenerateError, FileFormatError, InputError
from planner.files.hand_file import hand_file_from_dict
from planner.files.hand_limits import parse_limits
from planner.plan.hand_planner import default_mu_model, plan_hand
from planner.plan.plan_file import load_plan, save_plan
from planner.plan.policies import (
    MARGIN_KEPT,
    hold_set,
    least_effort,
    parse_policy,
    smoothest,
)
from planner.plan.spacing import MARGIN_KEPT as SPACING_KEPT
from planner.predict.feasibility import feasible_modes
from qsplan.cli import main

TRIANGLE = Path(__file__).resolve().parents[1] / "data" / "triangle_apex_hand.json"
MUS = np.linspace(0.0, 0.3, 31)


def _triangle(**segment) -> dict:
    d = json.loads(TRIANGLE.read_text())
    d["segment"].update({"max_time": 4.0, "waypoints": 16, **segment})
    return d


@pytest.fixture(scope="module")
def plans():
    hf = hand_file_from_dict(_triangle(), "triangle")
    return {p: plan_hand(hf, policy=p).segments[0]
            for p in ("midband", "smooth", "least-effort", "constant")}


def _bad(seg, k: int, end: int, tau: float) -> list[tuple[float, list[str]]]:
    """Friction samples at which the claim is not the only feasible mode with effort ``tau``
    held from waypoint ``k``: at waypoint ``k + end``'s state, with ``k``'s rates."""
    hand = seg.hand_model.hand
    w, at = seg.waypoints[k], seg.waypoints[min(k + end, len(seg.waypoints) - 1)]
    inputs = [{"effort": tau} if c == "effort" else {"velocity": w.velocity_commands[0]}
              for c in seg.control]
    system = hand.system(at.q, 0.0, inputs)
    out = []
    for mu in MUS:
        labels = feasible_modes(system, mu).labels
        if labels != [seg.claim]:
            out.append((float(mu), list(labels)))
    return out


@pytest.mark.long
def test_midband_jumps_where_a_rival_appears_and_the_default_does_not(plans):
    mid, smooth = plans["midband"].extra["commands"], plans["smooth"].extra["commands"]
    scale = 0.06  # N m: the load's torque scale here (0.981 N on a ~0.06 m lever)
    assert mid["largest_change"] > 30 * scale
    assert mid["within_bound"] is False
    assert smooth["within_bound"] is True
    assert smooth["largest_change"] <= smooth["bound"] + 1e-9
    assert smooth["bound"] == pytest.approx(0.0, abs=1e-9)  # one command fits every waypoint
    assert smooth["joint"] == "the left finger" and smooth["unit"] == "N m"
    assert plans["smooth"].policy == "smooth"


@pytest.mark.long
@pytest.mark.parametrize("policy", ["smooth", "least-effort", "midband", "constant"])
def test_commands_hold_the_claim_under_dense_friction_sampling(plans, policy):
    seg = plans[policy]
    assert seg.torques().shape == (len(seg.waypoints), 1)
    bad = [(k, end, b) for k in range(len(seg.waypoints) - 1) for end in (0, 1)
           if (b := _bad(seg, k, end, seg.waypoints[k].torque_commands[0]))]
    assert bad == []


@pytest.mark.long
def test_policies_order_effort_and_margin(plans):
    """Least effort squeezes least, max-margin (midband) keeps the largest margin, smooth keeps
    the required margin (half the hold band, capped at the load's scale)."""
    le, mm, sm = (np.abs(plans[p].torques()[:, 0]) for p in ("least-effort", "midband",
                                                             "smooth"))
    assert np.all(le <= mm + 1e-12) and np.all(le <= sm + 1e-9)
    margins = {p: plans[p].margins() for p in ("least-effort", "midband", "smooth")}
    assert np.all(margins["midband"] >= margins["least-effort"] - 1e-12)
    assert np.all(margins["smooth"] > 0) and np.all(margins["least-effort"] > 0)


@pytest.mark.long
def test_a_command_pushed_past_a_face_is_caught(plans):
    """Mutation: the smooth command moved just past the hold band's finite faces (1 % of the
    band, at least 1 % of the load's scale) fails the same dense check at some friction."""
    seg = plans["smooth"]
    caught = tried = 0
    for k, w in enumerate(seg.waypoints[:-1]):
        lo, hi = w.bands[0]
        width = hi - lo if np.isfinite(hi - lo) else 0.06
        for face, sign in ((hi, 1.0), (lo, -1.0)):
            if not np.isfinite(face):
                continue
            tried += 1
            tau = face + sign * max(0.01 * width, 0.01 * 0.06)
            caught += bool(_bad(seg, k, 0, tau) or _bad(seg, k, 1, tau))
    assert tried >= len(seg.waypoints) - 1
    assert caught == tried


def test_required_margin_share_is_the_spacing_rule():
    assert MARGIN_KEPT == SPACING_KEPT == 0.5


def test_smoothest_is_the_smallest_largest_change_and_least_effort_breaks_ties():
    # safe sets (margin 0.25 of radius 0.5 -> 0.25): [1.25, 1.75], [0.25, 0.75], [1.25, 1.75]
    holds = [hold_set(np.array([[1.0], [-1.0]]), np.array([hi, -lo]), 10.0, t)
             for t, (lo, hi) in enumerate([(1.0, 2.0), (0.0, 1.0), (1.0, 2.0)])]
    got = smoothest(holds, np.array([np.inf]), ["j"], "N m")
    assert got.bound == pytest.approx(0.5, abs=1e-7)
    assert np.max(np.abs(np.diff(got.taus[:, 0]))) <= 0.5 + 1e-7
    assert got.taus[1, 0] == pytest.approx(0.75, abs=1e-6)
    # one command in every set: no change at all, at the least effort
    # ([1, 2]: radius 0.5, required margin 0.25, safe [1.25, 1.75])
    flat = [hold_set(np.array([[1.0], [-1.0]]), np.array([2.0, -1.0]), 10.0, t) for t in (0, 1)]
    assert smoothest(flat, np.array([np.inf]), ["j"], "N m").taus[:, 0] == pytest.approx(
        [1.25, 1.25], abs=1e-6)
    assert least_effort(flat[0])[0] == pytest.approx(1.25, abs=1e-9)
    # the margin is capped at the load's scale: [0, 100] with scale 1 keeps 0.5
    wide = hold_set(np.array([[1.0], [-1.0]]), np.array([100.0, 0.0]), 1.0, 0.0)
    assert least_effort(wide)[0] == pytest.approx(0.5, abs=1e-9)


def test_rate_limits_too_low_name_the_joint_and_the_change():
    holds = [hold_set(np.array([[1.0], [-1.0]]), np.array([hi, -lo]), 10.0, t)
             for t, (lo, hi) in enumerate([(1.0, 2.0), (5.0, 6.0)])]
    with pytest.raises(DegenerateError, match=r"effort-rate limit of the left finger \(1 N m/s\)"
                       r".*between t = 0 and 1 s its command must change by at least 3\.5 N m"
                       r", 3\.5 times"):
        smoothest(holds, np.array([1.0]), ["the left finger"], "N m")
    assert smoothest(holds, np.array([4.0]), ["j"], "N m").bound == pytest.approx(3.5, abs=1e-6)


def test_least_effort_margin_beyond_the_set_is_refused():
    h = hold_set(np.array([[1.0], [-1.0]]), np.array([2.0, -1.0]), 10.0, 0.5)
    with pytest.raises(DegenerateError, match=r"least-effort:0\.8: at t = 0\.5 s the guaranteed "
                                              r"efforts keep a margin of at most 0\.5"):
        least_effort(h, 0.8)
    assert least_effort(h, 0.1)[0] == pytest.approx(1.1)


@pytest.mark.parametrize("text,expect", [
    ("smooth", ("smooth", None)), ("least-effort:0.05", ("least-effort", 0.05)),
    ("rival:R2S", ("rival", None)), ("midband", ("midband", None))])
def test_policy_names(text, expect):
    assert parse_policy(text) == expect


@pytest.mark.parametrize("text", ["least-effort:abc", "least-effort:-1", "smooth:2", "foo",
                                  "rival:"])
def test_bad_policy_names_are_refused(text):
    with pytest.raises(InputError, match="policy"):
        parse_policy(text)


def test_effort_limits_cut_the_commands_and_are_kept():
    d = _triangle(waypoints=6)
    d["limits"] = {"effort": {"left": [-0.02, 0.5]}}
    seg = plan_hand(hand_file_from_dict(d, "t")).segments[0]
    tau = seg.torques()[:, 0]
    assert np.all(tau >= -0.02) and np.all(tau < 0)
    assert np.all(seg.margins() > 0)


def test_limits_that_empty_the_region_name_the_joint_and_the_missing_effort(tmp_path, capsys):
    d = _triangle(waypoints=4)
    d["limits"] = {"effort": {"left": [0.01, 1.0]}}  # the guarantee needs a pull <= 0 N m
    path = tmp_path / "limited.json"
    path.write_text(json.dumps(d))
    assert main(["plan", str(path), "--out", str(tmp_path / "p.json")]) == 1
    err = capsys.readouterr().err
    assert "needs the left finger to exert an effort of at most 0 N m" in err
    assert "its limits are [0.01, 1] N m: 0.01 N m missing" in err
    assert not (tmp_path / "p.json").exists()


def test_speed_limit_below_the_drive_is_a_diagnosis():
    d = _triangle(waypoints=3)
    d["limits"] = {"speed": {"right": 0.01}}
    with pytest.raises(DegenerateError, match=r"the right finger must move at 0\.02 rad/s, above "
                                              r"its speed limit 0\.01 rad/s"):
        plan_hand(hand_file_from_dict(d, "t"))


@pytest.mark.parametrize("limits,match", [
    ({"effort": {"thumb": 1.0}}, r"limits\.effort\.thumb: expected a joint name, one of "
                                 r"\['left', 'right'\]"),
    ({"effort": {"left": [1.0, -1.0]}}, r"limits\.effort\.left: expected min < max"),
    ({"effort": {"left": [1.0]}}, r"limits\.effort\.left: expected \[min, max\] or one number"),
    ({"effort": {"left": -2}}, r"limits\.effort\.left: expected a positive number"),
    ({"effort_rate": {"left": 0}}, r"limits\.effort_rate\.left: expected a positive number"),
    ({"torque": {}}, r"limits: unknown key 'torque'"),
])
def test_bad_limits_are_refused_when_the_file_is_read(limits, match):
    d = _triangle()
    d["limits"] = limits
    with pytest.raises(FileFormatError, match=match):
        hand_file_from_dict(d, "t")


def test_limits_parse_per_joint():
    lim = parse_limits({"effort": {"right": 2.0, "left": [-1, 0.5]}, "effort_rate": {"left": 3},
                        "note": "free text"}, ["left", "right"])
    assert lim.effort_lo == (-1.0, -2.0) and lim.effort_hi == (0.5, 2.0)
    assert lim.effort_rate == (3.0, np.inf) and lim.limited


@pytest.mark.long
def test_the_change_report_is_in_the_plan_file_and_the_output(plans, tmp_path, capsys):
    path = tmp_path / "p.json"
    d = _triangle(waypoints=4)
    src = tmp_path / "tri.json"
    src.write_text(json.dumps(d))
    assert main(["plan", str(src), "--out", str(path)]) == 0
    out = capsys.readouterr().out
    assert "commands (smooth): largest change between waypoints" in out
    assert "bound 0 N m (the smallest largest change of any commands that keep the required " \
           "margin)" in out
    seg = load_plan(path).segments[0]
    assert seg.extra["commands"]["policy"] == "smooth"
    again = load_plan(save_plan(load_plan(path), tmp_path / "q.json")).segments[0]
    assert again.extra["commands"] == seg.extra["commands"]


def test_per_contact_intervals_as_an_array_are_independent():
    assert default_mu_model(np.array([[0.0, 0.3]] * 4)) == "independent"
    assert default_mu_model(np.array([0.0, 0.3])) == "common"
    d = copy.deepcopy(_triangle(waypoints=3))
    d["mu"]["interval"] = [[0.0, 0.3]] * 4
    plan = plan_hand(hand_file_from_dict(d, "t"))
    assert plan.mu_model == "independent"


@pytest.fixture(scope="module")
def three_finger():
    d = json.loads((Path(__file__).resolve().parents[2] / "scenarios" / "data" /
                    "three_finger_hand.json").read_text())
    d["segment"]["waypoints"] = 3
    return d


def test_two_effort_joints_smooth_commands_hold_over_the_friction_box(three_finger):
    """Two effort joints (the region is a polytope over the box of per-contact intervals): the
    smooth commands re-checked by feasible_modes at the box's corners and seeded inner points,
    at both ends of each hold interval."""
    seg = plan_hand(hand_file_from_dict(three_finger, "t"), control=(0,)).segments[0]
    assert len(seg.effort_joints) == 2 and seg.policy == "smooth"
    assert seg.extra["commands"]["within_bound"] is True
    hand = seg.hand_model.hand
    lo, hi = np.array(seg.mu_intervals).T
    rng = np.random.default_rng(0)
    corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(len(lo), -1).T
    mus = np.concatenate([corners, rng.uniform(lo, hi, size=(12, len(lo)))])
    for k, w in enumerate(seg.waypoints[:-1]):
        for at in (w, seg.waypoints[k + 1]):
            inputs, e = [], iter(w.torque_commands)
            v = iter(w.velocity_commands)
            for c in seg.control:
                inputs.append({"effort": next(e)} if c == "effort" else {"velocity": next(v)})
            system = hand.system(at.q, 0.0, inputs)
            bad = [m for m in mus if feasible_modes(system, m).labels != [seg.claim]]
            assert bad == []


def test_two_effort_joints_limits_name_the_joint_to_widen(three_finger):
    d = copy.deepcopy(three_finger)
    d["limits"] = {"effort": {"top": [0.001, 1.0]}}
    with pytest.raises(DegenerateError, match=r"needs the top finger to exert an effort of at "
                                              r"most 0 N m \(the other effort joints within "
                                              r"their limits\), but its limits are \[0\.001, 1\] "
                                              r"N m: 0\.001 N m missing"):
        plan_hand(hand_file_from_dict(d, "t"), control=(0,))
    d["limits"] = {"effort": {"right": [-1.0, 0.003]}}
    seg = plan_hand(hand_file_from_dict(d, "t"), control=(0,)).segments[0]
    assert np.all(seg.torques()[:, 0] <= 0.003) and np.all(seg.margins() > 0)


def test_an_effort_rate_limit_is_kept_by_smooth_and_enforced_on_other_policies():
    d = _triangle()
    d["limits"] = {"effort_rate": {"left": 0.5}}
    hf = hand_file_from_dict(d, "t")
    seg = plan_hand(hf).segments[0]
    dt = np.diff(seg.times())
    assert np.all(np.abs(np.diff(seg.torques()[:, 0])) <= 0.5 * dt + 1e-9)
    with pytest.raises(DegenerateError, match=r"policy 'midband' changes the effort of the left "
                                              r"finger by .* more than its effort-rate limit "
                                              r"\(0\.5 N m/s\)"):
        plan_hand(hf, policy="midband")


def test_a_negative_control_drops_the_policy_report(plans):
    from planner.plan.model import Plan, negative_control

    seg = plans["smooth"]
    neg = negative_control(Plan(hand=dict(seg.hand), segments=(seg,), mu_model="common",
                                mu_intervals=seg.mu_intervals[:1]))
    assert "commands" not in neg.segments[0].extra and "spacing" in neg.segments[0].extra
